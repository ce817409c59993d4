"""No feed a machine file allows resets the firmware or makes it step wrong, through the host's clamp.

For each firmware machine (the shipped ones, and the bench machine without speed limits of its
own, whose feeds the host must clamp), a program of G1 at the highest feed the machine allows
along each path and G0 back, on 1 to 4 axes, equal and in Bresenham ratios, is planned as a
firmware run plans it (retrofit.firmware.limits.plan_within_limits) and sent command by command
through the host's link endpoint, in lockstep with simavr, RDST every 2 ms. After every move, at
rest, RDPS must be the move's end and so must the step pins (less a backlash take-up); the board never restarts, no RDST
says ERROR or STEP_ERROR, and no axis steps faster than the table's rate for its case allows.
"""

from __future__ import annotations

import random
import shutil

import numpy as np
import pytest

from retrofit.link.replies import Position, Status, StatusFlags
from retrofit.machine.config import load_machine

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
mx = pytest.importorskip("retrofit.firmware.stress_mix")
fl = pytest.importorskip("retrofit.firmware.limits")
BENCH = fs.ROOT / "bench" / "steprate.toml"
SHARES = (1.0, 0.5, 0.25, 0.125)


def program(machine) -> str:
    """G1 out at the machine's top feed along each path, G0 back, for 1-4 axes equal and in ratios."""
    names = [a for a in machine.axis_names if a in "XYZABCUVW"]      # (tul-mill's E: the ATC's)
    room = {a.name: min(a.max_mm, 10.0) / 2 if a.max_mm > 0 else max(a.min_mm, -10.0) / 2
            for a in machine.axes}
    lines = ["G21 G90"]
    for k in range(1, min(4, len(names)) + 1):
        for shares in {(1.0,) * k, SHARES[:k]}:
            to = {a: room[a] * s for a, s in zip(names[:k], shares)}
            length = sum(v * v for v in to.values()) ** 0.5
            feed = min([machine.motion.rapid_feed_mm_min / 60]
                       + [machine.axis(a).max_velocity_mm_s * length / abs(v) for a, v in to.items()])
            lines.append("G1 " + " ".join(f"{a}{v:.4f}" for a, v in to.items()) + f" F{feed * 60:.1f}")
            lines.append("G0 " + " ".join(f"{a}0" for a in to))
    return "\n".join(lines + ["M2"]) + "\n"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mitic-lathe", "tul-mill", "steprate"])
def test_every_feed_the_machine_allows_runs_clean_through_the_host_clamp(tmp_path, name):
    from tests.test_firmware_limits import planned
    machine = load_machine(BENCH if name == "steprate" else name)
    elf = fs.build_copy(machine, tmp_path)
    exp, notes = planned(program(machine), machine)
    assert (name == "steprate") == bool(notes), notes          # only the bench machine is clamped
    run = mx.MixRun(seed=1)
    board = mx.Lockstep(elf, machine).start()
    ends, pos = [], {a: 0 for a in machine.axis_names}
    try:
        host = mx._Host(board, machine, random.Random(1), run, 0.0, 0.0, (2.0, 2.0), 120.0)
        for cmd in exp.commands:
            host.send(str(cmd))
            if type(cmd).__name__ in ("FMov", "PMov"):
                pos.update({a: round(mm * machine.axis(a).steps_per_mm) for a, mm in cmd.axes})
                ends.append(dict(pos))
                assert host.rest()[1] == ends[-1]
    finally:
        run.log = log = board.stop()
    assert log.answer_bytes().count(b"retrofit firmware") == 1          # no restart
    answers = mx.answer_cycles(log, machine)
    assert not any(int(r.flags) & (StatusFlags.ERROR | StatusFlags.STEP_ERROR)
                   for _, r in answers if isinstance(r, Status))
    positions = [(c, dict(r.steps)) for c, r in answers if isinstance(r, Position)]
    pins = mx.pin_positions(log, machine, [c for c, _ in positions])
    for counted, (_, said) in zip(pins, positions):           # the motor: the position, or a
        for a, n in zip(machine.axis_names, map(int, counted)):   # backlash take-up beyond it
            assert n - said[a] in {0, machine.axis(a).backlash_steps}
    limits = fl.load()
    fastest = max(limits.steps[k] for k in limits.steps if not k.endswith("long-pulse"))
    for a in machine.axis_names:
        rises, _, _ = fs.step_times(log, machine, a)
        allowed = min(fastest, machine.axis(a).max_velocity_mm_s * machine.axis(a).steps_per_mm)
        assert len(rises) < 2 or np.diff(rises).min() >= fs.F_CPU / allowed - 16, a   # +-1 us


#: the cases of firmware/limits.toml: the step count of each moving axis per 1000 base steps
#: (bench/firmware_limits.py measures them; the long-pulse case needs its own build)
CASES = {"1": (1000,), "2": (1000, 1000), "3": (1000, 1000, 1000), "4": (1000,) * 4,
         "2:bresenham": (1000, 500), "3:bresenham": (1000, 500, 250),
         "3:bresenham-b": (1000, 670, 670), "4:bresenham": (1000, 750, 500, 250)}


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    machine = load_machine(BENCH)
    return machine, fs.build_copy(machine, tmp_path_factory.mktemp("feeds"))


@pytest.mark.slow
@pytest.mark.parametrize("poll_ms", [2, 20])
@pytest.mark.parametrize("case", list(CASES))
def test_no_stall_at_the_planned_limit_of_every_case(bench, case, poll_ms):
    """A quarter-second move at the rate the host plans with for its case (the table's limit),
    RDST every 2 or 20 ms: exact steps, no interval 100 us longer than the period, every cruise
    interval within +-1 us of it (2 us under the blind 2 ms polling, which overfills the link)."""
    from tests.test_firmware_engine import STALL_CYCLES, assert_exact, polled_move
    machine, elf = bench
    rate = fl.load().steps[case]
    steps = {a: round(rate * 0.25 * r / 1000) for a, r in zip("XYZA", CASES[case])}
    log, answers = polled_move(machine, elf, steps, rate, poll_ms, seconds=0.35)
    assert_exact(log, machine, answers, steps)
    rises, _, _ = fs.step_times(log, machine, "X")
    gaps = np.diff(rises)
    n = len(rises)
    assert gaps.max() < fs.F_CPU / rate + STALL_CYCLES
    assert np.abs(gaps[n // 8: -n // 8] - fs.F_CPU / rate).max() <= (16 if poll_ms >= 20 else 32)


@pytest.mark.slow
@pytest.mark.parametrize("share", [0.25, 0.5, 0.75, 1.0, "tolerance"])
def test_thread_pulses_are_never_shorter_than_configured_up_to_the_top_speed(share):
    """mitic-lathe (400 counts a turn, 100 us pulse) threading at a share of its 2 000 rpm, and
    at 2 000 rpm + its speed tolerance (15 %: the fastest the host plans a spindle to turn):
    every Z pulse at least 100 us, and exactly the line's steps."""
    from tests.test_firmware_sim import Script
    machine = load_machine("mitic-lathe")
    elf = fs.build(machine.name)
    spindle = machine.parts["spindle"]
    rpm = spindle.max_rpm * (1 + spindle.speed_tolerance if share == "tolerance" else share)
    script = (Script(machine).at(3_100_000, f"SPIN S{min(rpm, spindle.max_rpm):g} D1")
              .at(3_200_000, "ISTP").at(3_300_000, "PFDR F0.25").at(3_400_000, "PMOV Z-2"))
    log = fs.Harness(elf, machine, script=script.items, cycles=int((0.3 + 12 * 60 / rpm) * fs.F_CPU),
                     spindle_rpm=rpm).run()
    rises, falls, _ = fs.step_times(log, machine, "Z")
    assert len(rises) == round(2 * machine.axis("Z").steps_per_mm)
    width_us = (falls - rises) / 16
    assert width_us.min() >= machine.axis("Z").pulse_high_ticks * machine.tick_us


def test_colinear_short_lines_hold_their_feed_across_the_joints(bench):
    """Twelve colinear PMOVs of 500 X steps at 10 000 steps/s, queued ahead: after the first
    line's start every interval within 10 % of the period, and the chain as long as its steps at
    that rate (+2 %). Before, a line's last sliver of an event was cut as a segment of no time,
    whose rate (0/0) upset the next segment's timing: the first segment of every new line below
    20 000 steps/s ran at a quarter of the feed (539 intervals of 406 us, 0.764 s for 0.600)."""
    from tests.test_firmware_sim import Script
    machine, elf = bench
    script = Script(machine).at(2_000_000, "PFDR F600")
    for k in range(12):
        script.at(2_100_000 + k * 60_000, f"PMOV X{(k + 1) * 0.5:g}")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(1.6 * fs.F_CPU)).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    assert len(rises) == 6000
    gaps = np.diff(rises)[20:] / 16
    slow = int((gaps > 110).sum())
    took = (rises[-1] - rises[0]) / fs.F_CPU
    assert slow == 0 and took <= 0.6 * 1.02, (f"{slow} intervals over 110 us (longest "
                                              f"{gaps.max():.0f} us); the chain took {took:.3f} s for 0.600")
