"""A move's velocity profile as pieces, so the rest of a move can be re-planned mid-move.

A move starts with one profile row (``motion.profile``). When the operator changes the feed
(MFDR, FFDR) the move is re-planned from where it has got to: the part already run keeps its
row, the rest gets new pieces starting at the current speed. Times here are seconds from the
start of the move; a one-piece profile gives exactly ``profile.time_at``, bit for bit.
"""

from __future__ import annotations

import bisect
import math
import types

from ..motion import profile as prof


def _python(kernel):
    """A profile kernel as plain Python: called once per step from Python, the compiled kernel's
    call overhead would dominate; the arithmetic, hence every float, is the same. A function
    object of its own, so the switch to compiled kernels (which swaps the kernel's own function
    wherever a module names it) leaves it Python."""
    func = getattr(kernel, "py_func", kernel)
    return types.FunctionType(func.__code__, func.__globals__, func.__name__, func.__defaults__,
                              func.__closure__)


_trapezoid_time = _python(prof._trapezoid_time)
_exponential_time = _python(prof._exponential_time)


def _time_at(s: float, row) -> float:
    """``profile.time_at`` on a row held as a list of floats."""
    if row[prof.P_KIND] == prof.TRAPEZOID:
        return _trapezoid_time(s, row)
    return _exponential_time(s, row)


def speed_at(s: float, row) -> float:
    """Speed (mm/s) ``s`` mm into a profile row (trapezoid or exponential)."""
    length, d1, d2 = row[prof.P_LEN], row[prof.P_D1], row[prof.P_D2]
    cruise_end = length - d2
    if row[prof.P_KIND] == prof.TRAPEZOID:
        a, vc = row[prof.P_A], row[prof.P_VC]
        if s <= d1:
            return math.sqrt(row[prof.P_V0] ** 2 + 2.0 * a * s)
        if s <= cruise_end:
            return vc
        return math.sqrt(max(vc * vc - 2.0 * a * (s - cruise_end), 0.0))
    if s <= d1:
        return _ramp_speed(s, row[prof.P_V0], row[prof.P_V1ASYM], row[prof.P_LAM1])
    if s <= cruise_end:
        return row[prof.P_VC]
    return _ramp_speed(max(length - s, 0.0), row[prof.P_V1], row[prof.P_V2ASYM], row[prof.P_LAM2])


def _ramp_speed(s: float, v_start: float, v_asym: float, lam: float) -> float:
    if lam <= 0.0:
        return v_start
    return v_asym - (v_asym - v_start) * math.exp(-s / lam)


def ramp_pieces(length: float, v0: float, vc: float, v1: float, a: float) -> list:
    """Trapezoid rows covering ``length`` mm from ``v0`` to ``v1`` with cruise ``vc``, where the
    entry may be above the cruise (the feed was lowered): then it first slows down to ``vc``.

    The exit is raised to what braking at ``a`` over the length allows, if it was below.
    Returns [(length, row), ...].
    """
    if v0 <= vc:
        return [(length, prof.trapezoid(length, v0, vc, min(v1, vc), a))]
    braking = (v0 * v0 - vc * vc) / (2.0 * a)
    if braking >= length:
        floor = math.sqrt(max(v0 * v0 - 2.0 * a * length, 0.0))
        return [(length, prof.trapezoid(length, v0, v0, max(v1, floor), a))]
    return [(braking, prof.trapezoid(braking, v0, v0, vc, a)),
            (length - braking, prof.trapezoid(length - braking, vc, vc, min(v1, vc), a))]


class MoveProfile:
    """Seconds from the start of a move to ``s`` mm along it, as one or more profile rows."""

    def __init__(self, row):
        row = [float(v) for v in row]
        self.length = row[prof.P_LEN]
        self.starts = [0.0]           # s (mm) where each piece starts
        self.offsets = [0.0]          # time (s) at which each piece starts
        self.rows = [row]

    def time_at(self, s: float) -> float:
        if len(self.rows) == 1:
            return _time_at(s, self.rows[0])
        i = bisect.bisect_right(self.starts, s) - 1
        return self.offsets[i] + _time_at(s - self.starts[i], self.rows[i])

    def position_at(self, t: float, lo: float, hi: float) -> float:
        """The position (mm) reached ``t`` seconds into the move, searched between ``lo`` and
        ``hi`` mm (``time_at(lo) <= t``): the largest ``s`` there with ``time_at(s) <= t``."""
        while True:
            mid = 0.5 * (lo + hi)
            if not lo < mid < hi:
                return lo
            if self.time_at(mid) <= t:
                lo = mid
            else:
                hi = mid

    def speed_at(self, s: float) -> float:
        i = bisect.bisect_right(self.starts, s) - 1
        return speed_at(s - self.starts[i], self.rows[i])

    @property
    def duration(self) -> float:
        if len(self.rows) == 1:
            return prof.duration(self.rows[0])
        return self.offsets[-1] + prof.duration(self.rows[-1])

    @property
    def exit_speed(self) -> float:
        return float(self.rows[-1][prof.P_V1])

    def replan(self, s: float, pieces: list) -> None:
        """Keep the profile up to ``s`` mm and follow ``pieces`` (see :func:`ramp_pieces`) after."""
        t = self.time_at(s)
        i = bisect.bisect_right(self.starts, s) - 1
        starts, offsets, rows = self.starts[:i + 1], self.offsets[:i + 1], self.rows[:i + 1]
        if s <= starts[-1]:                 # the piece s falls in had not begun: drop it
            starts, offsets, rows = starts[:-1], offsets[:-1], rows[:-1]
        for length, row in pieces:
            row = [float(v) for v in row]
            starts.append(s)
            offsets.append(t)
            rows.append(row)
            t += prof.duration(row)
            s += length
        self.starts, self.offsets, self.rows = starts, offsets, rows
