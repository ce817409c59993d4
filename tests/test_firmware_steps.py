"""The firmware's step generation in simavr, measured on its pins in cycles: the exact pulse
width and period at the highest rate it runs, look-ahead across a joint, braking to the stop
rate at a move's end, acceleration within the limit, and a link full of garbage during a move.

Oracles: the configured pulse width and the period 1/rate; the host planner's junction speed
(retrofit.motion.lookahead) for a joint; the start rate of a motor at rest, sqrt(2 a) steps/s;
the machine file's acceleration limit.
"""

from __future__ import annotations

import math
import re
import shutil

import numpy as np
import pytest

from retrofit.commands import parse_command
from retrofit.link import QUEUED, encode_command, encode_frame, seq_byte
from retrofit.link.script import ScriptedHost
from retrofit.machine.config import load_machine
from retrofit.motion.lookahead import Kinematics, junction_speed

from tests.test_firmware_sim import Script

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
fr = pytest.importorskip("retrofit.firmware.runs")
st = pytest.importorskip("retrofit.firmware.stress")
S = fs.F_CPU
BENCH = fs.ROOT / "bench" / "steprate.toml"


@pytest.fixture(scope="module")
def mill():
    machine = load_machine("tul-mill")
    return machine, fs.build(machine.name)


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """The bench machine (2 us pulse, no speed limit the firmware could reach) built in a copy."""
    machine = load_machine(BENCH)
    return machine, fs.build_copy(machine, tmp_path_factory.mktemp("steprate"))


def top(axes: str, rate: float) -> float:
    """``rate``, or the firmware's ceiling for that many axes stepping together if lower (it
    clamps every line to the rate it keeps with the link busy: firmware/planner.c KEEP_RATE)."""
    return min(rate, st.keep_rate((1.0,) * len(axes)))


def cruise_move(machine, elf, axes: str, rate: float, stats: bool = False):
    """A move of ``axes`` (equal distances) cruising at ``rate`` steps/s for ~40 ms; the log."""
    steps = int(rate * 0.04)
    feed = rate * math.sqrt(len(axes)) * 60 / machine.axis(axes[0]).steps_per_mm
    move = "FMOV " + " ".join(f"{a}{steps / machine.axis(a).steps_per_mm:g}" for a in axes)
    script = Script(machine).at(2_000_000, f"FFDR F{feed:.4f}").at(2_200_000, move)
    log = fs.Harness(elf, machine, script=script.items, stats=stats,
                     cycles=2_400_000 + int(steps / rate * S * 1.3) + 800_000).run()
    return log, steps


@pytest.mark.parametrize("axes, rate", [("X", 60_000), ("XYZ", 60_000), ("XYZA", 60_000)])
def test_every_pulse_and_interval_is_exact_at_the_top_rate(bench, axes, rate):
    machine, elf = bench
    rate = top(axes, rate)
    log, steps = cruise_move(machine, elf, axes, rate)
    rises, falls, _ = fs.step_times(log, machine, axes[0])
    assert len(rises) == len(falls) == steps
    width_us = (falls - rises) / 16
    assert width_us.min() >= 2.0 and width_us.max() <= 3.0          # 2 us configured, +1 at most
    cruise = np.diff(rises)[steps // 4: 3 * steps // 4]
    assert np.abs(cruise - S / rate).max() <= 16                     # +-1 us of the period
    for other in axes[1:]:                                           # every axis on the same edge
        r, f, _ = fs.step_times(log, machine, other)
        assert len(r) == steps and np.abs(r - rises).max() <= 16
        assert ((f - r) / 16).min() >= 2.0


def bresenham_move(machine, elf, stats: bool = False):
    """X 1.6 mm, Y 0.8, Z 0.4 cruising at 40 kHz on X; the log."""
    rate, steps = 40_000, 1600
    feed = rate * math.sqrt(1 + 0.25 + 0.0625) * 60 / 1000
    script = Script(machine).at(2_000_000, f"FFDR F{feed:.4f}").at(2_200_000, "FMOV X1.6 Y0.8 Z0.4")
    return fs.Harness(elf, machine, script=script.items, stats=stats,
                      cycles=2_400_000 + int(steps / rate * S * 1.3) + 800_000).run()


def test_bresenham_axes_step_on_the_base_axis_edges_with_exact_pulses_at_40_khz(bench):
    """X 4 mm, Y 2, Z 1 at 40 kHz on X: Y steps at every second X step, Z at every fourth."""
    machine, elf = bench
    rate, steps = 40_000, 1600
    log = bresenham_move(machine, elf)
    rx, fx, _ = fs.step_times(log, machine, "X")
    assert len(rx) == steps
    assert np.abs(np.diff(rx)[steps // 4: 3 * steps // 4] - S / rate).max() <= 16
    for axis, every in (("Y", 2), ("Z", 4)):
        r, f, _ = fs.step_times(log, machine, axis)
        assert len(r) == steps // every
        width_us = (f - r) / 16
        assert width_us.min() >= 2.0 and width_us.max() <= 3.0
        # each of its steps on an X step's edge (Bresenham from the mid-point: no drift)
        nearest = np.abs(r[:, None] - rx[None, :]).min(axis=1)
        assert nearest.max() <= 16
        cruise = np.diff(r)[len(r) // 4: 3 * len(r) // 4]
        assert np.abs(cruise - every * S / rate).max() <= 16


def bench_variant(tmp_path, name: str, pulse_ticks: int = 2, axes: str = "xyza"):
    """The bench machine with another pulse width or fewer axes, built in a copy."""
    sections = re.split(r"(?m)^(?=\[)", BENCH.read_text())
    text = "".join(p for p in sections if not p.startswith("[axis.") or p[6] in axes)
    text = text.replace("pulse_high_ticks = 2", f"pulse_high_ticks = {pulse_ticks}")
    (tmp_path / f"{name}.toml").write_text(text.replace('name = "steprate"', f'name = "{name}"'))
    machine = load_machine(tmp_path / f"{name}.toml")
    return machine, fs.build_copy(machine, tmp_path / "build")


@pytest.mark.parametrize("name, pulse_ticks, axes, rate", [
    ("steprate1", 2, "x", 60_000),    # one axis: the shortest tick ends its pulse itself
    ("steprate3", 3, "xyza", 40_000),  # the longest pulse the tick still ends itself
    ("steprate5", 5, "xyza", 40_000),  # too long to wait for: compare B's interrupt ends it
])
def test_a_pulse_is_never_shorter_than_configured_and_at_most_1_us_longer(
        tmp_path, name, pulse_ticks, axes, rate):
    machine, elf = bench_variant(tmp_path, name, pulse_ticks, axes)
    rate = top("X", rate)
    log, steps = cruise_move(machine, elf, "X", rate)
    rises, falls, _ = fs.step_times(log, machine, "X")
    assert len(rises) == len(falls) == steps
    width_us = (falls - rises) / 16
    assert width_us.min() >= pulse_ticks and width_us.max() <= pulse_ticks + 1.0
    cruise = np.diff(rises)[steps // 4: 3 * steps // 4]
    assert np.abs(cruise - S / rate).max() <= 16


@pytest.fixture(scope="module")
def bench5(tmp_path_factory):
    """The bench machine with a 5 us pulse: compare B's interrupt ends it, not the tick."""
    return bench_variant(tmp_path_factory.mktemp("steprate5"), "steprate5", 5)


@pytest.mark.parametrize("rate", [30_000, 35_000, 37_500, 40_000, 42_500, 45_000])
def test_a_5_us_pulse_keeps_every_interval_at_every_rate_up_to_45_khz(bench5, rate):
    """With compare B ending the pulses the tick's rest runs with interrupts on; the 1 ms clock
    waits for its end. Nested in a segment's hand-over it pushed the next tick past its slot (a
    rise 6 us late at 42.5 kHz, where the clock and a hand-over met)."""
    machine, elf = bench5
    rate = top("X", rate)
    log, steps = cruise_move(machine, elf, "X", rate)
    rises, falls, _ = fs.step_times(log, machine, "X")
    assert len(rises) == len(falls) == steps
    assert ((falls - rises) / 16).min() >= 5.0
    cruise = np.diff(rises)[steps // 4: 3 * steps // 4]
    assert np.abs(cruise - S / rate).max() <= 16


# 10 us at 16 MHz: the longest another interrupt (a received byte) may wait for the CPU.
OFF_LIMIT_CYCLES = 160


@pytest.mark.parametrize("axes, rate", [("X", 60_000), ("XYZ", 40_000), ("bresenham", 40_000)])
def test_interrupts_are_never_off_longer_than_10_us_at_the_top_rate(bench, axes, rate):
    machine, elf = bench
    if axes == "bresenham":                                          # Y, Z minor axes
        log, steps = bresenham_move(machine, elf, stats=True), 1600
    else:
        rate = top(axes, rate)
        log, steps = cruise_move(machine, elf, axes, rate, stats=True)
    rises, _, _ = fs.step_times(log, machine, "X")
    assert len(rises) == steps
    assert np.abs(np.diff(rises)[steps // 4: 3 * steps // 4] - S / rate).max() <= 16
    assert 0 < log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES
    assert log.stats["off_main_longest"] <= OFF_LIMIT_CYCLES


@pytest.mark.parametrize("pulse_ticks", [3, 5])
def test_a_longer_pulse_keeps_interrupts_off_at_most_10_us(tmp_path, pulse_ticks):
    """3 us: the longest pulse that ends inside the tick; 5 us: compare B's interrupt ends it."""
    machine, elf = bench_variant(tmp_path, f"steprate{pulse_ticks}", pulse_ticks, "xyz")
    log, steps = cruise_move(machine, elf, "XYZ", 40_000, stats=True)
    assert len(fs.step_times(log, machine, "Z")[0]) == steps
    assert 0 < log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES


TIMER1_COMPB_VECTOR = 18              # the ATmega2560's vector number of compare B


def test_compare_b_stays_off_while_the_tick_ends_its_own_pulses(bench):
    """A 2 us pulse ends inside the tick, so compare B's interrupt has nothing to do while the
    timer clocks the steps. Left on, it came at every wrap of the free-running counter (every
    32.8 ms, at whatever count OCR1B last held) and held the next tick's entry back by its 57
    cycles: a rise 1.1 us late at 60 kHz on four axes when the two met."""
    machine, elf = bench
    log, steps = cruise_move(machine, elf, "XYZA", top("XYZA", 60_000), stats=True)
    assert len(fs.step_times(log, machine, "X")[0]) == steps
    assert log.stats["cycles"] > 4 * 65536 * 8                       # the counter wrapped
    assert log.stats.get(f"vector{TIMER1_COMPB_VECTOR}", 0) == 0


JOINT_RATE = 15_000              # steps/s: grbl 1.1h's clean rate over the bench's short segments


def test_a_joint_between_colinear_lines_costs_no_longer_than_a_normal_interval(bench):
    """Twelve colinear PMOVs of 500 X steps at 15 000 steps/s, queued ahead: every interval from
    the first joint to the last within 1 us of the period. Before, a new line was worked out in
    its first tick (the line's check, its counters, its AMASS level: 1 243 cycles), so each
    joint's interval was a long one (96 us against 66.7 here, 90.6 against 50 at 20 000)."""
    machine, elf = bench
    script = Script(machine).at(2_000_000, f"PFDR F{JOINT_RATE * 60 / 1000:g}")
    for k in range(12):
        script.at(2_100_000 + k * 60_000, f"PMOV X{(k + 1) * 0.5:g}")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(1.0 * S)).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    assert len(rises) == 6000
    gaps = np.diff(rises)[499:5500]                 # from the first joint's to the last's
    worst = np.abs(gaps - S / JOINT_RATE).max() / 16
    assert worst <= 1.0, f"an interval {worst:.2f} us off the period (joints at every 500th)"


def corner(machine, elf, turn_deg: float):
    """FMOV X10, then 10 mm on at ``turn_deg`` from X: the X step times."""
    x, y = 10 + 10 * math.cos(math.radians(turn_deg)), 10 * math.sin(math.radians(turn_deg))
    script = Script(machine).at(3_200_000, "FMOV X10").at(3_300_000, f"FMOV X{x:.4f} Y{y:.4f}")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(1.0 * S)).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    return rises, log


def test_a_colinear_two_segment_path_does_not_stop_at_the_joint(mill):
    machine, elf = mill
    rises, _ = corner(machine, elf, 0.0)
    assert len(rises) == 2000
    speed = 1.0 / (np.diff(rises) / S)                                # X steps/s, interval by interval
    # at the joint (step 1000) the axis runs at the rapid feed, 50 mm/s = 5000 steps/s, as in the
    # middle of a single move: no braking towards the stop rate (447 steps/s)
    assert speed[990:1010].min() == pytest.approx(5000, rel=0.02)
    # and the two moves take as long as one 20 mm move: 20/50 + 50/1000 s (a trapezoid)
    assert (rises[-1] - rises[0]) / S == pytest.approx(0.45, rel=0.03)


def test_a_shallow_turn_is_taken_at_the_host_planners_junction_speed(mill):
    machine, elf = mill
    turn = 5.0
    rises, _ = corner(machine, elf, turn)
    axes = machine.axes
    before = Kinematics(10.0, np.array([1.0, 0, 0, 0]), 50.0, 1000.0)
    after = Kinematics(10.0, np.array([math.cos(math.radians(turn)), math.sin(math.radians(turn)), 0, 0]),
                       50.0, 1000.0)
    vj = junction_speed(before, after, machine.motion.junction_deviation_mm,
                        np.array([a.max_accel_mm_s2 for a in axes]), np.array([a.step_mm for a in axes]))
    assert 5 < vj < 20                                                # 10.6 mm/s: between stop and feed
    speed_mm_s = 1.0 / (np.diff(rises) / S) / machine.axis("X").steps_per_mm
    slowest = speed_mm_s[900:1100].min()                              # X's speed around the joint
    assert vj * math.cos(math.radians(turn)) * 0.97 <= slowest <= vj * 1.25


def test_a_move_brakes_to_the_stop_rate_at_its_end_within_the_acceleration_limit(mill):
    machine, elf = mill
    script = Script(machine).at(3_200_000, "FMOV X20")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.8 * S)).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    assert len(rises) == 2000
    x = machine.axis("X")
    accel = x.max_accel_mm_s2 * x.steps_per_mm                       # 100 000 steps/s^2
    stop_rate = math.sqrt(2 * accel)                                  # one step from rest: 447/s
    last = np.diff(rises[-6:]) / S
    assert np.all(np.diff(last) >= -1e-6)                             # still slowing down
    # braking at a to the stop rate r0 at the end: the step k from the end takes
    # (sqrt(r0^2 + 2 a k) - sqrt(r0^2 + 2 a (k - 1))) / a, the last (632 - 447) / a s
    for k in (1, 2, 3):
        planned = (math.sqrt(stop_rate ** 2 + 2 * accel * k)
                   - math.sqrt(stop_rate ** 2 + 2 * accel * (k - 1))) / accel
        assert last[-k] == pytest.approx(planned, rel=0.15), k
    window = 0.02
    assert fr.windowed_accel(rises, window) <= accel + 2 / window ** 2
    report = fs.report(log, machine)
    assert not report["violations"]


def test_framed_garbage_during_a_move_leaves_every_step_interval_as_planned(mill):
    """Damaged frames back to back for most of FMOV X30: each is NAKed, the move's steps come
    at the same cycles as without them, to the interrupt latency the frames cost (< 1 us)."""
    machine, elf = mill
    end = int(1.0 * S)

    def run(garbage: bool):
        script = Script(machine).at(3_200_000, "FMOV X30").at(end - 200_000, "RDPS")
        if garbage:
            good = encode_frame(seq_byte(QUEUED, 5), encode_command(parse_command("FMOV X1"), machine))
            bad = bytearray(good)
            bad[6] ^= 0x10                                            # the CRC fails
            for k in range(int(0.6 * S / 35_200)):
                script.items.append((3_400_000 + k * 35_200, bytes(bad)))
        return fs.Harness(elf, machine, script=script.items, cycles=end).run()

    quiet, noisy = run(False), run(True)
    answers = ScriptedHost(machine).replies(noisy.answer_bytes())
    naks = sum(type(a).__name__ == "Nak" for a in answers)
    assert naks == int(0.6 * S / 35_200)
    assert dict(answers[-1].steps)["X"] == 3000                       # executed once
    q, _, _ = fs.step_times(quiet, machine, "X")
    n, _, _ = fs.step_times(noisy, machine, "X")
    assert len(q) == len(n) == 3000
    assert np.abs(n - q).max() <= 32                                  # every step within 2 us


@pytest.mark.slow
def test_the_474_segment_circle_runs_within_5_percent_of_the_host_plan(mill):
    """3 R10 circles at F1200, sent through the link as the host streams them (BUSY waited
    out), the AVR's time at the wall clock's pace: as long as the host plan (junction deviation
    over 16 moves) to 5 %, each axis's acceleration within its limit plus the quantisation."""
    from retrofit.gcode import compile_program
    from retrofit.run.program import plan_compiled
    machine, elf = mill
    text = "G21 G90 G17\nG0 X30 Y20\nG1 F1200\n" + "G2 X30 Y20 I-10 J0\n" * 3 + "M2\n"
    program = compile_program(text, machine, file="circle.ngc")
    assert sum(type(c).__name__ == "PMov" for c in program.commands) == 474
    _, plan = plan_compiled(program, machine)
    log, remote = fr.send_through_link(elf, machine, program.commands)
    assert remote["position_steps"] == {"X": 3000, "Y": 2000, "Z": 0, "E": 0}
    rx, _, _ = fs.step_times(log, machine, "X")
    ry, _, _ = fs.step_times(log, machine, "Y")
    both = np.sort(np.concatenate([rx, ry]))
    assert (both[-1] - both[0]) / S == pytest.approx(plan.end_s, rel=0.05)
    window = 0.02
    for name, rises in (("X", rx), ("Y", ry)):
        a = machine.axis(name)
        assert fr.windowed_accel(rises, window) <= a.max_accel_mm_s2 * a.steps_per_mm + 2 / window ** 2
    assert not fs.report(log, machine)["violations"]
