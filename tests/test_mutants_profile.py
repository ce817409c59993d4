"""Velocity profiles and the look-ahead's passes checked against hand computations and a numerical
integration of 1/v(s): where a tool is when, at what speed it enters and leaves each move."""

from __future__ import annotations

import math

import numpy as np
import pytest

from retrofit.motion import profile as prof
from retrofit.motion.lookahead import JUNCTION_SHARE, Kinematics, junction_speed, plan_speeds


def integrated_time(speed, s_end, n=20_000):
    """Seconds to reach ``s_end`` at ``speed(s)`` mm/s: the midpoint rule on ``n`` slices of ``w``
    with ``s = s_end w^2 / 2`` from each end (finite where the tool starts or stops at rest)."""
    w = (np.arange(n) + 0.5) / n
    half = s_end * w * w / 2
    return float(np.sum(s_end * w / speed(half) + s_end * w / speed(s_end - half)) / n)


def trapezoid_speed(length, v0, vc, v1, a):
    """v(s) of a trapezoid from the textbook: up at a, cruise, down at a."""
    return lambda s: np.minimum(np.minimum(np.sqrt(v0 * v0 + 2 * a * s), vc),
                                np.sqrt(v1 * v1 + 2 * a * np.maximum(length - s, 0.0)))


@pytest.mark.parametrize("length, v0, vc, v1, a", [
    (10.0, 0.0, 5.0, 0.0, 10.0),       # cruises from 1.25 to 8.75 mm
    (10.0, 2.0, 5.0, 3.0, 4.0),        # moving entry and exit, unequal ramps
    (1.0, 1.0, 50.0, 2.0, 10.0),       # a triangle: peaks at sqrt(12.5) mm/s, short of the feed
])
def test_a_trapezoids_times_are_those_of_its_speed_along_the_move(length, v0, vc, v1, a):
    row = prof.trapezoid(length, v0, vc, v1, a)
    speed = trapezoid_speed(length, v0, vc, v1, a)
    peak = min(vc, math.sqrt((2 * a * length + v0 * v0 + v1 * v1) / 2))
    assert row[prof.P_VC] == pytest.approx(peak)
    assert row[prof.P_D1] == pytest.approx((peak * peak - v0 * v0) / (2 * a))
    assert row[prof.P_D2] == pytest.approx((peak * peak - v1 * v1) / (2 * a))
    for s in (0.3 * length, 0.5 * length, 0.9 * length, length):
        assert prof.time_at(s, row) == pytest.approx(integrated_time(speed, s), rel=1e-4)
    assert prof.duration(row) == pytest.approx(integrated_time(speed, length), rel=1e-4)
    assert prof.time_at(0.0, row) == 0.0


def exponential_speed(v0, vc, a):
    """v(s) of a ramp from v0 towards V = vc + (vc - v0) / 20, with the λ that keeps v dv/ds <= a."""
    big_v = vc + (vc - v0) / 20
    grid = np.linspace(v0, vc, 100_001)
    lam = float(np.max(grid * (big_v - grid))) / a
    return (lambda s: big_v - (big_v - v0) * np.exp(-s / lam)), lam * math.log(21)


@pytest.mark.parametrize("length, v0, vc, v1, a", [
    (40.0, 1.0, 10.0, 1.0, 20.0),      # up from the start speed, cruise, down again
    (40.0, 6.0, 10.0, 2.0, 20.0),      # the peak acceleration inside the ramp, then at its start
])
def test_an_exponential_ramp_moves_as_its_speed_law_says(length, v0, vc, v1, a):
    row = prof.exponential(length, v0, vc, v1, a, 1.0)
    up, d1 = exponential_speed(v0, vc, a)
    down, d2 = exponential_speed(v1, vc, a)
    assert row[prof.P_D1] == pytest.approx(d1, rel=1e-6) and row[prof.P_D2] == pytest.approx(d2, rel=1e-6)
    assert float(up(np.array(d1))) == pytest.approx(vc)                # the ramp ends on the feed

    def speed(s):
        return np.where(s <= d1, up(s), np.where(s >= length - d2, down(np.maximum(length - s, 0.0)), vc))
    for s in (0.5 * d1, d1, length / 2, length - 0.5 * d2, length):
        assert prof.time_at(s, row) == pytest.approx(integrated_time(speed, s), rel=1e-5)
    assert prof.duration(row) == pytest.approx(integrated_time(speed, length), rel=1e-5)
    # the acceleration v dv/ds reaches a and never exceeds it
    s = np.linspace(0.0, d1, 20_001)
    accel = up(s) * np.gradient(up(s), s)
    assert accel.max() == pytest.approx(a, rel=1e-3) and accel.max() <= a * (1 + 1e-3)


def test_a_short_exponential_move_lowers_its_cruise_until_both_ramps_fit():
    row = prof.exponential(2.0, 0.5, 30.0, 0.5, 20.0, 1.0)        # entry and exit raised to 1 mm/s
    assert row[prof.P_V0] == 1.0 and row[prof.P_V1] == 1.0
    assert 1.0 < row[prof.P_VC] < 30.0
    assert row[prof.P_D1] + row[prof.P_D2] == pytest.approx(2.0, rel=1e-9)
    assert row[prof.P_D1] == pytest.approx(1.0, rel=1e-9)            # the same ramp up and down
    up, d1 = exponential_speed(1.0, row[prof.P_VC], 20.0)
    assert d1 == pytest.approx(1.0, rel=1e-6)
    assert prof.duration(row) == pytest.approx(2 * integrated_time(up, 1.0), rel=1e-5)
    # entered at the feed: no ramp up, the time of the first mm is 1 / feed
    flat = prof.exponential(10.0, 5.0, 5.0, 5.0, 20.0, 1.0)
    assert prof.time_at(1.0, flat) == pytest.approx(0.2) and prof.duration(flat) == pytest.approx(2.0)


def along(x, z, v_max=100.0, a_max=10.0, length=None):
    unit = np.array([x, z], float) / math.hypot(x, z)
    return Kinematics(math.hypot(x, z) if length is None else length, unit, v_max, a_max)


def test_the_passes_let_the_tool_stop_at_the_end_of_what_the_window_sees():
    # three collinear moves of 4, 1 and 1 mm at 10 mm/s^2: to stop by the end of the third the
    # tool leaves the first at sqrt(2 * 10 * 2); seeing only two it must leave at sqrt(2 * 10 * 1)
    def moves():
        return [along(1, 0, length=4.0), along(1, 0, length=1.0), along(1, 0, length=1.0)]
    r20, r40 = math.sqrt(20.0), math.sqrt(40.0)
    assert plan_speeds(moves(), 16, 0.02) == pytest.approx([(0.0, r40), (r40, r20), (r20, 0.0)])
    assert plan_speeds(moves(), 2, 0.02) == pytest.approx([(0.0, r20), (r20, r20), (r20, 0.0)])
    assert plan_speeds(moves(), 1, 0.02) == [(0.0, 0.0)] * 3
    capped = moves()
    capped[1].v_max_mm_s = 5.0                                       # the middle one is slower
    assert plan_speeds(capped, 16, 0.02)[0][1] == pytest.approx(5.0)
    # a quarter of the acceleration (the exponential ramps): every speed halves
    assert plan_speeds(moves(), 16, 0.02, accel_scale=0.25) == pytest.approx(
        [(0.0, r40 / 2), (r40 / 2, r20 / 2), (r20 / 2, 0.0)])
    # a short first move cannot reach what the window allows: it leaves at sqrt(2 a L)
    short = [along(1, 0, length=0.05), along(1, 0, length=10.0)]
    assert plan_speeds(short, 16, 0.02)[0] == pytest.approx((0.0, 1.0))


def test_a_stop_between_moves_is_entered_at_rest_and_a_turn_halves_the_acceleration():
    stop = Kinematics(0.0, np.zeros(2), 1.0, 1.0, stop_before=True)
    moves = [along(1, 0, length=5.0), stop, along(1, 0, length=5.0)]
    assert plan_speeds(moves, 16, 0.02) == [(0.0, 0.0)] * 3
    assert moves[0].a_max_mm_s2 == 10.0 and moves[2].a_max_mm_s2 == 10.0        # rest to rest: whole
    halt = along(1, 0, length=5.0)
    halt.stop_before = True                                         # a ZMOV: stops before it
    assert plan_speeds([along(1, 0, length=5.0), halt], 16, 0.02) == [(0.0, 0.0)] * 2
    turning = [along(1, 0, length=5.0), along(0, 1, length=5.0), along(0, 1, length=5.0)]
    speeds = plan_speeds(turning, 16, 0.02)
    assert speeds[0][1] > 0.0                                        # the right angle taken moving
    assert [m.a_max_mm_s2 for m in turning] == [10.0 * (1 - JUNCTION_SHARE)] * 2 + [10.0]
    assert plan_speeds([], 16, 0.02) == []


def test_a_turn_at_speed_holds_each_axiss_velocity_jump_to_its_share_of_one_steps_acceleration():
    # a 90 degree turn X -> Z: the deviation alone would allow sqrt(100 * 0.5 * s45 / (1 - s45))
    before, after = along(1, 0, a_max=100.0), along(0, 1, a_max=100.0)
    accel, step = np.array([50.0, 200.0]), np.array([0.01, 0.002])
    v = junction_speed(before, after, 0.5, accel, step)
    s45 = math.sqrt(0.5)
    assert v < math.sqrt(100 * 0.5 * s45 / (1 - s45))
    # each axis's jump v * 1 fits share * a * dt, dt = step / (v + sqrt(2 a step)); the tighter axis
    # holds the speed to where its jump just fits
    fits = [JUNCTION_SHARE * a * s / (v + math.sqrt(2 * a * s)) / v for a, s in zip(accel, step)]
    assert min(fits) == pytest.approx(1.0) and max(fits) > 1.0
    assert junction_speed(before, after, 0.5) == pytest.approx(math.sqrt(100 * 0.5 * s45 / (1 - s45)))
    assert junction_speed(before, Kinematics(0.0, np.zeros(2), 1.0, 1.0), 0.5) == 0.0   # into a dwell
    assert junction_speed(Kinematics(0.0, np.zeros(2), 1.0, 1.0), after, 0.5) == 0.0
    # a turn that leaves one axis's velocity unchanged: only the other axis limits
    slant = along(1, 1, a_max=100.0)
    only_z = junction_speed(along(1, 0, a_max=100.0), slant, 0.5, np.array([50.0, 1e9]), np.array([0.01, 1.0]))
    du_x = 1 - math.sqrt(0.5)
    assert only_z == pytest.approx(min(math.sqrt(100 * 0.5 * math.cos(math.pi / 8) / (1 - math.cos(math.pi / 8))),
                                       jump_limit(du_x, 1.0, 50.0, 0.01)))


def jump_limit(du, m, a, step):
    """The largest v with v du <= share a step / (v m + sqrt(2 a step)), by bisection."""
    lo, hi = 0.0, 1e6
    for _ in range(200):
        v = (lo + hi) / 2
        lo, hi = (v, hi) if v * du * (v * m + math.sqrt(2 * a * step)) <= JUNCTION_SHARE * a * step else (lo, v)
    return lo
