"""Arcs as chords: the engraver paper's chord length from an allowed radius error (004).

An arc of radius ``r`` is cut into chords whose sagitta (the largest gap between a chord and the
arc, at the chord's middle) is at most the allowed radius error ``e``. 004 gives the chord length
``l = 2·sqrt(r² − (r − e)²)`` and the central angle it spans, ``θ = 2·asin(l / 2r)``; the arc is
then cut into the fewest equal central angles no larger than ``θ`` and each chord is run as a
line. Positions are in mm; the last point is the end point exactly, so an arc never leaves a
rounding error behind it::

    >>> pts = arc_points((10.0, 0.0), (0.0, 10.0), (0.0, 0.0), False, (0, 1), 0.5)
    >>> len(pts), pts[-1]
    (3, (0.0, 10.0))
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

#: no chord spans more than a quarter turn, however coarse the tolerance
MAX_CHORD_ANGLE = math.pi / 2


def chord_length(radius_mm: float, tolerance_mm: float) -> float:
    """Longest chord of an arc of ``radius_mm`` whose sagitta is ``tolerance_mm`` (004's ``l``).

    ``l = 2·sqrt(r² − (r − e)²) = 2·sqrt(e·(2r − e))``; for ``r <= e`` the whole circle lies
    within the tolerance and the diameter ``2r`` is returned.
    """
    _check(radius_mm, tolerance_mm)
    if radius_mm <= tolerance_mm:
        return 2.0 * radius_mm
    return 2.0 * math.sqrt(tolerance_mm * (2.0 * radius_mm - tolerance_mm))


def chord_angle(radius_mm: float, tolerance_mm: float) -> float:
    """Central angle (radians) of the chord whose sagitta is the allowed radius error.

    ``θ = 2·asin(l / 2r)`` with ``l`` from :func:`chord_length`, never more than a quarter turn
    (:data:`MAX_CHORD_ANGLE`): for ``r <= e`` one chord per quarter turn.

    >>> round(math.degrees(chord_angle(15.0, 0.002)), 3)
    1.871
    """
    half = chord_length(radius_mm, tolerance_mm) / 2.0
    return min(MAX_CHORD_ANGLE, 2.0 * math.asin(min(1.0, half / radius_mm)))


def arc_sweep(start: Sequence[float], end: Sequence[float], center: Sequence[float],
              clockwise: bool, plane_axes: tuple[int, int], full_turns: int = 0) -> float:
    """Central angle (radians, > 0) travelled from ``start`` to ``end`` around ``center``.

    Coordinates are tuples over all axes; ``plane_axes`` = (first, second) index of the plane,
    counter-clockwise being from the first axis towards the second. ``start == end`` in the
    plane is a full turn; ``full_turns`` adds whole turns.
    """
    a, b = plane_axes
    a0 = math.atan2(start[b] - center[b], start[a] - center[a])
    a1 = math.atan2(end[b] - center[b], end[a] - center[a])
    if (start[a], start[b]) == (end[a], end[b]):
        sweep = 2.0 * math.pi
    else:
        sweep = (a0 - a1) if clockwise else (a1 - a0)
        sweep %= 2.0 * math.pi
        if sweep == 0.0:          # same angle, different radius: a spiral once round
            sweep = 2.0 * math.pi
    return sweep + 2.0 * math.pi * full_turns


def arc_points(start: Sequence[float], end: Sequence[float], center: Sequence[float],
               clockwise: bool, plane_axes: tuple[int, int], tolerance_mm: float,
               full_turns: int = 0) -> list[tuple[float, ...]]:
    """End points (mm) of the chords of an arc; the start point is not included.

    Parameters
    ----------
    start, end, center : tuples over all axes (the centre's coordinates off the plane are ignored)
    clockwise : G2 (True) or G3 (False), seen with the plane's normal pointing at the viewer
    plane_axes : (first, second) index of the plane's axes in the tuples, e.g. (0, 1) for XY
    tolerance_mm : the allowed radius error ``e`` (largest sagitta of a chord)
    full_turns : whole turns added to the sweep (``start == end`` is already one full turn)

    Every chord spans the same central angle, at most :func:`chord_angle` of the larger of the
    start and end radius, so no chord strays more than ``e`` from the arc. When the end radius
    differs from the start radius the radius changes linearly with the angle (a spiral), and so
    does every axis off the plane (helical motion). The last point is ``tuple(end)`` exactly.
    """
    a, b = plane_axes
    r0, r1, sweep, n, a0, sign = _chords(start, end, center, clockwise, plane_axes, tolerance_mm, full_turns)
    points = []
    for k in range(1, n):
        f = k / n
        angle = a0 + sign * sweep * f
        radius = r0 + (r1 - r0) * f
        p = [s + (e - s) * f for s, e in zip(start, end)]
        p[a] = center[a] + radius * math.cos(angle)
        p[b] = center[b] + radius * math.sin(angle)
        points.append(tuple(p))
    points.append(tuple(float(v) for v in end))
    return points


def arc_columns(start: Sequence[float], end: Sequence[float], center: Sequence[float],
                clockwise: bool, plane_axes: tuple[int, int], tolerance_mm: float,
                full_turns: int = 0) -> np.ndarray:
    """:func:`arc_points` as one array [chord, axis] (mm), float for float: the same operations in
    the same order, each over every chord at once (``math.cos`` and ``math.sin`` still give the
    plane's coordinates, so no library's vector maths can move a last bit).

        >>> arc_columns((10.0, 0.0), (0.0, 10.0), (0.0, 0.0), False, (0, 1), 0.5).tolist() == \\
        ...     [list(p) for p in arc_points((10.0, 0.0), (0.0, 10.0), (0.0, 0.0), False, (0, 1), 0.5)]
        True
    """
    a, b = plane_axes
    r0, r1, sweep, n, a0, sign = _chords(start, end, center, clockwise, plane_axes, tolerance_mm, full_turns)
    f = np.arange(1, n, dtype=np.float64) / n
    angles = (a0 + sign * sweep * f).tolist()
    radius = r0 + (r1 - r0) * f
    points = np.empty((n, len(start)))
    for k, (s, e) in enumerate(zip(start, end)):
        points[:-1, k] = s + (e - s) * f
    points[:-1, a] = center[a] + radius * np.fromiter(map(math.cos, angles), np.float64, n - 1)
    points[:-1, b] = center[b] + radius * np.fromiter(map(math.sin, angles), np.float64, n - 1)
    points[-1] = [float(v) for v in end]
    return points


def arcs_columns(arcs: Sequence[tuple], tolerance_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`arc_columns` of many arcs at once, float for float: (the points [chord, axis] of
    every arc in turn, the number of chords of each). ``arcs`` holds (start, end, centre,
    clockwise, plane_axes, full_turns) tuples; each operation of :func:`arc_columns` runs once over
    the chords of every arc, on the same operands."""
    shapes = [_chords(start, end, centre, clockwise, plane, tolerance_mm, turns)
              for start, end, centre, clockwise, plane, turns in arcs]
    counts = np.array([shape[3] for shape in shapes], np.int64)
    total, width = int(counts.sum()), len(arcs[0][0]) if arcs else 0
    firsts = np.cumsum(counts) - counts
    k = np.arange(total, dtype=np.float64) - np.repeat(firsts, counts) + 1.0
    f = k / np.repeat(counts, counts).astype(np.float64)
    r0, r1, sweep, _, a0, sign = (np.repeat(np.array(c, np.float64), counts) for c in zip(*shapes)) \
        if arcs else (np.empty(0),) * 6
    angles = (a0 + sign * sweep * f).tolist()
    radius = r0 + (r1 - r0) * f
    starts, ends = (np.repeat(np.array([arc[j] for arc in arcs], np.float64).reshape(-1, width), counts, axis=0)
                    for j in (0, 1))
    points = starts + (ends - starts) * f[:, None]
    rows = np.arange(total)
    plane = np.repeat(np.array([arc[4] for arc in arcs], np.int64).reshape(-1, 2), counts, axis=0)
    centres = np.repeat(np.array([arc[2] for arc in arcs], np.float64).reshape(-1, width), counts, axis=0)
    points[rows, plane[:, 0]] = centres[rows, plane[:, 0]] + radius * np.fromiter(map(math.cos, angles),
                                                                                   np.float64, total)
    points[rows, plane[:, 1]] = centres[rows, plane[:, 1]] + radius * np.fromiter(map(math.sin, angles),
                                                                                   np.float64, total)
    last = firsts + counts - 1
    points[last] = ends[last]
    return points, counts


def _chords(start, end, center, clockwise: bool, plane_axes: tuple[int, int], tolerance_mm: float,
            full_turns: int) -> tuple[float, float, float, int, float, float]:
    """(start radius, end radius, sweep, chords, start angle, sense) of an arc cut into chords."""
    a, b = plane_axes
    r0 = math.hypot(start[a] - center[a], start[b] - center[b])
    r1 = math.hypot(end[a] - center[a], end[b] - center[b])
    if r0 == 0.0 or r1 == 0.0:
        raise ValueError("arc radius is 0: the centre is on the start or the end point")
    sweep = arc_sweep(start, end, center, clockwise, plane_axes, full_turns)
    n = max(1, math.ceil(sweep / chord_angle(max(r0, r1), tolerance_mm)))
    a0 = math.atan2(start[b] - center[b], start[a] - center[a])
    return r0, r1, sweep, n, a0, -1.0 if clockwise else 1.0


def arc_extent(start: Sequence[float], end: Sequence[float], center: Sequence[float],
               clockwise: bool, plane_axes: tuple[int, int], tolerance_mm: float,
               full_turns: int = 0) -> tuple[list[float], list[float], int, float]:
    """The arc's geometry before any chord is built: (lowest, highest) coordinate reached on
    every axis, the number of chords :func:`arc_points` would make, and the path length (mm).

    Limits can then be checked on the arc itself, and an arc of a million chords refused, in
    constant time::

        >>> lo, hi, n, length = arc_extent((10.0, 0.0), (0.0, 10.0), (0.0, 0.0), False, (0, 1), 0.5)
        >>> [round(v, 6) for v in lo + hi], n, round(length, 4)
        ([0.0, 0.0, 10.0, 10.0], 3, 15.708)
    """
    a, b = plane_axes
    r0 = math.hypot(start[a] - center[a], start[b] - center[b])
    r1 = math.hypot(end[a] - center[a], end[b] - center[b])
    values = list(start) + list(end) + list(center) + [r0, r1]
    if not all(math.isfinite(v) for v in values) or r0 == 0.0 or r1 == 0.0:
        raise ValueError("arc geometry is not finite or its radius is 0")
    sweep = arc_sweep(start, end, center, clockwise, plane_axes, full_turns)
    lo = [min(s, e) for s, e in zip(start, end)]
    hi = [max(s, e) for s, e in zip(start, end)]
    a0 = math.atan2(start[b] - center[b], start[a] - center[a])
    radius = max(r0, r1)
    for quarter in range(4):
        angle = quarter * math.pi / 2
        travelled = ((a0 - angle) if clockwise else (angle - a0)) % (2.0 * math.pi)
        if travelled <= sweep:
            x, y = center[a] + radius * math.cos(angle), center[b] + radius * math.sin(angle)
            lo[a], hi[a] = min(lo[a], x), max(hi[a], x)
            lo[b], hi[b] = min(lo[b], y), max(hi[b], y)
    chords = max(1, math.ceil(sweep / chord_angle(radius, tolerance_mm)))
    off_plane = math.sqrt(sum((e - s) ** 2 for i, (s, e) in enumerate(zip(start, end))
                              if i not in plane_axes))
    return lo, hi, chords, math.hypot(sweep * (r0 + r1) / 2.0, off_plane)


def _check(radius_mm: float, tolerance_mm: float) -> None:
    if not radius_mm > 0.0:
        raise ValueError(f"arc radius {radius_mm} mm: must be > 0")
    if not tolerance_mm > 0.0:
        raise ValueError(f"arc tolerance {tolerance_mm} mm: must be > 0")
