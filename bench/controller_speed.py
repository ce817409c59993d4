"""Speed of the 002 controller, measured in one run: the readable per-tick path vs the compiled loop.

Machine-seconds simulated per CPU-second, for the programs that must run through the controller
(threads under the indexer, homing against switches) and a job that mixes a G76 thread with G1
turning, on mitic-lathe (as shipped: 100 us tick, Bresenham) and chivu-lathe (50 us tick, 004's
digital integration; it has no spindle of its own, so it gets mitic-lathe's [spindle] section).
Each program runs twice on its own simulated machine -- ``kernels=False`` (every tick in Python,
the reference) and the default -- and the two must give the same port frames.

    python bench/controller_speed.py [--quick]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from retrofit.commands import ZMov
from retrofit.controller import Controller
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.sim import SimMachine

G76 = "G18 G21 G90\nG0 X12 Z3\nS600 M3\nG76 P1.5 Z-{z} I-0.5 J0.25 K0.92 R1.5 Q0 H2\nG0 X20\nM5\n"
G33 = "G18 G21 G90\nG0 X12 Z3\nS1200 M3\nG33 Z-{z} K1.0\nG0 X14\nM5\n"
TURNING = "G1 X11 Z2 F300\nG1 Z-{z} F120\nG1 X12.5 Z-{z2} F90\nG1 X14\nG0 Z3\n"


def mix(z: float, rounds: int) -> str:
    """A job of ``rounds`` x (a G76 thread, then a G1 turning pass of the next diameter)."""
    text = "G18 G21 G90\nG0 X14 Z3\nS600 M3\n"
    for _ in range(rounds):
        text += f"G0 X12 Z3\nG76 P1.5 Z-{z} I-0.5 J0.25 K0.92 R1.5 Q0 H2\nG0 X14\n"
        text += TURNING.format(z=z, z2=z + 1.0)
    return text + "M5\n"


def lathes():
    mitic = load_machine("mitic-lathe")
    chivu = load_machine("chivu-lathe")
    chivu = replace(chivu, parts={**chivu.parts, "spindle": mitic.parts["spindle"]})
    return mitic, chivu


def timed(machine, commands, kernels: bool):
    """(CPU seconds, controller) of one run to the end on a fresh simulated machine."""
    ctl = Controller(machine, sim=SimMachine(machine), kernels=kernels)
    start = time.process_time()
    ctl.stream(commands)
    ctl.run_until_idle(2_000_000_000)
    return time.process_time() - start, ctl


def row(name: str, machine, commands) -> None:
    t_ref, ref = timed(machine, commands, kernels=False)
    t_fast, fast = timed(machine, commands, kernels=True)
    assert fast.frames() == ref.frames() and fast.fault is None, name
    machine_s = fast.ticks * machine.tick_s
    share = fast.spans.ticks / fast.ticks
    print(f"  {name:<34} {machine_s:7.1f} s  {machine_s / t_ref:9.1f}  {machine_s / t_fast:9.1f}"
          f"  {t_ref / t_fast:6.1f}x  {share:6.1%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter programs (a smoke run)")
    quick = parser.parse_args().quick
    compiled()
    mitic, chivu = lathes()
    z = 6 if quick else 12
    programs = [("G76 mitic-lathe", mitic, G76.format(z=z)), ("G76 chivu-lathe (DDA, 50 us)", chivu, G76.format(z=z)),
                ("G33 mitic-lathe", mitic, G33.format(z=30 if quick else 150)),
                ("G76 + G1 mix mitic-lathe", mitic, mix(z, 1 if quick else 3)),
                ("G76 + G1 mix chivu-lathe", chivu, mix(z, 1 if quick else 3))]
    timed(mitic, compile_program(G33.format(z=2), mitic, "warm.ngc").commands, True)   # load the kernels
    print("machine-seconds per CPU-second, readable per-tick controller vs compiled tick loop")
    print(f"  {'program':<34} {'machine':>9}  {'per-tick':>9}  {'compiled':>9}  {'ratio':>7}  compiled ticks")
    for name, machine, text in programs:
        row(name, machine, compile_program(text, machine, "bench.ngc").commands)
    row("ZMOV homing mitic-lathe (from 0, 0)", mitic, [ZMov()])


if __name__ == "__main__":
    main()
