"""The CAM side's trajectory table: a tool path becomes one row per loop period (1 ms).

As the paper's add-in does, the whole plan is made before sending: each straight segment gets a
trapezoidal speed profile (accelerate, cruise, decelerate) at the axes' limits; the speeds at the
junctions are the main planner's (retrofit.motion.lookahead: ``[motion] junction_deviation_mm``,
backward and forward passes over the whole path). The profile is then sampled every
loop period into rows: per axis, the feedrate (-255..255, 255 = the axis's max velocity) and the
position in pulses.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import MotionError
from ..machine.config import Machine
from ..motion import lookahead
from ..motion.lookahead import Kinematics
from .protocol import FEED_LIMIT, ROW_AXES, Row

#: plan at most this fraction of an axis's max velocity: the loop needs room above the feed-forward
VELOCITY_HEADROOM = 0.9


@dataclass
class Segment:
    """One straight move of the path, with the speeds the planner gives it (mm, mm/s, mm/s^2)."""

    start: np.ndarray
    unit: np.ndarray
    length: float
    v_max: float
    accel: float
    v_entry: float = 0.0
    v_exit: float = 0.0


def xyz_axes(machine: Machine):
    """The machine's axes, which must be X, Y, Z in that order (the columns of a row)."""
    if machine.axis_names != ROW_AXES:
        raise MotionError(f"{machine.name}: the CAM link drives axes X, Y, Z; this machine has "
                          f"{', '.join(machine.axis_names)}")
    return machine.axes


def segments(machine: Machine, start_mm: Sequence[float],
             moves: Iterable[tuple[Sequence[float], float]]) -> list[Segment]:
    """The path's segments, each limited by its feed (mm/min) and by every axis it moves."""
    axes = xyz_axes(machine)
    out: list[Segment] = []
    here = np.asarray(start_mm, dtype=float)
    for point, feed_mm_min in moves:
        end = np.asarray(point, dtype=float)
        for axis, value in zip(axes, end):
            if not axis.min_mm - 1e-9 <= value <= axis.max_mm + 1e-9:
                raise MotionError(f"{machine.name}: {axis.name}{value:g} outside travel "
                                  f"{axis.min_mm:g}..{axis.max_mm:g} mm")
        delta = end - here
        length = float(np.linalg.norm(delta))
        if length < 1e-9:
            continue
        if not feed_mm_min > 0:
            raise MotionError(f"feed {feed_mm_min:g} mm/min: a move needs a feed > 0")
        unit = delta / length
        v_max, accel = feed_mm_min / 60.0, math.inf
        for axis, u in zip(axes, np.abs(unit)):
            if u > 1e-12:
                v_max = min(v_max, VELOCITY_HEADROOM * axis.max_velocity_mm_s / u)
                accel = min(accel, axis.max_accel_mm_s2 / u)
        out.append(Segment(here, unit, length, v_max, accel))
        here = end
    return out


def plan_speeds(machine: Machine, segs: list[Segment]) -> None:
    """Entry and exit speeds by the main planner's look-ahead (:func:`retrofit.motion.lookahead.plan_speeds`):
    the same junction rule, passes and acceleration cut at turning corners as a G-code program's, over
    the whole path; a segment's acceleration is the one the planner leaves it."""
    moves = [Kinematics(s.length, s.unit, s.v_max, s.accel) for s in segs]
    speeds = lookahead.plan_speeds(moves, max(len(segs), 1), machine.motion.junction_deviation_mm,
                                   axis_accel=np.array([a.max_accel_mm_s2 for a in machine.axes]),
                                   axis_step=np.array([a.step_mm for a in machine.axes]))
    for seg, move, (entry, exit_) in zip(segs, moves, speeds):
        seg.v_entry, seg.v_exit, seg.accel = entry, exit_, move.a_max_mm_s2


def _pieces(seg: Segment) -> list[tuple[float, float, float, float]]:
    """Constant-acceleration pieces of one segment: (duration s, start distance, start speed, accel)."""
    v0, v1, a, length = seg.v_entry, seg.v_exit, seg.accel, seg.length
    peak = seg.v_max
    if (2 * peak ** 2 - v0 ** 2 - v1 ** 2) / (2 * a) > length:      # no room to cruise
        peak = math.sqrt((2 * a * length + v0 ** 2 + v1 ** 2) / 2)
    peak = max(peak, v0, v1)
    d_acc, d_dec = (peak ** 2 - v0 ** 2) / (2 * a), (peak ** 2 - v1 ** 2) / (2 * a)
    cruise = max(0.0, length - d_acc - d_dec)
    out = [((peak - v0) / a, 0.0, v0, a)]
    if cruise > 0:
        out.append((cruise / peak, d_acc, peak, 0.0))
    out.append(((peak - v1) / a, d_acc + cruise, peak, -a))
    return [p for p in out if p[0] > 0]


def plan_rows(machine: Machine, start_mm: Sequence[float],
              moves: Iterable[tuple[Sequence[float], float]]) -> Iterator[Row]:
    """Rows, one per loop period, that take the axes from ``start_mm`` through ``moves``.

    ``moves`` is ``[(point_mm, feed_mm_min), ...]``; the path starts and ends at rest, and the
    last row is the last point exactly, with feedrate 0.
    """
    segs = segments(machine, start_mm, moves)
    plan_speeds(machine, segs)
    axes = xyz_axes(machine)
    scale = [FEED_LIMIT / a.max_velocity_mm_s for a in axes]
    dt, t_start, end = machine.tick_s, 0.0, np.asarray(start_mm, dtype=float)
    k = 0
    for seg in segs:
        for duration, s0, v0, acc in _pieces(seg):
            while k * dt < t_start + duration:
                tau = k * dt - t_start
                s = min(seg.length, s0 + v0 * tau + 0.5 * acc * tau * tau)
                v = v0 + acc * tau
                yield _row(axes, scale, seg.start + seg.unit * s, seg.unit * v)
                k += 1
            t_start += duration
        end = seg.start + seg.unit * seg.length
    yield _row(axes, scale, end, np.zeros(len(axes)))


def _row(axes, scale, point_mm: np.ndarray, velocity_mm_s: np.ndarray) -> Row:
    feeds = tuple(max(-FEED_LIMIT, min(FEED_LIMIT, round(v * f))) for v, f in zip(velocity_mm_s, scale))
    positions = tuple(a.to_steps(float(p)) for a, p in zip(axes, point_mm))
    return Row(feeds, positions)


def hold_rows(positions: Sequence[int], periods: int) -> Iterator[Row]:
    """``periods`` rows standing still at ``positions`` (pulses): a dwell, or time to settle."""
    row = Row((0, 0, 0), tuple(int(p) for p in positions))
    for _ in range(periods):
        yield row


def arc_points(center_mm: Sequence[float], radius_mm: float, start_deg: float, end_deg: float,
               tolerance_mm: float = 0.002) -> list[tuple[float, ...]]:
    """Points of an arc in the XY plane at the centre's Z, as chords within ``tolerance_mm``.

    The chord angle follows from the allowed radius error e (the engraver paper's rule):
    2 acos((r - e) / r). Counter-clockwise when ``end_deg`` > ``start_deg``.
    """
    if not radius_mm > tolerance_mm > 0:
        raise MotionError(f"arc radius {radius_mm:g} mm must exceed its tolerance {tolerance_mm:g} mm > 0")
    step = 2.0 * math.acos((radius_mm - tolerance_mm) / radius_mm)
    sweep = math.radians(end_deg - start_deg)
    n = max(1, math.ceil(abs(sweep) / step))
    cx, cy, cz = (float(c) for c in center_mm)
    a0 = math.radians(start_deg)
    return [(cx + radius_mm * math.cos(a0 + sweep * i / n), cy + radius_mm * math.sin(a0 + sweep * i / n), cz)
            for i in range(n + 1)]
