"""Look-ahead over a queue of moves: junction speeds that let nearly collinear segments flow.

Two limits decide how fast the tool may pass from one move into the next:

* the change of direction — the junction is treated as a tiny arc that may deviate from the
  sharp corner by ``junction_deviation_mm``; its centripetal acceleration must stay within the
  moves' acceleration, so a straight continuation is free and a reversal needs a full stop;
* what is queued — the tool must always be able to stop at the end of the last move the planner
  can see (``lookahead`` moves), so entry speeds come from a backward pass over that window and
  reachable exit speeds from a forward pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class Kinematics:
    """What the planner needs of one move: length, direction, and its speed and acceleration caps."""

    length_mm: float
    unit: np.ndarray            # direction in mm space (unit vector), zeros for a dwell
    v_max_mm_s: float           # feed, limited so that no axis exceeds its own speed
    a_max_mm_s2: float          # acceleration, limited so that no axis exceeds its own
    stop_before: bool = False   # a dwell or a stop ends the flow: entry speed 0


def junction_speed(prev: Kinematics, nxt: Kinematics, deviation_mm: float) -> float:
    """Highest speed (mm/s) at which the tool may turn from ``prev`` into ``nxt``."""
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
    v2 = accel * radius
    return min(limit, math.sqrt(v2))


def plan_speeds(moves: list[Kinematics], depth: int, deviation_mm: float,
                accel_scale: float = 1.0) -> list[tuple[float, float]]:
    """(entry, exit) speed of every move, planning ``depth`` moves ahead and stopping at the end.

    ``accel_scale`` (≤ 1) makes the passes assume a gentler acceleration, for ramps that cover
    a speed change in a longer distance than a trapezoid (the exponential profile).
    """
    n = len(moves)
    junction = [0.0] + [junction_speed(moves[i - 1], moves[i], deviation_mm) for i in range(1, n)]
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
