"""The planner behind the pipeline: junction speeds and exit speeds over the moves it holds.

The controller prepares commands ahead into a window of ``lookahead`` moves (plus one, to know
how the last of them turns). When a move starts, this module plans it from what the window holds:
its exit speed is the highest from which the tool can still stop at the end of the window, and
the acceleration a move may use is cut where it turns at speed. The planning is
:func:`retrofit.motion.lookahead.plan_window`: the kernels :func:`~retrofit.motion.lookahead.plan_speeds`
runs over a whole program, run over the window, so a program that streams through the controller
gets the very same speeds.
"""

from __future__ import annotations

import numpy as np

from ..machine.config import Machine
from ..motion.lookahead import Kinematics, plan_window
from ..motion.planner import EXP_ACCEL_SCALE, profile_row


class WindowPlanner:
    """Plans one move at a time from the window of moves behind it."""

    def __init__(self, machine: Machine):
        settings = machine.motion
        self.depth = settings.lookahead
        self.deviation = settings.junction_deviation_mm
        self.exponential = settings.profile == "exponential"
        self.accel_scale = EXP_ACCEL_SCALE if self.exponential else 1.0
        self.axis_accel = np.array([a.max_accel_mm_s2 for a in machine.axes])
        self.axis_step = np.array([a.step_mm for a in machine.axes])

    @property
    def capacity(self) -> int:
        """Moves the window holds ahead of the one running."""
        return self.depth + 1

    def plan(self, prev: Kinematics | None, moves: list[Kinematics], entry: float,
             length: float | None = None) -> tuple[float, float]:
        """(exit speed, acceleration) of ``moves[0]`` entered at ``entry`` mm/s.

        ``moves[1:]`` are the moves behind it in the window; past the last one the tool stops.
        ``length`` replaces the first move's length when only its rest is planned.
        """
        return plan_window(prev, moves, entry, self.depth, self.deviation, self.accel_scale,
                           self.axis_accel, self.axis_step, length)

    def profile_row(self, kin: Kinematics, entry: float, exit_: float, accel: float):
        """The profile row of a whole move, as the program planner makes it."""
        return profile_row(kin, entry, exit_, accel, self.exponential)
