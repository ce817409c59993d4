"""Motion's pure functions checked where a mutation run found them unchecked (bench/mutation.py):
the pulses a window of a 004 (DDA) move requests, the speed a sharp corner is taken at, the ticks of a ramp from a moving start,
the fast paths' step shaping (period, hold, set-up, look-ahead window) and following error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from retrofit.motion.fast import move_requests
from retrofit.motion.lookahead import Kinematics, junction_speed
from retrofit.motion.profile import ticks_at, trapezoid


def dda_requests(delta, windows, length_mm=6.0, rate=1000.0):
    """The ticks each axis's pulses are requested on, a 1 mm/s move of ``length_mm``, taken in
    ``windows`` (cycle bounds ``c0, c_stop``) with the interpolator's state carried between them."""
    n = max(abs(d) for d in delta)
    delta = np.array(delta, np.int64)
    state = np.zeros((2, len(delta)), np.int64)
    out = np.zeros((len(delta), n + 2), np.int64)
    fill = np.zeros(len(delta), np.int64)
    rows = trapezoid(length_mm, 1.0, 1.0, 1.0, 1.0)[None, :]
    for c0, c_stop in windows:
        move_requests(True, n, c0, c_stop, delta, state, length_mm, 0.0, np.zeros(1), np.zeros(1), rows,
                      rate, out, np.zeros((len(delta), 0), np.int64), fill, np.zeros(0, np.int64))
    return [out[a, :fill[a]].tolist() for a in range(len(delta))]


def test_a_dda_move_requests_every_pulse_at_its_place_whole_or_in_windows():
    # 6 base steps and 4 on the other axis over 6 mm at 1 mm/s: the short axis's pulses at
    # 1.5, 3, 4.5 and 6 mm, the last one at the move's end
    whole = dda_requests((6, -4), [(0, 6)])
    assert whole == [[1000, 2000, 3000, 4000, 5000, 6000], [1500, 3000, 4500, 6000]]
    assert dda_requests((6, -4), [(0, 3), (3, 6)]) == whole


def along(degrees):
    return Kinematics(10.0, np.array([math.cos(math.radians(degrees)), math.sin(math.radians(degrees))]), 50.0, 100.0)


def test_a_corner_sharper_than_a_right_angle_is_taken_slow_but_not_stopped():
    # a 120 degree turn leaves a 60 degree corner: the arc that rounds it within 0.01 mm has a
    # radius of 0.01 mm (half-angle sine 1/2), so at 100 mm/s2 the speed is sqrt(100 * 0.01) = 1
    assert junction_speed(along(0), along(120), 0.01) == pytest.approx(1.0)
    # a right angle: radius 0.01 * sin45 / (1 - sin45)
    s45 = math.sqrt(0.5)
    assert junction_speed(along(0), along(90), 0.01) == pytest.approx(math.sqrt(100 * 0.01 * s45 / (1 - s45)))
    assert junction_speed(along(0), along(180), 0.01) == 0.0           # a reversal stops
    assert junction_speed(along(0), along(0), 0.01) == 50.0            # straight on: the feed


def test_steps_while_speeding_up_from_a_moving_start_fall_on_the_ramp():
    # from 2 mm/s at 4 mm/s2 (cruise 10 mm/s from 12 mm on): s = 2 t + 2 t^2, so the place 6 mm
    # is reached at t = (sqrt(4 + 48) - 2) / 4 s and 0.5 mm at (sqrt(8) - 2) / 4 s; 1000 ticks/s
    out = np.zeros(2, np.int64)
    ticks_at(np.array([0.5, 6.0]), trapezoid(20.0, 2.0, 10.0, 2.0, 4.0), 0.0, 1000.0, out)
    assert out.tolist() == [round((math.sqrt(8) - 2) / 4 * 1000), round((math.sqrt(52) - 2) / 4 * 1000)]


def shaped(wanted, dirs, counts, seen, period=5, setup=1, hold=2, state=None):
    """(rises, turns, state) of one axis's requests by the fast paths' kernel."""
    from retrofit.motion.stepshape import fresh_state, shape_steps
    state = fresh_state(1)[0] if state is None else state
    n = len(wanted)
    rises, turn_ticks, turn_dirs = np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64)
    turns = shape_steps(state, np.array(wanted, np.int64), np.array(dirs, np.int64), np.array(counts, np.int64),
                        np.array(seen, np.int64), period, setup, hold, rises, turn_ticks, turn_dirs)
    return rises.tolist(), list(zip(turn_ticks[:turns].tolist(), turn_dirs[:turns].tolist())), state


def test_the_fast_paths_steps_wait_for_the_period_the_hold_the_set_up_and_the_look_ahead():
    # the output stage's worked example (test_mutants_pulses.py): a period of 5, a hold of 2 and
    # a set-up of 1; steps wanted on 1, 2 and (turning positive) 8 rise on 1, 6 and 11, the
    # direction turning on 8
    rises, turns, state = shaped([1, 2, 8], [-1, -1, 1], [3], [0])
    assert rises == [1, 6, 11] and turns == [(8, 1)]
    assert state.tolist() == [1, 11, 8, 3]
    # the same, the turning move (the second) entering the look-ahead window on tick 20: the pin
    # turns then, and the step follows the set-up
    rises, turns, _ = shaped([1, 2, 8], [-1, -1, 1], [2, 3], [0, 20])
    assert rises == [1, 6, 21] and turns == [(20, 1)]
    # continued from a state: the next request is looked at the tick after the last rise
    rises, turns, _ = shaped([3], [1], [1], [0], state=np.array([1, 11, 8, 3], np.int64))
    assert rises == [16] and turns == []


def test_the_look_ahead_window_and_the_following_error_of_the_fast_paths():
    from retrofit.motion.stepshape import NEVER, fresh_state, lag_of, window_seen
    loaded = np.array([0, 10, 20, 30, 40], np.int64)
    assert window_seen(loaded, 1).tolist() == [0, 0, 0, 10, 20]           # loaded 2 moves before
    assert window_seen(loaded, 0).tolist() == [0, 0, 10, 20, 30]
    assert window_seen(loaded, 8).tolist() == [0] * 5
    assert fresh_state(2).tolist() == [[-1, NEVER, NEVER, 0]] * 2
    wanted, rises = np.array([1, 2, 3, 4], np.int64), np.array([1, 6, 11, 16], np.int64)
    assert lag_of(wanted, rises, 0, 0) == 2                               # by 6: four wanted, two risen
    assert lag_of(wanted, rises[2:], 0, 2) == 1 and lag_of(wanted[2:], rises[2:], 2, 2) == 1
    assert lag_of(wanted, np.array([1, 2, 3, 4], np.int64), 0, 0) == 0


def requests(dda, delta, windows, pieces=((0.0, 0.0, 1.0),), length_mm=6.0, rate=1000.0):
    """(ticks each axis's steps are wanted on, ticks of the cycles that make them, tick of every
    cycle) of a move of ``length_mm`` taken in ``windows``; ``pieces``: (start mm, start s, speed
    mm/s) of a profile kept in constant-speed pieces, as the controller keeps a re-planned move."""
    n = max(abs(d) for d in delta)
    delta = np.array(delta, np.int64)
    state = np.zeros((2, len(delta)), np.int64)
    out, made = np.zeros((len(delta), n + 2), np.int64), np.zeros((len(delta), n + 2), np.int64)
    fill = np.zeros(len(delta), np.int64)
    starts = np.array([p[0] for p in pieces])
    rows = np.array([trapezoid(length_mm - p[0], p[2], p[2], p[2], 1.0) for p in pieces])
    due = []
    for c0, c_stop in windows:
        cycles = np.zeros(c_stop - c0, np.int64)
        move_requests(dda, n, c0, c_stop, delta, state, length_mm, 0.0, starts, np.array([p[1] for p in pieces]),
                      rows, rate, out, made, fill, cycles)
        due += cycles.tolist()
    return ([out[a, :fill[a]].tolist() for a in range(len(delta))],
            [made[a, :fill[a]].tolist() for a in range(len(delta))], due)


def test_a_bresenham_move_requests_each_step_on_the_cycle_nearest_the_line():
    # 6 cycles, 4 steps on the short axis: after cycle k it should be at round(4k/6) = 1 1 2 3 3 4,
    # so it steps on cycles 1, 3, 4, 6 (ticks 1000 ... at 1 mm/s)
    ticks, made, due = requests(False, (6, -4), [(0, 6)])
    assert ticks == made == [[1000, 2000, 3000, 4000, 5000, 6000], [1000, 3000, 4000, 6000]]
    assert due == [1000, 2000, 3000, 4000, 5000, 6000]
    assert requests(False, (6, -4), [(0, 2), (2, 3), (3, 6)])[:2] == (ticks, made)
    # a tie in the middle (half a step after cycle 1 of 2): a positive axis steps late, a negative
    # one early, so a move and its reverse visit the same points
    assert requests(False, (2, 1), [(0, 2)], length_mm=2.0)[0] == [[1000, 2000], [2000]]
    assert requests(False, (2, -1), [(0, 2)], length_mm=2.0)[0] == [[1000, 2000], [1000]]
    # ties after cycles 1 and 3 of 4 round towards the nearer end: late, then early
    assert requests(False, (-4, 2), [(0, 4)], length_mm=4.0)[0][1] == [2000, 3000]


def test_a_dda_moves_pulses_and_the_cycles_that_send_them():
    # the short axis's pulses at 1.5, 3, 4.5 and 6 mm are sent by cycles 6j // 4 = 1, 3, 4, 6
    ticks, made, due = requests(True, (6, -4), [(0, 6)])
    assert ticks[1] == [1500, 3000, 4500, 6000] and made[1] == [1000, 3000, 4000, 6000]
    assert due == [1000, 2000, 3000, 4000, 5000, 6000]
    assert requests(True, (6, -4), [(0, 4), (4, 6)])[:2] == (ticks, made)


def test_a_re_planned_move_is_timed_by_the_piece_each_step_falls_in():
    # 1 mm/s for the first 3 mm, then 2 mm/s from 3 s on: cycles at 1 2 3 3.5 4 4.5 s
    pieces = ((0.0, 0.0, 1.0), (3.0, 3.0, 2.0))
    ticks, _, due = requests(False, (6, 3), [(0, 6)], pieces)
    assert due == [1000, 2000, 3000, 3500, 4000, 4500]
    assert ticks[1] == [2000, 3500, 4000]                     # cycles 2, 4, 5 (ties towards the nearer end)
    assert requests(True, (6, 4), [(0, 6)], pieces)[0][1] == [1500, 3000, 3750, 4500]
