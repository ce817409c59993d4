"""Look-ahead over a queue of moves: junction speeds that let nearly collinear segments flow.

Two limits decide how fast the tool may pass from one move into the next:

* the change of direction — the junction is treated as a tiny arc that may deviate from the
  sharp corner by ``junction_deviation_mm``; its centripetal acceleration must stay within the
  moves' acceleration, so a straight continuation is free and a reversal needs a full stop;
* what is queued — the tool must always be able to stop at the end of the last move the planner
  can see (``lookahead`` moves), so entry speeds come from a backward pass over that window and
  reachable exit speeds from a forward pass.

A turn at speed changes each axis's velocity at once, by ``v·Δu``. A stepper sees that jump
within about one step interval, so it is held to a share (``JUNCTION_SHARE``) of the axis's
acceleration over one step, and a move that begins or ends with such a jump accelerates with
the rest of the axis's acceleration only. A rest-to-rest move keeps the whole acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: share of an axis's acceleration kept for the velocity jump of a turn taken at speed
JUNCTION_SHARE = 0.5


@dataclass
class Kinematics:
    """What the planner needs of one move: length, direction, and its speed and acceleration caps."""

    length_mm: float
    unit: np.ndarray            # direction in mm space (unit vector), zeros for a dwell
    v_max_mm_s: float           # feed, limited so that no axis exceeds its own speed
    a_max_mm_s2: float          # acceleration, limited so that no axis exceeds its own
    stop_before: bool = False   # a dwell or a stop ends the flow: entry speed 0


def junction_speed(prev: Kinematics, nxt: Kinematics, deviation_mm: float,
                   axis_accel: np.ndarray | None = None, axis_step: np.ndarray | None = None) -> float:
    """Highest speed (mm/s) at which the tool may turn from ``prev`` into ``nxt``.

    ``axis_accel`` (mm/s²) and ``axis_step`` (mm) of every axis, when given, also hold each
    axis's velocity jump to ``JUNCTION_SHARE`` of its acceleration over one step interval.
    """
    if nxt.stop_before or prev.length_mm == 0.0 or nxt.length_mm == 0.0:
        return 0.0
    cos_turn = float(np.dot(prev.unit, nxt.unit))          # 1 straight on, -1 a reversal
    limit = min(prev.v_max_mm_s, nxt.v_max_mm_s)
    if cos_turn >= 1.0 - 1e-12:
        return limit
    if cos_turn <= -1.0 + 1e-12:
        return 0.0
    # the corner's inside angle is pi - turn; its half-angle sine is cos(turn / 2)
    sin_half = math.sqrt(0.5 * (1.0 + cos_turn))
    accel = min(prev.a_max_mm_s2, nxt.a_max_mm_s2)
    radius = deviation_mm * sin_half / (1.0 - sin_half)     # the arc that rounds the corner
    limit = min(limit, math.sqrt(accel * radius))
    if axis_accel is not None:
        limit = min(limit, _jump_limit(prev.unit, nxt.unit, axis_accel, axis_step))
    return limit


def _jump_limit(before: np.ndarray, after: np.ndarray, accel: np.ndarray, step: np.ndarray) -> float:
    """Speed at which every axis's velocity jump fits ``JUNCTION_SHARE`` of its acceleration.

    A jump ``v·Δu`` of an axis must fit ``share·a·dt``, with ``dt`` the step interval around the
    junction: no longer than ``step / (v·|u| + sqrt(2·a·step))`` (the speed there, plus what one
    step of full acceleration adds). Solved for ``v``: a quadratic.
    """
    jump = np.abs(after - before)
    fastest = np.maximum(np.abs(before), np.abs(after))
    moving = jump > 0
    if not np.any(moving):
        return math.inf
    du, m = jump[moving], fastest[moving]
    c = np.sqrt(2.0 * accel[moving] * step[moving])
    budget = JUNCTION_SHARE * accel[moving] * step[moving]
    v = (-du * c + np.sqrt(du * du * c * c + 4.0 * du * m * budget)) / (2.0 * du * m)
    return float(np.min(v))


def plan_speeds(moves: list[Kinematics], depth: int, deviation_mm: float, accel_scale: float = 1.0,
                axis_accel: np.ndarray | None = None, axis_step: np.ndarray | None = None,
                ) -> list[tuple[float, float]]:
    """(entry, exit) speed of every move, planning ``depth`` moves ahead and stopping at the end.

    ``accel_scale`` (≤ 1) makes the passes assume a gentler acceleration, for ramps that cover
    a speed change in a longer distance than a trapezoid (the exponential profile). A move whose
    entry or exit turns at speed has its acceleration cut to ``1 - JUNCTION_SHARE`` (in place).
    """
    n = len(moves)
    junction = [0.0] + [junction_speed(moves[i - 1], moves[i], deviation_mm, axis_accel, axis_step)
                        for i in range(1, n)] + [0.0]
    for i, move in enumerate(moves):
        turning = any(junction[j] > 0.0 and _turns(moves, j) for j in (i, i + 1))
        if turning:
            move.a_max_mm_s2 *= 1.0 - JUNCTION_SHARE
    speeds = []
    entry = 0.0
    for i in range(n):
        last = min(n, i + depth)
        v_next = 0.0                                      # stop at the end of what is queued
        for j in range(last - 1, i, -1):
            reach = math.sqrt(v_next * v_next + 2.0 * moves[j].a_max_mm_s2 * accel_scale * moves[j].length_mm)
            v_next = min(junction[j], moves[j].v_max_mm_s, reach)
        move = moves[i]
        reach_up = math.sqrt(entry * entry + 2.0 * move.a_max_mm_s2 * accel_scale * move.length_mm)
        exit_ = min(v_next, reach_up, move.v_max_mm_s)
        speeds.append((entry, exit_))
        entry = exit_
    return speeds


def _turns(moves: list[Kinematics], j: int) -> bool:
    """True when the junction before move ``j`` changes direction."""
    if j <= 0 or j >= len(moves):
        return False
    return float(np.dot(moves[j - 1].unit, moves[j].unit)) < 1.0 - 1e-12
