"""The compiled firmware in simavr (cycle-exact ATmega2560), measured from its pins in cycles.

Every figure here comes from the harness's log of pin changes stamped with the AVR's cycle
counter (16 per microsecond); no test reads the host's clock. The commands go in as a script of
frames at chosen cycles, so each run is the same on a loaded machine.
"""

from __future__ import annotations

import shutil
from fractions import Fraction

import numpy as np
import pytest

from retrofit.commands import parse_command
from retrofit.controller.program import ProgramError, run_commands
from retrofit.link import (
    IMMEDIATE,
    QUEUED,
    Ack,
    Position,
    Session,
    Status,
    StatusFlags,
    encode_command,
    encode_frame,
    seq_byte,
)
from retrofit.link.script import KEEPALIVE_S, SIMAVR_FIRST_SESSION, ScriptedHost
from retrofit.machine.config import load_machine
from retrofit.motion.indexer import IndexerTrack, lead_in_counts
from retrofit.sim import SimMachine

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
CYCLES_PER_US = 16
S = 16_000_000                       # cycles a second


@pytest.fixture(scope="module")
def lathe():
    machine = load_machine("mitic-lathe")
    return machine, fs.build(machine.name)


class Script:
    """Frames at chosen AVR cycles, numbered and bound to the firmware's sessions as a host would
    (retrofit.link.script); unless ``keepalive`` is False, a keep-alive frame every 0.2 s for
    KEEPALIVE_S of simulated time keeps the heartbeat (500 ms) from stopping a long move."""

    def __init__(self, machine, keepalive: bool = True):
        self.machine, self.items = machine, []
        self.host = ScriptedHost(machine)
        self.items += [(1_000_000, self.host.sync(QUEUED)), (1_000_000, self.host.sync(IMMEDIATE))]
        every = int(KEEPALIVE_S * S)
        if keepalive:
            self.items += [(1_100_000 + k * every, self.host.keepalive())
                           for k in range(int(KEEPALIVE_HORIZON_S / KEEPALIVE_S))]

    def at(self, cycle: int, text: str, channel: int | None = None) -> Script:
        self.items.append((cycle, self.host.frame(text, channel=channel)))
        return self

    def payload(self, cycle: int, payload: bytes, channel: int = QUEUED) -> Script:
        """A frame of a raw payload (built byte by byte by the test)."""
        self.items.append((cycle, self.host.frame(payload=payload, channel=channel)))
        return self


#: how long a script keeps the link alive (simulated seconds; the longest run here is shorter)
KEEPALIVE_HORIZON_S = 30.0


def replies(log, machine):
    """The firmware's answers (the keep-alives' ERR 4 left out)."""
    return ScriptedHost(machine).replies(log.answer_bytes())


def test_a_rapid_move_steps_every_pulse_as_wide_as_configured_and_ends_on_target(lathe):
    machine, elf = lathe
    script = Script(machine).at(3_200_000, "FMOV X12").at(14_000_000, "RDPS").at(14_000_000, "RDST")
    log = fs.Harness(elf, machine, script=script.items, cycles=14_500_000).run()
    answers = replies(log, machine)
    assert answers[:3] == [Session(SIMAVR_FIRST_SESSION), Session(SIMAVR_FIRST_SESSION + 1), Ack()]
    assert answers[3] == Position((("X", 1200), ("Z", 0)))
    assert not answers[4].flags & (StatusFlags.MOVING | StatusFlags.ERROR)
    rises, falls, _ = fs.step_times(log, machine, "X")
    assert len(rises) == 1200 + machine.axis("X").backlash_steps      # take-up steps first
    high_us = (falls - rises) / CYCLES_PER_US
    low_us = (rises[1:] - falls[:-1]) / CYCLES_PER_US
    x = machine.axis("X")
    assert high_us.min() >= x.pulse_high_ticks * machine.tick_us          # 100 us, on the wire
    assert low_us.min() >= x.pulse_low_ticks * machine.tick_us
    # the cruise at 1500 mm/min is 2500 steps/s: 400 us a step
    assert np.median(np.diff(rises)) / CYCLES_PER_US == pytest.approx(400, abs=2)
    report = fs.report(log, machine)
    assert report["motor_steps"]["X"] == 1202
    assert not report["violations"]                           # pulse, low time, direction set-up


def test_ffdr_mid_move_slows_the_running_move_measured_in_cycles(lathe):
    machine, elf = lathe
    script = (Script(machine).at(3_200_000, "FMOV X39")
              .at(int(0.5 * S), "FFDR F15"))                  # a hundredth: 25 steps/s
    log = fs.Harness(elf, machine, script=script.items, cycles=int(1.0 * S)).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    gaps = np.diff(rises) / S
    before = gaps[(rises[1:] > 0.3 * S) & (rises[1:] < 0.5 * S)]
    after = gaps[rises[1:] > 0.7 * S]
    assert np.median(before) == pytest.approx(1 / 2500, rel=0.01)
    assert len(after) >= 2 and np.median(after) == pytest.approx(1 / 25, rel=0.02)


def test_a_reversal_keeps_the_direction_set_up_before_the_first_step(lathe):
    machine, elf = lathe
    script = Script(machine).at(3_200_000, "FMOV X0.5").at(3_300_000, "FMOV X0")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.6 * S)).run()
    report = fs.report(log, machine)
    assert report["motor_steps"]["X"] == 0 and not report["violations"]


def test_interrupt_figures_are_measured_and_the_main_loop_never_masks_long(lathe):
    machine, elf = lathe
    script = Script(machine).at(3_200_000, "FMOV X10")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.6 * S), stats=True).run()
    assert log.stats["cycles"] >= int(0.6 * S)
    assert 0 < log.stats["isr_cycles"] < log.stats["cycles"]
    assert log.stats["isr_longest"] > 0


def test_the_mill_with_its_carousel_builds_and_its_e_axis_steps_on_the_e0_socket():
    machine = load_machine("tul-mill")
    elf = fs.build(machine.name)
    script = Script(machine).at(3_200_000, "FMOV E1")          # one pocket pitch: 160 steps
    script.at(int(0.5 * S), "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.55 * S)).run()
    answers = replies(log, machine)
    assert answers[2] == Ack() and isinstance(answers[1], Session)
    assert dict(answers[3].steps)["E"] == 160
    rises, _, _ = fs.step_times(log, machine, "E")
    assert len(rises) >= 160 and fs.MEGA_PINS[26] == ("A", 4)


def thread_pass(machine, elf, rpm: float, move: str = "PMOV Z-1", turns: float = 4, **kw):
    """SPIN at ``rpm`` with the harness's spindle turning at it, then ISTP, 0.5 mm a turn and
    ``move``; the log."""
    script = (Script(machine).at(3_100_000, f"SPIN S{rpm:g} D1").at(3_200_000, "ISTP")
              .at(3_300_000, "PFDR F0.5").at(3_400_000, move))
    return fs.Harness(elf, machine, script=script.items, cycles=int((0.3 + turns * 60 / rpm) * S),
                      spindle_rpm=rpm, **kw).run()


def counts_and_rises(log, machine, axis="Z"):
    """The encoder's counts (ICLK rising) and the axis's step rises, in cycles."""
    rises, falls, dirs = fs.step_times(log, machine, axis)
    iclk = np.array([c for c, port, bit, level in log.inputs if (port, bit, level) == ("D", 0, 1)])
    return iclk, rises, falls, dirs


@pytest.mark.parametrize("rpm", [300, 600, 1200])
def test_a_thread_pass_leads_in_and_cuts_the_pitch_on_the_host_controllers_track(lathe, rpm):
    """PMOV Z-1 at 0.5 mm a turn (80 Z steps over 800 counts). The host controller's rule
    (retrofit/motion/indexer.py, exact fractions): the pass synchronises on the first index
    after it starts; its reference index is the next one (the lead-in needs counts before it);
    the axis starts L counts before that on a parabola that meets the line L counts after it,
    L from the spindle speed plus its tolerance and the synchronised share of the acceleration.
    On the pins: every Z step within one step of that track in the lead-in, exactly on it after
    (40 steps a turn at the same spindle angle at every speed), none before the index."""
    machine, elf = lathe
    spindle, z = machine.parts["spindle"], machine.axis("Z")
    counts = spindle.encoder_counts_per_rev
    log = thread_pass(machine, elf, rpm)
    iclk, rises, _, dirs = counts_and_rises(log, machine)
    assert len(rises) == round(1 * z.steps_per_mm) and not dirs.any()    # towards -Z
    sind = np.array([c for c, port, bit, level in log.inputs if (port, bit, level) == ("D", 1, 1)])
    index = sind[sind > 3_400_000]
    assert rises[0] > index[0]                                # no step before the index pulse
    per_rev = Fraction(round(0.5 * z.steps_per_mm))
    lead = lead_in_counts(per_rev, counts, rpm * (1 + spindle.speed_tolerance),
                          z.max_accel_mm_s2 * spindle.sync_accel_share * z.steps_per_mm)
    assert 0 < lead < counts                                  # 11, 42, 166 counts
    count_of = lambda cycles: np.searchsorted(iclk, cycles, side="right")   # noqa: E731
    reference = int(count_of(index[1]))                       # one turn after the synchronising one
    track = IndexerTrack(per_rev, counts, Fraction(reference), lead, len(rises))
    at = count_of(rises)
    host = np.array([track.target(int(c)) for c in at])
    position = np.arange(1, len(rises) + 1)
    on_line = at >= reference + lead
    assert np.abs(position - host)[~on_line].max(initial=0) <= 1
    assert (position == host)[on_line].all()
    assert (~on_line).sum() >= 1 and on_line.sum() >= 60


# 10 us at 16 MHz: the longest another interrupt (a received byte) may wait for the CPU.
OFF_LIMIT_CYCLES = 160


@pytest.mark.parametrize("rpm", [300, 1200])
def test_in_a_thread_each_step_rises_at_the_same_delay_after_its_count_and_interrupts_stay_on(
        lathe, rpm):
    """The encoder's interrupt raises the pins it prepared at the count before, first thing: each
    Z step within 10 us of its encoder count, all at the same delay to 1 us (the same spindle
    angle), and interrupts never off longer than 10 us (the counting and the next event run
    with them on)."""
    machine, elf = lathe
    log = thread_pass(machine, elf, rpm, stats=True)
    iclk, rises, falls, _ = counts_and_rises(log, machine)
    assert len(rises) == 80
    delay = rises - iclk[np.searchsorted(iclk, rises) - 1]
    assert delay.max() <= 10 * CYCLES_PER_US
    assert delay.max() - delay.min() <= CYCLES_PER_US
    assert ((falls - rises) / CYCLES_PER_US).min() >= 100              # the lathe's 100 us pulse
    assert 0 < log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES
    assert log.stats["off_main_longest"] <= OFF_LIMIT_CYCLES


def test_a_limit_switch_stops_a_thread_pass_within_a_step_of_its_trip_point(lathe):
    """PLSZ trips at Z 20.5 mm (1 640 steps); the carriage starts 10 steps short of it and the
    thread pass runs 80 steps towards it: the steps stop at the switch and the firmware reports
    ERROR, with interrupts never off longer than 10 us on the way."""
    machine, elf = lathe
    rpm, start = 600, 1630
    script = (Script(machine).at(3_100_000, f"SPIN S{rpm} D1").at(3_200_000, "ISTP")
              .at(3_300_000, "PFDR F0.5").at(3_400_000, "PMOV Z1").at(int(0.55 * S), "RDST"))
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.6 * S), spindle_rpm=rpm,
                     start_steps={"Z": start}, stats=True).run()
    status = replies(log, machine)[-1]
    assert status.flags & StatusFlags.ERROR
    assert log.stats["off_main_longest"] <= OFF_LIMIT_CYCLES        # the stop, too
    assert log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES
    iclk, rises, _, dirs = counts_and_rises(log, machine)
    assert dirs.all()                                          # towards +Z
    trip = round(20.5 * machine.axis("Z").steps_per_mm) - start
    # the switch is read once a millisecond and debounced over three readings: at 600 rpm
    # (40 Z steps a turn, 400 steps/s) at most two steps more
    assert trip <= len(rises) <= trip + 2


@pytest.fixture(scope="module")
def mill():
    machine = load_machine("tul-mill")
    return machine, fs.build(machine.name)


def test_homing_z_alone_latches_within_one_step_of_its_switch(mill):
    """Z seeks its switch, backs off and latches within one step of it; stopping on the switch
    (the rest of the seek dropped) keeps interrupts off at most 10 us, like the stepping."""
    machine, elf = mill
    end = int(5.5 * S)                   # seek at 50 mm/s, back off and latch at 0.5 mm/s
    script = Script(machine).at(3_200_000, "ZMOV Z").at(end - 100_000, "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=end, start_steps={"Z": -2000},
                     stats=True).run()
    assert log.stats["off_main_longest"] <= OFF_LIMIT_CYCLES
    assert log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES
    steps = dict(zip([a.name for a in fs.firmware_axes(machine)], log.steps))
    assert steps["Z"] in (0, 1) and steps["X"] == steps["Y"] == 0       # Z homes up, to its top switch
    assert dict(replies(log, machine)[-1].steps)["Z"] == 0
    report = fs.report(log, machine, {"Z": -2000})
    assert report["carriage_mm"]["Z"] == pytest.approx(0.0, abs=0.011)
    assert not report["violations"]


@pytest.mark.slow
@pytest.mark.parametrize("start", [
    {"X": 1500, "Y": 2500, "Z": -800},
    {"X": 4400, "Y": 10, "Z": -3000},
    {"X": 1, "Y": 4000, "Z": -4500},
], ids=["middle", "x-far-y-near", "z-far-x-near"])
def test_homing_z_y_x_stops_each_carriage_within_one_step_of_its_switch(mill, start):
    machine, elf = mill
    end = int(16 * S)
    script = Script(machine).at(3_200_000, "ZMOV Z Y X").at(end - 1_000_000, "RDST")
    script.at(end - 1_000_000, "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=end, start_steps=start).run()
    answers = replies(log, machine)
    status, position = answers[-2], answers[-1]
    assert isinstance(status, Status) and status.flags & StatusFlags.HOMED, status
    assert not status.flags & (StatusFlags.MOVING | StatusFlags.ERROR)
    order = fs.firmware_axes(machine)
    steps = dict(zip([a.name for a in order], log.steps))      # the carriages, counted on the pins
    for axis, beyond in (("X", -1), ("Y", -1), ("Z", 1)):      # the switches trip at 0 steps
        assert steps[axis] in (0, beyond), (axis, steps)       # X, Y below theirs, Z above its top one
        assert dict(position.steps)[axis] == 0
    assert steps["E"] == 0                                     # not homed, not moved
    # Z homed first, then Y, then X: the first step of each axis comes in that order
    first = {a: fs.step_times(log, machine, a)[0][0] for a in "XYZ"}
    assert first["Z"] < first["Y"] < first["X"]


def test_a_second_of_framed_garbage_during_a_move_leaves_its_deceleration_intact(lathe):
    """Damaged frames (a flipped CRC bit) at the line's full rate for 1 s while FMOV X20 runs:
    each answered NAK, the move's steps and their timing the same as without them."""
    machine, elf = lathe
    end = int(1.6 * S)

    def run(garbage: bool):
        script = Script(machine).at(3_200_000, "FMOV X20").at(end - 200_000, "RDPS")
        damaged = 0
        if garbage:
            good = encode_frame(seq_byte(QUEUED, 5), encode_command(parse_command("FMOV X1"), machine))
            bad = bytearray(good)
            bad[6] ^= 0x10                                    # a bit of X: the CRC fails
            # back to back: simavr's USART ignores U2X, so the firmware's 115 200 baud runs at
            # 57 600 there (11 bytes in ~1.9 ms); one frame every 2.2 ms fills the line
            for k in range(int(1.0 * S / 35_200)):
                script.items.append((4_000_000 + k * 35_200, bytes(bad)))
                damaged += 1
        log = fs.Harness(elf, machine, script=script.items, cycles=end).run()
        return log, damaged

    quiet, _ = run(False)
    noisy, damaged = run(True)
    answers = replies(noisy, machine)
    naks = sum(type(a).__name__ == "Nak" for a in answers)
    assert naks == damaged                                    # every damaged frame answered
    assert answers[-1] == Position((("X", 2000), ("Z", 0)))   # executed once, nothing twice
    q, _, _ = fs.step_times(quiet, machine, "X")
    n, _, _ = fs.step_times(noisy, machine, "X")
    assert len(n) == len(q) == 2002
    # the braking at the end as without the garbage: the speed profile changes its rate once a
    # millisecond, so an interval may take the next rate one step earlier or later (< 6 %);
    # the braking takes as long, and the last step comes at the same rate, to 1 us
    dn, dq = np.diff(n)[-200:], np.diff(q)[-200:]
    assert (np.abs(dn - dq) / dq).max() < 0.06
    assert abs(int(dn.sum()) - int(dq.sum())) < S // 1000
    assert abs(int(dn[-1]) - int(dq[-1])) <= CYCLES_PER_US


def test_a_host_that_polls_faster_than_the_answers_drain_cannot_hold_the_motion(lathe):
    """RDST frames back to back at the line's full rate for 0.7 s during FMOV X20: each STAT
    answer is longer than its request, so the transmit side falls behind. The firmware reads
    the next byte only when the answer it may complete fits the transmit buffer (the link
    degrades: late frames are dropped, the host resends), so the main loop never waits for the
    wire: the move's steps come as without the polls, and the board never resets. (Waiting in
    uart_putc, the main loop starved the segment buffer and the stall guard reset the board
    after 295 of the 2 002 steps.)"""
    machine, elf = lathe
    frame_cycles = 10 * 8 * S // 57_600              # 8 bytes at simavr's 57 600 baud

    def run(polls: int):
        script = Script(machine).at(3_200_000, "FMOV X20")
        for k in range(1, polls + 1):
            script.at(4_000_000 + k * frame_cycles, "RDST")
        return fs.Harness(elf, machine, script=script.items, cycles=int(1.6 * S)).run()

    quiet, noisy = run(0), run(500)
    q, _, _ = fs.step_times(quiet, machine, "X")
    n, _, _ = fs.step_times(noisy, machine, "X")
    assert len(n) == len(q) == 2002
    assert np.abs(n - q).max() <= CYCLES_PER_US
    assert noisy.answer_bytes().count(b"retrofit firmware machine=") == 1     # no reset
    # the script cannot resend what the firmware dropped: once a frame is lost the rest of its
    # session is out of step (ERR 5), and a session's numbers do not wrap (protocol.md §4); the
    # firmware answers on (STAT while in step, ERR 5 and NAK after)
    answers = replies(noisy, machine)
    assert sum(isinstance(a, Status) for a in answers) >= 50 and len(answers) >= 400


def test_the_spindle_pwm_runs_while_on_and_its_pin_stays_low_when_off(lathe):
    machine, elf = lathe
    script = (Script(machine).at(3_200_000, "SPIN S1000 D1")
              .at(int(0.3 * S), "SPIN S0 D0"))
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.4 * S)).run()
    cycles, levels = log.pin("W", 4)                          # D10 = PB4 = OC2A, on the wire
    on = (cycles > int(0.25 * S)) & (cycles < int(0.3 * S))
    rises_on = int(((levels == 1) & on).sum())
    assert rises_on >= 40                                     # ~1 kHz PWM for 50 ms
    off = cycles > int(0.31 * S)
    assert not (levels[off] == 1).any()                       # no 4 us spike every period


def test_the_watchdog_does_not_fire_while_the_main_loop_runs(lathe):
    machine, elf = lathe
    script = Script(machine).at(3_200_000, "FMOV X2").at(int(0.5 * S), "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.55 * S)).run()
    assert replies(log, machine)[-1] == Position((("X", 200), ("Z", 0)))   # no reset on the way


@pytest.mark.parametrize("rpm, pitch, move, why", [
    (300, 6.0, "PMOV Z-3", "480 Z steps a turn, 400 encoder counts"),
    (1200, 2.5, "PMOV Z-3", "Z at 4 600 steps/s with the spindle 15 % fast, its limit 3 200"),
    (1200, 1.9, "PMOV Z-3", "Z at 3 040 steps/s at 1 200 rpm, 3 496 at 1 380: over its limit"),
    (1200, 1.5, "PMOV Z-1", "a lead-in of 496 counts (1.86 mm) for a line of 1 mm"),
    (0, 0.5, "PMOV Z-1", "the spindle is stopped"),
], ids=["steps-over-counts", "too-fast", "too-fast-with-tolerance", "lead-in-too-long", "stopped"])
def test_a_thread_the_host_refuses_is_refused_with_error_before_any_step(
        lathe, rpm, pitch, move, why):
    """The firmware refuses what the host controller refuses (its MotionError is the oracle)."""
    machine, elf = lathe
    texts = ([f"SPIN S{rpm} D1"] if rpm else []) + ["ISTP", f"PFDR F{pitch}", move]
    with pytest.raises(ProgramError):
        run_commands([parse_command(t) for t in texts], machine, sim=SimMachine(machine))
    script = Script(machine)
    for k, text in enumerate(texts):
        script.at(3_200_000 + 100_000 * k, text)
    script.at(int(0.45 * S), "RDST")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.5 * S),
                     spindle_rpm=rpm or 600).run()
    status = replies(log, machine)[-1]
    assert status.flags & StatusFlags.ERROR, why
    rises, _, _ = fs.step_times(log, machine, "Z")
    assert len(rises) == 0, why


def test_a_thread_within_every_rule_runs_on_both(lathe):
    """The control case of the refusals: 1.7 mm a turn at 1 200 rpm (Z at 3 128 steps/s at
    1 380 rpm; a lead-in of 562 counts, 2.39 mm) over 3 mm runs on the host controller and
    the firmware alike."""
    machine, elf = lathe
    texts = ["SPIN S1200 D1", "ISTP", "PFDR F1.7", "PMOV Z-3"]
    ctl = run_commands([parse_command(t) for t in texts], machine, sim=SimMachine(machine))
    assert ctl.processor.position_steps()[[a.name for a in machine.axes].index("Z")] == -240
    script = Script(machine)
    for k, text in enumerate(texts):
        script.at(3_200_000 + 100_000 * k, text)
    script.at(int(0.5 * S), "RDST").at(int(0.5 * S), "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.55 * S), spindle_rpm=1200).run()
    status, position = replies(log, machine)[-2:]
    assert not status.flags & (StatusFlags.ERROR | StatusFlags.MOVING)
    assert dict(position.steps)["Z"] == -240
    assert len(fs.step_times(log, machine, "Z")[0]) == 240
