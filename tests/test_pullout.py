"""The simulator's pull-out model: a stepper follows gentle ramps, loses steps on steep ones, says so."""

import math
from dataclasses import replace

import numpy as np
import pytest

from retrofit.commands import PMov
from retrofit.errors import ConfigError
from retrofit.frames import PinMap, PortFrames
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.run.report import build_report
from retrofit.sim import SimMachine
from retrofit.sim.pullout import MotorModel, PullOutMotor

BENCH = """
[machine]
name = "bench"
tick_us = 1.0
port = "none"

[axis.x]
steps_per_mm = 80.0
min_mm = -1000.0
max_mm = 1000.0
pulse_high_ticks = 2
pulse_low_ticks = 2
dir_setup_ticks = 2
dir_hold_ticks = 2
max_velocity_mm_s = 150.0
max_accel_mm_s2 = 1000.0

[axis.y]
steps_per_mm = 80.0
min_mm = -1000.0
max_mm = 1000.0
max_velocity_mm_s = 150.0

[sim.motor.x]
microsteps = 8
inertia_kg_m2 = 1.2e-4
load_torque_nm = 0.08
pullout_curve = [[0, 0.45], [150, 0.40], [300, 0.30], [600, 0.18], [1200, 0.08], [1500, 0.05]]
{extra}
[motion]
default_feed_mm_min = 9000.0
"""


def bench(tmp_path, extra="", name="bench.toml"):
    path = tmp_path / name
    path.write_text(BENCH.replace("{extra}", extra), encoding="utf-8")
    return load_machine(path)


def ramp(machine, accel, profile="trapezoid"):
    axes = tuple(replace(a, max_accel_mm_s2=accel) for a in machine.axes)
    return replace(machine, axes=axes, motion=replace(machine.motion, profile=profile))


def run_x(machine, mm=40.0):
    log = execute_fast(plan_program([PMov((("X", mm),))], machine))
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


def pulses(machine, rise_ticks, directions=None):
    """Port frames with a step pulse of axis X rising at each tick (direction +1 unless given)."""
    pins = PinMap(machine)
    end = int(max(rise_ticks)) + 10
    per_tick = np.full(end, pins.byte([0, 0], [1, 1]), dtype=np.uint8)
    directions = directions if directions is not None else [1] * len(rise_ticks)
    for tick, direction in zip(rise_ticks, directions):
        per_tick[tick - 3:tick] = pins.byte([0, 0], [direction, 1])
        per_tick[tick:tick + 2] = pins.byte([1, 0], [direction, 1])
        per_tick[tick + 2:tick + 5] = pins.byte([0, 0], [direction, 1])
    return PortFrames.from_per_tick(per_tick)


def test_motor_table_is_read_strictly(tmp_path):
    machine = bench(tmp_path)
    motor = machine.sim.motors["X"]
    assert "Y" not in machine.sim.motors
    assert (motor.full_steps_per_rev, motor.microsteps, motor.steps_per_rev) == (200, 8, 1600)
    assert motor.damping_ratio == 0.3 and motor.pullout_curve[0] == (0.0, 0.45)
    with pytest.raises(ConfigError, match=r"typo.toml \[sim.motor.x\] inertia_kgm2: unknown key"):
        bench(tmp_path, "inertia_kgm2 = 1.0", "typo.toml")
    curve = tmp_path / "curve.toml"
    curve.write_text(BENCH.replace("{extra}", "").replace("[[0, 0.45]", "[[10, 0.45]"))
    with pytest.raises(ConfigError, match=r"curve.toml \[sim.motor.x\] pullout_curve .*starting at 0 rpm"):
        load_machine(curve)
    text = BENCH.replace("{extra}", "").replace("[sim.motor.x]", "[sim.motor.q]")
    (tmp_path / "axis.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"\[sim.motor.q\]: no axis 'q'; axes are x, y"):
        load_machine(tmp_path / "axis.toml")


def test_torque_curve_gives_acceleration_top_rate_and_pull_in():
    motor = MotorModel(inertia_kg_m2=1e-4, pullout_curve=((0.0, 1.0), (300.0, 0.5), (600.0, 0.1)),
                       load_torque_nm=0.3)
    assert motor.torque_nm(0) == 1.0 and motor.torque_nm(500) == pytest.approx(0.75)    # 150 rpm
    assert motor.torque_nm(2001) == 0.0                                                 # past the curve
    assert motor.max_accel_steps_s2(0) == pytest.approx(0.7 / 1e-4 * 200 / (2 * math.pi))
    assert motor.max_rate_steps_s() == pytest.approx((300 + 300 * 0.2 / 0.4) * 200 / 60)
    assert motor.pull_in_rate_steps_s() == pytest.approx(math.sqrt(4 * motor.max_accel_steps_s2(0)))


def test_without_motor_tables_every_step_is_taken():
    machine = load_machine("chivu-lathe")
    assert machine.sim.motors == {}
    sim = SimMachine(machine)
    assert sim.motors == [None, None]


@pytest.mark.parametrize("profile", ["trapezoid", "exponential"])
def test_a_gentle_ramp_loses_nothing(tmp_path, profile):
    machine = ramp(bench(tmp_path), 2000.0, profile)
    log, sim = run_x(machine)
    assert log.steps_emitted["X"] == 3200 and sim.motor_steps[0] == 3200
    assert sim.motors[0].lost == 0 and sim.violations == []
    assert sim.carriage_mm("X") == pytest.approx(40.0)


def test_a_steep_ramp_loses_steps_and_says_so(tmp_path):
    machine = ramp(bench(tmp_path), 40_000.0)
    log, sim = run_x(machine)
    assert log.steps_emitted["X"] == 3200
    assert sim.motor_steps[0] < 3200 - 100                    # the motor stalled: far behind the count
    assert sim.motors[0].lost == 3200 - sim.motor_steps[0]
    lost = [v for v in sim.violations if v.kind == "lost_steps"]
    assert lost and lost[0].axis == "X" and "fell out of step" in lost[0].detail
    assert "pull-in rate" in lost[0].detail
    report = build_report(log, sim)
    assert report["axes"]["X"]["motor_mm"] < 40.0 - 1.0
    assert report["axes"]["X"]["carriage_mm"] == pytest.approx(report["axes"]["X"]["motor_mm"])
    assert any(v["kind"] == "lost_steps" for v in report["violations"])


def test_the_limit_lies_between_the_motor_s_acceleration_at_top_speed_and_at_rest(tmp_path):
    machine = bench(tmp_path)
    motor, spm = machine.sim.motors["X"], 80.0
    at_top = motor.max_accel_steps_s2(150 * spm) / spm
    at_rest = motor.max_accel_steps_s2(0) / spm
    assert run_x(ramp(machine, 0.9 * at_top))[1].motors[0].lost == 0
    assert run_x(ramp(machine, 1.5 * at_rest))[1].motors[0].lost > 0


def test_faster_than_the_top_rate_loses_steps(tmp_path):
    machine = bench(tmp_path)
    fast = replace(machine, axes=(replace(machine.axes[0], max_velocity_mm_s=600.0, max_accel_mm_s2=1500.0),
                                  machine.axes[1]),
                   motion=replace(machine.motion, default_feed_mm_min=36_000.0))
    assert machine.sim.motors["X"].max_rate_steps_s() / 80.0 == pytest.approx(400.0)
    _, sim = run_x(fast, 150.0)
    assert sim.motors[0].lost > 0


def test_tick_jitter_and_uneven_spacing_do_not_lose_steps(tmp_path):
    """A coarse timer's rounding and a Bresenham minor axis's uneven gaps only wiggle the rotor."""
    machine = bench(tmp_path)
    a = 160_000.0                                             # steps/s², 2000 mm/s²
    top = int(10_000 ** 2 / (2 * a))                          # steps to reach 10 000 steps/s
    ideal = [math.sqrt(2 * k / a) for k in range(1, top + 1)]
    ideal += [ideal[-1] + k * 1e-4 for k in range(1, 3001)]
    coarse = [1000 + 25 * round(t * 1e6 / 25) for t in ideal]        # a 25 us timer: +-12 us
    uneven = [coarse[-1] + int(t) for t in np.cumsum(np.tile([80, 120], 500))]
    sim = SimMachine(machine)
    sim.feed(pulses(machine, coarse + uneven))
    assert sim.motors[0].lost == 0, sim.violations[:1]
    assert sim.motor_steps[0] == len(coarse) + len(uneven)


def test_a_stalled_motor_pulls_in_again_when_the_pulses_slow_down(tmp_path):
    machine = bench(tmp_path)
    motor = machine.sim.motors["X"]
    slow_gap = math.ceil(1e6 / motor.pull_in_rate_steps_s()) + 5        # ticks, slower than pull-in
    abrupt = list(range(1000, 1000 + 40 * 60, 40))                      # 25 000 steps/s from rest
    slow = [abrupt[-1] + slow_gap * (k + 1) for k in range(50)]
    sim = SimMachine(machine)
    sim.feed(pulses(machine, abrupt + slow))
    trace = sim.traces["X"]
    assert sim.motors[0].lost > 0
    after = trace.motor_steps[-1] - trace.motor_steps[len(abrupt)]
    assert after == len(slow) - 1                                       # every slow step is taken


def test_the_model_is_deterministic_and_direction_aware(tmp_path):
    machine = bench(tmp_path)
    ticks = [1000 + 40 * k for k in range(200)]
    runs = []
    for _ in range(2):
        sim = SimMachine(machine)
        sim.feed(pulses(machine, ticks, [-1] * len(ticks)))
        runs.append((sim.motor_steps[0], sim.motors[0].lost, [v.detail for v in sim.violations]))
    assert runs[0] == runs[1] and runs[0][0] > -200 and runs[0][1] > 0


def test_follow_reports_each_step_turned():
    motor = PullOutMotor(MotorModel(inertia_kg_m2=1e-4, pullout_curve=((0.0, 1.0), (600.0, 0.5))), "X", 1e-6)
    assert [motor.follow(t, 1) for t in (0, 5000, 10_000)] == [1, 1, 1]
    assert motor.lost == 0 and motor.n == 3
