"""fpga-sim:// — 004's FPGA pulse engine (Amaranth HDL, ``retrofit.fpga``) in simulation.

URL grammar: ``fpga-sim://[?limit_s=SECONDS&clocks_per_tick=K&sim=amaranth|compiled]``.

The run's port frames are read back into each axis's pulse records (delay, direction, width:
what 004's ARM sends its FPGA), streamed into the simulated gateware chunk by chunk, and the
gateware's step/dir pins drive the simulated machine (drivers, screws, carriages) that the
report reads. The pins must equal the run's frames at every tick, and the engine must end with
no underrun and no refused record: anything else is an error naming the first tick that differs
(so a ``vcd://`` output beside it shows the gateware's pins too).

Amaranth's simulator takes about 6 000 ticks a CPU-second (docs/fpga.md), so a run longer than
``limit_s`` seconds of machine time (default 0.5) is refused before it is simulated.
``sim=compiled`` runs the same gateware compiled (``retrofit.fpga.compiled``: Yosys's CXXRTL and
g++, built once into the cache), 500 to 800 times faster: raise ``limit_s`` with it.
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
    grammar = "fpga-sim://[?limit_s=SECONDS&clocks_per_tick=K&sim=amaranth|compiled]"
    summary = "004's FPGA pulse engine simulated in Amaranth HDL; its pins checked against the run's and drive sim://"
    options = {"limit_s": (float, 0.5), "clocks_per_tick": (int, 1), "sim": (str, "amaranth")}

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
        self.records = RecordCompiler(self.machine)
        self.gate = None
        self._make_gate = lambda: GateSim(self.machine, k)
        self.chunks: list[PortFrames] = []
        self.end_tick = 0
        super().open()

    def write(self, frames: PortFrames) -> None:
        if frames.end_tick > self.limit_ticks:
            raise OutputError(f"{self.url.text}: the run goes on to tick {frames.end_tick} or later, past the "
                              f"bound of {self.limit_ticks} ticks ({self.opts['limit_s']:g} s of machine time); "
                              f"the simulated gateware takes about 6 000 ticks a CPU-second: raise limit_s "
                              f"(?limit_s=SECONDS) or run on sim://")
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
