"""Draws docs/fpga-timing.png: the engraver FPGA's pins as Amaranth's simulator gives them, on a
short stretch of the shipped engraving, with a record's delay, a pulse width and a direction
set-up marked (measured on the simulated pins).

    python docs/fpga_timing.py
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from retrofit.fpga.host import compile_records
from retrofit.fpga.simulate import simulate
from retrofit.frames import PinMap
from retrofit.gcode import compile_program
from retrofit.lab.plot import pyplot, save_figure
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.run.program import plan_compiled

PROGRAM = "G21 G90\nG1 X0.1 Y0.05 F3000\nG1 X0.0 Y0.1\n"


def main(out=Path(__file__).with_name("fpga-timing.png")) -> Path:
    machine = replace(load_machine("engraver"), tick_us=20.0)
    _, plan = plan_compiled(compile_program(PROGRAM, machine, file="timing.ngc"), machine)
    frames = execute_fast(plan).frames
    run = simulate(machine, compile_records(machine, frames), frames.end_tick)
    logical = run.frames.per_tick() ^ PinMap(machine).invert
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(11, 4.2))
    names = []
    for row, axis in enumerate(machine.axes[:2]):
        for k, (kind, bit) in enumerate((("step", axis.step_bit), ("dir", axis.dir_bit))):
            level = (logical >> bit) & 1
            base = 2 * (2 * row + k)
            ax.step(np.arange(len(level)), base + 1.4 * level, where="post", lw=1)
            names.append((base + 0.7, f"{axis.name}.{kind}"))
    x_dir = (logical >> machine.axes[0].dir_bit) & 1
    x_step = (logical >> machine.axes[0].step_bit) & 1
    turn = int(np.flatnonzero(np.diff(x_dir) != 0)[-1] + 1)                # X turns back
    rise = int(turn + np.flatnonzero(x_step[turn:])[0])
    fall = int(rise + np.flatnonzero(x_step[rise:] == 0)[0])
    last = int(np.flatnonzero(np.diff(x_step[:turn]) == 1)[-1] + 1)     # X's last rise before the turn
    ax.annotate("", (last, 3.8), (turn, 3.8), arrowprops=dict(arrowstyle="<->"))
    ax.text(turn + 4, 3.75, f"turn {turn - last} ticks after the rise (hold {machine.axes[0].dir_hold_ticks})", fontsize=8)
    ax.annotate("", (turn, 1.8), (rise, 1.8), arrowprops=dict(arrowstyle="<->"))
    ax.text((turn + rise) / 2, 1.95, f"record (delay {rise - turn}, dir 0, width {fall - rise}): "
            f"set-up {rise - turn} >= {machine.axes[0].dir_setup_ticks} ticks", ha="center", fontsize=8)
    ax.annotate("", (rise, -0.3), (fall, -0.3), arrowprops=dict(arrowstyle="<->"))
    ax.text(fall + 3, -0.45, f"width {fall - rise} ticks", fontsize=8)
    ax.set_xlim(last - 60, rise + 60)
    ax.set_ylim(-0.8, 8)
    ax.set_yticks([y for y, _ in names], [n for _, n in names])
    ax.set_xlabel(f"tick ({machine.tick_us:g} us here; on the board a tick is a whole number of FPGA clocks)")
    ax.set_title("engraver FPGA pins from Amaranth's simulator: X reverses between two pulses")
    return save_figure(fig, out.parent, out.name)


if __name__ == "__main__":
    print("wrote", main())
