"""Velocity profiles and look-ahead, judged from the step times on the wire."""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.commands import FMov, PFdr, PMov
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program

from tests.helpers import limit_breaches, step_times


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def analytic_time(machine, start_mm, end_mm, feed_mm_min):
    """Rest-to-rest trapezoid time of one straight move, from the machine's limits."""
    d = np.array(end_mm) - np.array(start_mm)
    length = float(np.linalg.norm(d))
    u = np.abs(d) / length
    v = min([feed_mm_min / 60] + [a.max_velocity_mm_s / ui for a, ui in zip(machine.axes, u) if ui > 0])
    acc = min(a.max_accel_mm_s2 / ui for a, ui in zip(machine.axes, u) if ui > 0)
    if length >= v * v / acc:
        return length / v + v / acc
    return 2 * math.sqrt(length / acc)


@pytest.mark.parametrize("end,feed", [((-10.0, 0.0), 600), ((0.0, -30.0), 1200), ((-5.0, -40.0), 900),
                                      ((-0.5, -0.2), 600), ((-20.0, -150.0), 3000)],
                         ids=["x-only", "z-only", "diagonal", "short-triangle", "rapid-long"])
def test_single_move_time_matches_the_trapezoid(lathe, end, feed):
    plan = plan_program([PFdr(feed), PMov((("X", end[0]), ("Z", end[1])))], lathe, backlash_comp=False)
    log = execute_fast(plan)
    rises = step_times(lathe, log.frames)
    last = max(r[-1] for r, _ in rises.values() if len(r)) * lathe.tick_s
    expected = analytic_time(lathe, (0, 0), end, feed)
    assert abs(last - expected) <= 0.05 * expected


moves = st.lists(st.tuples(st.sampled_from(["G0", "G1"]), st.integers(-400, 400), st.integers(-1000, 400),
                           st.sampled_from([60, 300, 1200, 6000])), min_size=1, max_size=6)


@settings(max_examples=40)
@given(moves, st.sampled_from(["trapezoid", "exponential"]), st.sampled_from([1, 4, 16]))
def test_step_times_respect_every_axis_limit(lathe, program, profile, depth):
    machine = replace(lathe, motion=replace(lathe.motion, profile=profile, lookahead=depth))
    commands = []
    for kind, x, z, feed in program:
        target = (("X", x / 40), ("Z", z / 50))
        commands += [FMov(target)] if kind == "G0" else [PFdr(feed), PMov(target)]
    log = execute_fast(plan_program(commands, machine))
    breaches = limit_breaches(machine, log.frames)
    if profile == "exponential":      # the ramp starts at a stepper's start speed: a jump from rest
        breaches = [b for b in breaches if b[1] == "velocity"]
    assert breaches == []


def circle_chords(n, radius, center=(0.0, -20.0)):
    return [PMov((("X", center[0] + radius * math.sin(2 * math.pi * k / n)),
                  ("Z", center[1] + radius * math.cos(2 * math.pi * k / n)))) for k in range(n + 1)]


def test_hundred_chord_arc_keeps_its_feed_at_the_junctions(lathe):
    feed = 300.0                                           # a finishing feed on this lathe
    commands = [FMov((("X", 0.0), ("Z", -5.0))), PFdr(feed)] + circle_chords(100, 15.0)
    plan = plan_program(commands, lathe, backlash_comp=False)
    arc = plan.moves[2:]                                   # the 100 chords after the approach
    assert len(arc) == 100
    entries = [m.profile[1] for m in arc[1:]]              # speed at each junction between chords
    assert min(entries) >= 0.9 * feed / 60
    log = execute_fast(plan)
    assert limit_breaches(lathe, log.frames) == []
    # and the whole circle takes barely longer than at constant feed
    circumference = 100 * 2 * 15.0 * math.sin(math.pi / 100)
    arc_time = plan.end_s - arc[0].t0_s
    assert arc_time <= circumference / (feed / 60) * 1.05 + 0.2


def test_without_lookahead_every_junction_stops(lathe):
    machine = replace(lathe, motion=replace(lathe.motion, lookahead=1))
    plan = plan_program([PFdr(600)] + circle_chords(20, 15.0), machine, backlash_comp=False)
    assert all(m.profile[1] == 0.0 and m.profile[3] == 0.0 for m in plan.moves)


def test_reversal_needs_a_full_stop(lathe):
    plan = plan_program([PFdr(600), PMov((("X", -5.0),)), PMov((("X", 0.0),))], lathe, backlash_comp=False)
    assert plan.moves[0].profile[3] == 0.0 and plan.moves[1].profile[1] == 0.0


def random_kinematics(machine, data, n):
    """``n`` straight moves and dwells between random lattice points, with random feeds."""
    from retrofit.motion.lookahead import Kinematics
    from retrofit.motion.planner import kinematics
    out, here = [], (0, 0)
    for _ in range(n):
        if data.draw(st.integers(0, 5)) == 0:
            out.append(Kinematics(0.0, np.zeros(2), 1.0, 1.0, stop_before=True))
            continue
        there = tuple(data.draw(st.integers(-60, 60)) for _ in range(2))
        out.append(kinematics(machine, here, there, data.draw(st.sampled_from([2.0, 10.0, 50.0]))))
        here = there
    return out


@settings(max_examples=60)
@given(st.data(), st.sampled_from([1, 3, 16]), st.sampled_from([1.0, 0.25]))
def test_a_window_slid_along_a_program_plans_the_program_s_speeds(lathe, data, depth, scale):
    """The controller's window planner (``plan_window``) and the whole-program planner
    (``plan_speeds``) are one planner: entry, exit and acceleration of every move agree exactly."""
    from copy import deepcopy

    from retrofit.motion.lookahead import plan_speeds, plan_window
    moves = random_kinematics(lathe, data, data.draw(st.integers(1, 12)))
    whole = deepcopy(moves)
    speeds = plan_speeds(whole, depth, 0.02, scale, axis_accel(lathe), axis_step(lathe))
    entry, prev = 0.0, None
    for i, move in enumerate(moves):
        if move.length_mm == 0.0:                # a dwell: the controller stops and starts afresh
            entry, prev = 0.0, move
            assert speeds[i] == (0.0, 0.0)
            continue
        exit_, accel = plan_window(prev, moves[i:i + depth + 1], entry, depth, 0.02, scale,
                                   axis_accel(lathe), axis_step(lathe))
        assert (entry, exit_, accel) == (*speeds[i], whole[i].a_max_mm_s2)
        entry, prev = exit_, move


def axis_accel(machine):
    return np.array([a.max_accel_mm_s2 for a in machine.axes])


def axis_step(machine):
    return np.array([a.step_mm for a in machine.axes])
