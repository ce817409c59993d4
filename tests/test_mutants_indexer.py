"""The indexer (the spindle encoder as a thread's step source) on its own, against hand
computations: steps a revolution, the lead-in's counts, the base axis's target on the parabola
and on the line, and the steps each count releases."""

from __future__ import annotations

from fractions import Fraction

import pytest

from retrofit.errors import MotionError
from retrofit.motion.bresenham import prepare_line
from retrofit.motion.indexer import (
    IndexerExecutor,
    IndexerTrack,
    lead_in_counts,
    lead_in_mm,
    steps_per_rev,
    stopping_revs,
    thread_speed_mm_s,
)


def test_steps_a_revolution_speed_and_lead_in_distance_of_a_thread():
    assert steps_per_rev(1.5, 30.0, 6000) == 300             # 1.5 mm of 30 mm: 1/20 of 6000 steps
    assert steps_per_rev(1.25, 10.0, 333) == Fraction(333, 8)  # 41.625 steps, kept exact
    assert steps_per_rev(0.1, 3.0, 1) == Fraction(1, 30)
    assert thread_speed_mm_s(2.0, 600.0) == 20.0              # 2 mm a turn at 10 turns/s
    assert lead_in_mm(2.0, 600.0, 100.0) == 2.0               # 20^2 / (2 * 100)
    assert stopping_revs(600.0, 3000.0) == 1.25
    assert stopping_revs(1200.0, 1000.0) == pytest.approx(15.0)   # 20 rev/s at 0.8 * 1000/60 rev/s^2


def test_the_lead_in_takes_half_the_time_to_thread_speed_in_counts_rounded_up():
    # 300 steps a turn at 600 rpm: 3000 steps/s; at 12000 steps/s^2 that is 0.25 s, half of it
    # before the index: 0.125 s of 10 turns/s of 1000 counts = 1250 counts exactly
    assert lead_in_counts(Fraction(300), 1000, 600.0, 12000.0) == 1250
    # at 7000 steps/s^2: 2142.86 counts, rounded up so the acceleration stays within 7000
    assert lead_in_counts(Fraction(300), 1000, 600.0, 7000.0) == 2143
    assert lead_in_counts(Fraction(1, 2), 4, 60.0, 1.0) == 1          # 0.25 counts: one
    for rpm, accel in ((0.0, 100.0), (600.0, 0.0), (-5.0, 100.0), (600.0, -1.0)):
        with pytest.raises(MotionError, match="lead-in needs a turning spindle and an acceleration"):
            lead_in_counts(Fraction(300), 1000, rpm, accel)


def test_more_steps_than_counts_a_revolution_is_refused_one_a_count_is_accepted():
    with pytest.raises(MotionError, match=r"101 base steps a revolution exceed the 100 encoder counts"):
        IndexerTrack(Fraction(101), 100, Fraction(0), 0, 10)
    track = IndexerTrack(Fraction(100), 100, Fraction(0), 0, 1000)
    assert [track.target(c) for c in (0, 1, 2, 99, 100)] == [0, 1, 2, 99, 100]


def test_the_line_rounds_at_the_half_step_and_stops_at_the_moves_end():
    # 75 steps a turn of 100 counts from count 400: 0.75 steps a count
    track = IndexerTrack(Fraction(75), 100, Fraction(400), 0, 100)
    assert [track.target(c) for c in (0, 399, 400, 401, 402, 403, 404, 500)] == [0, 0, 0, 1, 2, 2, 3, 75]
    assert track.target(540) == 100 and track.target(10_000) == 100       # 105 due, the move has 100
    assert track.start_count == 400 and track.end_count == 400 + Fraction(100 * 100, 75)
    assert track.locked(400) and not track.locked(399)
    # an origin between two counts (a chained move): 0.75 (c - 400.5)
    half = IndexerTrack(Fraction(75), 100, Fraction(801, 2), 0, 100)
    assert [half.target(c) for c in (400, 401, 402, 403, 500)] == [0, 0, 1, 2, 75]
    assert half.end_count == Fraction(801, 2) + Fraction(400, 3)


def test_the_lead_in_follows_a_parabola_that_meets_the_line_with_its_slope():
    # S = 100, C = 1000, index at 2000, L = 500: from 1500 the target is 100 (c - 1500)^2 / 2e6,
    # then 100 (c - 2000) / 1000 from 2500 on
    track = IndexerTrack(Fraction(100), 1000, Fraction(2000), 500, 300)
    assert track.start_count == 1500 and track.end_count == 5000
    parabola = {1500: 0, 1550: 0, 1600: 1, 1700: 2, 2000: 13, 2400: 41, 2499: 50}   # 0.125 0.5 2 12.5 40.5 49.9
    assert {c: track.target(c) for c in parabola} == parabola
    line = {2500: 50, 2505: 51, 3000: 100, 4995: 300, 6000: 300}
    assert {c: track.target(c) for c in line} == line
    assert not track.locked(2499) and track.locked(2500)
    # every count advances the target by at most one step once it is under way: no jump
    targets = [track.target(c) for c in range(1500, 5001)]
    assert max(b - a for a, b in zip(targets, targets[1:])) == 1 and targets[-1] == 300


def test_the_executor_runs_the_lines_cycles_as_the_counts_come():
    line = prepare_line((0, 0), (6, -3))                      # 6 base steps, every other one on Z
    run = IndexerExecutor(line, IndexerTrack(Fraction(3), 10, Fraction(0), 0, 6))   # 0.3 steps a count
    got = {c: run.advance(c) for c in (0, 1, 2, 5, 10, 20, 30)}
    assert got[0] == got[1] == [] and len(got[2]) == 1         # 0.6 steps: the first cycle
    assert len(got[5]) == 1 and len(got[10]) == 1              # 1.5 -> 2, 3
    assert len(got[20]) == 3 and got[30] == [] and run.done    # 6, then the move is over
    cycles = [c for k in sorted(got) for c in got[k]]
    assert [c[0] for c in cycles] == [1] * 6 and sum(c[1] for c in cycles) == -3
