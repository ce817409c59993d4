"""The simulated machine: drivers -> motors -> lead screws with a dead band -> carriages.

It reads only the port bytes, the way the real electronics do, and reports what really happened:
where each motor and carriage is, how often each reversed, and every timing or travel violation.
"""

from __future__ import annotations

import bisect

import numpy as np

from ..backlash import DeadBand
from ..config import Machine
from ..frames import PortFrames
from .drivers import DriverInput, Violation


class AxisTrace:
    """Motor and carriage of one axis after each step, in tick order (run-length, per tick on demand)."""

    def __init__(self):
        self.ticks: list[int] = []
        self.motor_steps: list[int] = []
        self.carriage_mm: list[float] = []

    def at(self, tick: int, default_motor: int = 0, default_carriage: float = 0.0) -> tuple[int, float]:
        """Motor steps and carriage mm at the end of frame ``tick``."""
        i = bisect.bisect_right(self.ticks, tick) - 1
        if i < 0:
            return default_motor, default_carriage
        return self.motor_steps[i], self.carriage_mm[i]


class SimMachine:
    """A machine built from a machine file, moved only by port frames."""

    def __init__(self, machine: Machine, start_steps: tuple[int, ...] | None = None):
        self.machine = machine
        start = start_steps or (0,) * len(machine.axes)
        self.drivers = [DriverInput(a) for a in machine.axes]
        self.motor_steps = list(start)
        self.screws = [DeadBand(machine.sim.dead_band_mm[a.name] * a.steps_per_mm, s)
                       for a, s in zip(machine.axes, start)]
        self.traces = {a.name: AxisTrace() for a in machine.axes}
        self.reversals = [0] * len(machine.axes)
        self._last_dir = [0] * len(machine.axes)
        self._out_of_travel = [False] * len(machine.axes)
        self.extra_violations: list[Violation] = []
        self.end_tick = 0
        self._initial = [(s, s / a.steps_per_mm) for s, a in zip(start, machine.axes)]

    def feed(self, frames: PortFrames) -> None:
        """Run the machine through a chunk of frames."""
        for i, (axis, driver) in enumerate(zip(self.machine.axes, self.drivers)):
            rises, dirs = driver.edges(frames.ticks, frames.values)
            self._move(i, axis, rises, dirs)
        self.end_tick = max(self.end_tick, frames.end_tick)

    def _move(self, i, axis, rises: np.ndarray, dirs: np.ndarray) -> None:
        trace, screw, spm = self.traces[axis.name], self.screws[i], axis.steps_per_mm
        motor, last_dir = self.motor_steps[i], self._last_dir[i]
        for tick, direction in zip(rises.tolist(), dirs.tolist()):
            if last_dir and direction != last_dir:
                self.reversals[i] += 1
            last_dir = direction
            motor += direction
            carriage = screw.move_motor(direction) / spm
            trace.ticks.append(tick)
            trace.motor_steps.append(motor)
            trace.carriage_mm.append(carriage)
            self._check_travel(i, axis, tick, carriage)
        self.motor_steps[i], self._last_dir[i] = motor, last_dir

    def _check_travel(self, i, axis, tick: int, carriage: float) -> None:
        outside = not (axis.min_mm - 1e-9 <= carriage <= axis.max_mm + 1e-9)
        if outside and not self._out_of_travel[i]:
            self.extra_violations.append(Violation(tick, axis.name, "travel",
                f"carriage at {carriage:.3f} mm, outside {axis.min_mm:g}..{axis.max_mm:g} mm"))
        self._out_of_travel[i] = outside

    @property
    def violations(self) -> list[Violation]:
        found = [v for d in self.drivers for v in d.violations] + self.extra_violations
        return sorted(found, key=lambda v: (v.tick, v.axis, v.kind))

    def carriage_mm(self, axis: str) -> float:
        i = self.machine.axis_names.index(axis)
        return self.screws[i].carriage / self.machine.axes[i].steps_per_mm

    def state_at(self, tick: int) -> dict[str, tuple[int, float]]:
        """(motor steps, carriage mm) of every axis at the end of frame ``tick``."""
        return {axis.name: self.traces[axis.name].at(tick, *self._initial[i])
                for i, axis in enumerate(self.machine.axes)}
