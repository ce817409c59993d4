"""Checks of lab 06 (threading): run with `retrofit lab check 06`, or pytest on this file.

Besides the lab's thread, cut here through the controller, the checks draw passes at random
(seeded: RETROFIT_CHECK_SEED draws them again): any start, pitch and turn, samples at irregular
angles, lead-ins that creep off the start rather than rest exactly on it, motors that start
anywhere. The expected values are worked here.
"""

import math

import numpy as np
import pytest

from retrofit.commands import IStp, Spin
from retrofit.machine.config import load_machine
from retrofit.controller.program import run_commands
from retrofit.gcode import compile_program
from retrofit.lab.check import cases, seed_note
from retrofit.lab.core import expect, load_target
from retrofit.sim import SimMachine

PITCH, Z_START, SKIP_MM = 1.5, 3.0, 2.5
PROGRAM = "G18 G21 G90\nG0 X12 Z3\nS1200 M3\nG76 P1.5 Z-15 I-0.5 J0.3 K0.9 R1 H1\nG0 X20\n"
SPEEDS = (300.0, 600.0, 1200.0)


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("mitic-lathe")


@pytest.fixture(scope="module")
def cut(lathe):
    """The thread of the lab cut by the checks themselves: (simulated machine, number of passes)."""
    commands, passes = [], 0
    for cmd in compile_program(PROGRAM, lathe, "thread.ngc").commands:
        if cmd == IStp():
            commands.append(Spin(SPEEDS[passes % len(SPEEDS)], 1))
            passes += 1
        commands.append(cmd)
    sim = SimMachine(lathe)
    run_commands(commands, lathe, sim=sim)
    return sim, passes


def reference_passes(sim):
    """Indices of the Z steps of each pass: runs of steps towards -Z."""
    motor = np.asarray(sim.traces["Z"].motor_steps)
    down = np.flatnonzero(np.diff(motor, prepend=0) < 0)
    return [g.tolist() for g in np.split(down, np.flatnonzero(np.diff(down) > 1) + 1)]


def beyond_lead_in(z, revs):
    z, revs = np.asarray(z, float), np.asarray(revs, float)
    keep = z < Z_START - SKIP_MM
    return z[keep], revs[keep]


def test_split_passes_on_a_short_list(lab):
    """TODO 1: split_passes finds every run of steps towards -Z"""
    cases = [(([1, 2, 3, 2, 1, 0, 1, 2, 1, 0, -1], 0), [[3, 4, 5], [8, 9, 10]]),
             (([-1, -2, -1, 0, -1], 0), [[0, 1], [4]]),
             (([5, 6, 7], 4), [])]
    for (motor, start), want in cases:
        got = [list(map(int, g)) for g in lab.split_passes(motor, start)]
        expect(got == want, f"split_passes({motor}, start={start})", expected=want, got=got,
               hint="a step is towards -Z when the motor's position is below the one before it (before the "
                    "first: start); a new pass begins at each such step that follows a step the other way")


def split_reference(motor, start):
    """Every run of steps towards -Z, worked by the checks."""
    groups, previous, last_down = [], start, False
    for i, steps in enumerate(motor):
        down = steps < previous
        if down and not last_down:
            groups.append([])
        if down:
            groups[-1].append(i)
        last_down, previous = down, steps
    return groups


def test_split_passes_random_motors(lab):
    """TODO 1: split_passes on random motor paths that start anywhere"""
    rng = cases("06 split passes")
    for _ in range(40):
        start = rng.randint(-500, 500)
        motor, at = [], start
        for _ in range(rng.randint(0, 40)):
            at += rng.choice([-1, -1, 1, 1, 0]) if rng.random() < 0.8 else rng.choice([-3, 2])
            motor.append(at)
        got = [list(map(int, g)) for g in lab.split_passes(motor, start)]
        want = split_reference(motor, start)
        expect(got == want, f"split_passes({motor}, start={start}); {seed_note()}", expected=want, got=got,
               hint="a step is towards -Z when the motor's position is below the one before it (before the first: "
                    "start, whatever it is); a new pass begins at each such step that follows a step the other way")


def synthetic_pass(n, z_start, pitch, offset, lead_in, samples=60):
    """A pass on the helix z = z_start - pitch (revs - n), ``offset`` of a turn late, still at the start
    for its first ``lead_in`` samples (the lead-in, off the helix)."""
    revs = np.linspace(n - 0.6, n + 6.0, samples)
    z = z_start - pitch * (revs - n - offset)
    z[:lead_in] = z_start
    return z, revs


SYNC_CASES = [(7, 3.0, 1.5, 0.0, 6), (7, 3.0, 1.5, 0.3, 6), (12, 3.0, 1.5, -0.4, 10), (9, -1.0, 2.0, 0.2, 8),
              (5, 0.5, 1.0, 0.45, 25), (20, 3.0, 1.5, -0.45, 5)]


def test_sync_revolution(lab):
    """TODO 3: sync_revolution finds the revolution at which the helix passes the start"""
    for n, z_start, pitch, offset, lead_in in SYNC_CASES:
        z, revs = synthetic_pass(n, z_start, pitch, offset, lead_in)
        median = float(np.median(revs + (z - z_start) / pitch))
        got = lab.sync_revolution(z, revs, z_start, pitch)
        expect(got == n and isinstance(got, (int, np.integer)),
               f"sync_revolution on a helix through {z_start:g} mm at turn {n + offset:g} (pitch {pitch:g} mm), "
               f"at rest for its first {lead_in} samples",
               expected=f"{n} (an int: the median estimate {median:.3f} rounded to the nearest turn)", got=repr(got),
               hint="each sample gives revs + (z - z_start) / pitch; take the median (the lead-in pulls a mean "
                    "away), then round it to the nearest whole revolution, not down or up; use the z_start and "
                    "pitch you are given")


def test_advance_per_rev(lab):
    """TODO 4: advance_per_rev: the carriage's travel in each whole revolution"""
    revs = np.array([0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.2])
    z = -2.0 * revs
    z[3] += 0.1                                    # at turn 2 the carriage is 0.1 mm behind
    got = np.asarray(lab.advance_per_rev(z, revs), float)
    want = np.array([1.9, 2.1])
    ok = got.shape == want.shape and np.allclose(got, want, atol=1e-9)
    expect(ok, "advance_per_rev(z, revs) with z at whole turns 1, 2, 3 = -2.0, -3.9, -6.0",
           expected="[1.9, 2.1] (positive, one per whole revolution between the first and last sample)",
           got=np.round(got, 6).tolist(), hint="np.interp the carriage at every whole revolution, then the "
                                               "differences, sign turned so that the advance is positive")


def random_pass(rng):
    """A pass at random: the helix through z_start at turn n + offset, irregular angles, a lead-in that
    creeps off the start (the carriage speeding up: behind the helix, not resting on z_start)."""
    n, z_start, pitch = rng.randint(1, 60), round(rng.uniform(-8.0, 12.0), 3), round(rng.uniform(0.4, 4.0), 3)
    offset, samples = rng.uniform(-0.45, 0.45), rng.randint(30, 150)
    first = n + offset + rng.uniform(-0.1, 0.05)
    revs = np.sort(first + np.cumsum([rng.uniform(0.02, 0.3) for _ in range(samples)]))
    helix = z_start - pitch * (revs - n - offset)
    lead = rng.randint(0, samples * 2 // 5)
    creep = np.array([(k / max(lead, 1)) ** 2 for k in range(lead)])
    z = helix.copy()
    z[:lead] = np.minimum(z_start, z_start + creep * (helix[:lead] - z_start) * rng.uniform(0.2, 0.9))
    return n, z_start, pitch, offset, lead, z, revs


def test_sync_revolution_random_passes(lab):
    """TODO 3: sync_revolution on random passes: any start, pitch and turn, lead-ins that creep off the start"""
    rng = cases("06 sync")
    for _ in range(60):
        n, z_start, pitch, offset, lead, z, revs = random_pass(rng)
        got = lab.sync_revolution(z, revs, z_start, pitch)
        expect(got == n and isinstance(got, (int, np.integer)),
               f"sync_revolution on a helix through {z_start:g} mm at turn {n + offset:.3f} (pitch {pitch:g} mm), "
               f"{len(z)} samples at irregular angles, the first {lead} on a lead-in off the helix; {seed_note()}",
               expected=f"{n} (an int: the median of revs + (z - z_start) / pitch, rounded to the nearest turn)",
               got=repr(got), hint="the median keeps the lead-in from pulling the estimate, whatever the lead-in does; "
                                   "round to the nearest whole revolution; use the z_start and pitch you are given")


def test_advance_per_rev_random(lab):
    """TODO 4: advance_per_rev on random passes: irregular angles, first samples on or off a whole turn"""
    rng = cases("06 advance")
    for k in range(30):
        pitch = round(rng.uniform(0.4, 4.0), 3)
        first = rng.randint(0, 30) + (0.0 if k % 3 == 0 else rng.uniform(0.01, 0.99))
        revs = first + np.concatenate([[0.0], np.cumsum([rng.uniform(0.05, 0.6) for _ in range(rng.randint(3, 40))])])
        z = rng.uniform(-5, 5) - pitch * revs + np.array([rng.uniform(-0.01, 0.01) for _ in revs])
        whole = np.arange(math.ceil(revs[0]), math.floor(revs[-1]) + 1)
        want = -np.diff(np.interp(whole, revs, z))
        got = np.asarray(lab.advance_per_rev(z, revs), float)
        ok = got.shape == want.shape and np.allclose(got, want, atol=1e-9)
        expect(ok, f"advance_per_rev on a pass from turn {revs[0]:.3f} to {revs[-1]:.3f}, pitch {pitch:g}; {seed_note()}",
               expected=f"{np.round(want, 4).tolist()} (one per whole revolution from the first whole one at or after "
                        "the first sample to the last at or before the last)", got=np.round(got, 4).tolist(),
               hint="np.interp the carriage at every whole revolution from ceil(first) to floor(last), then the "
                    "differences, sign turned so that the advance is positive")


def test_split_passes_finds_every_pass(lab, cut):
    """TODO 1: on the lab's thread, one group of steps for every pass of the G76"""
    sim, passes = cut
    trace = sim.traces["Z"]
    got = [list(map(int, g)) for g in lab.split_passes(trace.motor_steps, 0)]
    want = reference_passes(sim)
    expect(len(got) == passes, "split_passes on the Z motor of the lab's thread",
           expected=f"{passes} passes (the G76 makes {passes})", got=f"{len(got)} groups",
           hint="the rapids back to the start go towards +Z; only the cuts go towards -Z")
    expect(got == want, "the steps of each pass", expected=f"{[len(g) for g in want]} steps",
           got=f"{[len(g) for g in got]} steps", hint="keep every step towards -Z, the first one of a pass too")


def test_pass_curves(lab, cut):
    """TODO 2: pass_curves gives the carriage (mm) and the spindle angle (revolutions) of every step"""
    sim, _ = cut
    trace = sim.traces["Z"]
    ticks, carriage = np.asarray(trace.ticks), np.asarray(trace.carriage_mm)
    want = [(carriage[g], sim.spindle.revolutions_at(ticks[g])) for g in reference_passes(sim)]
    got = lab.pass_curves(sim)
    expect(len(got) == len(want), "pass_curves(sim): one (z_mm, revs) per pass", expected=f"{len(want)} passes",
           got=f"{len(got)}")
    for k, ((z, revs), (wz, wrevs)) in enumerate(zip(got, want)):
        z, revs = np.asarray(z, float), np.asarray(revs, float)
        ok_z = z.shape == wz.shape and np.allclose(z, wz, atol=1e-9)
        expect(ok_z, f"pass {k + 1}: the Z carriage", expected=f"{len(wz)} values from {wz[0]:.4f} to {wz[-1]:.4f} mm",
               got=f"{len(z)} values" + (f" from {z[0]:.4f} to {z[-1]:.4f}" if len(z) else ""),
               hint="sim.traces['Z'].carriage_mm at the pass's indices (the carriage, not the motor steps)")
        ok_r = revs.shape == wrevs.shape and np.allclose(revs, wrevs, atol=1e-9)
        expect(ok_r, f"pass {k + 1}: the spindle angle", expected=f"revolutions from {wrevs[0]:.4f} to {wrevs[-1]:.4f}",
               got=f"{len(revs)} values" + (f" from {revs[0]:.4f} to {revs[-1]:.4f}" if len(revs) else ""),
               hint="sim.spindle.revolutions_at(the ticks of the pass's steps), in revolutions, not degrees")


def test_passes_overlay_within_a_step(lab, lathe, cut):
    """Your whole analysis: past the lead-in, every pass is on one helix, within one step"""
    sim, passes = cut
    step = lathe.axis("Z").step_mm
    errors = []
    for k, (z, revs) in enumerate(lab.pass_curves(sim), 1):
        n = lab.sync_revolution(z, revs, Z_START, PITCH)
        zs, rs = beyond_lead_in(z, revs)
        error = zs - (Z_START - PITCH * (rs - n))
        worst = float(np.abs(error).max()) if len(error) else 0.0
        expect(worst <= step + 1e-9, f"pass {k}: the carriage about the helix through {Z_START:g} mm at its "
               f"turn {n}, {SKIP_MM:g} mm past the start",
               expected=f"within one step ({step:g} mm) everywhere", got=f"{worst:.4f} mm ({worst / PITCH:.2f} pitches) off",
               hint="if a pass is a whole pitch off, its sync_revolution is one turn out: round, do not truncate")
        errors.append(error)
    expect(len(errors) == passes, "passes found", expected=passes, got=len(errors))


def test_mean_pitch(lab, lathe, cut):
    """Your whole analysis: past the lead-in, the carriage advances the programmed pitch each turn"""
    sim, _ = cut
    step = lathe.axis("Z").step_mm
    advances = np.concatenate([np.asarray(lab.advance_per_rev(*beyond_lead_in(z, revs)), float)
                               for z, revs in lab.pass_curves(sim)])
    expect(len(advances) >= 30, "whole revolutions measured past the lead-ins", expected="at least 30 (4 passes)",
           got=len(advances))
    mean = advances.mean()
    expect(abs(mean - PITCH) <= 0.001, "the mean advance a revolution",
           expected=f"{PITCH:g} mm within 0.001 mm", got=f"{mean:.5f} mm",
           hint="mm a revolution, positive; measured only where the lead-in is over")
    worst = np.abs(advances - PITCH).max()
    expect(worst <= step + 1e-9, "the pitch error of every single revolution",
           expected=f"at most one step ({step:g} mm)", got=f"{worst:.4f} mm")
