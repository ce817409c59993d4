"""Lab 04: backlash — measure the lead screws' dead band with a dial indicator, then compensate it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.sim import SimMachine

MACHINE = "chivu-lathe"
APPROACH_STEPS = 20     # out this far in + first, so the nut bears on one face of the thread
REVERSE_STEPS = 12      # then back one step at a time, reading the dial after each
ZIGZAG_MM = [(5.0, 4.0), (2.0, 1.0), (6.0, 5.0), (1.0, 2.0), (4.0, 0.5), (0.0, 3.0), (3.0, 3.0)]


def drive(machine, targets, backlash_comp: bool = True):
    """Run the paper's position-error loop through the targets and a simulated lathe: (log, sim)."""
    log = PositionErrorLoop(machine, backlash_comp=backlash_comp).run(targets)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


def dial_targets(machine, axis: str, approach: int = APPROACH_STEPS,
                 reverse: int = REVERSE_STEPS) -> list[tuple[int, ...]]:
    """The experiment's targets: ``axis`` out to +approach steps, then back one step at a time."""
    i = machine.axis_names.index(axis)

    def at(steps: int) -> tuple[int, ...]:
        point = [0] * len(machine.axes)
        point[i] = steps
        return tuple(point)

    return [at(approach)] + [at(approach - k) for k in range(1, reverse + 1)]


def dial_readings(machine, axis: str, targets) -> list[tuple[int, float]]:
    """Drive the targets without compensation; (motor steps, carriage mm) of ``axis`` at each one."""
    log, sim = drive(machine, targets, backlash_comp=False)
    return [sim.state_at(w.reached_tick)[axis] for w in log.waypoints]


def dead_band_mm(machine, axis: str, readings) -> float:
    """The dead band from the readings: how much further the motor went back than the carriage, mm."""
    step_mm = machine.axis(axis).step_mm
    (motor_0, carriage_0), (motor_1, carriage_1) = readings[0], readings[-1]
    return abs(motor_1 - motor_0) * step_mm - abs(carriage_1 - carriage_0)


def with_clearance(machine, clearances: dict[str, float]):
    """The same machine with the compensation clearance (``backlash_mm``) of some axes replaced."""
    axes = tuple(replace(a, backlash_mm=clearances.get(a.name, a.backlash_mm)) for a in machine.axes)
    return replace(machine, axes=axes)


def zigzag(machine) -> list[tuple[int, ...]]:
    """A test path that reverses both axes several times, in steps (X, Z)."""
    return [tuple(machine.axis(name).to_steps(mm) for name, mm in zip(("X", "Z"), point)) for point in ZIGZAG_MM]


def carriage_errors(machine, log, sim) -> dict[str, list[float]]:
    """Per axis, |carriage - target| in mm when each target is reached (as in lab 01)."""
    errors: dict[str, list[float]] = {a.name: [] for a in machine.axes}
    for w in log.waypoints:
        state = sim.state_at(w.reached_tick)
        for i, a in enumerate(machine.axes):
            errors[a.name].append(abs(state[a.name][1] - a.to_mm(w.steps[i])))
    return errors


def measure(machine) -> tuple[dict, dict]:
    """The experiment on every axis: (readings per axis, measured dead band per axis in mm)."""
    readings = {a.name: dial_readings(machine, a.name, dial_targets(machine, a.name)) for a in machine.axes}
    return readings, {name: dead_band_mm(machine, name, r) for name, r in readings.items()}


def plot_dial(machine, readings: dict, measured: dict, out_dir) -> Path:
    """Dial reading against motor steps during the reversal, per axis."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(readings), figsize=(11, 4.5))
    for ax, (name, values) in zip(axes, readings.items()):
        axis = machine.axis(name)
        motor = [m * axis.step_mm for m, _ in values]
        dial = [c - values[0][1] for _, c in values]
        ax.plot(motor, dial, "o-", ms=4, label="dial (carriage) reading")
        ax.plot(motor, [m - motor[0] for m in motor], "--", color="gray", label="motor, no play")
        ax.invert_xaxis()
        ax.set_xlabel(f"{name} motor position [mm] (going back)")
        ax.set_ylabel("change since the reversal [mm]")
        ax.set_title(f"{name}: measured {measured[name]:.3f} mm, simulated play "
                     f"{machine.sim.dead_band_mm[name]:.3f} mm", fontsize=9)
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "dial_indicator.png")


def plot_before_after(machine, before: dict, after: dict, out_dir) -> Path:
    """Carriage error at every target of the zigzag, before and after compensation."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(machine.axes), figsize=(11, 4))
    for ax, axis in zip(axes, machine.axes):
        ax.plot(before[axis.name], "o-", label="before (no clearance known)")
        ax.plot(after[axis.name], "s-", label="after (measured clearance)")
        ax.axhline(axis.step_mm, color="gray", ls="--", lw=0.8, label="one step")
        ax.set_xlabel("zigzag target")
        ax.set_ylabel(f"{axis.name} carriage error [mm]")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("the zigzag: carriage error before and after compensation")
    return save_figure(fig, out_dir, "before_after.png")


def main(out_dir="out") -> list[Path]:
    """Measure every axis, compensate with what was measured, compare the zigzag before and after."""
    machine = with_clearance(load_machine(MACHINE), {"X": 0.0, "Z": 0.0})    # nothing known yet
    readings, measured = measure(machine)
    compensated = with_clearance(machine, measured)
    targets = zigzag(machine)
    before = carriage_errors(machine, *drive(machine, targets))
    after = carriage_errors(compensated, *drive(compensated, targets))
    for name in machine.axis_names:
        print(f"{name}: dead band measured {measured[name]:.3f} mm; worst zigzag error "
              f"{max(before[name]):.3f} mm before, {max(after[name]):.3f} mm after")
    return [plot_dial(machine, readings, measured, out_dir),
            plot_before_after(machine, before, after, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
