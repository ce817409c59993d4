"""The engraver's FPGA pulse engine in Amaranth's simulator: how fast it simulates, and the step
rate it sustains, measured on its simulated pins.

1. Simulation speed: ticks of the 3-axis engine a CPU-second, on 30 000 ticks of the shipped
   engraving (the engraver's 1 us tick), one FPGA clock a tick.
2. Step rate: every axis fed records as fast as its driver timing allows (a rise every
   high + low ticks), four FPGA clocks a tick so the host model keeps the FIFOs full; the rises
   counted on the pins over 20 000 ticks, per axis and in all, for the engraver's timing
   (5 + 5 us) and for the shortest (1 + 1 tick), beside the SPI bus's bound at a quarter of
   the board's clock.
3. The compiled simulation (``retrofit.fpga.compiled``: Yosys's CXXRTL, g++): its build from an
   empty cache (Amaranth, Yosys and g++, CPU-seconds with the children's), then the whole
   engraving on each variant: CPU-seconds, clock cycles a CPU-second, pins equal to sim://'s.

    python bench/fpga_speed.py
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import replace
from importlib import resources

import numpy as np

from retrofit.fpga.board import CLOCK_HZ
from retrofit.fpga.host import compile_records
from retrofit.fpga.record import pack
from retrofit.fpga.simulate import first_difference, simulate
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.run.program import plan_compiled

TICKS = 20_000


def engraving(machine):
    text = (resources.files("retrofit") / "examples" / "engraving.ngc").read_text()
    _, plan = plan_compiled(compile_program(text, machine, file="engraving.ngc"), machine)
    return plan, execute_fast(plan).frames


def sim_speed(machine) -> None:
    _, frames = engraving(machine)
    end = 30_000
    lo = int(np.searchsorted(frames.ticks, end))
    from retrofit.frames import PortFrames
    part = PortFrames(frames.ticks[:lo], frames.values[:lo], end)
    words = compile_records(machine, part)
    start = time.process_time()
    run = simulate(machine, words, end)
    cpu = time.process_time() - start
    same = first_difference(part, run.frames) is None
    print(f"simulation: {end} ticks in {cpu:.1f} s of CPU = {end / cpu:,.0f} ticks/s "
          f"({end / cpu * machine.tick_us * 1e-6:.4f} s of machine time a CPU-second); pins equal: {same}")
    print(f"  the whole engraving ({frames.end_tick:,} ticks) would take about "
          f"{frames.end_tick / (end / cpu) / 3600:.1f} h")


def step_rate(machine, high: int, low: int) -> None:
    axes = tuple(replace(a, pulse_high_ticks=high, pulse_low_ticks=low) for a in machine.axes)
    machine = replace(machine, axes=axes)
    period = high + low
    n = TICKS // period + 2
    first = max(a.dir_setup_ticks for a in axes)                  # the set-up after the turn
    words = [[pack(1, 1, 0), pack(first, 1, high)] + [pack(period, 1, high)] * n for _ in axes]
    run = simulate(machine, words, TICKS, clocks_per_tick=4)
    per_tick = run.frames.per_tick()
    rises = []
    for a in machine.axes:
        bit = (per_tick >> a.step_bit) & 1
        rises.append(int(np.sum(np.diff(bit.astype(int)) == 1)))
    seconds = TICKS * machine.tick_us * 1e-6
    rates = [r / seconds for r in rises]
    print(f"step rate with {high} + {low} ticks high + low: per axis "
          f"{', '.join(f'{r / 1e3:.0f} k' for r in rates)} steps/s, {sum(rates) / 1e3:.0f} k in all; "
          f"underrun {run.underrun}, fault {run.fault}")


def cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def compiled_speed(machine) -> None:
    from retrofit.fpga.compiled import CompiledSim
    from retrofit.fpga.lines import compile_lines
    plan, frames = engraving(machine)
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp()        # an empty cache: the build is measured
    for variant in ("pulse", "di"):
        start = cpu()
        gate = CompiledSim(machine, variant=variant)
        built = cpu()
        words = compile_lines(plan, frames) if variant == "di" else compile_records(machine, frames)
        made = cpu()
        gate.add(words)
        run = gate.result(frames.end_tick)
        done = cpu()
        same = first_difference(frames, run.frames) is None
        print(f"compiled, {variant}: build {built - start:.1f} CPU-s; records {made - built:.1f} CPU-s; the whole "
              f"engraving ({frames.end_tick:,} ticks) {done - made:.1f} CPU-s = {run.cycles / (done - made):,.0f} "
              f"cycles/s; pins equal: {same}")


def main() -> None:
    machine = load_machine("engraver")
    compiled_speed(machine)
    sim_speed(machine)
    step_rate(machine, 5, 5)
    step_rate(machine, 1, 1)
    spi_hz = CLOCK_HZ / 4
    print(f"SPI bus at {spi_hz / 1e6:g} MHz (a quarter of {CLOCK_HZ / 1e6:g} MHz): {spi_hz / 32 / 1e3:.0f} k "
          f"records/s shared by the axes (one a step, one more a turn)")


if __name__ == "__main__":
    main()
