"""Checks of lab 01 (the circle): run with `retrofit lab check 01`, or pytest on this file.

The cases are drawn at random (seeded: RETROFIT_CHECK_SEED draws them again): lathes from the
shipped set and lathes with other screws (steps per mm that are not whole numbers), radii that
are not whole millimetres, any number of points, compensation on and off. The expected values
are worked here, from the paper's formula and the simulated carriage, never by retrofit's own circle.
"""

import math
from dataclasses import replace
from pathlib import Path

import pytest

from retrofit.machine.config import load_machine
from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def random_lathe(rng, base=None):
    """A lathe with random screws (steps/mm with decimals), backlash and dead band."""
    base = base or load_machine(rng.choice(["chivu-lathe", "mitic-lathe"]))
    axes = tuple(replace(a, steps_per_mm=round(rng.uniform(12.0, 320.0), 3), backlash_mm=round(rng.uniform(0.01, 0.2), 3))
                 for a in base.axes)
    band = {a.name: round(a.backlash_mm * rng.uniform(0.9, 1.1), 4) for a in axes}
    return replace(base, name=f"{base.name} (screws {', '.join(f'{a.name} {a.steps_per_mm:g}' for a in axes)} "
                              f"steps/mm)", axes=axes, sim=replace(base.sim, dead_band_mm=band))


def lathes(rng, count):
    """The shipped lathes, then ``count`` random ones."""
    return [load_machine("chivu-lathe"), load_machine("mitic-lathe")] + [random_lathe(rng) for _ in range(count)]


def paper_point(n, kt, kl, radius, points):
    """CalcNextInput worked here: the exact point in steps, and every answer truncation allows.

    A product that lands within 1e-9 of a whole step may be cut either way by rounding in the
    last bit, so both neighbours are accepted there.
    """
    angle = n * 2 * math.pi / points
    exact = (radius * math.sin(angle) * kt, radius * math.cos(angle) * kl)
    allowed = []
    for value in exact:
        near = round(value)
        allowed.append({math.trunc(value)} | ({near, math.trunc(near - math.copysign(1, near))}
                                               if abs(value - near) < 1e-9 and near else set()))
    return exact, allowed


def _same_point(got, allowed) -> bool:
    return len(got) == 2 and all(isinstance(v, int) or float(v).is_integer() for v in got) \
        and all(int(v) in a for v, a in zip(got, allowed))


def _hint(got, exact):
    if tuple(got) == tuple(round(v) for v in exact):
        return "you rounded to the nearest step; the paper truncates (math.trunc or int())"
    if tuple(got) == tuple(math.floor(v) for v in exact):
        return "math.floor goes down for negative numbers; trunc goes towards zero (math.trunc or int())"
    if tuple(got) == tuple(math.trunc(v) for v in reversed(exact)):
        return "return (x_steps, z_steps): the transversal X first, then the longitudinal Z"
    return ("X = trunc(radius sin(n 2 pi / points) * KT), Z = trunc(radius cos(n 2 pi / points) * KL), from the "
            "arguments you are given: none of 15, 100, 40 or 50 written in, and nothing cut before the end")


def test_point_zero_is_on_the_z_axis(lab):
    """TODO 1: point 0 lies on the Z axis, 15 mm out (0 X steps, 750 Z steps)"""
    got = lab.calc_next_input(0, 40.0, 50.0)
    expect(tuple(got) == (0, 750), "calc_next_input(0, kt=40, kl=50) for the 15 mm circle",
           expected="(0, 750): X = 15 sin 0 * 40 = 0 steps, Z = 15 cos 0 * 50 = 750 steps",
           got=repr(got), hint="return (x_steps, z_steps): the transversal X first, then the longitudinal Z")


def test_truncated_to_steps_like_the_paper(lab):
    """TODO 1: every point of the paper's circle is cut to whole steps towards zero, as its trunc does"""
    for n in range(101):
        exact, allowed = paper_point(n, 40.0, 50.0, 15.0, 100)
        got = tuple(lab.calc_next_input(n, 40.0, 50.0))
        expect(_same_point(got, allowed), f"calc_next_input({n}, kt=40, kl=50)",
               expected=f"{tuple(min(a, key=abs) for a in allowed)} (exact {exact[0]:.3f}, {exact[1]:.3f} steps)",
               got=repr(got), hint=_hint(got, exact))


def test_random_circles(lab):
    """TODO 1: random radii (not whole mm), point counts and steps per mm (not whole): none written in"""
    rng = cases("01 random circles")
    for _ in range(300):
        kt, kl = round(rng.uniform(5.0, 400.0), rng.choice([0, 2, 3])), round(rng.uniform(5.0, 400.0), 3)
        radius, points = round(rng.uniform(0.3, 90.0), rng.choice([1, 3])), rng.randint(3, 400)
        n = rng.randint(0, points)
        exact, allowed = paper_point(n, kt, kl, radius, points)
        got = tuple(lab.calc_next_input(n, kt, kl, radius, points))
        expect(_same_point(got, allowed), f"calc_next_input({n}, kt={kt!r}, kl={kl!r}, radius_mm={radius!r}, "
                                          f"points={points}); {seed_note()}",
               expected=f"{tuple(min(a, key=abs) for a in allowed)} (exact {exact[0]:.4f}, {exact[1]:.4f} steps)",
               got=repr(got), hint=_hint(got, exact))


def test_circle_computed_by_you(lab):
    """TODO 2: circle_targets works the circle out with your calc_next_input, not retrofit's own circle"""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.demo": set()})
    expect(not places, "where your file takes the circle from", expected="your own calc_next_input",
           got="retrofit's circle: " + "; ".join(places),
           hint="the lab is to write the circle; call calc_next_input(n, KT, KL, radius_mm, points) for each n")


def test_101_targets_visited_in_turn(lab, lathe):
    """TODO 2: the circle has 101 targets, points 0..100, the last one back at the start"""
    targets = [tuple(t) for t in lab.circle_targets(lathe)]
    expect(len(targets) == 101, "how many targets circle_targets(lathe) gives",
           expected="101 (NrPunct = 0, 1, ..., 100: the tool goes once round and ends where it began)",
           got=f"{len(targets)} targets",
           hint="range(points + 1) gives 0..points" if len(targets) == 100 else "one target per point 0..100")
    expect(targets[0] == targets[-1] == (0, 750), "the first and the last target",
           expected="both (0, 750)", got=f"{targets[0]} and {targets[-1]}")


def test_targets_on_random_lathes_and_circles(lab):
    """TODO 2: on shipped and random lathes, for random circles, the targets follow the machine and the arguments"""
    rng = cases("01 random targets")
    for machine in lathes(rng, 6):
        kt, kl = machine.axis("X").steps_per_mm, machine.axis("Z").steps_per_mm
        for args in ((), (round(rng.uniform(0.5, 30.0), 2), rng.randint(3, 150))):
            radius, points = args or (15.0, 100)
            got = [tuple(t) for t in lab.circle_targets(machine, *args)]
            call = f"circle_targets({machine.name}{''.join(f', {a!r}' for a in args)}); {seed_note()}"
            expect(len(got) == points + 1, call + ", how many targets", expected=f"{points + 1} targets",
                   got=f"{len(got)} targets", hint="one target per point 0..points")
            for n, g in enumerate(got):
                exact, allowed = paper_point(n, kt, kl, radius, points)
                expect(_same_point(g, allowed), f"{call}, target {n}",
                       expected=repr(tuple(min(a, key=abs) for a in allowed)), got=repr(g),
                       hint="KT and KL from machine.axis('X').steps_per_mm and machine.axis('Z').steps_per_mm, not 40 "
                            "and 50; pass radius_mm and points on to calc_next_input")


def _random_targets(rng, machine, count):
    """Targets that reverse often, somewhere on each axis (not from 0)."""
    x, z = machine.axis("X"), machine.axis("Z")
    return [(rng.randint(-int(8 * x.steps_per_mm), int(8 * x.steps_per_mm)),
             rng.randint(-int(8 * z.steps_per_mm), int(8 * z.steps_per_mm))) for _ in range(count)]


def test_carriage_errors_are_measured_at_reached_targets(lab):
    """TODO 3: carriage_errors gives, per axis, |carriage - commanded target| in mm at every reached target"""
    rng = cases("01 carriage errors")
    for k, machine in enumerate(lathes(rng, 3)):
        for comp in (False, True):
            targets = _random_targets(rng, machine, 6)
            log, sim = lab.drive(machine, targets, comp)
            got = lab.carriage_errors(machine, log, sim)
            expect(isinstance(got, dict) and set(got) == {"X", "Z"}, "what carriage_errors returns",
                   expected="a dict {'X': [...], 'Z': [...]}", got=repr(got)[:120])
            for i, axis in enumerate(machine.axes):
                want = [abs(sim.state_at(w.reached_tick)[axis.name][1] - w.steps[i] / axis.steps_per_mm)
                        for w in log.waypoints]
                values = list(got[axis.name])
                ok = len(values) == len(want) and all(abs(a - b) < 1e-9 for a, b in zip(values, want))
                expect(ok, f"carriage_errors for axis {axis.name} of {machine.name}, targets {targets}, compensation "
                           f"{'on' if comp else 'off'}; {seed_note()}",
                       expected=[round(v, 4) for v in want], got=[round(float(v), 4) for v in values],
                       hint="one value per waypoint, in mm, positive: abs(carriage_mm - axis.to_mm(waypoint.steps[i])), "
                            "the carriage from sim.state_at(waypoint.reached_tick), the target the commanded one")


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
