"""Checks of lab 05 (acceleration and lost steps): `retrofit lab check 05`, or pytest on this file."""

from dataclasses import replace
from pathlib import Path

import pytest

from retrofit.config import load_machine
from retrofit.labs import expect, load_target

MACHINE_FILE = Path(__file__).resolve().parent / "engraver-x.toml"
GENTLE, STEEP = 1000.0, 40000.0


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def machine():
    return load_machine(MACHINE_FILE)


@pytest.fixture(scope="module")
def fine(machine):
    """A second engraver axis: the same motor on a 10 mm/rev screw, 160 steps/mm, 75 mm/s at most."""
    axes = tuple(replace(a, steps_per_mm=160.0, max_velocity_mm_s=75.0) for a in machine.axes)
    return replace(machine, axes=axes)


def library_ramp(machine, accel, profile="trapezoid"):
    axes = tuple(replace(a, max_accel_mm_s2=accel) for a in machine.axes)
    return replace(machine, axes=axes, motion=replace(machine.motion, profile=profile))


def lost(machine, log, sim):
    return log.steps_emitted["X"] - sim.motor_steps[0]


def test_with_ramp(lab, machine):
    """TODO 1: with_ramp makes a machine with the new acceleration and profile, the original unchanged"""
    new = lab.with_ramp(machine, 2500.0, "exponential")
    expect(new.axis("X").max_accel_mm_s2 == 2500.0 and new.motion.profile == "exponential",
           "with_ramp(machine, 2500, 'exponential')",
           expected="axis X max_accel_mm_s2 = 2500 and motion.profile = 'exponential'",
           got=f"max_accel_mm_s2 = {new.axis('X').max_accel_mm_s2}, profile = {new.motion.profile!r}",
           hint="replace(axis, max_accel_mm_s2=...) for each axis, replace(machine.motion, profile=...)")
    expect(machine.axis("X").max_accel_mm_s2 == 1000.0 and machine.motion.profile == "trapezoid",
           "the machine you were given", expected="unchanged (1000 mm/s², trapezoid)",
           got=f"{machine.axis('X').max_accel_mm_s2} mm/s², {machine.motion.profile}",
           hint="dataclasses.replace makes a new object; do not assign to the old one")
    expect(new.sim == machine.sim and new.axis("X").steps_per_mm == 80.0, "everything else (motor, steps/mm)",
           expected="unchanged", got="changed")
    lathe = load_machine("chivu-lathe")
    new = lab.with_ramp(lathe, 300.0)
    got = {a.name: a.max_accel_mm_s2 for a in new.axes}
    expect(got == {a.name: 300.0 for a in lathe.axes}, "with_ramp(a lathe with axes X and Z, 300)",
           expected="every axis at 300 mm/s²", got=f"{got}", hint="replace every axis of machine.axes, not only the first")


@pytest.mark.parametrize("which", ["engraver", "fine"])
def test_position_error(lab, machine, fine, which):
    """TODO 2: position_error_mm is how far the motor ended behind the steps sent, in mm"""
    chosen = machine if which == "engraver" else fine
    spm = chosen.axis("X").steps_per_mm
    steep = library_ramp(chosen, 8000.0)
    log, sim = lab.run_move(steep)
    got = float(lab.position_error_mm(steep, log, sim))
    want = lost(steep, log, sim) / spm
    expect(abs(got - want) < 1e-9, f"position_error_mm after a 40 mm move with an 8000 mm/s² ramp, {spm:g} steps/mm",
           expected=f"{want:.4f} mm ({lost(steep, log, sim)} steps sent but not turned, / {spm:g} steps/mm)",
           got=f"{got:.4f} mm", hint="(log.steps_emitted['X'] - sim.motor_steps[0]) / machine.axis('X').steps_per_mm")


@pytest.mark.parametrize("which,speed", [("engraver", v) for v in (0.0, 75.0, 150.0, 300.0, 500.0)]
                         + [("fine", v) for v in (0.0, 40.0, 200.0)])
def test_motor_ramp_limit(lab, machine, fine, which, speed):
    """TODO 3: the steepest ramp the motor can follow, from its torque curve"""
    chosen = machine if which == "engraver" else fine
    motor, spm = chosen.sim.motors["X"], chosen.axis("X").steps_per_mm
    want = motor.max_accel_steps_s2(speed * spm) / spm
    got = float(lab.motor_ramp_limit(chosen, speed))
    expect(abs(got - want) <= 1e-6 * max(want, 1.0), f"motor_ramp_limit(machine, {speed:g} mm/s), {spm:g} steps/mm",
           expected=f"{want:.1f} mm/s² (torque {motor.torque_nm(speed * spm):.3f} N·m at "
                    f"{speed * spm:.0f} steps/s, load {motor.load_torque_nm} N·m)",
           got=f"{got:.1f} mm/s²",
           hint="(torque - load) / inertia is rad/s²; times (mm per revolution) / (2 pi); 0 when the "
                "torque is below the load")


def test_gentle_ramp_loses_nothing(lab, machine):
    """A gentle ramp (1000 mm/s²) loses no step"""
    gentle = lab.with_ramp(machine, GENTLE)
    log, sim = lab.run_move(gentle)
    error = float(lab.position_error_mm(gentle, log, sim))
    kinds = sorted({v.kind for v in sim.violations})
    expect(error == 0.0 and not kinds, f"the 40 mm move with a {GENTLE:g} mm/s² ramp",
           expected="motor on the last step sent (error 0 mm), no violations",
           got=f"error {error:.3f} mm, violations {kinds}")


def test_steep_ramp_loses_steps(lab, machine):
    """A too-steep ramp (40000 mm/s²) loses steps, and the simulator reports them"""
    steep = lab.with_ramp(machine, STEEP)
    log, sim = lab.run_move(steep)
    error = float(lab.position_error_mm(steep, log, sim))
    kinds = {v.kind for v in sim.violations}
    expect(error > 0.0 and "lost_steps" in kinds, f"the 40 mm move with a {STEEP:g} mm/s² ramp",
           expected="the motor behind the steps sent, and a 'lost_steps' violation",
           got=f"error {error:.3f} mm, violations {sorted(kinds)}",
           hint="with_ramp must set max_accel_mm_s2, or the planner keeps the gentle ramp")


def test_a_ramp_below_the_motor_limit_is_safe(lab, machine):
    """A ramp 10 % below what your motor_ramp_limit allows at cruise speed loses nothing"""
    limit = float(lab.motor_ramp_limit(machine, machine.axis("X").max_velocity_mm_s))
    ramp = 0.9 * limit
    m = library_ramp(machine, ramp)
    log, sim = lab.run_move(m)
    expect(lost(m, log, sim) == 0, f"a {ramp:.0f} mm/s² ramp (0.9 x your limit at cruise speed)",
           expected="no step lost", got=f"{lost(m, log, sim)} steps lost",
           hint="the limit at cruise speed is the smallest on the way up: the torque falls with speed")
