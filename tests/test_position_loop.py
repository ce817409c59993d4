"""The 1 ms position loop: the simulated servo axis against its python-control model."""

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from retrofit.camlink.loop import PositionLoop, ServoAxis
from retrofit.camlink.model import loop_model, model_response, ramp_comparison, step_comparison
from retrofit.camlink.motor import ServoMotor
from retrofit.machine.config import load_machine

MILL = load_machine("grenoble-mill")


def with_gains(kp, ki=0.0, feedforward=True):
    servo = replace(MILL.parts["servo"], kp=kp, ki=ki, feedforward=feedforward)
    return replace(MILL, parts={**MILL.parts, "servo": servo})


GAINS = [with_gains(0.5), with_gains(0.3, ki=5.0), with_gains(0.8)]
GAIN_IDS = ["P-shipped", "PI", "P-stiff"]


def within_10_percent(sim, model):
    return abs(sim - model) <= 0.10 * abs(model)


@pytest.mark.parametrize("machine", GAINS, ids=GAIN_IDS)
def test_step_overshoot_of_the_simulation_is_within_10_percent_of_the_model(machine):
    cmp = step_comparison(machine, "X", step_mm=0.2, periods=300)
    model, sim = cmp.overshoot("model"), cmp.overshoot("sim")
    assert model > 0.05, "the gains chosen give a visible overshoot"
    assert within_10_percent(sim, model), f"overshoot sim {sim:.4f} vs model {model:.4f}"
    assert abs(cmp.sim[-1] - 200) <= MILL.parts["servo"].in_position_pulses


@pytest.mark.parametrize("machine", GAINS, ids=GAIN_IDS)
@pytest.mark.parametrize("feedforward", [False, True], ids=["no-feedforward", "feedforward"])
def test_ramp_following_error_of_the_simulation_is_within_10_percent_of_the_model(machine, feedforward):
    cmp = ramp_comparison(machine, "X", speed_mm_s=10.0, periods=400, feedforward=feedforward)
    model, sim = cmp.following_error("model"), cmp.following_error("sim")
    peak_model, peak_sim = np.abs(model).max(), np.abs(sim).max()
    assert within_10_percent(peak_sim, peak_model), f"peak sim {peak_sim:.1f} vs model {peak_model:.1f}"
    if not feedforward and machine.parts["servo"].ki == 0.0:
        # a P loop's following error on a ramp settles to v / (kp K): speed over velocity gain
        kv = machine.parts["servo"].kp * 50_000 / 255
        assert model[-1] == pytest.approx(10_000 / kv, rel=0.01)
        assert within_10_percent(sim[-50:].mean(), model[-50:].mean())


def test_the_models_prediction_is_the_discrete_closed_loop():
    model = loop_model(MILL, "X")
    y = model_response(model, np.full(400, 100.0), np.zeros(400))
    assert y[0] == 0.0                     # the plant has no direct path: a period goes by first
    assert y[-1] == pytest.approx(100.0, abs=1e-3)
    assert model.dt == MILL.tick_s


def test_feed_255_runs_the_axis_near_its_max_velocity_and_feed_0_lets_it_stop():
    servo, axis = MILL.parts["servo"], MILL.axis("X")
    motor = ServoMotor(axis, servo, 0)
    for _ in range(200):
        motor.run(255, MILL.tick_s)
    assert motor.speed_pulses_s / 1000.0 == pytest.approx(50.0, rel=0.02)     # friction costs < 2 %
    for _ in range(200):
        motor.run(0, MILL.tick_s)
    assert motor.at_rest and motor.omega == 0.0
    still = motor.encoder()
    motor.run(0, MILL.tick_s)
    assert motor.encoder() == still


def test_a_weak_drive_cannot_break_static_friction():
    servo = replace(MILL.parts["servo"], coulomb_nm=0.05)
    motor = ServoMotor(MILL.axis("X"), servo, 1234)
    for _ in range(50):
        motor.run(3, MILL.tick_s)
    assert motor.encoder() == 1234


def test_the_loop_writes_whole_feedrates_within_the_drives_range():
    servo = MILL.parts["servo"]
    axis = ServoAxis(ServoMotor(MILL.axis("X"), servo, 0), PositionLoop(servo, MILL.tick_s), MILL.tick_s)
    sample = axis.step(10_000, 0)                  # a 10 mm error: far beyond the drive's range
    assert sample.feed_out == 255 and sample.following_error == 10_000
    sample = axis.step(10_000, 0)
    assert isinstance(sample.feed_out, int) and sample.feed_out == 255


def test_no_integral_wind_up_while_the_drive_is_saturated():
    machine = with_gains(0.3, ki=5.0)
    servo = machine.parts["servo"]
    axis = ServoAxis(ServoMotor(MILL.axis("X"), servo, 0), PositionLoop(servo, MILL.tick_s), MILL.tick_s)
    for _ in range(100):
        axis.step(20_000, 0)
    assert axis.loop.integral < 1000 * 100         # only the unsaturated periods were summed


def test_importing_the_cam_link_does_not_import_control_or_matplotlib():
    code = ("import sys, retrofit.camlink, retrofit.camlink.server, retrofit.camlink.model; "
            "print('control' in sys.modules, 'matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert out.stdout.split() == ["False", "False"], out.stderr


def test_loop_model_command_prints_both_figures_and_plots(tmp_path, capsys):
    from retrofit.cli import main
    png = tmp_path / "step.png"
    assert main(["loop-model", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "overshoot: model" in out and "simulation" in out
    assert png.stat().st_size > 1000
