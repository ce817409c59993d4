"""Checks of lab 07 (position-loop tuning): run with `retrofit lab check 07`, or pytest on this file."""

import math

import numpy as np
import pytest

from retrofit.camlink.model import step_comparison
from retrofit.config import load_machine
from retrofit.labs import expect, load_target


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
    got = float(lab.overshoot_percent(c.setpoint, c.sim))
    expect(abs(got - 100 * c.overshoot("sim")) < 1e-9, "overshoot_percent on the simulated 0.2 mm step, kp 0.5",
           expected=f"{100 * c.overshoot('sim'):.2f} %", got=f"{got:.2f}")


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
    over = 100 * max(c.overshoot("sim"), 0.0)
    settled = np.abs(c.setpoint - c.sim)[-50:].max() <= 0.02 * 200
    expect(over <= 5.0 + 1e-9 and settled, f"the simulated step with your best gain kp = {best}",
           expected="overshoot at most 5 % and within 2 % of the step over the last 50 ms",
           got=f"overshoot {over:.1f} %, last 50 ms within the band: {settled}")


def test_model_agrees_with_simulation(lab, mill):
    """With the shipped gain, the python-control model and the simulation overshoot alike (within 3 points)"""
    c = step_comparison(lab.with_gains(mill, 0.5), "X", 0.2, 200)
    model, sim = 100 * c.overshoot("model"), 100 * c.overshoot("sim")
    expect(abs(model - sim) <= 3.0, "overshoot of model and simulation at kp 0.5", expected="within 3 points",
           got=f"model {model:.1f} %, simulation {sim:.1f} %")
