"""The pulse engine in Amaranth's simulator, fed a run's pulse records, its pins recorded as port
frames (what ``fpga-sim://`` and the tests compare with ``sim://``'s frames).

The host model writes one record per clock cycle into whichever FIFO has room (round robin), primes
the FIFOs before the first tick, then sets ``run``. With ``clocks_per_tick`` = K the pins are read
at each tick's clock; tick n is the n-th tick after ``run``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    events: dict = field(default_factory=dict)


def engine_for(machine, clocks_per_tick: int = 1, depth: int = 16) -> PulseEngine:
    """The pulse engine for a machine's axes (their driver timing as guards)."""
    return PulseEngine([AxisTiming.of(a) for a in machine.axes], clocks_per_tick, depth)


def simulate(machine, words: list[list[int]], end_tick: int, clocks_per_tick: int = 1,
             stop_tick: int | None = None, late_feed: dict | None = None, depth: int = 16) -> GateRun:
    """Run the engine for ``end_tick`` ticks on per-axis records ``words``; its pins as frames.

    ``stop_tick`` raises ``stop`` from that tick on; ``late_feed`` = {axis: tick} holds back that
    axis's records after the first until that tick (to provoke an underrun).
    """
    dut = engine_for(machine, clocks_per_tick, depth)
    pins = PinMap(machine)
    n = len(machine.axes)
    queues = [list(w) for w in words]
    heads = [0] * n
    out: dict = {"ticks": [], "values": []}
    status: dict = {}

    top = Module()
    top.submodules.engine = dut
    watch = Signal(3 * n + 2)          # step pins, dir pins, FIFOs with room, underrun, fault: one read
    top.d.comb += watch.eq(Cat(*dut.steps, *dut.dirs, *[a.fifo.w_rdy for a in dut.axes], dut.underrun, dut.fault))

    def feed(ctx, tick: int, seen: int) -> None:
        """Write one record (if any axis has room and something to send) before the next edge."""
        for k in range(n):
            a = (tick + k) % n
            held = late_feed is not None and a in late_feed and heads[a] >= 1 and tick < late_feed[a]
            if heads[a] < len(queues[a]) and not held and seen >> (2 * n + a) & 1:
                ctx.set(dut.wr_axis, a)
                ctx.set(dut.wr_data, queues[a][heads[a]])
                ctx.set(dut.wr_en, 1)
                heads[a] += 1
                return
        ctx.set(dut.wr_en, 0)

    async def bench(ctx):
        for _ in range(depth * n + 2):                   # prime the FIFOs
            feed(ctx, 0, ctx.get(watch))
            await ctx.tick()
        ctx.set(dut.run, 1)
        last, tick, cycle, seen = -1, 0, 0, ctx.get(watch)
        mask_pins, last_pins = (1 << 2 * n) - 1, -1
        while tick < end_tick:
            if stop_tick is not None and tick >= stop_tick:
                ctx.set(dut.stop, 1)
            feed(ctx, tick, seen)
            await ctx.tick()
            seen = ctx.get(watch)
            cycle += 1
            if clocks_per_tick > 1 and (cycle - 1) % clocks_per_tick:
                continue
            if seen & mask_pins != last_pins:
                last_pins = seen & mask_pins
                value = pins.byte([seen >> a & 1 for a in range(n)], [(seen >> (n + a) & 1) * 2 - 1 for a in range(n)])
                if value != last:
                    out["ticks"].append(tick)
                    out["values"].append(value)
                    last = value
            if status.get("fault_tick") is None and seen >> (3 * n):
                status["fault_tick"] = tick
            tick += 1
        status["positions"] = [ctx.get(a.position) for a in dut.axes]
        status["underrun"], status["fault"] = bool(ctx.get(dut.underrun)), bool(ctx.get(dut.fault))
        status["cycles"] = cycle

    sim = Simulator(top)
    sim.add_clock(1e-6 / clocks_per_tick)
    sim.add_testbench(bench)
    sim.run()
    frames = PortFrames(np.array(out["ticks"], np.int64), np.array(out["values"], np.uint8), end_tick)
    return GateRun(frames, status["positions"], status["underrun"], status["fault"], status["cycles"],
                   status.get("fault_tick"))


def first_difference(expected: PortFrames, got: PortFrames) -> str | None:
    """None when two runs' pins are equal at every tick, else where and how they first differ."""
    if expected == got:
        return None
    end = max(expected.end_tick, got.end_tick)
    ticks = np.union1d(expected.ticks, got.ticks)
    for tick in ticks.tolist() + [end]:
        want = expected.value_at(tick) if tick < expected.end_tick else None
        have = got.value_at(tick) if tick < got.end_tick else None
        if want != have:
            fmt = lambda v: "ended" if v is None else f"{v:08b}"
            return f"tick {tick}: reference {fmt(want)}, gateware {fmt(have)}"
    return f"same levels, frames differ (ends {expected.end_tick} / {got.end_tick})"


def gateware_equals(machine, frames: PortFrames, clocks_per_tick: int = 1) -> tuple[GateRun, str | None]:
    """The engine fed the records read from ``frames``: its run, and where its pins first differ."""
    from .host import compile_records
    run = simulate(machine, compile_records(machine, frames), frames.end_tick, clocks_per_tick)
    return run, first_difference(frames, run.frames)
