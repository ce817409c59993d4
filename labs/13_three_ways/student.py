"""Lab 13 (your file): the same motion three ways — a tick loop in Python, gateware in simulation, and the firmware."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from amaranth.hdl import Elaboratable, Module, Signal
from amaranth.sim import Simulator

from retrofit.machine.config import load_machine
from retrofit.frames import PinMap
from retrofit.gcode import compile_program
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.execute import execute_reference
from retrofit.run.program import plan_compiled

MACHINE = "engraver"
TICK_US = 20.0            # a coarse tick keeps the gateware's simulation short (the engraver's is 1 us)
PROGRAM = "G21 G90\nG1 X0.1 Y0.05 F3000\nG1 X0.05 Y0.1\n"
SINCE_TOP = (1 << 17) - 1  # where the delay counter stops counting


class DelayCounter(Elaboratable):
    """One axis of the engraver's FPGA: it takes pulse records and makes the step and direction pins.

    A record is (delay, dir, width): ``delay`` ticks after the axis's last event (the first counts
    from tick 0) the direction pin takes ``dir`` and, if ``width`` > 0, the step pin goes high for
    ``width`` ticks. The record waits at the input (``valid``, ``delay``, ``dir``, ``width``) until
    the counter takes it (``ready`` high in that clock cycle). One clock cycle is one tick: the
    pins after the n-th clock edge are those of tick n.
    """

    def __init__(self):
        self.valid = Signal()           # a record waits at the input
        self.delay = Signal(16)
        self.dir = Signal()
        self.width = Signal(8)
        self.ready = Signal()           # out: the record is taken (it fires) in this cycle
        self.step = Signal()            # out: the step pin
        self.dir_pin = Signal()         # out: the direction pin
        self.since = Signal(17)         # ticks from the last event to the tick computed next
        self.high = Signal(8)           # ticks the step pin still stays high

    def elaborate(self, platform):
        m = Module()
        fire = self.delay_counter(m)
        self.width_counter(m, fire)
        return m

    def delay_counter(self, m: Module) -> Signal:
        """The record fires when ``since`` equals its delay: taken, the direction set, ``since``
        back to 1 (the next tick is one after this event); else ``since`` counts up to SINCE_TOP."""
        # TODO 1 (README, task 1): the hints there open one at a time.
        raise NotImplementedError("TODO 1: write DelayCounter.delay_counter(m): the delay counter and the fire signal")

    def width_counter(self, m: Module, fire: Signal) -> None:
        """A firing record with a width loads ``high``; otherwise ``high`` counts down to 0; the
        step pin is high while ``high`` is not 0."""
        # TODO 2 (README, task 2): the hints there open one at a time.
        raise NotImplementedError("TODO 2: write DelayCounter.width_counter(m, fire): the width counter and the step pin")


def records_of(step: list[int], direction: list[int]) -> list[tuple[int, int, int]]:
    """The processor's side: one axis's pins tick by tick turned into its records (delay, dir, width).

    An event is a rising edge of the step pin (its record carries the direction at that tick and
    the pulse's width, known at the falling edge) or a change of the direction pin alone. A pulse
    still high at the end is closed there. Delays count from the last event (the first from tick 0).
    """
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write records_of(step, direction): one axis's pins into records")


def run_gateware(records, ticks: int) -> dict[str, list[int]]:
    """Simulate a DelayCounter fed ``records`` for ``ticks`` ticks: its pins, its counters, and the
    tick each record was taken."""
    dut = DelayCounter()
    out = {"step": [], "dir": [], "since": [], "high": [], "taken": []}

    async def bench(ctx):
        i = 0
        for tick in range(ticks):
            if i < len(records):
                delay, d, width = records[i]
                ctx.set(dut.valid, 1)
                ctx.set(dut.delay, delay)
                ctx.set(dut.dir, d)
                ctx.set(dut.width, width)
            else:
                ctx.set(dut.valid, 0)
            took = ctx.get(dut.ready)
            await ctx.tick()
            if took:
                out["taken"].append(tick)
                i += 1
            for name, sig in (("step", dut.step), ("dir", dut.dir_pin), ("since", dut.since), ("high", dut.high)):
                out[name].append(ctx.get(sig))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return out


def reference_pins(program: str = PROGRAM, tick_us: float = TICK_US):
    """Way one: the tick loop in Python (retrofit's reference path): every axis's step and
    direction pins tick by tick, {"X": (step, dir), ...}, and the machine."""
    machine = replace(load_machine(MACHINE), tick_us=tick_us)
    _, plan = plan_compiled(compile_program(program, machine, file="lab13.ngc"), machine)
    per_tick = execute_reference(plan).frames.per_tick()
    pins, pins_of = PinMap(machine), {}
    for k, axis in enumerate(machine.axes):
        decoded = [pins.decode(int(v)) for v in per_tick]
        pins_of[axis.name] = ([s[k] for s, _ in decoded], [1 if d[k] > 0 else 0 for _, d in decoded])
    return pins_of, machine


def plot_two_ways(out_dir) -> Path:
    """X and Y step/dir pins: the Python tick loop above, the gateware below (the same when right)."""
    plt = pyplot()
    ref, machine = reference_pins()
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(11, 6))
    for ax, way in zip(axes, ("tick loop in Python (reference path)", "gateware in simulation (your DelayCounter)")):
        for row, name in enumerate(("X", "Y")):
            step, direction = ref[name]
            if way.startswith("gateware"):
                got = run_gateware(records_of(step, direction), len(step))
                step, direction = got["step"], got["dir"]
            ax.step(range(len(step)), [3 * row + 1.4 * v for v in step], where="post", lw=1, label=f"{name}.step")
            ax.step(range(len(step)), [3 * row + 1.6 + 0.8 * v for v in direction], where="post", lw=1,
                    label=f"{name}.dir")
        ax.set_title(way)
        ax.set_yticks([0.7, 2.0, 3.7, 5.0], ["X.step", "X.dir", "Y.step", "Y.dir"])
        ax.legend(loc="upper right", fontsize=7, ncol=4)
    axes[-1].set_xlabel(f"tick ({TICK_US:g} us)")
    fig.suptitle(f"{machine.name}: the same motion two ways, pin for pin")
    return save_figure(fig, out_dir, "two_ways.png")


def plot_counters(out_dir) -> Path:
    """The delay and width counters of X over its first pulses."""
    plt = pyplot()
    ref, _ = reference_pins()
    step, direction = ref["X"]
    records = records_of(step, direction)[:6]
    end = sum(d for d, _, _ in records) + 15
    got = run_gateware(records, end)
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 6))
    axes[0].step(range(end), got["since"], where="post")
    axes[0].set_ylabel("since")
    axes[0].set_title("delay counter: ticks since the last event")
    axes[1].step(range(end), got["high"], where="post", color="tab:orange")
    axes[1].set_ylabel("high")
    axes[1].set_title("width counter: step-high ticks still to come")
    axes[2].step(range(end), got["step"], where="post", color="tab:green", label="X.step")
    axes[2].step(range(end), [1.2 + 0.5 * d for d in got["dir"]], where="post", color="tab:red", label="X.dir")
    for tick in got["taken"]:
        axes[2].axvline(tick, color="grey", lw=0.5, ls=":")
    axes[2].set_ylabel("pins")
    axes[2].set_title("pins; dotted: a record taken")
    axes[2].set_xlabel("tick")
    axes[2].legend(loc="upper right", fontsize=8)
    return save_figure(fig, out_dir, "counters.png")


def main(out_dir="out") -> list[Path]:
    return [plot_two_ways(out_dir), plot_counters(out_dir)]


if __name__ == "__main__":
    for path in main():
        print("wrote", path)
