"""sim:// — the built-in simulated machine.

URL grammar: ``sim://`` (no target, no options).

It decodes the port bytes like a stepper driver, checks pulse and direction timing, and moves
motors, lead screws with their physical dead band, and carriages; see :mod:`retrofit.sim`.
"""

from __future__ import annotations

from ..frames import PortFrames
from ..sim import SimMachine
from .base import Output


class SimOutput(Output):
    scheme = "sim"
    grammar = "sim://"
    summary = "simulated machine: drivers, motors, lead screws with dead band, carriages"
    options = {}

    def open(self) -> None:
        if not self.is_open:
            self.sim = SimMachine(self.machine, self.start_steps, **self.trace_options)
        super().open()

    start_steps: tuple[int, ...] | None = None
    #: SimMachine's trace options (trace_limit, trace_windows, trace_around); default: every step
    trace_options: dict = {}

    def write(self, frames: PortFrames) -> None:
        self.sim.feed(frames)

    def observe(self) -> dict:
        return {"sim": self.sim}
