"""Lab 01 (your file): the lathe paper's circle — the commanded path against the path the carriage takes."""

from __future__ import annotations

import math
from pathlib import Path

from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.run.plot import carriage_path
from retrofit.sim import SimMachine

MACHINE = "chivu-lathe"
RADIUS_MM = 15.0
POINTS = 100


def calc_next_input(n: int, kt: float, kl: float, radius_mm: float = RADIUS_MM,
                    points: int = POINTS) -> tuple[int, int]:
    """Point ``n`` of the circle in whole steps: (transversal X, longitudinal Z), as CalcNextInput.

    ``kt`` and ``kl`` are the steps per mm of the transversal and longitudinal axes (KT, KL).
    """
    # TODO 1 (README, task 1): the hints there open one at a time.
    raise NotImplementedError("TODO 1: write calc_next_input(n, kt, kl): point n of the circle in steps")


def circle_targets(machine, radius_mm: float = RADIUS_MM, points: int = POINTS) -> list[tuple[int, int]]:
    """Every target of the circle in turn, as (X steps, Z steps): points 0, 1, ..., ``points``."""
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write circle_targets(machine): the list of targets in steps")


def drive(machine, targets, backlash_comp: bool = True):
    """Run the paper's position-error loop through the targets and a simulated lathe: (log, sim)."""
    log = PositionErrorLoop(machine, backlash_comp=backlash_comp).run(targets)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


def carriage_errors(machine, log, sim) -> dict[str, list[float]]:
    """Per axis, how far (mm) the carriage is from the commanded target when each target is reached."""
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write carriage_errors(machine, log, sim): error per axis at each reached target")


def plot_paths(machine, runs: dict, out_dir) -> Path:
    """Commanded points and carriage paths, whole circle and a zoom where X turns round."""
    plt = pyplot()
    fig, (whole, zoom) = plt.subplots(1, 2, figsize=(12, 6))
    x, z = machine.axis("X"), machine.axis("Z")
    first = next(iter(runs.values()))[0]
    commanded = [(w.steps[1] / z.steps_per_mm, w.steps[0] / x.steps_per_mm) for w in first.waypoints]
    for ax in (whole, zoom):
        ax.plot(*zip(*commanded), "o", ms=3, color="black", label="commanded targets")
        for (label, (log, sim)), color in zip(runs.items(), ("tab:blue", "tab:red")):
            path = carriage_path(sim)
            ax.plot(path[:, 1], path[:, 0], "-", lw=0.9, color=color, label=f"carriage, {label}")
        ax.set_xlabel("Z, longitudinal [mm]")
        ax.set_ylabel("X, transversal [mm]")
        ax.grid(True, lw=0.3)
    whole.set_aspect("equal")
    whole.set_title(f"{machine.name}: circle of {RADIUS_MM:g} mm, {POINTS} points")
    zoom.set_xlim(-1.5, 1.5)
    zoom.set_ylim(RADIUS_MM - 0.35, RADIUS_MM + 0.1)
    zoom.set_title("zoom: X turns round at the top")
    zoom.legend(loc="lower center", fontsize=8)
    return save_figure(fig, out_dir, "circle_paths.png")


def plot_errors(machine, errors: dict, out_dir) -> Path:
    """Carriage error at each reached target, per axis, with and without compensation."""
    plt = pyplot()
    fig, axes = plt.subplots(len(machine.axes), 1, sharex=True, figsize=(9, 6))
    for ax, axis in zip(axes, machine.axes):
        for label, per_axis in errors.items():
            ax.plot(per_axis[axis.name], ".-", lw=0.8, label=label)
        ax.axhline(axis.step_mm, color="gray", ls="--", lw=0.8, label="one step")
        ax.set_ylabel(f"{axis.name} error [mm]")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("target number")
    fig.suptitle(f"{machine.name}: carriage error at each reached target of the circle, per axis")
    return save_figure(fig, out_dir, "circle_errors.png")


def main(out_dir="out") -> list[Path]:
    """Drive the circle with and without backlash compensation; save the two plots."""
    machine = load_machine(MACHINE)
    targets = circle_targets(machine)
    runs = {"compensation on": drive(machine, targets, True),
            "compensation off": drive(machine, targets, False)}
    errors = {label: carriage_errors(machine, log, sim) for label, (log, sim) in runs.items()}
    for label, per_axis in errors.items():
        worst = ", ".join(f"{name} {max(values):.3f} mm" for name, values in per_axis.items())
        print(f"{label}: worst carriage error {worst}")
    return [plot_paths(machine, runs, out_dir), plot_errors(machine, errors, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
