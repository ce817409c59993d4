"""Lab 05 (your file): acceleration and lost steps — how steep a ramp the stepper can follow, from its torque curve."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from retrofit.commands import PMov
from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.sim import SimMachine

MACHINE_FILE = Path(__file__).resolve().parent / "engraver-x.toml"
DISTANCE_MM = 40.0
RAMPS_MM_S2 = [500, 1000, 2000, 4000, 6000, 8000, 12000, 20000, 40000]


def with_ramp(machine, accel_mm_s2: float, profile: str = "trapezoid"):
    """The machine with every axis's ``max_accel_mm_s2`` set to the ramp, and the planner's profile."""
    # TODO 1 (README, task 1): the hints there open one at a time.
    raise NotImplementedError("TODO 1: write with_ramp(machine, accel_mm_s2, profile): a machine with that ramp")


def run_move(machine, distance_mm: float = DISTANCE_MM):
    """One move of X from 0 to ``distance_mm`` at the machine's feed: planned, stepped, simulated: (log, sim)."""
    plan = plan_program([PMov((("X", distance_mm),))], machine)
    log = execute_fast(plan)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


def position_error_mm(machine, log, sim) -> float:
    """How far the X motor ended behind the steps sent to it, in mm (0 when no step was lost)."""
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write position_error_mm(machine, log, sim): how far the motor is behind")


def motor_ramp_limit(machine, speed_mm_s: float) -> float:
    """The steepest ramp (mm/s²) the X motor can follow at this speed: (T(speed) - T_load) / J."""
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write motor_ramp_limit(machine, speed_mm_s): from the torque curve")


def sweep(machine, profile: str) -> list[float]:
    """Position error after the move for every ramp of RAMPS_MM_S2."""
    return [position_error_mm(m, *run_move(m)) for m in (with_ramp(machine, a, profile) for a in RAMPS_MM_S2)]


def plot_sweep(machine, errors: dict, out_dir) -> Path:
    """Position error against the ramp, for each profile, with the motor's limits marked."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for profile, values in errors.items():
        ax.plot(RAMPS_MM_S2, values, "o-", label=f"{profile} ramp")
    cruise = machine.axis("X").max_velocity_mm_s
    for speed, style in ((0.0, ":"), (cruise, "--")):
        ax.axvline(motor_ramp_limit(machine, speed), color="gray", ls=style,
                   label=f"motor limit at {speed:g} mm/s: {motor_ramp_limit(machine, speed):.0f} mm/s²")
    ax.set_xscale("log")
    ax.set_xlabel("ramp: the planner's acceleration [mm/s²]")
    ax.set_ylabel("motor behind the steps sent [mm]")
    ax.set_title(f"{machine.name}: {DISTANCE_MM:g} mm move at {cruise:g} mm/s")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "error_vs_ramp.png")


def plot_runs(machine, ramps, out_dir) -> Path:
    """For a gentle and a steep ramp: the step rate sent, and how far the motor falls behind."""
    plt = pyplot()
    fig, (rate_ax, lag_ax) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    spm = machine.axis("X").steps_per_mm
    for accel in ramps:
        m = with_ramp(machine, accel)
        log, sim = run_move(m)
        trace = sim.traces["X"]
        t_ms = [tick * m.tick_us / 1000 for tick in trace.ticks]
        rates = [1e3 / (b - a) / spm if b > a else 0 for a, b in zip(t_ms, t_ms[1:])]
        rate_ax.plot(t_ms[1:], rates, lw=0.8, label=f"{accel:g} mm/s²")
        lag_ax.plot(t_ms, [(k + 1 - s) / spm for k, s in enumerate(trace.motor_steps)], lw=1.0,
                    label=f"{accel:g} mm/s²")
    rate_ax.axhline(machine.sim.motors["X"].max_rate_steps_s() / spm, color="gray", ls="--",
                    label="the motor's top speed (torque = load)")
    rate_ax.set_ylabel("speed of the pulses [mm/s]")
    rate_ax.set_title(f"{machine.name}: a {DISTANCE_MM:g} mm move with a gentle and a steep ramp")
    rate_ax.legend(fontsize=8, loc="center")
    lag_ax.set_title("how far the motor falls behind the pulses sent")
    lag_ax.set_ylabel("steps sent - motor [mm]")
    lag_ax.set_xlabel("time [ms]")
    for ax in (rate_ax, lag_ax):
        ax.grid(True, lw=0.3)
    return save_figure(fig, out_dir, "ramps.png")


def plot_motor_limit(machine, out_dir) -> Path:
    """The ramp the motor can follow at each speed, from its torque curve, against constant ramps."""
    plt = pyplot()
    top = machine.sim.motors["X"].max_rate_steps_s() / machine.axis("X").steps_per_mm
    speeds = [top * k / 200 for k in range(201)]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(speeds, [motor_ramp_limit(machine, v) for v in speeds], lw=2, label="what the motor can follow")
    for accel in (4000, 8000):
        ax.axhline(accel, ls="--", lw=0.8, color="gray")
        ax.text(top * 0.98, accel, f"trapezoid ramp {accel} mm/s²", ha="right", va="bottom", fontsize=8)
    ax.axvline(machine.axis("X").max_velocity_mm_s, color="tab:red", lw=0.8, label="the move's cruise speed")
    ax.set_xlabel("speed [mm/s]")
    ax.set_ylabel("acceleration [mm/s²]")
    ax.set_title("(pull-out torque - load) / inertia, along the torque curve")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "motor_limit.png")


def main(out_dir="out") -> list[Path]:
    """Sweep the ramps with both profiles; plot the error, and a gentle and a steep run."""
    machine = load_machine(MACHINE_FILE)
    errors = {profile: sweep(machine, profile) for profile in ("trapezoid", "exponential")}
    for profile, values in errors.items():
        print(f"{profile}: " + ", ".join(f"{a:g} mm/s² -> {e:.3f} mm" for a, e in zip(RAMPS_MM_S2, values)))
    return [plot_sweep(machine, errors, out_dir), plot_runs(machine, (4000, 8000), out_dir),
            plot_motor_limit(machine, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
