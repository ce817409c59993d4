"""A stepper driver as the simulator sees it: decode step/dir bits, check their timing.

A rising edge on the step input moves the motor one step in the direction sampled at that edge.
The driver needs the step high and low for a minimum time and the direction stable for a set-up
time before the edge and a hold time after it; every breach is recorded as a violation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..machine.config import Axis

_LONG_AGO = -(1 << 40)


@dataclass(frozen=True)
class Violation:
    tick: int
    axis: str
    kind: str       # pulse_high, pulse_low, dir_setup, dir_hold, travel, ...
    detail: str

    def as_dict(self) -> dict:
        return {"tick": self.tick, "axis": self.axis, "kind": self.kind, "detail": self.detail}


class DriverInput:
    """Edge detector and timing checker of one axis's step and direction inputs."""

    def __init__(self, axis: Axis):
        self.axis = axis
        self.step = 0
        self.direction = -1
        self.last_rise = _LONG_AGO
        self.last_fall = _LONG_AGO
        self.last_dir_change = _LONG_AGO
        self.violations: list[Violation] = []

    def edges(self, ticks: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Feed a chunk of frames; return (ticks of rising edges, direction sampled at each)."""
        a = self.axis
        logical = values ^ np.uint8((a.invert_step << a.step_bit) | (a.invert_dir << a.dir_bit))
        step = ((logical >> a.step_bit) & 1).astype(np.int8)
        direction = np.where((logical >> a.dir_bit) & 1, 1, -1).astype(np.int8)
        prev_step = np.concatenate(([self.step], step[:-1]))
        prev_dir = np.concatenate(([self.direction], direction[:-1]))
        rise = np.flatnonzero((step == 1) & (prev_step == 0))
        fall = np.flatnonzero((step == 0) & (prev_step == 1))
        turn = np.flatnonzero(direction != prev_dir)
        self._check(ticks[rise], ticks[fall], ticks[turn])
        if len(step):
            self.step, self.direction = int(step[-1]), int(direction[-1])
        return ticks[rise], direction[rise]

    def _check(self, rises: np.ndarray, falls: np.ndarray, turns: np.ndarray) -> None:
        """Merge the edges in tick order and check each against the driver's minimum times."""
        a = self.axis
        events = sorted([(int(t), 0) for t in turns] + [(int(t), 1) for t in falls]
                        + [(int(t), 2) for t in rises])
        for tick, kind in events:
            if kind == 0:                                       # direction changed
                if tick - self.last_rise < a.dir_hold_ticks:
                    self._flag(tick, "dir_hold", f"direction changed {tick - self.last_rise} tick(s) after a "
                               f"rising step edge; needs >= {a.dir_hold_ticks}")
                self.last_dir_change = tick
            elif kind == 1:                                     # step fell
                if tick - self.last_rise < a.pulse_high_ticks:
                    self._flag(tick, "pulse_high", f"step high for {tick - self.last_rise} tick(s); "
                               f"needs >= {a.pulse_high_ticks}")
                self.last_fall = tick
            else:                                               # step rose
                if tick - self.last_fall < a.pulse_low_ticks:
                    self._flag(tick, "pulse_low", f"step low for {tick - self.last_fall} tick(s) before "
                               f"rising; needs >= {a.pulse_low_ticks}")
                if tick - self.last_dir_change < a.dir_setup_ticks:
                    self._flag(tick, "dir_setup", f"direction changed {tick - self.last_dir_change} tick(s) "
                               f"before a rising step edge; needs >= {a.dir_setup_ticks}")
                self.last_rise = tick

    def _flag(self, tick: int, kind: str, detail: str) -> None:
        self.violations.append(Violation(tick, self.axis.name, kind, detail))
