"""Digital integration (004): short-axis pulses evenly spaced between base pulses, ending on the end point."""

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.errors import MotionError
from retrofit.motion import dda
from retrofit.motion.bresenham import prepare_line
from retrofit.motion.dda import DdaExecutor, dda_positions


@st.composite
def lines(draw, reach=3000):
    """A random straight move of 1-4 axes: start within a few thousand steps, some axes still."""
    axes = draw(st.integers(1, 4))
    start = draw(st.lists(st.integers(-reach, reach), min_size=axes, max_size=axes))
    span = draw(st.sampled_from([4, 40, reach]))
    delta = draw(st.lists(st.one_of(st.just(0), st.integers(-span, span)),
                          min_size=axes, max_size=axes))
    return tuple(start), tuple(s + d for s, d in zip(start, delta))


def run(move):
    """Execute a move base pulse by base pulse: (pulse positions per axis, final lattice point)."""
    ex = DdaExecutor(move)
    positions = [[] for _ in range(move.axes)]
    while not ex.done:
        for axis, delay in enumerate(ex.step()):
            if delay is not None:
                assert 0.0 <= delay < 1.0
                positions[axis].append(ex.long + delay)
    return [np.array(p, dtype=np.float64) for p in positions], ex.position


def ticks(positions, period_ticks):
    """Each pulse on the tick nearest its ideal time, with base pulses every period_ticks."""
    return np.rint(positions * period_ticks).astype(np.int64)


@pytest.mark.parametrize("end", [(20, 10), (-20, 10), (10, -20)], ids=["x-base", "x-negative", "y-base"])
def test_at_2_to_1_the_short_axis_pulses_every_2_base_pulses(end):
    move = prepare_line((0, 0), end)
    short = dda_positions(move)[1 - move.base]
    np.testing.assert_array_equal(short, np.arange(2.0, 21.0, 2.0))
    ex = DdaExecutor(move)
    assert [ex.step()[1 - move.base] for _ in range(4)] == [None, 0.0, None, 0.0]


def test_at_2_to_1_the_executor_pulses_on_every_second_base_pulse():
    ex = DdaExecutor(prepare_line((0, 0), (6, 3)))
    assert [ex.step() for _ in range(6)] == [(0.0, None), (0.0, 0.0)] * 3
    assert ex.position == (6, 3)


def test_at_3_to_2_the_short_axis_pulses_every_one_and_a_half_base_pulses():
    move = prepare_line((5, 5, 5), (5 + 30, 5 - 20, 5))
    base, short, still = dda_positions(move)
    np.testing.assert_array_equal(base, np.arange(1.0, 31.0))
    np.testing.assert_array_equal(np.diff(short, prepend=0.0), np.full(20, 1.5))
    assert still.size == 0
    ex = DdaExecutor(move)
    assert [ex.step()[1] for _ in range(6)] == [0.5, None, 0.0, 0.5, None, 0.0]


@settings(max_examples=150)
@given(n=st.integers(1, 3000), data=st.data())
def test_short_pulse_intervals_vary_by_at_most_one_tick(n, data):
    d = data.draw(st.integers(1, n), label="short pulses")
    period_ticks = data.draw(st.integers(2, 50), label="ticks per base pulse")
    short = dda_positions(prepare_line((0, 0), (n, -d)))[1]
    intervals = np.diff(ticks(short, period_ticks), prepend=0)
    assert intervals.max() - intervals.min() <= 1
    assert abs(intervals.mean() - n * period_ticks / d) < 1


@settings(max_examples=150)
@given(lines())
def test_executor_and_fast_path_place_every_pulse_at_the_same_position(line):
    move = prepare_line(*line)
    executed, _ = run(move)
    fast = dda_positions(move)
    assert len(fast) == move.axes
    for axis in range(move.axes):
        assert fast[axis].dtype == np.float64
        np.testing.assert_array_equal(executed[axis], fast[axis])     # bit for bit


@settings(max_examples=150)
@given(lines())
def test_each_axis_gets_delta_pulses_and_the_move_ends_on_its_end_point(line):
    start, end = line
    move = prepare_line(start, end)
    _, final = run(move)
    assert final == end
    for delta, positions in zip(move.delta, dda_positions(move)):
        assert positions.size == abs(delta)
        if delta:
            assert positions[-1] == move.n
            assert positions[0] > 0 and np.all(np.diff(positions) > 0)
    np.testing.assert_array_equal(dda_positions(move)[move.base], np.arange(1, move.n + 1))


def test_a_long_move_still_ends_exactly_on_n():
    move = prepare_line((-8_000_000, 0, 0), (1_999_999 - 8_000_000, 1_234_567, -3))
    for positions in dda_positions(move)[1:]:
        assert positions[-1] == move.n
        steps = np.diff(positions, prepend=0.0)
        assert np.ptp(steps) < 1e-6


def test_null_move_has_no_pulses():
    move = prepare_line((1, 2), (1, 2))
    assert [p.size for p in dda_positions(move)] == [0, 0]
    ex = DdaExecutor(move)
    assert ex.done and ex.position == (1, 2)
    with pytest.raises(MotionError, match="done"):
        ex.step()


def test_docstring_examples_run():
    assert doctest.testmod(dda).failed == 0
