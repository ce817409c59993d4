"""One conformance suite, two devices: ``retrofit mcu`` and the firmware running in simavr.

Every test talks raw frames (tests/conformance/rawlink.py) to a device started as its own
process, and checks what docs/protocol.md promises: the answers' bytes and sequence bytes,
SYNC, the queue of three and BUSY, the immediate commands, STOP, NAK and resend, duplicates,
and the positions RDPS reports after moves. The machine is mitic-lathe (X 100, Z 80 steps/mm).
"""

import time

import pytest

from retrofit.commands import Cool, Dely, parse_command
from retrofit.link import (
    IMMEDIATE,
    QUEUED,
    Ack,
    BadFrame,
    Busy,
    Err,
    Nak,
    Position,
    Session,
    StatusFlags,
    decode_reply,
    encode_command,
    encode_frame,
)

from tests.conformance.rawlink import RawLink
from tests.conformance.targets import TARGETS

F = StatusFlags
LONG_DWELL = Dely(4_000_000.0)     # 46 days: keeps the processor busy until a STOP ends it


def hexs(data: bytes) -> str:
    return data.hex(" ").upper()


def dwell_forever(link):
    """Start a long dwell and wait until the device reports it."""
    assert link.send(LONG_DWELL) == Ack()
    end = time.monotonic() + 60
    while not link.status().flags & F.DWELLING:
        assert time.monotonic() < end, "the dwell never started"
        time.sleep(0.01)


def fill_until_waiting(link, waiting: int) -> int:
    """Behind a long dwell, send short moves until ``waiting`` commands wait in the queue.

    What the processor takes ahead of the queue differs by design (the firmware prepares one
    pending move, as 002 does; retrofit mcu's planner looks 16 moves ahead), so the moves
    are sent until RDST counts them waiting. Returns how many were sent.
    """
    dwell_forever(link)
    for sent in range(1, 40):
        assert link.send(f"FMOV X{1 + sent % 2}") == Ack()
        if link.status().queued >= waiting:
            return sent
    raise AssertionError("the queue never filled")


# -- the handshake ------------------------------------------------------------------------------

@pytest.mark.parametrize("fresh", TARGETS, indirect=True)
def test_after_power_up_only_sync_is_answered_then_the_worked_example_bytes(fresh, machine):
    link = RawLink(fresh.url, machine)
    try:
        link.write(encode_frame(0x80, b"\x0e"))                         # RDST, N = 0
        assert hexs(link.answer_bytes()) == hexs(encode_frame(0x80, bytes((0x83, 4, 0))))
        link.write(bytes.fromhex("7E 05 00 7F 00 00 00 01 C3 D1 B7 51"))  # SYNC, queued, N = 0
        sess_q = link.answer()
        link.write(bytes.fromhex("7E 05 80 7F 00 00 00 02 44 68 F2 33"))  # SYNC, immediate
        sess_i = link.answer()
        q, i = (decode_reply(a.payload) for a in (sess_q, sess_i))
        assert (sess_q.seq, sess_i.seq) == (0x00, 0x80) and not sess_q.bound
        assert isinstance(q, Session) and isinstance(i, Session) and q.number != i.number
        if fresh.name == "firmware":             # simavr's zeroed EEPROM: boot 1, the docs' sessions
            assert (q.number, i.number) == (0x00010000, 0x00010001)
        link.write(bytes.fromhex("7E 05 80 7F 00 00 00 02 44 68 F2 33"))  # again: the same SESS
        assert link.answer() == sess_i
        link.sessions = {QUEUED: q.number, IMMEDIATE: i.number}
        link.write(encode_frame(0x81, b"\x0d"))                         # RDPS bound to nothing
        assert decode_reply(link.answer().payload) == Err(4, 0)
        seq, reply = link.exchange(IMMEDIATE, 1, b"\x0d")              # RDPS, N = 1, bound
        assert (seq, reply) == (0x81, Position((("X", 0), ("Z", 0))))
        seq, reply = link.exchange(IMMEDIATE, 5, b"\x0d")              # N = 5: out of step
        assert (seq, reply) == (0x85, Err(5, 1))
        seq, reply = link.exchange(IMMEDIATE, 2, b"\x0e")              # N = 2 is still next
        assert seq == 0x82 and not reply.flags & F.MOVING
    finally:
        link.close()


# -- set-up and motion ----------------------------------------------------------------------------

def test_pstn_sets_the_actual_position_and_init_clears_it(link):
    assert link.send("PSTN X12.5 Z-3") == Ack()
    link.wait_idle()
    assert link.position() == {"X": 1250, "Z": -240}
    assert link.send("INIT") == Ack()
    st = link.wait_idle()
    assert link.position() == {"X": 0, "Z": 0}
    assert not st.flags & (F.ERROR | F.STOPPED | F.HOMED | F.INDEXER | F.SPINDLE_ON)


def test_fmov_and_pmov_end_exactly_where_commanded(link):
    for text in ("FMOV X2 Z-1", "PFDR F600", "PMOV X1 Z-2", "PMOV X1.5 Z-1.25", "FMOV Z-0.5"):
        assert link.send_until_accepted(text) == Ack()
    link.wait_idle()
    assert link.position() == {"X": 150, "Z": -40}


def test_rdps_is_answered_while_a_move_runs_and_stays_on_the_line(link):
    assert link.send("FMOV X30 Z-24") == Ack()
    seen, moving = [], False
    for _ in range(2000):
        moving |= bool(link.status().flags & F.MOVING)
        seen.append(link.position())
        if seen[-1] == {"X": 3000, "Z": -1920} and not link.status().flags & F.MOVING:
            break
    assert moving, "RDST never reported MOVING during a 38 mm move"
    assert seen[-1] == {"X": 3000, "Z": -1920}
    xs = [p["X"] for p in seen]
    assert xs == sorted(xs), "X went backwards during a move in +X"
    for p in seen:             # on the line, within a step and the backlash take-up (2 steps)
        assert abs(p["Z"] + p["X"] * 1920 / 3000) <= 3.0, p


def test_rdst_reports_spindle_coolant_step_source_and_dwell(link):
    def flags_after(text):
        assert link.send_until_accepted(text) == Ack()
        return link.wait_idle().flags

    assert flags_after("SPIN S500 D1") & F.SPINDLE_ON
    assert flags_after("COOL M8") & F.COOLANT_ON
    assert flags_after("ISTP") & F.INDEXER
    assert not flags_after("CSTP") & F.INDEXER
    assert not flags_after("SPIN S0 D0") & F.SPINDLE_ON
    assert not flags_after("COOL M0") & F.COOLANT_ON
    dwell_forever(link)
    assert link.status().flags & F.MOVING
    assert link.send("STOP") == Ack()
    st = link.status()
    assert st.flags & F.STOPPED and not st.flags & (F.DWELLING | F.MOVING) and st.queued == 0


def test_a_move_outside_the_soft_limits_is_refused_until_init(link):
    assert link.send("FMOV X45") == Err(6, 0x02)           # X travels -40..40 mm
    st = link.wait_idle()
    assert st.flags & F.ERROR and link.position() == {"X": 0, "Z": 0}
    assert link.send("FMOV X1") == Err(6, 0x02)            # in ERROR: refused until INIT
    assert link.send("INIT") == Ack()
    assert link.send("FMOV X1") == Ack()


def test_feeds_of_zero_are_refused(link):
    assert link.send("FFDR F0") == Err(3, 0x06)            # an override out of range
    assert link.send("MFDR F0") == Err(3, 0x07)
    assert not link.status().flags & F.ERROR
    assert link.send("PFDR F0") == Err(6, 0x08)            # a program that cannot run
    assert link.status().flags & F.ERROR


def test_homing_ends_in_error_without_switches_and_at_home_with_them(link, device):
    assert link.send("ZMOV") == Ack()
    st = link.wait_idle(timeout_s=60)
    if device.name == "mcu":                               # no switch is wired to retrofit mcu
        assert st.flags & F.ERROR and not st.flags & F.HOMED
        assert link.position()["X"] > 4000                 # it sought past the switch's place
        return
    # the firmware in simavr: the switches of the machine file are wired to its pins
    assert st.flags & F.HOMED and not st.flags & F.ERROR
    assert link.position() == {"X": 4000, "Z": 1600}       # home_mm at the precise switches
    assert link.send("FMOV X0 Z0") == Ack()                # back where the other tests start
    link.wait_idle(timeout_s=60)


# -- the queue, BUSY and the immediate commands ----------------------------------------------------

def test_with_three_waiting_the_next_gets_busy_and_immediates_still_answer(link):
    fill_until_waiting(link, 3)
    st = link.status()                                     # immediate channel: not held up
    assert st.flags & F.QUEUE_FULL and st.queued == 3
    assert link.send(Cool(8)) == Busy()                    # the fourth waiting command
    assert link.position() == {"X": 0, "Z": 0}
    assert link.send(Cool(8)) == Busy()                    # BUSY is not recorded: same number
    assert link.status().queued == 3
    assert link.send("STOP") == Ack()
    assert link.status().queued == 0
    assert link.send("INIT") == Ack()
    assert link.send_until_accepted(Cool(8)) == Ack()      # the resent frame is taken now
    assert link.wait_idle().flags & F.COOLANT_ON


def test_commands_take_effect_in_program_order(link):
    for text in ("FMOV X1", "FMOV X2 Z-1", "DELY P0.05", "PSTN X-1", "FMOV X0"):
        assert link.send_until_accepted(text) == Ack()
    link.wait_idle()
    assert link.position() == {"X": 0, "Z": -80}           # PSTN came after the moves before it


def test_stop_halts_a_move_at_once_and_clears_the_queue(link):
    assert link.send("FMOV X39 Z-190") == Ack()
    assert link.send("FMOV X0 Z0") == Ack()
    while not link.status().flags & F.MOVING:
        pass
    assert link.send("STOP") == Ack()
    st = link.status()
    assert st.flags & F.STOPPED and not st.flags & F.MOVING and st.queued == 0
    stopped_at = link.position()
    assert stopped_at != {"X": 3900, "Z": -15200}, "STOP came too late to test"
    time.sleep(0.3)
    assert link.position() == stopped_at                   # nothing moves after STOP
    assert link.send("INIT") == Ack()
    assert not link.wait_idle().flags & F.STOPPED
    assert link.send("FMOV X0.5") == Ack()
    link.wait_idle()
    assert link.position() == {"X": 50, "Z": 0}


# -- damaged and repeated frames -------------------------------------------------------------------

def test_a_corrupted_frame_gets_nak_and_its_resend_is_executed_once(link, machine):
    number = link.next[QUEUED]
    frame = link.frame(QUEUED, number, encode_command(parse_command("FMOV X1.25 Z-0.5"), machine))
    damaged = bytearray(frame)
    damaged[5] ^= 0x10                                     # a bit of the X position
    link.write(bytes(damaged))
    assert hexs(link.answer_bytes()) == "7E 01 00 81 64 3C 00 93"   # NAK, sequence byte 0x00
    link.write(frame)
    got = link.answer()
    assert (got.seq, decode_reply(got.payload, machine)) == (number, Ack())
    link.next[QUEUED] = number + 1
    link.wait_idle()
    assert link.position() == {"X": 125, "Z": -40}


@pytest.mark.parametrize("bad, why", [
    (bytes.fromhex("7E 00 01 0D 00 00"), "length 0"),
    (bytes.fromhex("7E 21 01"), "length 33"),
    (bytes.fromhex("7E 01 01 7D 00 00 00"), "an escape of a byte that needs none"),
], ids=["len-0", "len-33", "bad-escape"])
def test_bad_length_and_bad_escape_get_nak(link, bad, why):
    link.write(bad)
    got = link.answer()
    assert (got.seq, decode_reply(got.payload)) == (0x00, Nak()), why


def test_noise_and_a_truncated_frame_are_not_answered_and_the_next_frame_is(link, machine):
    number = link.next[IMMEDIATE]
    rdst = link.frame(IMMEDIATE, number, b"\x0e")
    link.write(b"\x00\x11garbage" + rdst[:4])              # noise, then a frame cut short ...
    assert link.silence() == []
    link.write(rdst)                                       # ... by the next SOF
    got = link.answer()
    assert got.seq == 0x80 | number and decode_reply(got.payload, machine).queued == 0


def test_a_duplicated_frame_is_answered_again_but_not_executed_twice(link, machine):
    fill_until_waiting(link, 1)
    waiting = link.status().queued
    number = link.next[QUEUED]
    frame = link.frame(QUEUED, number, encode_command(Cool(8), machine))
    link.write(frame)
    first = link.answer_bytes()
    link.write(frame)                                      # the host missed the ACK: resend
    assert link.answer_bytes() == first == encode_frame(number, b"\x80", link.sessions[QUEUED])
    link.next[QUEUED] = number + 1
    assert link.status().queued == waiting + 1             # queued once, not twice
    rdps = link.frame(IMMEDIATE, link.next[IMMEDIATE], b"\x0d")
    link.write(rdps)
    answer = link.answer_bytes()
    link.write(rdps)
    assert link.answer_bytes() == answer                   # the recorded POS, unchanged
    link.next[IMMEDIATE] += 1
    link.send("STOP")


@pytest.mark.parametrize("payload, err", [
    (bytes((0x20,)), Err(1, 0x20)),                        # no such opcode
    (bytes((0x06, 0x00, 0x01)), Err(2, 0x06)),             # FFDR with 2 argument bytes
    (bytes((0x02, 0x02, 0x00, 0x00, 0x01)), Err(3, 0x02)),  # FMOV Y on a lathe
    (bytes((0x04, 0x01, 0x80, 0x00, 0x00)), Err(3, 0x04)),  # the reserved position 0x800000
    (bytes((0x0F, 0x01, 0xF4, 0x05)), Err(3, 0x0F)),       # SPIN direction 5
    (bytes((0x10, 0x09)), Err(3, 0x10)),                   # COOL mode 9
    (bytes((0x11,)), Err(2, 0x11)),                        # PROB without its flags byte
    (bytes((0x11, 0x02, 0x04, 0xFF, 0xFE, 0xC0)), Err(3, 0x11)),   # PROB flag bit 1
], ids=["opcode", "length", "axis", "reserved-position", "spin-direction", "coolant-mode",
        "prob-length", "prob-flags"])
def test_layout_errors_are_answered_err_and_recorded(link, machine, payload, err):
    number = link.next[QUEUED]
    assert link.exchange(QUEUED, number, payload) == (number, err)
    assert link.exchange(QUEUED, number, payload) == (number, err)      # a duplicate: the same
    link.next[QUEUED] = number + 1
    assert link.send("CSTP") == Ack()                                   # the number moved on
    assert link.position() == {"X": 0, "Z": 0}


def test_prob_without_a_probe_input_is_refused_err_6_and_error_until_init(link):
    """The lathe has no tool setter: PROB is refused where it is decided, the controller reports
    ERROR and makes no step, and INIT clears it."""
    assert link.send("PROB Z-1") == Err(6, 0x11)
    assert link.status().flags & StatusFlags.ERROR
    assert link.position() == {"X": 0, "Z": 0}
    assert link.send("INIT") == Ack()
    assert not link.status().flags & StatusFlags.ERROR


def test_a_burst_of_frames_is_answered_in_order(link):
    # The protocol keeps one frame in flight per channel; a burst beyond that must still not be
    # mangled as long as it fits the device's 128-byte receive buffer (12 frames of 5-6 bytes).
    numbers = [(link.next[IMMEDIATE] + i) % 128 for i in range(12)]
    link.write(b"".join(link.frame(IMMEDIATE, n, b"\x0e") for n in numbers))
    got = link.answers(12, timeout_s=10)
    assert not any(isinstance(g, BadFrame) for g in got)
    assert [g.seq for g in got] == [0x80 | n for n in numbers]
    link.next[IMMEDIATE] = (numbers[-1] + 1) % 128
