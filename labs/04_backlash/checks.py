"""Checks of lab 04 (backlash): run with `retrofit lab check 04`, or pytest on this file."""

import pytest

from dataclasses import replace

from retrofit.config import load_machine
from retrofit.labs import expect, load_target
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.sim import SimMachine


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def finer(lathe):
    """A second lathe: finer screws (64 steps/mm on X, 80 on Z) and more play (0.15 and 0.13 mm)."""
    spm = {"X": 64.0, "Z": 80.0}
    axes = tuple(replace(a, steps_per_mm=spm[a.name]) for a in lathe.axes)
    return replace(lathe, axes=axes, sim=replace(lathe.sim, dead_band_mm={"X": 0.15, "Z": 0.13}))


def reference_readings(machine, axis, approach=20, reverse=12):
    """The experiment done by the checks themselves, to test dead_band_mm on its own."""
    i = machine.axis_names.index(axis)
    targets = [tuple(approach - k if j == i else 0 for j in range(len(machine.axes))) for k in range(reverse + 1)]
    log = PositionErrorLoop(machine, backlash_comp=False).run(targets)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return targets, [sim.state_at(w.reached_tick)[axis] for w in log.waypoints]


@pytest.mark.parametrize("axis", ["X", "Z"])
def test_dial_targets(lab, lathe, axis):
    """TODO 1: out to +approach on one axis, then back one step at a time"""
    for approach, reverse in ((20, 5), (9, 3)):
        want = [tuple(approach - k if name == axis else 0 for name in lathe.axis_names) for k in range(reverse + 1)]
        got = [tuple(t) for t in lab.dial_targets(lathe, axis, approach, reverse)]
        expect(got == want, f"dial_targets(lathe, {axis!r}, approach={approach}, reverse={reverse})", expected=want,
               got=got, hint=f"{reverse + 1} targets: the approach point, then one step less each time; 0 on the "
                             "other axis; (X steps, Z steps) in that order")


@pytest.mark.parametrize("axis", ["X", "Z"])
def test_dial_readings(lab, lathe, axis):
    """TODO 2: one (motor steps, carriage mm) reading at every reached target"""
    targets, want = reference_readings(lathe, axis, 20, 6)
    got = [(int(m), float(c)) for m, c in lab.dial_readings(lathe, axis, targets)]
    ok = len(got) == len(want) and all(m == wm and abs(c - wc) < 1e-9 for (m, c), (wm, wc) in zip(got, want))
    expect(ok, f"dial_readings(lathe, {axis!r}, ...) on {len(targets)} targets without compensation",
           expected=[(m, round(c, 4)) for m, c in want], got=[(m, round(c, 4)) for m, c in got],
           hint="for each waypoint of the log: sim.state_at(waypoint.reached_tick)[axis]; "
                "drive with backlash_comp=False so the controller adds no steps")


@pytest.mark.parametrize("axis", ["X", "Z"])
@pytest.mark.parametrize("which", ["chivu", "finer"])
def test_dead_band_from_readings(lab, lathe, finer, which, axis):
    """TODO 3: the dead band from the readings: motor travel minus carriage travel, in mm"""
    machine = lathe if which == "chivu" else finer
    step = machine.axis(axis).step_mm
    for approach, reverse in ((20, 12), (30, 9), (15, 14)):
        _, readings = reference_readings(machine, axis, approach, reverse)
        (m0, c0), (m1, c1) = readings[0], readings[-1]
        want = abs(m1 - m0) * step - abs(c1 - c0)
        got = float(lab.dead_band_mm(machine, axis, readings))
        expect(abs(got - want) <= 1e-9, f"dead_band_mm({which} lathe, {axis!r}, readings) after {approach} steps out and "
               f"{reverse} back: motor {m0} -> {m1} steps, carriage {c0:.4f} -> {c1:.4f} mm",
               expected=f"{want:.4f} mm = {abs(m1 - m0)} steps x {step:g} mm - {abs(c1 - c0):.4f} mm",
               got=f"{got:.4f} mm" + (f" ({(want - got) / step:+.2f} steps off)" if step else ""),
               hint="from the first reading (at the reversal) to the last; in mm, not steps: motor steps times "
                    "this axis's step_mm, minus the carriage's travel (already mm)")


@pytest.mark.parametrize("axis", ["X", "Z"])
def test_measured_dead_band_within_a_step(lab, lathe, axis):
    """TODOs 1-3: your whole experiment finds the simulator's dead band within one step"""
    readings = lab.dial_readings(lathe, axis, lab.dial_targets(lathe, axis))
    got = float(lab.dead_band_mm(lathe, axis, readings))
    want, step = lathe.sim.dead_band_mm[axis], lathe.axis(axis).step_mm
    expect(abs(got - want) <= step + 1e-9, f"the dead band of {axis} your experiment measures",
           expected=f"{want:.3f} mm (the machine file's [sim] dead_band_mm) within one step, {step:g} mm",
           got=f"{got:.4f} mm", hint="reverse more steps than the play, so the carriage has moved by the end")


def test_with_clearance_makes_a_new_machine(lab, lathe):
    """TODO 4: with_clearance replaces backlash_mm and leaves everything else alone"""
    new = lab.with_clearance(lathe, {"X": 0.125})
    expect(new.axis("X").backlash_mm == 0.125 and new.axis("X").backlash_steps == 5,
           "with_clearance(lathe, {'X': 0.125}).axis('X')", expected="backlash_mm 0.125 (5 steps)",
           got=f"backlash_mm {new.axis('X').backlash_mm}")
    expect(new.axis("Z") == lathe.axis("Z") and new.sim == lathe.sim and new.name == lathe.name,
           "the other axis and the rest of the machine", expected="unchanged", got="changed",
           hint="only replace the axes named in clearances")
    expect(lathe.axis("X").backlash_mm == 0.10, "the machine you were given", expected="unchanged (0.10 mm on X)",
           got=f"{lathe.axis('X').backlash_mm} mm", hint="use dataclasses.replace to make a new machine")


def test_compensated_error_within_a_step(lab, lathe):
    """Compensated with what you measured, the zigzag's carriage error is at most one step"""
    bare = lab.with_clearance(lathe, {"X": 0.0, "Z": 0.0})
    measured = {a: float(lab.dead_band_mm(bare, a, lab.dial_readings(bare, a, lab.dial_targets(bare, a))))
                for a in ("X", "Z")}
    compensated = lab.with_clearance(bare, measured)
    log, sim = lab.drive(compensated, lab.zigzag(compensated), True)
    errors = lab.carriage_errors(compensated, log, sim)
    for axis in compensated.axes:
        worst = max(errors[axis.name])
        expect(worst <= axis.step_mm + 1e-9, f"the {axis.name} carriage on the zigzag, compensated with "
               f"{measured[axis.name]:.3f} mm", expected=f"at most one step ({axis.step_mm:g} mm) off",
               got=f"{worst:.3f} mm", hint="the clearance goes into backlash_mm in mm")
