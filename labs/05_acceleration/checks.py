"""Checks of lab 05 (acceleration and lost steps): `retrofit lab check 05`, or pytest on this file.

Besides the engraver's axis, the checks draw axes at random (seeded: RETROFIT_CHECK_SEED draws them
again): other screws (steps per mm with decimals), other motors (pull-out curves, inertia, load,
microsteps), moves of any length, not only 40 mm. The ramp limit is worked here from the torque
curve, never by the motor model's own max_accel_steps_s2.
"""

import bisect
import math
from dataclasses import replace
from pathlib import Path

import pytest

from retrofit.commands import PMov
from retrofit.machine.config import load_machine
from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.sim import SimMachine

MACHINE_FILE = Path(__file__).resolve().parent / "engraver-x.toml"
GENTLE, STEEP = 1000.0, 40000.0


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def machine():
    return load_machine(MACHINE_FILE)


def random_axis(rng, machine):
    """The engraver's axis with another screw and another motor: curve, inertia, load, microsteps."""
    motor = machine.sim.motors["X"]
    rpm = sorted(rng.sample(range(50, 2000, 10), 4))
    torques = sorted((round(rng.uniform(0.05, 0.9), 3) for _ in range(5)), reverse=True)
    curve = tuple(zip([0.0] + [float(r) for r in rpm], torques))
    new_motor = replace(motor, pullout_curve=curve, inertia_kg_m2=rng.uniform(3e-5, 4e-4),
                        load_torque_nm=round(rng.uniform(0.0, 0.6 * torques[0]), 3),
                        full_steps_per_rev=rng.choice([200, 400]), microsteps=rng.choice([1, 2, 4, 8, 16]))
    spm = round(new_motor.steps_per_rev / rng.uniform(4.0, 25.0), rng.choice([0, 3]))
    axes = tuple(replace(a, steps_per_mm=spm, max_velocity_mm_s=round(rng.uniform(20.0, 150.0), 1)) for a in machine.axes)
    return replace(machine, name=f"engraver-x with {spm:g} steps/mm, {new_motor.steps_per_rev} steps/rev, curve {curve}, "
                                 f"J {new_motor.inertia_kg_m2:.3g} kg m², load {new_motor.load_torque_nm} N·m",
                   axes=axes, sim=replace(machine.sim, motors={"X": new_motor}))


def ramp_limit(machine, speed_mm_s):
    """The steepest ramp in mm/s², worked here: the pull-out curve read linearly, (T - T_L) / J rad/s²,
    one revolution = steps_per_rev / steps_per_mm mm."""
    motor, spm = machine.sim.motors["X"], machine.axis("X").steps_per_mm
    steps_per_rev = motor.full_steps_per_rev * motor.microsteps
    rpm = speed_mm_s * spm * 60.0 / steps_per_rev
    speeds = [p[0] for p in motor.pullout_curve]
    if rpm > speeds[-1]:
        torque = 0.0
    else:
        i = min(bisect.bisect_right(speeds, rpm) - 1, len(speeds) - 2)
        (r0, t0), (r1, t1) = motor.pullout_curve[i], motor.pullout_curve[i + 1]
        torque = t0 + (t1 - t0) * (rpm - r0) / (r1 - r0)
    spare = max(torque - motor.load_torque_nm, 0.0)
    return spare / motor.inertia_kg_m2 * (steps_per_rev / spm) / (2 * math.pi), torque


def library_ramp(machine, accel, profile="trapezoid"):
    axes = tuple(replace(a, max_accel_mm_s2=accel) for a in machine.axes)
    return replace(machine, axes=axes, motion=replace(machine.motion, profile=profile))


def checks_move(machine, distance_mm):
    """One move of X from 0 to ``distance_mm``, planned, stepped and simulated by the checks: (log, sim)."""
    log = execute_fast(plan_program([PMov((("X", distance_mm),))], machine))
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


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


def test_position_error(lab, machine):
    """TODO 2: position_error_mm is how far the motor ended behind the steps sent, in mm, for any move"""
    rng = cases("05 position error")
    for k in range(5):
        chosen = machine if k == 0 else random_axis(rng, machine)
        spm = chosen.axis("X").steps_per_mm
        distance = 40.0 if k == 0 else round(rng.uniform(2.0, 90.0), rng.choice([1, 3]))
        steep = library_ramp(chosen, rng.choice([8000.0, 20000.0, 60000.0]))
        log, sim = checks_move(steep, distance)
        got = float(lab.position_error_mm(steep, log, sim))
        want = lost(steep, log, sim) / spm
        expect(abs(got - want) < 1e-9, f"position_error_mm after a {distance:g} mm move with a "
               f"{steep.axis('X').max_accel_mm_s2:g} mm/s² ramp on {chosen.name}; {seed_note()}",
               expected=f"{want:.4f} mm ({lost(steep, log, sim)} of the {log.steps_emitted['X']} steps sent not turned, "
                        f"/ {spm:g} steps/mm)", got=f"{got:.4f} mm",
               hint="(log.steps_emitted['X'] - sim.motor_steps[0]) / machine.axis('X').steps_per_mm: the steps the "
                    "log says were sent, not a move length written in")


def test_ramp_limit_is_your_own(lab):
    """TODO 3: motor_ramp_limit works the limit out from the torque curve, not with the motor model's own"""
    places = borrowed(target_path(Path(__file__).parent), {}, within={"motor_ramp_limit"},
                      methods=frozenset({"max_accel_steps_s2", "max_rate_steps_s"}))
    expect(not places, "how your motor_ramp_limit gets the limit", expected="from the torque, the load and the inertia",
           got="the motor model's own answer: " + "; ".join(places),
           hint="the lab is to work it out: motor.torque_nm(rate), minus the load, over the inertia, to mm/s²")


def test_motor_ramp_limit(lab, machine):
    """TODO 3: the steepest ramp the motor can follow, from its torque curve, for random motors and screws"""
    rng = cases("05 ramp limit")
    for k in range(14):
        chosen = machine if k < 4 else random_axis(rng, machine)
        top = chosen.axis("X").max_velocity_mm_s
        speed = (0.0, 75.0, 300.0, 500.0)[k] if k < 4 else round(rng.uniform(0.0, 2.5 * top), rng.choice([0, 2]))
        want, torque = ramp_limit(chosen, speed)
        got = float(lab.motor_ramp_limit(chosen, speed))
        motor, spm = chosen.sim.motors["X"], chosen.axis("X").steps_per_mm
        expect(abs(got - want) <= 1e-6 * max(want, 1.0), f"motor_ramp_limit({chosen.name}, {speed:g} mm/s); {seed_note()}",
               expected=f"{want:.1f} mm/s² (torque {torque:.3f} N·m at {speed * spm:.0f} steps/s, load "
                        f"{motor.load_torque_nm} N·m)", got=f"{got:.1f} mm/s²",
               hint="(torque - load) / inertia is rad/s²; times (mm per revolution) / (2 pi), a revolution being "
                    "motor.steps_per_rev / steps_per_mm mm; 0 when the torque is below the load")


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
    log, sim = checks_move(m, 40.0)
    expect(lost(m, log, sim) == 0, f"a {ramp:.0f} mm/s² ramp (0.9 x your limit at cruise speed)",
           expected="no step lost", got=f"{lost(m, log, sim)} steps lost",
           hint="the limit at cruise speed is the smallest on the way up: the torque falls with speed")
