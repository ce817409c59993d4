"""Checks of lab 01 (the circle): run with `retrofit lab check 01`, or pytest on this file."""

import math
from dataclasses import replace

import pytest

from retrofit.config import load_machine
from retrofit.demo import circle_targets as library_targets
from retrofit.labs import expect, load_target


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def finer():
    """A second lathe: the chivu lathe with finer screws, 64 steps/mm on X and 80 on Z."""
    machine = load_machine("chivu-lathe")
    spm = {"X": 64.0, "Z": 80.0}
    return replace(machine, axes=tuple(replace(a, steps_per_mm=spm[a.name]) for a in machine.axes))


def _paper_point(n, kt=40.0, kl=50.0, radius=15.0, points=100):
    angle = n * 2 * math.pi / points
    return math.trunc(radius * math.sin(angle) * kt), math.trunc(radius * math.cos(angle) * kl)


def test_point_zero_is_on_the_z_axis(lab):
    """TODO 1: point 0 lies on the Z axis, 15 mm out (0 X steps, 750 Z steps)"""
    got = lab.calc_next_input(0, 40.0, 50.0)
    expect(tuple(got) == (0, 750), "calc_next_input(0, kt=40, kl=50) for the 15 mm circle",
           expected="(0, 750): X = 15 sin 0 * 40 = 0 steps, Z = 15 cos 0 * 50 = 750 steps",
           got=repr(got), hint="return (x_steps, z_steps): the transversal X first, then the longitudinal Z")


def test_truncated_to_steps_like_the_paper(lab):
    """TODO 1: every point is cut to whole steps towards zero, as the paper's trunc does"""
    for n in range(101):
        got, want = tuple(lab.calc_next_input(n, 40.0, 50.0)), _paper_point(n)
        if got == want:
            continue
        angle = n * 2 * math.pi / 100
        exact = (15 * math.sin(angle) * 40, 15 * math.cos(angle) * 50)
        rounded = (round(exact[0]), round(exact[1]))
        floored = (math.floor(exact[0]), math.floor(exact[1]))
        hint = ("you rounded to the nearest step; the paper truncates (math.trunc or int())"
                if got == rounded else
                "math.floor goes down for negative numbers; trunc goes towards zero (math.trunc or int())"
                if got == floored else
                "X = trunc(15 sin(n 2 pi / 100) * KT), Z = trunc(15 cos(n 2 pi / 100) * KL)")
        expect(False, f"calc_next_input({n}, kt=40, kl=50)",
               expected=f"{want} (exact values {exact[0]:.3f}, {exact[1]:.3f} steps)", got=repr(got), hint=hint)


OTHER_CIRCLES = [(12, 64.0, 80.0, 7.5, 50), (37, 25.0, 125.0, 40.0, 60), (3, 50.0, 40.0, 2.0, 8)]


def test_other_circles(lab):
    """TODO 1: other radii, point counts and steps per mm: the ones you are given, none written in"""
    for n, kt, kl, radius, points in OTHER_CIRCLES:
        got, want = tuple(lab.calc_next_input(n, kt, kl, radius, points)), _paper_point(n, kt, kl, radius, points)
        expect(got == want, f"calc_next_input({n}, kt={kt:g}, kl={kl:g}, radius_mm={radius:g}, points={points})",
               expected=repr(want), got=repr(got),
               hint="use the arguments radius_mm, points, kt and kl; 15, 100, 40 and 50 are only the defaults")


def test_101_targets_visited_in_turn(lab, lathe):
    """TODO 2: the circle has 101 targets, points 0..100, the last one back at the start"""
    targets = [tuple(t) for t in lab.circle_targets(lathe)]
    expect(len(targets) == 101, "how many targets circle_targets(lathe) gives",
           expected="101 (NrPunct = 0, 1, ..., 100: the tool goes once round and ends where it began)",
           got=f"{len(targets)} targets",
           hint="range(points + 1) gives 0..points" if len(targets) == 100 else "one target per point 0..100")
    expect(targets[0] == targets[-1] == (0, 750), "the first and the last target",
           expected="both (0, 750)", got=f"{targets[0]} and {targets[-1]}")


def test_targets_equal_the_papers_circle(lab, lathe):
    """TODO 2: the targets are the paper's, in the lathe's axis order (X, Z)"""
    got = [tuple(t) for t in lab.circle_targets(lathe)]
    want = list(library_targets(lathe))
    for n, (g, w) in enumerate(zip(got, want)):
        if g == w:
            continue
        own = tuple(lab.calc_next_input(n, 40.0, 50.0))
        hint = (f"that is what your calc_next_input gives for point {n}: fix TODO 1 first" if own == g else
                "point n of the list is calc_next_input(n, KT, KL) with the lathe's own "
                "KT = machine.axis('X').steps_per_mm and KL = machine.axis('Z').steps_per_mm")
        expect(False, f"target {n} of circle_targets(lathe)", expected=repr(w), got=repr(g), hint=hint)
    expect(len(got) == len(want), "the number of targets", expected=len(want), got=len(got))


def test_targets_on_another_lathe_and_circle(lab, finer):
    """TODO 2: on a lathe with other screws, and for another circle, the targets follow the machine and the arguments"""
    for args in ((), (7.5, 50), (40.0, 12)):
        got = [tuple(t) for t in lab.circle_targets(finer, *args)]
        want = list(library_targets(finer, *args))
        first = next((k for k, (g, w) in enumerate(zip(got, want)) if g != w), None)
        if first is None and len(got) == len(want):
            continue
        call = f"circle_targets(lathe with 64 steps/mm on X and 80 on Z{''.join(f', {a:g}' for a in args)})"
        expect(False, call + (f", target {first}" if first is not None else ", how many targets"),
               expected=repr(want[first]) if first is not None else f"{len(want)} targets",
               got=repr(got[first]) if first is not None else f"{len(got)} targets",
               hint="KT and KL from machine.axis('X').steps_per_mm and machine.axis('Z').steps_per_mm, not 40 and "
                    "50; pass radius_mm and points on to calc_next_input")


def test_carriage_errors_are_measured_at_reached_targets(lab, lathe):
    """TODO 3: carriage_errors gives, per axis, |carriage - target| in mm at every reached target"""
    targets = [(0, 0), (40, 0), (0, 50), (-20, -25), (0, 0)]
    log, sim = lab.drive(lathe, targets, False)
    got = lab.carriage_errors(lathe, log, sim)
    expect(isinstance(got, dict) and set(got) == {"X", "Z"}, "what carriage_errors returns",
           expected="a dict {'X': [...], 'Z': [...]}", got=repr(got)[:120])
    for i, axis in enumerate(lathe.axes):
        want = [abs(sim.state_at(w.reached_tick)[axis.name][1] - w.steps[i] / axis.steps_per_mm)
                for w in log.waypoints]
        values = list(got[axis.name])
        ok = len(values) == len(want) and all(abs(a - b) < 1e-9 for a, b in zip(values, want))
        expect(ok, f"carriage_errors for axis {axis.name} on the targets {targets} without compensation",
               expected=[round(v, 4) for v in want], got=[round(float(v), 4) for v in values],
               hint="one value per waypoint, in mm, positive: abs(carriage_mm - axis.to_mm(waypoint.steps[i]))")


def test_compensated_carriage_within_a_step(lab, lathe):
    """With compensation on, the carriage is within one step of every reached target"""
    targets = [tuple(t) for t in lab.circle_targets(lathe)]
    log, sim = lab.drive(lathe, targets, True)
    for i, axis in enumerate(lathe.axes):
        worst, at = 0.0, None
        for n, w in enumerate(log.waypoints):
            error = abs(sim.state_at(w.reached_tick)[axis.name][1] - w.steps[i] / axis.steps_per_mm)
            if error > worst:
                worst, at = error, n
        expect(worst <= axis.step_mm + 1e-9, f"the {axis.name} carriage on your circle, compensation on",
               expected=f"within one step ({axis.step_mm:g} mm) of every target",
               got=f"{worst:.3f} mm off at target {at}",
               hint="drive() must pass backlash_comp on to PositionErrorLoop")
