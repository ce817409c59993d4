"""The indexer of 002: the spindle encoder as the step source of a move, for threads.

Under ISTP a move is timed by the spindle, not the clock. The encoder gives ``C`` pulses (ICLK)
and one index pulse (SIND) a revolution; the move's feed is a distance per revolution, so its
base axis must make ``S`` steps a revolution. Two Bresenhams in cascade do it, as 002 says
("the same algorithm has been used for discretization of the synchronized spindle-tool motion
space"): counts -> base steps (:class:`IndexerTrack`), then base steps -> every axis's steps
(the line's own Bresenham, :class:`~retrofit.motion.bresenham.BresenhamExecutor`).

The base axis's target is a function of the count alone, never of time, so a spindle that slows
under load slows the axis with it and the thread keeps its pitch:

* the **line**: ``p(c) = S (c - c_ref) / C`` base steps, where ``c_ref`` is an index count: the
  helix passes the move's start point on the index, whatever the speed, in every pass;
* the **lead-in**: an axis at rest cannot jump to thread speed. It starts ``L`` counts *before*
  ``c_ref`` and follows a parabola in the count, ``p(c) = S (c - c_ref + L)^2 / (4 C L)``, which
  meets the line with the line's slope ``L`` counts after ``c_ref``. At a steady spindle that is a
  constant acceleration; ``L`` comes from the speed and the acceleration the axis may use
  (:func:`lead_in_counts`). Past the lead-in the axis is on the same helix as every other pass.

Every position is exact: ``S`` and the origin are fractions and each step falls where the exact
target passes a half step, so over any number of revolutions the axis advances exactly ``S``
steps a revolution, with no drift.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..errors import MotionError
from .bresenham import BresenhamExecutor, LineMove

if TYPE_CHECKING:                  # fractions loads decimal: only a threading run needs them
    from fractions import Fraction

#: denominator bound of steps-per-revolution fractions (a float feed is read as the nearest one)
MAX_DENOMINATOR = 1_000_000


def steps_per_rev(feed_mm_rev: float, length_mm: float, base_steps: int) -> Fraction:
    """``S``: base-axis steps per spindle revolution of a move ``length_mm`` long with
    ``base_steps`` base steps, at ``feed_mm_rev`` along its path per revolution."""
    from fractions import Fraction
    exact = Fraction(feed_mm_rev) * base_steps / Fraction(length_mm)
    return exact.limit_denominator(MAX_DENOMINATOR)


def thread_speed_mm_s(feed_mm_rev: float, rpm: float) -> float:
    """Path speed (mm/s) of a move at ``feed_mm_rev`` with the spindle at ``rpm``."""
    return feed_mm_rev * rpm / 60.0


def lead_in_mm(feed_mm_rev: float, rpm: float, accel_mm_s2: float) -> float:
    """Distance (mm) a lead-in needs to reach thread speed from rest: ``v^2 / (2 a)``."""
    v = thread_speed_mm_s(feed_mm_rev, rpm)
    return v * v / (2.0 * accel_mm_s2)


#: share of the drive's reversing rate (``reverse_rpm_s``) the controller plans a spindle's stop
#: with, at the ends of a rigid tap (the rest takes up the load's wander)
PLAN_SHARE = 0.8


def stopping_revs(rpm: float, reverse_rpm_s: float) -> float:
    """Revolutions a spindle turns while the controller brings it to rest from ``rpm``.

    >>> stopping_revs(600.0, 3000.0)     # 10 rev/s, slowing at 0.8 x 50 rev/s^2
    1.25
    """
    revs_s, decel = rpm / 60.0, PLAN_SHARE * reverse_rpm_s / 60.0
    return revs_s * revs_s / (2.0 * decel)


def lead_in_counts(steps_per_rev: Fraction, counts_per_rev: int, rpm: float,
                   accel_steps_s2: float) -> int:
    """``L``: counts the lead-in takes on each side of the reference index (0: none needed).

    At ``rpm`` the base axis runs ``v = S rpm / 60`` steps/s; accelerating at ``a`` takes
    ``v / a`` seconds, half of which (``L`` counts) fall before the index. Rounded up, so the
    acceleration stays at or below ``a``.
    """
    if rpm <= 0.0 or accel_steps_s2 <= 0.0:
        raise MotionError(f"lead-in needs a turning spindle and an acceleration (rpm {rpm:g}, "
                          f"acceleration {accel_steps_s2:g} steps/s^2)")
    revs_s = rpm / 60.0
    v = float(steps_per_rev) * revs_s
    return math.ceil(revs_s * counts_per_rev * v / (2.0 * accel_steps_s2) - 1e-9)


class IndexerTrack:
    """The base axis's target (whole steps) as a function of the encoder count.

    Parameters
    ----------
    steps_per_rev : Fraction
        ``S``, base steps per revolution; at most ``counts_per_rev`` (one step a count).
    counts_per_rev : int
        ``C``.
    origin : Fraction
        ``c_ref``: the count at which the line passes the move's start (an index count for a
        pass that synchronises; where the previous move's line ended for a chained move).
    lead : int
        ``L``, counts of lead-in on each side of ``origin`` (0 for none).
    steps : int
        Base steps of the move: the target never exceeds it.

    Examples
    --------
    75 steps a revolution, 100 counts, no lead-in: after one revolution exactly 75 steps.

    >>> from fractions import Fraction
    >>> track = IndexerTrack(Fraction(75), 100, Fraction(400), 0, 10_000)
    >>> track.target(400), track.target(500), track.target(500 + 100 * 100)
    (0, 75, 7575)
    """

    def __init__(self, steps_per_rev: Fraction, counts_per_rev: int, origin: Fraction, lead: int,
                 steps: int):
        if steps_per_rev > counts_per_rev:
            raise MotionError(f"indexer: {float(steps_per_rev):g} base steps a revolution exceed the "
                              f"{counts_per_rev} encoder counts; at most one step a count")
        self.s_num, self.s_den = steps_per_rev.numerator, steps_per_rev.denominator
        self.counts = counts_per_rev
        self.o_num, self.o_den = origin.numerator, origin.denominator
        self.origin = origin
        self.lead = lead
        self.steps = steps

    @property
    def start_count(self) -> Fraction:
        """The count at which the axis starts moving (the lead-in's start)."""
        return self.origin - self.lead

    @property
    def end_count(self) -> Fraction:
        """The count at which the line reaches the end of the move."""
        from fractions import Fraction
        return self.origin + Fraction(self.steps * self.counts * self.s_den, self.s_num)

    def locked(self, count: int) -> bool:
        """True once the lead-in is over: the axis is on the line."""
        return count >= self.origin + self.lead

    def target(self, count: int) -> int:
        """Whole base steps due at ``count``: the exact target rounded at the half step."""
        if count <= self.start_count:
            return 0
        if self.lead and count < self.origin + self.lead:
            # S (c - c_s)^2 / (4 C L), c_s = origin - L (an integer when there is a lead-in)
            rel = count * self.o_den - self.o_num + self.lead * self.o_den   # (c - c_s) * o_den
            num = self.s_num * rel * rel
            den = self.s_den * 4 * self.counts * self.lead * self.o_den * self.o_den
        else:
            num = self.s_num * (count * self.o_den - self.o_num)
            den = self.s_den * self.counts * self.o_den
        due = (2 * num + den) // (2 * den)
        return min(max(due, 0), self.steps)


class IndexerExecutor:
    """*Execute* phase of an indexed move: counts in, one line Bresenham cycle per base step out.

    Parameters
    ----------
    line : LineMove
        The prepared line (:func:`~retrofit.motion.bresenham.prepare_line`); ``line.n`` base steps.
    track : IndexerTrack
        The base axis's target per count.
    """

    def __init__(self, line: LineMove, track: IndexerTrack):
        self.line = line
        self.track = track
        self.bresenham = BresenhamExecutor(line)

    @property
    def done(self) -> bool:
        return self.bresenham.done

    def advance(self, count: int) -> list[tuple[int, ...]]:
        """Run the cycles due at encoder ``count``; each is the step (-1, 0, +1) of every axis."""
        due = self.track.target(count)
        cycles = []
        while self.bresenham.cycle < due:
            cycles.append(self.bresenham.step())
        return cycles
