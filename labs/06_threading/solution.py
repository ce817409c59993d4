"""Lab 06: thread cutting with the indexer — passes overlaid on one helix, the pitch turn by turn."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from retrofit.commands import IStp, Spin
from retrofit.machine.config import load_machine
from retrofit.controller.program import run_commands
from retrofit.gcode import compile_program
from retrofit.lab.core import pyplot, save_figure
from retrofit.sim import SimMachine

MACHINE = "mitic-lathe"
PITCH = 1.5              # mm a revolution
Z_START = 3.0            # every pass starts here (Q0: no compound angle), 3 mm clear of the work
Z_END = -15.0
PROGRAM = f"""G18 G21 G90
G0 X12 Z{Z_START:g}
S1200 M3
G76 P{PITCH:g} Z{Z_END:g} I-0.5 J0.3 K0.9 R1 H1
G0 X20
"""
#: the spindle speed of each pass, in turn: the passes must cut one helix whatever the speed
SPEEDS = (300.0, 600.0, 1200.0)
#: past the lead-in: 1.9 mm at 1200 rpm on mitic-lathe (v^2 / 2a), with some margin
SKIP_MM = 2.5


def thread_commands(machine, speeds=SPEEDS) -> list:
    """The G76 program as controller commands, with a SPIN before each pass (``speeds`` in turn)."""
    program = compile_program(PROGRAM, machine, "thread.ngc")
    out, k = [], 0
    for cmd in program.commands:
        if cmd == IStp():
            out.append(Spin(speeds[k % len(speeds)], 1))
            k += 1
        out.append(cmd)
    return out


def run_thread(machine, speeds=SPEEDS) -> SimMachine:
    """Cut the thread through the controller on a simulated lathe; return the simulated machine."""
    sim = SimMachine(machine)
    run_commands(thread_commands(machine, speeds), machine, sim=sim)
    return sim


def split_passes(motor_steps, start: int = 0) -> list[list[int]]:
    """The indices of the Z steps of each pass: every run of consecutive steps towards -Z.

    ``motor_steps`` is the Z motor's position after each of its steps; ``start`` where it was before
    the first one.
    """
    passes: list[list[int]] = []
    previous, in_pass = start, False
    for i, steps in enumerate(motor_steps):
        down = steps < previous
        if down and not in_pass:
            passes.append([])
        if down:
            passes[-1].append(i)
        in_pass, previous = down, steps
    return passes


def pass_curves(sim) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per pass: (Z carriage in mm, spindle angle in revolutions) after each of its Z steps."""
    trace = sim.traces["Z"]
    ticks = np.asarray(trace.ticks)
    carriage = np.asarray(trace.carriage_mm)
    curves = []
    for idx in split_passes(trace.motor_steps, 0):            # the lathe starts at Z 0
        curves.append((carriage[idx], sim.spindle.revolutions_at(ticks[idx])))
    return curves


def sync_revolution(z_mm, revs, z_start: float = Z_START, pitch: float = PITCH) -> int:
    """The spindle revolution (an index pulse) at which the pass's helix passes ``z_start``.

    On the helix, ``z = z_start - pitch * (revs - N)``; each sample gives an estimate of N.
    """
    estimates = np.asarray(revs) + (np.asarray(z_mm) - z_start) / pitch
    return int(round(float(np.median(estimates))))


def advance_per_rev(z_mm, revs) -> np.ndarray:
    """How far the carriage travelled in each whole revolution of the spindle, mm (positive)."""
    revs = np.asarray(revs)
    whole = np.arange(math.ceil(revs[0]), math.floor(revs[-1]) + 1)
    at = np.interp(whole, revs, np.asarray(z_mm))
    return -np.diff(at)


def beyond_lead_in(z_mm, revs, skip_mm: float = SKIP_MM):
    """The samples of a pass more than ``skip_mm`` past its start: the lead-in is over there."""
    z_mm, revs = np.asarray(z_mm), np.asarray(revs)
    keep = z_mm < Z_START - skip_mm
    return z_mm[keep], revs[keep]


def helix_error_mm(z_mm, revs, n: int) -> np.ndarray:
    """How far each sample is from the ideal helix through ``Z_START`` at revolution ``n``, mm."""
    return np.asarray(z_mm) - (Z_START - PITCH * (np.asarray(revs) - n))


def plot_passes(machine, curves, out_dir) -> Path:
    """Z against the spindle's turns since each pass's index, all passes overlaid; the error."""
    plt = pyplot()
    step = machine.axis("Z").step_mm
    fig, (path_ax, err_ax) = plt.subplots(2, 1, figsize=(9, 8))
    for k, (z, revs) in enumerate(curves):
        n = sync_revolution(z, revs)
        label = f"pass {k + 1}, {SPEEDS[k % len(SPEEDS)]:g} rpm"
        path_ax.plot(revs - n, z, lw=1.0, label=label)
        err_ax.plot(z, helix_error_mm(z, revs, n) / step, lw=0.8, label=label)
    turns = np.linspace(-1.5, (Z_START - Z_END) / PITCH, 50)
    path_ax.plot(turns, Z_START - PITCH * turns, "k:", lw=0.8, label="the helix")
    path_ax.set_xlabel("spindle turns since the pass's index pulse")
    path_ax.set_ylabel("Z carriage [mm]")
    path_ax.set_title(f"{MACHINE}: G76 P{PITCH:g}, every pass against the spindle's angle")
    err_ax.axvspan(Z_START - SKIP_MM, Z_START, color="0.9", label="lead-in zone")
    err_ax.set_ylim(-3, 1.5)
    err_ax.set_title("each pass's distance from the helix, along the thread (the tool moves right to left)")
    err_ax.set_xlabel("Z carriage [mm]")
    err_ax.set_ylabel("off the helix [steps]")
    err_ax.invert_xaxis()
    for ax in (path_ax, err_ax):
        ax.grid(True, lw=0.3)
    path_ax.legend(fontsize=8, loc="upper right")
    err_ax.legend(fontsize=8, loc="lower right", ncol=2)
    fig.tight_layout()
    return save_figure(fig, out_dir, "passes.png")


def plot_pitch(machine, curves, out_dir) -> Path:
    """The pitch error of every whole revolution past the lead-in, pass by pass."""
    plt = pyplot()
    step_um = machine.axis("Z").step_mm * 1000.0
    fig, ax = plt.subplots(figsize=(9, 4.5))
    every = []
    for k, (z, revs) in enumerate(curves):
        advance = advance_per_rev(*beyond_lead_in(z, revs))
        every.extend(advance)
        ax.plot(np.arange(1, len(advance) + 1), (advance - PITCH) * 1000.0, "o-", ms=4,
                label=f"pass {k + 1}, {SPEEDS[k % len(SPEEDS)]:g} rpm")
    for sign in (1, -1):
        ax.axhline(sign * step_um, color="gray", ls="--", lw=0.8, label="one step" if sign > 0 else None)
    ax.set_xlabel("whole revolution past the lead-in")
    ax.set_ylabel("advance - pitch [µm]")
    ax.set_title(f"pitch error: mean advance {np.mean(every):.5f} mm a revolution, programmed {PITCH:g}")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "pitch_error.png")


def main(out_dir="out") -> list[Path]:
    """Cut the thread, overlay the passes, and measure the pitch turn by turn."""
    machine = load_machine(MACHINE)
    sim = run_thread(machine)
    curves = pass_curves(sim)
    step = machine.axis("Z").step_mm
    for k, (z, revs) in enumerate(curves):
        n = sync_revolution(z, revs)
        zs, rs = beyond_lead_in(z, revs)
        error = helix_error_mm(zs, rs, n) / step
        advance = advance_per_rev(zs, rs)
        print(f"pass {k + 1} at {SPEEDS[k % len(SPEEDS)]:g} rpm: index {n}, off the helix "
              f"{error.min():+.2f}..{error.max():+.2f} steps, {len(advance)} turns of "
              f"{advance.mean():.5f} mm on average")
    return [plot_passes(machine, curves, out_dir), plot_pitch(machine, curves, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
