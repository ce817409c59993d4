"""The pulse engine in Amaranth's simulator, fed a run's pulse records, its pins recorded as port
frames (what ``fpga-sim://`` and the tests compare with ``sim://``'s frames).

The host model writes one record per clock cycle into whichever FIFO has room (round robin),
primes the FIFOs before the first tick, then sets ``run``. With ``clocks_per_tick`` = K the pins
are read at each tick's clock; tick n is the n-th tick after ``run``. Records can be added while
the simulation runs (:meth:`GateSim.add`, then :meth:`GateSim.run_to`), so a streamed run is
simulated chunk by chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from amaranth.hdl import Cat, Module, Signal
from amaranth.sim import Simulator

from ..frames import PinMap, PortFrames
from .engine import AxisTiming, PulseEngine


@dataclass
class GateRun:
    """What the simulated gateware did: its pins as port frames and its status at the end."""

    frames: PortFrames
    positions: list[int]
    underrun: bool = False
    fault: bool = False
    cycles: int = 0
    fault_tick: int | None = None


#: the two splits of 004's work: ``pulse`` (a record per pulse) and ``di`` (line records, the
#: digital integration in the gateware: ``retrofit.fpga.di``)
VARIANTS = ("pulse", "di")


def engine_for(machine, clocks_per_tick: int = 1, depth: int = 16, variant: str = "pulse"):
    """The engine of ``variant`` for a machine's axes (their driver timing as guards)."""
    timings = [AxisTiming.of(a) for a in machine.axes]
    if variant == "di":
        from .di import DiEngine
        return DiEngine(timings, [a.pulse_high_ticks for a in machine.axes], clocks_per_tick, depth)
    return PulseEngine(timings, clocks_per_tick, depth)


class GateSim:
    """One simulated engine, its host model and the record of its pins, run tick range by range.

    ``stop_tick`` raises ``stop`` from that tick on; ``late_feed`` = {axis: tick} holds back that
    axis's records after the first until that tick (to provoke an underrun).
    """

    def __init__(self, machine, clocks_per_tick: int = 1, stop_tick: int | None = None,
                 late_feed: dict | None = None, depth: int = 16, variant: str = "pulse"):
        self.dut = dut = engine_for(machine, clocks_per_tick, depth, variant)
        self.pins, self.n, self.k = PinMap(machine), len(machine.axes), clocks_per_tick
        self.nq = nq = len(dut.w_rdys)          # the FIFOs the host writes (per axis, or time/line/turn)
        self.stop_tick, self.late_feed, self.depth = stop_tick, late_feed or {}, depth
        self.queues: list[list[int]] = [[] for _ in range(nq)]
        self.heads = [0] * nq
        self.ticks: list[int] = []
        self.values: list[int] = []
        self.tick, self.cycles, self.fault_tick = 0, 0, None
        self._limit = 0
        top = Module()
        top.submodules.engine = dut
        self.watch = Signal(2 * self.n + nq + 2)   # step pins, dir pins, FIFOs with room, underrun, fault
        top.d.comb += self.watch.eq(Cat(*dut.steps, *dut.dirs, *dut.w_rdys, dut.underrun, dut.fault))
        self.sim = Simulator(top)
        self.sim.add_clock(1e-6 / clocks_per_tick)
        self.sim.add_testbench(self._bench)
        self.status: dict = {}

    def add(self, words: list[list[int]]) -> None:
        """More records per axis (they follow the ones already given)."""
        for queue, more in zip(self.queues, words):
            queue.extend(more)

    def run_to(self, end_tick: int) -> None:
        """Simulate until the pins of ticks before ``end_tick`` are recorded."""
        self._limit = max(self._limit, end_tick)
        while self.tick < self._limit:
            self.sim.advance()

    def result(self, end_tick: int) -> GateRun:
        """The pins of ticks 0..end_tick-1 as frames, and the engine's status."""
        self.run_to(end_tick)
        frames = PortFrames(np.array(self.ticks, np.int64), np.array(self.values, np.uint8), end_tick)
        s = self.status
        return GateRun(frames, s["positions"], s["underrun"], s["fault"], s["cycles"], self.fault_tick)

    def _feed(self, ctx, tick: int, seen: int) -> None:
        """Write one record (if any axis has room and something to send) before the next edge."""
        dut, n, nq = self.dut, self.n, self.nq
        for k in range(nq):
            a = (tick + k) % nq
            held = a in self.late_feed and self.heads[a] >= 1 and tick < self.late_feed[a]
            if self.heads[a] < len(self.queues[a]) and not held and seen >> (2 * n + a) & 1:
                ctx.set(dut.wr_axis, a)
                ctx.set(dut.wr_data, self.queues[a][self.heads[a]])
                ctx.set(dut.wr_en, 1)
                self.heads[a] += 1
                return
        ctx.set(dut.wr_en, 0)

    async def _bench(self, ctx):
        dut, n, k = self.dut, self.n, self.k
        for _ in range(self.depth * self.nq + 2):             # prime the FIFOs
            self._feed(ctx, 0, ctx.get(self.watch))
            await ctx.tick()
        ctx.set(dut.run, 1)
        last, seen, last_pins, mask_pins = -1, ctx.get(self.watch), -1, (1 << 2 * n) - 1
        while True:
            if self.stop_tick is not None and self.tick >= self.stop_tick:
                ctx.set(dut.stop, 1)
            self._feed(ctx, self.tick, seen)
            await ctx.tick()
            seen = ctx.get(self.watch)
            self.cycles += 1
            if k > 1 and (self.cycles - 1) % k:
                continue
            if seen & mask_pins != last_pins:
                last_pins = seen & mask_pins
                value = self.pins.byte([seen >> a & 1 for a in range(n)],
                                       [(seen >> (n + a) & 1) * 2 - 1 for a in range(n)])
                if value != last:
                    self.ticks.append(self.tick)
                    self.values.append(value)
                    last = value
            if self.fault_tick is None and seen >> (2 * n + self.nq):
                self.fault_tick = self.tick
            self.tick += 1
            self.status = {"positions": [ctx.get(a.position) for a in dut.axes],
                           "underrun": bool(seen >> (2 * n + self.nq) & 1),
                           "fault": bool(seen >> (2 * n + self.nq + 1) & 1),
                           "cycles": self.cycles} if self.tick == self._limit else self.status


def simulate(machine, words: list[list[int]], end_tick: int, clocks_per_tick: int = 1,
             stop_tick: int | None = None, late_feed: dict | None = None, depth: int = 16,
             variant: str = "pulse") -> GateRun:
    """Run the engine for ``end_tick`` ticks on records ``words`` (per FIFO); its pins as frames."""
    gate = GateSim(machine, clocks_per_tick, stop_tick, late_feed, depth, variant)
    gate.add(words)
    return gate.result(end_tick)


def first_difference(expected: PortFrames, got: PortFrames) -> str | None:
    """None when two runs' pins are equal at every tick, else where and how they first differ."""
    if expected == got:
        return None
    end = max(expected.end_tick, got.end_tick)
    for tick in np.union1d(expected.ticks, got.ticks).tolist() + [end]:
        want = expected.value_at(tick) if tick < expected.end_tick else None
        have = got.value_at(tick) if tick < got.end_tick else None
        if want != have:
            shown = ["ended" if v is None else f"{v:08b}" for v in (want, have)]
            return f"tick {tick}: reference {shown[0]}, gateware {shown[1]}"
    return f"same levels, frames differ (ends {expected.end_tick} / {got.end_tick})"


def gateware_equals(machine, frames: PortFrames, clocks_per_tick: int = 1) -> tuple[GateRun, str | None]:
    """The engine fed the records read from ``frames``: its run, and where its pins first differ."""
    from .host import compile_records
    run = simulate(machine, compile_records(machine, frames), frames.end_tick, clocks_per_tick)
    return run, first_difference(frames, run.frames)


def di_equals(plan, frames: PortFrames, clocks_per_tick: int = 1) -> tuple[GateRun, str | None]:
    """The digital-integration engine fed ``plan``'s line records: its run, and where its pins
    first differ from ``frames`` (the plan's run)."""
    from .lines import compile_lines
    run = simulate(plan.machine, compile_lines(plan, frames), frames.end_tick, clocks_per_tick, variant="di")
    return run, first_difference(frames, run.frames)
