"""fpga-sim:// — 004's FPGA (Amaranth HDL, ``retrofit.fpga``) in simulation, either split of its work.

URL grammar: ``fpga-sim://[?variant=pulse|di&limit_s=SECONDS&clocks_per_tick=K&sim=amaranth|compiled]``.

``variant=pulse`` (the default): the run's port frames are read back into each axis's pulse
records (delay, direction, width: what 004's ARM sends its FPGA). ``variant=di``: the digital
integration runs in the gateware, fed line records made from the run's plan (its step requests,
asked for through ``Output.wants_plan``) and turn records from the frames (``fpga.lines``); a run
without a plan (the circle demo, a run on the 002 controller) is refused. Either way the records
are streamed into the simulated gateware chunk by chunk, and its step/dir pins drive the
simulated machine (drivers, screws, carriages) that the report reads. The pins must equal the
run's frames at every tick, and the engine must end with no underrun and no refused record:
anything else is an error naming the first tick that differs (so a ``vcd://`` output beside it
shows the gateware's pins too).

Amaranth's simulator takes about 6 000 ticks a CPU-second (docs/fpga.md), so a run longer than
``limit_s`` seconds of machine time (default 0.5) is refused before it is simulated (on the
plan's end when the run hands the plan over, else on each chunk's end). ``sim=compiled`` runs the
same gateware compiled (``retrofit.fpga.compiled``: Yosys's CXXRTL and g++, built once into the
cache), 500 to 800 times faster: raise ``limit_s`` with it.
"""

from __future__ import annotations

from ..errors import OutputError
from ..frames import PortFrames
from .sim import SimOutput

#: ticks a record's width can still hold a pulse open: records of events older than this are whole
_OPEN_TICKS = 256


class FpgaSimOutput(SimOutput):
    """fpga-sim:// — the gateware in Amaranth's simulator, its pins driving the simulated machine."""

    scheme = "fpga-sim"
    grammar = "fpga-sim://[?variant=pulse|di&limit_s=SECONDS&clocks_per_tick=K&sim=amaranth|compiled]"
    summary = ("004's FPGA simulated in Amaranth HDL (the pulse engine, or di: the digital integration in it); "
               "its pins checked against the run's and drive sim://")
    options = {"variant": (str, "pulse"), "limit_s": (float, 0.5), "clocks_per_tick": (int, 1),
               "sim": (str, "amaranth")}

    def __init__(self, url, machine):
        super().__init__(url, machine)
        from ..fpga.simulate import VARIANTS
        if self.opts["variant"] not in VARIANTS:
            raise OutputError(f"{url.text}: variant={self.opts['variant']!r} is not one of {', '.join(VARIANTS)}; "
                              f"expected {self.grammar}")
        self.plan = None

    def wants_plan(self) -> bool:
        """Yes: the plan's end is checked against ``limit_s`` before anything is simulated, and
        ``variant=di`` makes its line records of it (a run without one: ``pulse`` only)."""
        return True

    def take_plan(self, plan) -> None:
        if plan is None and self.opts["variant"] == "di":
            raise OutputError(f"{self.url.text}: the digital-integration gateware is fed the run's plan (its "
                              f"step requests as line records) and this run has none (a demo's frames, a run on "
                              f"the 002 controller); use variant=pulse")
        self.plan = plan

    def open(self) -> None:
        if self.is_open:
            return
        from ..fpga.host import RecordCompiler  # lazily: only this output needs Amaranth
        from ..fpga.simulate import GateSim
        k, limit = self.opts["clocks_per_tick"], self.opts["limit_s"]
        if self.opts["sim"] == "compiled":
            from ..fpga.compiled import CompiledSim as GateSim  # noqa: F811 (the same methods)
        if not 1 <= k <= 1000 or not limit > 0 or self.opts["sim"] not in ("amaranth", "compiled"):
            raise OutputError(f"{self.url.text}: clocks_per_tick must be 1..1000, limit_s > 0 and sim amaranth "
                              f"or compiled; "
                              f"expected {self.grammar}")
        self.limit_ticks = round(limit * 1e6 / self.machine.tick_us)
        self.records = self._records(RecordCompiler)
        self.gate = None
        self._make_gate = lambda: GateSim(self.machine, k, variant=self.opts["variant"])
        self.chunks: list[PortFrames] = []
        self.end_tick = 0
        super().open()

    def _records(self, pulse_records):
        """What turns the run into the variant's records: ``feed(frames)``, ``finish(end_tick)``."""
        if self.plan is not None:              # a long run is refused before any record is made
            self._refuse_past_the_bound(round(self.plan.end_s / self.machine.tick_s))
        if self.opts["variant"] == "pulse":
            return pulse_records(self.machine)
        from ..fpga.lines import LineFeed
        if self.plan is None:
            raise OutputError(f"{self.url.text}: opened without the run's plan (outputs.deliver.hand_plan)")
        return LineFeed(self.plan)

    def _refuse_past_the_bound(self, end_tick: int) -> None:
        if end_tick > self.limit_ticks:
            raise OutputError(f"{self.url.text}: the run goes on to tick {end_tick} or later, past the "
                              f"bound of {self.limit_ticks} ticks ({self.opts['limit_s']:g} s of machine time); "
                              f"the simulated gateware takes about 6 000 ticks a CPU-second: raise limit_s "
                              f"(?limit_s=SECONDS) or run on sim://")

    def write(self, frames: PortFrames) -> None:
        self._refuse_past_the_bound(int(frames.end_tick))
        self.gate = self.gate or self._make_gate()
        self.chunks.append(frames)
        self.end_tick = max(self.end_tick, int(frames.end_tick))
        self.gate.add(self.records.feed(frames))
        self.gate.run_to(max(int(frames.end_tick) - _OPEN_TICKS, 0))

    def close(self) -> None:
        if not self.is_open:
            return
        try:
            self._finish()
        finally:
            super().close()

    def _finish(self) -> None:
        import numpy as np

        from ..fpga.simulate import first_difference
        self.gate = self.gate or self._make_gate()
        self.gate.add(self.records.finish(self.end_tick))
        run = self.gate.result(self.end_tick)
        self.run = run
        given = PortFrames(np.concatenate([c.ticks for c in self.chunks] or [np.zeros(0, np.int64)]),
                           np.concatenate([c.values for c in self.chunks] or [np.zeros(0, np.uint8)]),
                           self.end_tick)
        self.sim.feed(run.frames)
        if run.underrun or run.fault:
            raise OutputError(f"{self.url.text}: the gateware stopped at tick {run.fault_tick} "
                              f"({'underrun' if run.underrun else 'a record refused'})")
        diff = first_difference(given, run.frames)
        if diff is not None:
            raise OutputError(f"{self.url.text}: the gateware's pins differ from the run's frames: {diff}")

    def safe_stop(self) -> None:
        """Nothing leaves the simulation: the records not yet simulated are dropped."""
        self.chunks = []
        self.end_tick = 0
        self.is_open = False
