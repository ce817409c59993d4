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

from ._jit import compiled, kernel

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
    (The same compiled rule as a whole program's junctions in :func:`plan_speeds`.)
    """
    if nxt.stop_before or prev.length_mm == 0.0 or nxt.length_mm == 0.0:
        return 0.0
    use_axes = axis_accel is not None
    n = len(prev.unit)
    return float(_junction(np.asarray(prev.unit, np.float64), np.asarray(nxt.unit, np.float64),
                           prev.v_max_mm_s, nxt.v_max_mm_s, prev.a_max_mm_s2, nxt.a_max_mm_s2, deviation_mm,
                           use_axes, axis_accel if use_axes else np.zeros(n), axis_step if use_axes else np.zeros(n)))


@kernel
def _dot(a, b):
    total = 0.0
    for k in range(a.shape[0]):
        total += a[k] * b[k]
    return total


@kernel
def _junction(before, after, v_before, v_after, a_before, a_after, deviation_mm, use_axes, axis_accel, axis_step):
    """The junction rule of :func:`junction_speed` for two moves of non-zero length."""
    cos_turn = _dot(before, after)                          # 1 straight on, -1 a reversal
    limit = min(v_before, v_after)
    if cos_turn >= 1.0 - 1e-12:
        return limit
    if cos_turn <= -1.0 + 1e-12:
        return 0.0
    # the corner's inside angle is pi - turn; its half-angle sine is cos(turn / 2)
    sin_half = math.sqrt(0.5 * (1.0 + cos_turn))
    accel = min(a_before, a_after)
    radius = deviation_mm * sin_half / (1.0 - sin_half)     # the arc that rounds the corner
    limit = min(limit, math.sqrt(accel * radius))
    if use_axes:
        limit = min(limit, _jump_limit(before, after, axis_accel, axis_step))
    return limit


@kernel
def _jump_limit(before, after, accel, step):
    """Speed at which every axis's velocity jump fits ``JUNCTION_SHARE`` of its acceleration.

    A jump ``v·Δu`` of an axis must fit ``share·a·dt``, with ``dt`` the step interval around the
    junction: no longer than ``step / (v·|u| + sqrt(2·a·step))`` (the speed there, plus what one
    step of full acceleration adds). Solved for ``v``: a quadratic.
    """
    best = math.inf
    for k in range(before.shape[0]):
        du = abs(after[k] - before[k])
        if not du > 0:
            continue
        m = max(abs(before[k]), abs(after[k]))
        c = math.sqrt(2.0 * accel[k] * step[k])
        budget = JUNCTION_SHARE * accel[k] * step[k]
        v = (-du * c + math.sqrt(du * du * c * c + 4.0 * du * m * budget)) / (2.0 * du * m)
        if v < best:
            best = v
    return best


@kernel
def _junctions(units, lengths, v_max, a_max, stop_before, deviation_mm, use_axes, axis_accel, axis_step,
               junction):
    """``junction[i]``: speed from move ``i - 1`` into move ``i`` (``junction[0]`` and ``junction[n]``
    stay 0: the tool starts and ends at rest)."""
    for i in range(1, lengths.shape[0]):
        if not (stop_before[i] or lengths[i - 1] == 0.0 or lengths[i] == 0.0):
            junction[i] = _junction(units[i - 1], units[i], v_max[i - 1], v_max[i], a_max[i - 1], a_max[i],
                                    deviation_mm, use_axes, axis_accel, axis_step)


@kernel
def _cut_turning(units, junction, a_max):
    """A move that turns at speed at either end keeps ``1 - JUNCTION_SHARE`` of its acceleration."""
    n = a_max.shape[0]
    turns = np.zeros(n + 1, np.bool_)
    for j in range(1, n):
        turns[j] = _dot(units[j - 1], units[j]) < 1.0 - 1e-12
    for i in range(n):
        if (junction[i] > 0.0 and turns[i]) or (junction[i + 1] > 0.0 and turns[i + 1]):
            a_max[i] *= 1.0 - JUNCTION_SHARE


@kernel
def _exit_speed(i, entry, length, last, junction, lengths, v_max, a_max, accel_scale):
    """Exit speed of move ``i`` entered at ``entry`` with ``length`` mm to go, when the tool must be
    able to stop at the end of move ``last - 1`` (a backward pass, then what ``i`` can reach)."""
    v_next = 0.0                                          # stop at the end of what is seen
    for j in range(last - 1, i, -1):
        reach = math.sqrt(v_next * v_next + 2.0 * a_max[j] * accel_scale * lengths[j])
        v_next = min(junction[j], v_max[j], reach)
    reach_up = math.sqrt(entry * entry + 2.0 * a_max[i] * accel_scale * length)
    return min(v_next, reach_up, v_max[i])


@kernel
def _speeds(units, lengths, v_max, a_max, stop_before, depth, deviation_mm, accel_scale, use_axes,
            axis_accel, axis_step, first, entry, entries, exits):
    """Junctions, turning moves' acceleration cut (``a_max`` in place), then the two passes, from
    move ``first`` entered at ``entry`` (the moves before it are planned already: only their
    junction into ``first`` counts)."""
    n = lengths.shape[0]
    junction = np.zeros(n + 1)
    _junctions(units, lengths, v_max, a_max, stop_before, deviation_mm, use_axes, axis_accel, axis_step,
               junction)
    _cut_turning(units, junction, a_max)
    for i in range(first, n):
        exit_ = _exit_speed(i, entry, lengths[i], min(n, i + depth), junction, lengths, v_max, a_max,
                            accel_scale)
        entries[i] = entry
        exits[i] = exit_
        entry = exit_


def _arrays(moves: list[Kinematics], n_axes: int):
    """Units, lengths, speed and acceleration caps and stops of ``moves`` as arrays (a move of no
    length, such as a dwell, gets a zero direction whatever its own)."""
    n = len(moves)
    units = np.zeros((n, n_axes), dtype=np.float64)
    for i, m in enumerate(moves):
        if m.length_mm != 0.0:
            units[i] = m.unit
    return (units, np.array([m.length_mm for m in moves], dtype=np.float64),
            np.array([m.v_max_mm_s for m in moves], dtype=np.float64),
            np.array([m.a_max_mm_s2 for m in moves], dtype=np.float64),
            np.array([m.stop_before for m in moves], dtype=np.bool_))


def _axis_limits(n_axes: int, axis_accel, axis_step):
    use_axes = axis_accel is not None
    return (use_axes, np.asarray(axis_accel if use_axes else np.zeros(n_axes), np.float64),
            np.asarray(axis_step if use_axes else np.zeros(n_axes), np.float64))


def plan_window(prev: Kinematics | None, moves: list[Kinematics], entry: float, depth: int,
                deviation_mm: float, accel_scale: float = 1.0, axis_accel: np.ndarray | None = None,
                axis_step: np.ndarray | None = None, length: float | None = None) -> tuple[float, float]:
    """(exit speed, acceleration) of ``moves[0]``, entered at ``entry`` mm/s after ``prev`` (None:
    from rest), with ``moves[1:]`` queued behind it: :func:`plan_speeds`' rules for one move, run
    by the same kernels, for a controller that sees its program a window at a time.

    ``length`` replaces the first move's length when only its rest is planned.
    """
    ahead = ([prev] if prev is not None else []) + list(moves)
    i = len(ahead) - len(moves)
    n_axes = max(len(m.unit) for m in ahead)
    units, lengths, v_max, a_max, stop_before = _arrays(ahead, n_axes)
    use_axes, accel, step = _axis_limits(n_axes, axis_accel, axis_step)
    junction = np.zeros(len(ahead) + 1)
    _junctions(units, lengths, v_max, a_max, stop_before, float(deviation_mm), use_axes, accel, step, junction)
    _cut_turning(units, junction, a_max)
    run = lengths[i] if length is None else length
    exit_ = _exit_speed(i, float(entry), float(run), min(len(ahead), i + int(depth)), junction, lengths,
                        v_max, a_max, float(accel_scale))
    return float(exit_), float(a_max[i])


def plan_speeds(moves: list[Kinematics], depth: int, deviation_mm: float, accel_scale: float = 1.0,
                axis_accel: np.ndarray | None = None, axis_step: np.ndarray | None = None,
                ) -> list[tuple[float, float]]:
    """(entry, exit) speed of every move, planning ``depth`` moves ahead and stopping at the end.

    ``accel_scale`` (≤ 1) makes the passes assume a gentler acceleration, for ramps that cover
    a speed change in a longer distance than a trapezoid (the exponential profile). A move whose
    entry or exit turns at speed has its acceleration cut to ``1 - JUNCTION_SHARE`` (in place).
    One compiled pass over the program's arrays.
    """
    n = len(moves)
    if n == 0:
        return []
    compiled(n * 100)                     # a thousand moves pay for loading the compiler
    n_axes = len(moves[0].unit)
    units, lengths, v_max, a_max, stop_before = _arrays(moves, n_axes)
    entries, exits = speeds_of(units, lengths, v_max, a_max, stop_before, depth, deviation_mm, accel_scale,
                               axis_accel, axis_step)
    for move, a in zip(moves, a_max.tolist()):
        move.a_max_mm_s2 = a
    return list(zip(entries.tolist(), exits.tolist()))


def speeds_of(units, lengths, v_max, a_max, stop_before, depth: int, deviation_mm: float, accel_scale: float = 1.0,
              axis_accel: np.ndarray | None = None, axis_step: np.ndarray | None = None,
              first: int = 0, entry: float = 0.0):
    """:func:`plan_speeds` on columns (``units`` [moves, axes], the rest [moves]): the (entries,
    exits) arrays; ``a_max`` is cut in place for turning moves. ``first`` / ``entry``: the
    moves before ``first`` are planned already and ``first`` is entered at ``entry`` mm/s."""
    use_axes, accel, step = _axis_limits(units.shape[1], axis_accel, axis_step)
    entries, exits = np.zeros(len(lengths)), np.zeros(len(lengths))
    _speeds(units, lengths, v_max, a_max, stop_before, int(depth), float(deviation_mm), float(accel_scale),
            use_axes, accel, step, int(first), float(entry), entries, exits)
    return entries, exits
