"""Bresenham line interpolation (002): prepare checks the step space, execute stays on the line."""

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.errors import MotionError
from retrofit.motion import bresenham
from retrofit.motion.bresenham import STEP_SPACE_LIMIT, BresenhamExecutor, bresenham_cycles, prepare_line


@st.composite
def lines(draw, reach=3000):
    """A random straight move of 1-4 axes: start within a few thousand steps, some axes still."""
    axes = draw(st.integers(1, 4))
    start = draw(st.lists(st.integers(-reach, reach), min_size=axes, max_size=axes))
    span = draw(st.sampled_from([4, 40, reach]))        # short moves make half-step ties common
    delta = draw(st.lists(st.one_of(st.just(0), st.integers(-span, span)),
                          min_size=axes, max_size=axes))
    return tuple(start), tuple(s + d for s, d in zip(start, delta))


def run(move):
    """Execute a move cycle by cycle: (steps per cycle, lattice point after each cycle)."""
    ex = BresenhamExecutor(move)
    steps, points = [], []
    while not ex.done:
        steps.append(ex.step())
        points.append(ex.position)
    return steps, points


def points_of(start, end):
    return run(prepare_line(start, end))[1]


@settings(max_examples=150)
@given(lines())
def test_every_point_is_within_half_a_step_of_the_ideal_line(line):
    start, end = line
    move = prepare_line(start, end)
    for k, point in enumerate(run(move)[1], start=1):
        for s, p, d in zip(start, point, move.delta):
            # |(p - s) - k d / n| <= 1/2, in whole numbers
            assert abs(2 * move.n * (p - s) - 2 * k * d) <= move.n, (k, point)


@settings(max_examples=150)
@given(lines())
def test_executor_ends_on_the_end_point_and_each_axis_takes_delta_steps(line):
    start, end = line
    move = prepare_line(start, end)
    steps, points = run(move)
    assert len(steps) == move.n == max(abs(e - s) for s, e in zip(start, end))
    assert (points[-1] if points else start) == end
    per_axis = np.array(steps, dtype=np.int64).reshape(move.n, len(start))
    assert np.all(per_axis[:, move.base] == move.direction[move.base])    # base axis: every cycle
    assert per_axis.sum(axis=0).tolist() == list(move.delta)
    assert np.abs(per_axis).sum(axis=0).tolist() == [abs(d) for d in move.delta]


@settings(max_examples=150)
@given(lines())
def test_fast_path_steps_on_the_same_cycles_as_the_executor(line):
    move = prepare_line(*line)
    steps = np.array(run(move)[0], dtype=np.int64).reshape(move.n, move.axes)
    fast = bresenham_cycles(move)
    assert len(fast) == move.axes
    for axis, cycles in enumerate(fast):
        assert cycles.dtype == np.int64
        expected = np.flatnonzero(steps[:, axis]) + 1
        np.testing.assert_array_equal(cycles, expected)
        assert np.all(steps[cycles - 1, axis] == move.direction[axis])


@settings(max_examples=100)
@given(lines())
def test_the_reversed_move_visits_the_same_lattice_points(line):
    start, end = line
    there = [start] + points_of(start, end)
    back = [end] + points_of(end, start)
    assert there == back[::-1]


def test_classic_line_and_its_mirror():
    assert points_of((0, 0), (5, 2)) == [(1, 0), (2, 1), (3, 1), (4, 2), (5, 2)]
    assert points_of((0, 0), (-5, -2)) == [(-1, 0), (-2, -1), (-3, -1), (-4, -2), (-5, -2)]
    assert points_of((0, 0), (2, 5)) == [(0, 1), (1, 2), (1, 3), (2, 4), (2, 5)]


def test_half_step_ties_round_towards_the_nearer_end():
    # y = 0.5 at x = 1 (first half: stay at the start), y = 1.5 at x = 3 (second half: go on)
    assert points_of((0, 0), (4, 2)) == [(1, 0), (2, 1), (3, 2), (4, 2)]
    # y = 0.5 at the exact middle: the more negative coordinate, in both directions
    assert points_of((0, 0), (2, 1)) == [(1, 0), (2, 1)]
    assert points_of((2, 1), (0, 0)) == [(1, 0), (0, 0)]


def test_base_axis_is_the_longest_first_on_ties():
    assert prepare_line((0, 0, 0), (3, -7, 2)).base == 1
    assert prepare_line((0, 0, 0), (5, -5, 5)).base == 0
    assert prepare_line((10, 10), (10, 4)).base == 1


def test_null_move_has_no_cycles():
    move = prepare_line((12, -3, 0), (12, -3, 0))
    assert move.n == 0
    ex = BresenhamExecutor(move)
    assert ex.done and ex.position == (12, -3, 0)
    assert [c.size for c in bresenham_cycles(move)] == [0, 0, 0]
    with pytest.raises(MotionError, match="done"):
        ex.step()


def test_a_long_move_at_the_edge_of_the_step_space_stays_on_the_line():
    start = (-STEP_SPACE_LIMIT, STEP_SPACE_LIMIT, 5)
    end = (-STEP_SPACE_LIMIT + 2_000_003, STEP_SPACE_LIMIT - 1_234_567, -700_001)
    move = prepare_line(start, end)
    k = np.arange(move.n + 1, dtype=np.int64)
    for axis, cycles in enumerate(bresenham_cycles(move)):
        assert cycles.size == abs(move.delta[axis])
        offset = np.searchsorted(cycles, k, side="right") * move.direction[axis]
        assert np.all(np.abs(2 * move.n * offset - 2 * k * move.delta[axis]) <= move.n)


@pytest.mark.parametrize("start, end, message", [
    ((0, 0), (9_000_000, 0), "X end 9000000 steps is outside the 24-bit step space ±8388607"),
    ((0, -8_388_608), (0, 0), "Y start -8388608 steps is outside the 24-bit step space ±8388607"),
    ((0, 0, 0, 0), (0, 0, 0, 1 << 24), "A end 16777216 steps is outside"),
], ids=["x-end", "y-start-one-past", "a-end"])
def test_a_move_outside_the_step_space_is_refused(start, end, message):
    with pytest.raises(MotionError, match=message):
        prepare_line(start, end)


def test_the_error_uses_the_machines_axis_names():
    with pytest.raises(MotionError, match="^Z end 8388608 steps"):
        prepare_line((0, 0), (0, STEP_SPACE_LIMIT + 1), names=("X", "Z"))


def test_the_limits_themselves_are_accepted():
    move = prepare_line((STEP_SPACE_LIMIT, -STEP_SPACE_LIMIT), (STEP_SPACE_LIMIT - 3, -STEP_SPACE_LIMIT))
    steps, points = run(move)
    assert points[-1] == (STEP_SPACE_LIMIT - 3, -STEP_SPACE_LIMIT)
    assert prepare_line((-STEP_SPACE_LIMIT,), (STEP_SPACE_LIMIT,)).n == 2 * STEP_SPACE_LIMIT


@pytest.mark.parametrize("start, end, message", [
    ((0, 0), (1, 2, 3), "same axes"),
    ((), (), "same axes"),
    ((0, 0), (1.5, 2), "X end 1.5 is not a whole number of steps"),
], ids=["sizes-differ", "no-axes", "fractional-step"])
def test_malformed_moves_are_refused(start, end, message):
    with pytest.raises(MotionError, match=message):
        prepare_line(start, end)


def test_docstring_examples_run():
    assert doctest.testmod(bresenham).failed == 0
