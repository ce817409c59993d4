"""Checks of lab 07 (position-loop tuning): run with `retrofit lab check 07`, or pytest on this file.

Besides the mill's own step responses, the checks draw cases at random (seeded: RETROFIT_CHECK_SEED
draws them again): steps up and down of any size that come at any sample, samples at irregular
times that do not start at 0, set-points that change, bands and gain tables of any kind. The
expected values are worked here, never by the library's own comparison.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from retrofit.camlink.model import step_comparison
from retrofit.machine.config import load_machine
from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def mill():
    return load_machine("grenoble-mill")


def test_with_gains(lab, mill):
    """TODO 1: with_gains makes a machine with the new kp and ki, the original unchanged"""
    new = lab.with_gains(mill, 0.8, 3.0)
    servo = new.parts["servo"]
    expect((servo.kp, servo.ki) == (0.8, 3.0), "with_gains(mill, kp=0.8, ki=3.0).parts['servo']",
           expected="kp 0.8, ki 3.0", got=f"kp {servo.kp}, ki {servo.ki}",
           hint="dataclasses.replace(machine.parts['servo'], kp=kp, ki=ki)")
    old = mill.parts["servo"]
    expect((old.kp, old.ki) == (0.5, 0.0), "the machine you were given", expected="unchanged (kp 0.5, ki 0)",
           got=f"kp {old.kp}, ki {old.ki}", hint="build a new parts dict; do not assign into the old one")
    expect(servo.inertia_kg_m2 == old.inertia_kg_m2 and new.axes == mill.axes, "the motor and the axes",
           expected="unchanged", got="changed")


def test_overshoot(lab, mill):
    """TODO 2: overshoot in per cent of the step, 0 when the response never passes it"""
    cases = [([100] * 4, [0, 60, 117, 100], 17.0), ([100] * 4, [0, 40, 80, 95], 0.0),
             ([-50] * 3, [0, -60, -50], 20.0), ([0, 200, 200, 200, 200], [0, 0, 150, 230, 200], 15.0),
             ([0, -20, -20, -20], [0, -8, -21, -20], 5.0), ([100] * 5, [0, 80, 112, 106, 104], 12.0)]
    for setpoint, position, want in cases:
        got = float(lab.overshoot_percent(setpoint, position))
        expect(abs(got - want) < 1e-9, f"overshoot_percent({setpoint}, {position})", expected=f"{want:g} %",
               got=f"{got:g}", hint="100 * (peak - step) / step, the step being the last set-point; never below "
                                    "0; a step down peaks at its minimum")
    c = step_comparison(mill, "X", 0.2, 200)
    got, want = float(lab.overshoot_percent(c.setpoint, c.sim)), overshoot_reference(c.setpoint, c.sim)
    expect(abs(got - want) < 1e-9, "overshoot_percent on the simulated 0.2 mm step, kp 0.5",
           expected=f"{want:.2f} %", got=f"{got:.2f}")


def overshoot_reference(setpoint, position):
    """Overshoot worked by the checks: past the last set-point, in per cent of it, never below 0."""
    step = float(setpoint[-1])
    beyond = max((float(y) - step) * (1 if step > 0 else -1) for y in position)
    return max(0.0, 100.0 * beyond / abs(step))


def settling_reference(t_s, setpoint, position, band):
    """Settling time worked by the checks: the sample after the last one outside the band, in ms."""
    step = abs(float(setpoint[-1]))
    last = max((i for i in range(len(position)) if abs(float(setpoint[i]) - float(position[i])) > band * step),
               default=None)
    if last is None:
        return 0.0
    return math.inf if last == len(position) - 1 else float(t_s[last + 1]) * 1000.0


def random_response(rng, samples):
    """A step from 0 that comes at a random sample, to a random level up or down, and a response to it
    (the set-point may change on the way: a first level, then the step)."""
    level = rng.choice([-1, 1]) * round(rng.uniform(5.0, 900.0), rng.choice([0, 2]))
    at = rng.randint(0, samples // 3)
    setpoint = [0.0] * at + [level * (rng.uniform(0.3, 0.8) if rng.random() < 0.4 and k < at + 3 else 1.0)
                             for k in range(at, samples)]
    gain, wiggle = rng.uniform(0.15, 0.7), rng.uniform(0.0, 0.35)
    position, y = [], 0.0
    for k in range(samples):
        y += gain * (setpoint[k] - y) + (wiggle * level * math.sin(k) * rng.random() if k < samples - 6 else 0.0)
        position.append(round(y, 3))
    return setpoint, position


def test_overshoot_random_steps(lab):
    """TODO 2: overshoot of random steps, up and down, of any size, coming at any sample"""
    rng = cases("07 overshoot")
    for _ in range(40):
        setpoint, position = random_response(rng, rng.randint(6, 40))
        got, want = float(lab.overshoot_percent(setpoint, position)), overshoot_reference(setpoint, position)
        expect(abs(got - want) < 1e-9, f"overshoot_percent({setpoint}, {position}); {seed_note()}"[:900],
               expected=f"{want:g} %", got=f"{got:g}",
               hint="the step is the last set-point (the one the response settles to), up or down; the peak is "
                    "the furthest the response goes past it; in per cent of the step, never below 0")


def test_settling_time(lab):
    """TODO 3: settling time: from when the response stays within the band for good, in ms"""
    t = np.arange(8) * 0.001
    setpoint = [100] * 8
    cases = [([0, 50, 90, 103, 99, 101, 100, 100], 0.02, 4.0),
             ([0, 50, 90, 97, 99, 101, 100, 100], 0.05, 3.0),
             ([100] * 8, 0.02, 0.0),
             ([0, 50, 90, 97, 99, 101, 100, 90], 0.02, math.inf)]
    for position, band, want in cases:
        got = float(lab.settling_time_ms(t, setpoint, position, band))
        expect(got == want or abs(got - want) < 1e-9, f"settling_time_ms with position {position}, band {band:g}",
               expected=f"{want:g} ms", got=f"{got:g}",
               hint="the sample after the last one outside the band, t_s in seconds -> ms; math.inf if "
                    "the last sample is outside; 0 if none is")


def test_settling_time_random(lab):
    """TODO 3: settling time on samples at irregular times, not from 0, set-points that change, any band"""
    rng = cases("07 settling")
    for _ in range(40):
        samples = rng.randint(5, 40)
        setpoint, position = random_response(rng, samples)
        t0 = rng.choice([0.0, round(rng.uniform(0.001, 3.0), 4)])
        t_s = np.cumsum([t0] + [rng.uniform(0.0002, 0.004) for _ in range(samples - 1)])
        band = rng.choice([0.02, 0.05, round(rng.uniform(0.005, 0.2), 3)])
        got, want = float(lab.settling_time_ms(t_s, setpoint, position, band)), settling_reference(t_s, setpoint,
                                                                                                  position, band)
        expect(got == want or abs(got - want) < 1e-9,
               f"settling_time_ms(t_s {np.round(t_s, 5).tolist()}, set-points {setpoint}, positions {position}, "
               f"band {band:g}); {seed_note()}"[:1200], expected=f"{want:g} ms", got=f"{got:g}",
               hint="the time t_s (seconds, as given: not 1 ms apart, not from 0) of the sample after the last one "
                    "farther than band x |step| from its own set-point, in ms; math.inf if the last sample is "
                    "outside; 0 if none is")


def best_reference(metrics, allowed):
    kept = [(settle, kp) for kp, (over, settle) in metrics.items() if over <= allowed]
    return min(kept)[1]


def test_best_gain_random_tables(lab):
    """TODO 4: the best gain of random tables: overshoot within what is allowed, soonest settled, ties to the smaller"""
    rng = cases("07 best gain")
    for _ in range(40):
        gains = sorted(rng.sample([round(0.05 * k, 2) for k in range(1, 60)], rng.randint(2, 8)))
        rng.shuffle(gains)
        settles = [round(rng.uniform(10.0, 200.0)) for _ in range(3)] + [math.inf]
        metrics = {kp: (round(rng.uniform(0.0, 20.0), 1), rng.choice(settles)) for kp in gains}
        allowed = rng.choice([5.0, 10.0, round(rng.uniform(1.0, 15.0), 1)])
        first = gains[0]
        metrics[first] = (min(metrics[first][0], allowed), metrics[first][1] if metrics[first][1] < math.inf else 99.0)
        want, got = best_reference(metrics, allowed), lab.best_gain(metrics, allowed)
        table = ", ".join(f"{kp}: ({o:g} %, {s:g} ms)" for kp, (o, s) in metrics.items())
        expect(got == want, f"best_gain({{{table}}}, max_overshoot={allowed:g}); {seed_note()}", expected=repr(want),
               got=repr(got), hint="keep the gains whose overshoot is at most max_overshoot; of those, the one that "
                                   "settles soonest (the smaller gain on a tie); the table is in no particular order")


def test_analysis_is_your_own(lab):
    """TODO 2, 3: overshoot and settling time are worked out by you, not by the library's comparison"""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.camlink.model": set(), "retrofit.camlink": set()},
                      within={"overshoot_percent", "settling_time_ms", "best_gain"},
                      methods=frozenset({"overshoot", "following_error"}))
    expect(not places, "how your overshoot_percent and settling_time_ms get their figures",
           expected="from the set-points and positions you are given", got="the library's own: " + "; ".join(places),
           hint="the lab is to write them: the peak past the last set-point; the last sample outside the band")


BEST_GAIN_CASES = [
    ({0.1: (0.0, 160.0), 0.2: (1.8, 59.0), 0.3: (7.5, 40.0), 0.5: (17.7, 83.0)}, 5.0, 0.2,
     "0.3 settles sooner but overshoots 7.5 %"),
    ({0.1: (0.0, 160.0), 0.2: (0.6, 48.0), 0.3: (3.9, 70.0), 0.5: (17.7, 83.0)}, 5.0, 0.2,
     "0.3 is also within 5 % but settles later"),
    ({0.1: (0.0, 160.0), 0.2: (1.8, 59.0), 0.3: (7.5, 40.0), 0.5: (17.7, 83.0)}, 10.0, 0.3,
     "with 10 % allowed, 0.3 is within it and settles soonest"),
    ({0.2: (1.0, 50.0), 0.4: (2.0, 50.0), 0.6: (9.0, 20.0)}, 5.0, 0.2, "0.2 and 0.4 settle alike: the smaller"),
    ({0.2: (0.5, 90.0), 0.3: (5.0, 45.0), 0.5: (12.0, 30.0)}, 5.0, 0.3, "0.3 overshoots exactly 5 %, which is allowed"),
]


def test_best_gain(lab):
    """TODO 4: the best gain settles soonest without more overshoot than allowed"""
    for metrics, allowed, want, why in BEST_GAIN_CASES:
        got = lab.best_gain(metrics, allowed)
        table = ", ".join(f"{kp}: ({o:g} %, {t:g} ms)" for kp, (o, t) in metrics.items())
        expect(got == want, f"best_gain({{{table}}}, max_overshoot={allowed:g})", expected=f"{want} ({why})",
               got=repr(got), hint="keep the gains whose overshoot is at most max_overshoot; of those, the one that "
                                   "settles soonest (the smaller gain on a tie) — not simply the largest one kept")


def test_chosen_gain_is_good_in_the_simulation(lab, mill):
    """Your whole sweep: the gain you choose overshoots at most 5 % in the simulation and settles"""
    runs = lab.responses(mill)
    sim = lab.metrics_of(runs, "sim")
    best = lab.best_gain(sim)
    c = step_comparison(lab.with_gains(mill, best), "X", 0.2, 300)
    over = overshoot_reference(c.setpoint, c.sim)
    settled = np.abs(c.setpoint - c.sim)[-50:].max() <= 0.02 * 200
    expect(over <= 5.0 + 1e-9 and settled, f"the simulated step with your best gain kp = {best}",
           expected="overshoot at most 5 % and within 2 % of the step over the last 50 ms",
           got=f"overshoot {over:.1f} %, last 50 ms within the band: {settled}")


def test_model_agrees_with_simulation(lab, mill):
    """With the shipped gain, the python-control model and the simulation overshoot alike (within 3 points)"""
    c = step_comparison(lab.with_gains(mill, 0.5), "X", 0.2, 200)
    model, sim = overshoot_reference(c.setpoint, c.model), overshoot_reference(c.setpoint, c.sim)
    expect(abs(model - sim) <= 3.0, "overshoot of model and simulation at kp 0.5", expected="within 3 points",
           got=f"model {model:.1f} %, simulation {sim:.1f} %")
