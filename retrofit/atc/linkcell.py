"""The mill at the far end of the serial link: the changer's and the setter's moves made there.

:class:`LinkCell` is the executor of :class:`~retrofit.atc.changer.ToolChanger` and the prober of
:class:`~retrofit.atc.measure.ToolSetter` for a controller on the link (``serial://`` or
``serial+socket://``: the firmware on its board, or in simavr with ``retrofit firmware sim``).
It sends commands through a :class:`~retrofit.outputs.serial.SerialOutput` and waits until the
machine rests; a probing move is one PROB (docs/protocol.md §7): the controller moves until its
probe input (the setter's beam) changes and stops there, and the status bit PROBED says whether
it did. Positions come back from the controller (RDPS), so every next move starts where the
machine really is.

The first command list sent starts with INIT (the controller's position is then 0, the machine
standing at home, as the simulated cell starts).
"""

from __future__ import annotations

from typing import Iterable, Sequence

from ..commands import Command, PFdr, PMov, Prob
from ..config import Machine
from ..errors import OutputError, ProbeError
from .cell import ProbeHit


class LinkCell:
    """Commands and probing moves on the controller behind ``output`` (a serial output)."""

    def __init__(self, output, machine: Machine):
        if not getattr(output, "takes_commands", False):
            raise OutputError(f"{output.url.text}: the tool changer and the setter need a controller "
                              f"on the serial link (serial:// or serial+socket://) or sim://")
        self.output = output
        self.machine = machine
        self.steps = {a.name: 0 for a in machine.axes}    # where the controller says it is
        self.probes = 0

    def run(self, commands: Sequence[Command]) -> dict:
        """Send ``commands``, wait until the machine rests; the far end's summary."""
        remote = self.output.send_program(list(commands))
        self.output.opts["init"] = False                 # INIT once: positions go on from here
        self.steps = dict(remote["position_steps"])
        return remote

    def commanded_mm(self) -> dict[str, float]:
        return {a.name: a.to_mm(self.steps[a.name]) for a in self.machine.axes}

    def probe(self, commands: Iterable[Command], until_broken: bool = True) -> ProbeHit | None:
        """The setter's probing move (its feed, then one PMOV) as a PROB; where it stopped on the
        beam, or None when it reached its end with the beam unchanged."""
        commands = list(commands)
        moves = [c for c in commands if isinstance(c, PMov)]
        if len(moves) != 1 or any(not isinstance(c, (PFdr, PMov)) for c in commands):
            raise ProbeError(f"a probing move is a feed and one PMOV; got {'; '.join(map(str, commands))}")
        sent = [Prob(moves[0].axes, away=not until_broken) if c is moves[0] else c for c in commands]
        remote = self.run(sent)
        self.probes += 1
        if "PROBED" not in remote["status"]:
            return None
        at = self.commanded_mm()
        return ProbeHit(-1, at, {a.name: a.step_mm for a in self.machine.axes})
