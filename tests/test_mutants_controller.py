"""The controller checked where a mutation run found it unchecked (bench/mutation.py): a
compiled span hands back the frame whose step would open or close a limit switch, of its own
axis only; a feed override between two steps slows the carriage from where it is at that tick,
and two in one tick leave the last one's feed; the heartbeat's brake brings the carriage to rest
before it halts."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from retrofit.commands import MFdr, PFdr
from retrofit.controller import Controller
from retrofit.controller.kernels import G_DIR, G_HIGH, _switch_would_change

from tests.helpers import step_times
from tests.test_controller_pipeline import LATHE, feed, rises, z

Z_STEP_MM = LATHE.axis("Z").step_mm
Z_ACCEL = LATHE.axis("Z").max_accel_mm_s2


def would_change(motor_steps, direction, trip_mm, switch_axis, closed=0):
    """Axis 0 (100 steps/mm, no backlash) has a step rising in the next frame from ``motor_steps``
    towards ``direction``; one switch on ``switch_axis`` trips at ``trip_mm`` (+ side)."""
    gen = np.zeros((2, 6), np.int64)
    gen[0, G_HIGH], gen[0, G_DIR] = 1, direction
    sim = np.zeros((2, 2), np.int64)
    sim[0, 1] = motor_steps
    return bool(_switch_would_change(gen, sim, np.zeros(2), np.zeros(2), np.array([100.0, 100.0]),
                                     np.array([switch_axis], np.int64), np.array([1], np.int64),
                                     np.array([trip_mm]), np.array([0.0]), np.array([closed], np.int64)))


def test_the_step_that_reaches_a_switch_is_seen_before_its_frame():
    assert would_change(99, 1, 1.0, switch_axis=0)            # 0.99 mm -> 1.00 mm: it closes
    assert not would_change(98, 1, 1.0, switch_axis=0)        # 0.99 mm: still open
    assert not would_change(99, 1, 1.0, switch_axis=1)        # another axis's switch
    assert would_change(100, -1, 1.0, switch_axis=0, closed=1)   # backing off 1.00 -> 0.99: opens


def overridden(extra_ticks, feeds_mm_min):
    """chivu-lathe cruising at 10 mm/s along Z: ``extra_ticks`` after the step that reaches
    4.00 mm, the MFDRs ``feeds_mm_min`` are submitted in one tick. (the tick, the step rises)"""
    ctl = Controller(LATHE)
    feed(ctl, [PFdr(600.0), z(-6)])
    while ctl.position_steps[1] > -200:
        ctl.tick()
    for _ in range(extra_ticks):
        ctl.tick()
    at = ctl.ticks
    for f in feeds_mm_min:
        assert ctl.submit(MFdr(f)) is None
    ctl.run_until_idle(10**6)
    assert ctl.position_steps == (0, -300)
    return at, rises(ctl)


def slowed_step_tick(at, v, v_new, s_at, step):
    """The tick of step ``step`` (1: the first) once the carriage, at ``s_at`` mm and ``v`` mm/s
    on tick ``at``, has slowed to ``v_new`` at Z's acceleration: constant deceleration, then
    cruise (worked by hand from the feeds and the machine file, not by the controller)."""
    slow_s = (v - v_new) / Z_ACCEL
    s_slow = s_at + (v * v - v_new * v_new) / (2 * Z_ACCEL)
    return at + (slow_s + (step * Z_STEP_MM - s_slow) / v_new) / LATHE.tick_s


@pytest.mark.parametrize("extra_ticks", [0, 20], ids=["on-the-step", "between-steps"])
def test_a_feed_lowered_between_two_steps_slows_from_where_the_carriage_is_at_that_tick(extra_ticks):
    # at 10 mm/s a Z step (0.02 mm) takes 40 ticks: 20 ticks after the step at 4.00 mm the
    # carriage is at 4.01 mm. MFDR 60 mm/min: it slows at 250 mm/s^2 from there, then each step
    # comes 1 mm/s apart. Slowing from the last step's place (4.00) or the next one's (4.02)
    # instead would put every later step 180 ticks late or early.
    at, t = overridden(extra_ticks, [60.0])
    assert at - t[199] == extra_ticks
    s_at = 200 * Z_STEP_MM + 10.0 * extra_ticks * LATHE.tick_s
    for step in (215, 261, 290):
        assert t[step - 1] == pytest.approx(slowed_step_tick(at, 10.0, 1.0, s_at, step), abs=2)


def test_two_feed_overrides_in_one_tick_leave_the_last_ones_feed():
    # MFDR 120 then MFDR 60 mm/min on one tick between two steps: the carriage slows to 1 mm/s as
    # if only the 60 had come (the second re-plans from the same place as the first)
    at, t = overridden(20, [120.0, 60.0])
    s_at = 200 * Z_STEP_MM + 10.0 * 20 * LATHE.tick_s
    for step in (215, 261, 290):
        assert t[step - 1] == pytest.approx(slowed_step_tick(at, 10.0, 1.0, s_at, step), abs=2)
    assert np.array_equal(t, overridden(20, [60.0])[1])


def test_the_heartbeat_brakes_the_carriage_to_rest_before_it_halts():
    # Z accelerating at only 10 mm/s^2 to 10 mm/s (5 mm, 1 s), cruising; the host says nothing
    # after tick 0, so at 1.5 s (10 mm) the heartbeat brakes: 10 mm/s to rest takes 5 mm more, so
    # the carriage stops just short of 15 mm (step 750). Halting as soon as it is below 2 mm/s
    # would cut 0.2 mm (10 steps) of braking off: a stop at speed.
    machine = replace(LATHE, axes=tuple(replace(a, max_accel_mm_s2=10.0) if a.name == "Z" else a
                                        for a in LATHE.axes))
    ctl = Controller(machine)
    ctl.heartbeat_ticks = round(1.5 / LATHE.tick_s)
    ctl.heard()
    feed(ctl, [PFdr(600.0), z(-20)])
    ctl.run_until_idle(10**6)
    assert ctl.host_lost_at == (0, ctl.heartbeat_ticks)
    t = step_times(machine, ctl.frames())["Z"][0]
    assert sum(t <= ctl.heartbeat_ticks) == 500                 # 10 mm when it brakes
    assert 749 <= -ctl.position_steps[1] <= 750 and len(t) == -ctl.position_steps[1]
