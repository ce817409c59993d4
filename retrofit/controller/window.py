"""The planner behind the pipeline: junction speeds and exit speeds over the moves it holds.

The controller prepares commands ahead into a window of ``lookahead`` moves (plus one, to know
how the last of them turns). When a move starts, this module plans it from what the window holds:
its exit speed is the highest from which the tool can still stop at the end of the window, and
the acceleration a move may use is cut where it turns at speed -- the same rules, in the same
floating-point order, as :func:`retrofit.motion.lookahead.plan_speeds` applies to a whole
program, so a program that streams through the controller gets the very same speeds.
"""

from __future__ import annotations

import math

import numpy as np

from ..config import Machine
from ..motion import profile as prof
from ..motion.lookahead import JUNCTION_SHARE, Kinematics, junction_speed, turns
from ..motion.planner import EXP_START_MM_S

#: a dot product of unit vectors below this is a turn


class WindowPlanner:
    """Plans one move at a time from the window of moves behind it."""

    def __init__(self, machine: Machine):
        settings = machine.motion
        self.depth = settings.lookahead
        self.deviation = settings.junction_deviation_mm
        self.exponential = settings.profile == "exponential"
        self.accel_scale = 0.25 if self.exponential else 1.0
        self.axis_accel = np.array([a.max_accel_mm_s2 for a in machine.axes])
        self.axis_step = np.array([a.step_mm for a in machine.axes])

    @property
    def capacity(self) -> int:
        """Moves the window holds ahead of the one running."""
        return self.depth + 1

    def junction(self, before: Kinematics | None, after: Kinematics | None) -> float:
        """Speed (mm/s) at which the tool may pass from ``before`` into ``after`` (0: a stop)."""
        if before is None or after is None:
            return 0.0
        return junction_speed(before, after, self.deviation, self.axis_accel, self.axis_step)

    @staticmethod
    def _turns(before: Kinematics | None, after: Kinematics | None) -> bool:
        if before is None or after is None:
            return False
        return turns(before, after)

    def _accels(self, prev: Kinematics | None, moves: list[Kinematics], junction: list[float]):
        """Each move's acceleration, halved (JUNCTION_SHARE) when it turns at speed at either end."""
        out = []
        for k, move in enumerate(moves):
            before = prev if k == 0 else moves[k - 1]
            after = moves[k + 1] if k + 1 < len(moves) else None
            turning = ((junction[k] > 0.0 and self._turns(before, move))
                       or (junction[k + 1] > 0.0 and self._turns(move, after)))
            out.append(move.a_max_mm_s2 * (1.0 - JUNCTION_SHARE) if turning else move.a_max_mm_s2)
        return out

    def plan(self, prev: Kinematics | None, moves: list[Kinematics], entry: float,
             length: float | None = None) -> tuple[float, float]:
        """(exit speed, acceleration) of ``moves[0]`` entered at ``entry`` mm/s.

        ``moves[1:]`` are the moves behind it in the window; past the last one the tool stops.
        ``length`` replaces the first move's length when only its rest is planned.
        """
        n = len(moves)
        junction = ([self.junction(prev, moves[0])]
                    + [self.junction(moves[k - 1], moves[k]) for k in range(1, n)] + [0.0])
        accel = self._accels(prev, moves, junction)
        last = min(n, self.depth)
        v_next = 0.0                                        # stop at the end of what is held
        for j in range(last - 1, 0, -1):
            reach = math.sqrt(v_next * v_next + 2.0 * accel[j] * self.accel_scale * moves[j].length_mm)
            v_next = min(junction[j], moves[j].v_max_mm_s, reach)
        first = moves[0]
        run = first.length_mm if length is None else length
        reach_up = math.sqrt(entry * entry + 2.0 * accel[0] * self.accel_scale * run)
        return min(v_next, reach_up, first.v_max_mm_s), accel[0]

    def profile_row(self, kin: Kinematics, entry: float, exit_: float, accel: float):
        """The profile row of a whole move, as the program planner makes it."""
        if self.exponential:
            return prof.exponential(kin.length_mm, entry, kin.v_max_mm_s, exit_, accel,
                                    min(EXP_START_MM_S, kin.v_max_mm_s))
        return prof.trapezoid(kin.length_mm, entry, kin.v_max_mm_s, exit_, accel)
