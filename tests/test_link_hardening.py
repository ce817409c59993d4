"""The link under hostile timing and values: stale SYNCs, replayed and foreign frames, answers
that cannot be encoded, give-ups."""

import pytest

from retrofit.commands import Init, PMov, Rdps, Rdst
from retrofit.errors import LinkError, MotionError
from retrofit.link import (
    IMMEDIATE,
    QUEUED,
    Ack,
    DeviceEndpoint,
    Err,
    FrameDecoder,
    HostEndpoint,
    HostLink,
    Nak,
    Position,
    Session,
    SessionNumbers,
    Status,
    StatusFlags,
    decode_reply,
    encode_command,
    encode_frame,
    seq_byte,
)
from retrofit.link.faultbench import run_faults
from retrofit.link.simwire import FaultyWire
from retrofit.machine.config import load_machine

LATHE = load_machine("chivu-lathe")


class Recorder:
    def __init__(self, answer=None):
        self.delivered, self.answer = [], answer

    def __call__(self, cmd):
        self.delivered.append(cmd)
        return self.answer(cmd) if self.answer else None


def answers(device):
    """The (sequence byte, reply) of every frame the device sent since the last call (frames
    bound to a session the device runs, or to none)."""
    decoder = FrameDecoder(lambda seq: device.session(seq >> 7))
    return [(f.seq, decode_reply(f.payload, LATHE)) for f in decoder.feed(device.take_output())]


def sync_frame(channel, number, nonce):
    return encode_frame(seq_byte(channel, number), bytes((0x7F,)) + nonce.to_bytes(4, "big"))


def bound(device, channel, number, payload):
    """A frame bound to the session the device runs on ``channel``."""
    return encode_frame(seq_byte(channel, number), payload, device.session(channel))


def test_a_late_copy_of_the_sync_changes_nothing_so_the_resend_runs_once():
    """SYNC N=0 answered SESS, PMOV N=1 delivered but its ACK lost, a late copy of the SYNC
    arrives, then the host's resend of the PMOV: the copy neither ends the session under the
    host nor rewinds it, and the resend is answered from the record, not run a second time."""
    app = Recorder()
    device = DeviceEndpoint(LATHE, app, sessions=SessionNumbers(0x1000))
    sync = sync_frame(QUEUED, 0, 0xC0FFEE)
    device.receive(sync)
    assert answers(device) == [(0x00, Session(0x1000))]
    move = bound(device, QUEUED, 1, encode_command(PMov((("X", -9.925), ("Z", -184.08))), LATHE))
    device.receive(sync)                                      # the host's resend of the SYNC
    assert answers(device) == [(0x00, Session(0x1000))]       # the same session, nothing rewound
    device.receive(move)
    device.take_output()                                      # ... the ACK of the move is lost
    device.receive(sync)                                      # a late copy of the SYNC
    assert answers(device) == [(0x00, Session(0x1000))]       # the running session, unchanged
    assert device.session(QUEUED) == 0x1000
    device.receive(move)                                      # the host's resend
    assert answers(device) == [(0x01, Ack())]                 # answered from the record
    assert app.delivered == [PMov((("X", -9.925), ("Z", -184.08)))]
    assert device.stats.stale_syncs == 2 and device.stats.duplicates == 1   # the resent SYNC, its late copy


def test_a_sync_of_a_new_session_restarts_the_channel():
    app = Recorder()
    device = DeviceEndpoint(LATHE, app, sessions=SessionNumbers(7))
    device.receive(sync_frame(QUEUED, 0, 1))
    device.receive(bound(device, QUEUED, 1, b"\x01"))
    first = answers(device)
    device.receive(sync_frame(QUEUED, 40, 2))                 # a new host: nonce 2 at N = 40
    device.receive(bound(device, QUEUED, 41, b"\x01"))
    assert [r for _, r in first + answers(device)] == [Session(7), Ack(), Session(8), Ack()]
    assert app.delivered == [Init(), Init()]


def test_frames_of_another_session_or_of_none_are_not_delivered():
    """Replayed frames of an earlier session fail the CRC (NAK); frames bound to no session
    (version 2's) are ERR 4; a session's numbers do not wrap (N = 0 after 127 is ERR 4)."""
    app = Recorder()
    device = DeviceEndpoint(LATHE, app, sessions=SessionNumbers(0xA0))
    device.receive(sync_frame(QUEUED, 0, 1))
    old = bound(device, QUEUED, 1, b"\x01")
    device.receive(sync_frame(QUEUED, 0, 2))                  # another session starts
    answers(device)
    device.receive(old)                                       # the earlier session's INIT
    device.receive(encode_frame(seq_byte(QUEUED, 1), b"\x01"))   # an INIT bound to nothing
    assert answers(device) == [(0x00, Nak()), (0x01, Err(4, 0))]
    assert app.delivered == [] and device.stats.unbound == 1
    for n in range(1, 128):
        device.receive(bound(device, QUEUED, n, encode_command(Rdst(), LATHE)))
    device.receive(bound(device, QUEUED, 0, encode_command(Rdst(), LATHE)))
    assert answers(device)[-1] == (0x00, Err(4, 0)) and len(app.delivered) == 127


def test_a_sync_of_the_wrong_length_is_err_2():
    device = DeviceEndpoint(LATHE, Recorder())
    device.receive(encode_frame(0x00, b"\x7f"))               # version 1's bare SYNC
    assert answers(device) == [(0x00, Err(2, 0x7F))]


def test_the_host_takes_a_new_session_for_every_sync():
    host = HostEndpoint(LATHE, nonce=0xFFFFFFFE, timeout_s=0.01, max_tries=1)
    host.send(Init(), 0.0)
    first = FrameDecoder().feed(host.take_output())[0]
    with pytest.raises(LinkError):
        host.poll(0.02)                                       # given up: the channel re-syncs
    host.send(Init(), 0.03)
    second = FrameDecoder().feed(host.take_output())[0]
    assert first.payload == bytes.fromhex("7F FFFFFFFF")
    assert second.payload == bytes.fromhex("7F 00000000")     # wraps modulo 2**32


def test_an_answer_the_payload_cannot_carry_is_err_3_and_the_device_keeps_serving():
    big = Recorder(lambda cmd: Position((("X", 1 << 23), ("Z", 0))) if isinstance(cmd, Rdps)
                   else None)
    device = DeviceEndpoint(LATHE, big, sessions=SessionNumbers(5))
    device.receive(sync_frame(IMMEDIATE, 0, 7))
    device.receive(bound(device, IMMEDIATE, 1, b"\x0d"))      # RDPS
    device.receive(bound(device, IMMEDIATE, 1, b"\x0d"))      # its resend: same answer
    device.receive(bound(device, IMMEDIATE, 2, b"\x0e"))      # RDST still answered
    assert answers(device) == [(0x80, Session(5)), (0x81, Err(3, 0x0D)), (0x81, Err(3, 0x0D)),
                               (0x82, Ack())]


def test_a_controller_that_raises_is_answered_err_6():
    def refuse(cmd):
        raise MotionError("PMOV X99: outside the soft limits")
    device = DeviceEndpoint(LATHE, refuse, sessions=SessionNumbers(5))
    device.receive(sync_frame(QUEUED, 0, 7))
    device.receive(bound(device, QUEUED, 1, encode_command(PMov((("X", 1.0),)), LATHE)))
    assert answers(device) == [(0x00, Session(5)), (0x01, Err(6, 0x04))]


class DeafQueue:
    """A port whose device runs every command but whose queued-channel answers are all lost."""

    def __init__(self):
        self.timeout, self.pending = 0.0, b""
        self.device = DeviceEndpoint(LATHE, self.handle)
        self.position = (("X", 0), ("Z", 0))

    def handle(self, cmd):
        if isinstance(cmd, PMov):
            self.position = tuple((n, LATHE.axis(n).to_steps(mm)) for n, mm in cmd.axes)
        if isinstance(cmd, Rdst):
            return Status(StatusFlags(0), 0)
        return Position(self.position) if isinstance(cmd, Rdps) else None

    def write(self, data):
        self.device.receive(data)
        out = self.device.take_output()
        frames = FrameDecoder(lambda seq: self.device.session(seq >> 7)).feed(out)
        self.pending += b"".join(
            encode_frame(f.seq, f.payload, self.device.session(f.seq >> 7) if f.bound else None)
            for f in frames if f.seq >> 7 or f.seq == 0)   # immediate, or the SYNC's SESS

    @property
    def in_waiting(self):
        return len(self.pending)

    def read(self, size=1):
        out, self.pending = self.pending[:size], self.pending[size:]
        return out


def test_a_command_given_up_on_says_it_may_have_run_and_where_rdps_finds_the_machine():
    clock = iter(i * 0.01 for i in range(10**6))
    link = HostLink(DeafQueue(), LATHE, clock=lambda: next(clock), timeout_s=0.05, max_tries=3)
    link.request(Rdst())
    with pytest.raises(LinkError) as err:
        link.request(PMov((("X", 12.5), ("Z", -3.0))))
    text = str(err.value)
    assert "PMOV X12.5 Z-3 (sequence 1, sent 3 times): not acknowledged — may have run; RDPS says " \
           "X12.5 Z-3 mm (3 tries, 0.05 s timeout each;" in text   # it ran: the operator can tell


@pytest.mark.parametrize("seed", [1, 2])
def test_thousands_of_commands_with_late_duplicates_arrive_once_in_order(seed):
    tally = run_faults(1500, seed=seed, flip=0.02, drop=0.01, duplicate=0.05, insert=0.005)
    assert (tally.lost, tally.duplicated, tally.corrupted, tally.wrong_answers) == (0, 0, 0, 0)
    assert tally.in_order and tally.given_up == 0
    assert tally.wire["duplicated"] > 50 and tally.wire["flipped"] > 500


def test_late_copies_arrive_after_later_writes():
    import random
    wire = FaultyWire(random.Random(3), duplicate=1.0, late=2)
    out = [wire.carry(bytes([i])) for i in range(6)]
    assert sorted(b"".join(out)) == sorted(bytes(range(6)) * 2)[:len(b"".join(out))]
    assert any(len(chunk) > 1 and chunk[0] != chunk[-1] for chunk in out)   # an older copy came late


@pytest.mark.slow
def test_a_hundred_thousand_commands_at_the_bench_rates_arrive_once_in_order_uncorrupted():
    """bench/link_faults.py's shard at its rates (2 % flips, 1 % drops, 1 % duplicates, most of
    them late, 0.5 % inserted bytes): nothing lost, repeated, corrupted or reordered."""
    tally = run_faults(100_000, seed=1000, flip=0.02, drop=0.01, duplicate=0.01, insert=0.005)
    assert (tally.lost, tally.duplicated, tally.corrupted, tally.wrong_answers) == (0, 0, 0, 0)
    assert tally.in_order and tally.given_up == 0 and tally.commands == 100_000
    assert tally.bad_frames_seen > 50_000                  # the line really was that noisy


def test_a_device_that_restarts_mid_run_fails_the_command_at_once_not_after_its_tries():
    """The device restarts (its watchdog) while a move is outstanding: its start line comes, and
    the host's resends, bound to a session the device no longer runs, would only be NAKed (seed
    10023 of the firmware's stress bench: 50 NAKs, then "not acknowledged"). The move fails at
    the start line, saying the device restarted and why; the next command opens a new session."""
    app = Recorder(lambda cmd: Status(StatusFlags(0), 0) if isinstance(cmd, Rdst) else None)
    device = DeviceEndpoint(LATHE, app, sessions=SessionNumbers(5))
    host = HostEndpoint(LATHE, timeout_s=0.05, max_tries=50, nonce=1)
    t = host.send(Init(), 0.0)
    while not t.done:
        device.receive(host.take_output())
        host.receive(device.take_output(), 0.0)
    move = host.send(PMov((("X", 1.0),)), 0.1)
    device.reset()                                        # the frame's way: the board restarts
    device.receive(host.take_output())
    assert answers(device) == [(0x00, Nak())]
    with pytest.raises(LinkError) as err:
        host.receive(b"\r\nretrofit firmware machine=chivu-lathe link=3 reset=watch", 0.11)
        host.receive(b"dog\r\n" + encode_frame(0x00, bytes((Nak.opcode,))), 0.11)
    assert "PMOV X1 (sequence 2, sent 1 times): the device restarted (reset=watchdog)" in str(err.value)
    assert move.unacknowledged and host.stats.restarts == 1 and host.stats.frames_sent == 3
    again = host.send(Rdst(), 0.2)
    while not again.done:
        device.receive(host.take_output())
        host.receive(device.take_output(), 0.2)
    assert isinstance(again.reply, Status) and host.stats.sessions == 2
