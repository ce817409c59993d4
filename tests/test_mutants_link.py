"""The link's pieces checked where a mutation run found them unchecked (bench/mutation.py): the
bytes stuffing writes, a scripted host's frames and sessions, how often a simulated noisy wire inserts
bytes, a host link over a port that dies, a host's answer to an answer it cannot read, a ZMOV
with a stray byte, the bytes a decoder counts as noise, and the status bit of a dwell."""

from __future__ import annotations

import random

import pytest

from retrofit.commands import PMov
from retrofit.link.codec import OPCODES, SYNC, decode_command
from retrofit.link.framing import FrameDecoder, encode_frame, stuff
from retrofit.link.script import SIMAVR_FIRST_SESSION, SYNC_COPIES, ScriptedHost
from retrofit.link.simwire import FaultyWire
from retrofit.machine.config import load_machine


def test_stuffing_escapes_the_frame_start_and_the_escape_byte():
    # 0x7E -> 0x7D 0x5E and 0x7D -> 0x7D 0x5D (the byte XOR 0x20); other bytes pass
    assert stuff(bytes([0x7E, 0x7D, 0x41])) == bytes([0x7D, 0x5E, 0x7D, 0x5D, 0x41])


def test_a_wire_that_only_inserts_inserts_at_its_rate():
    wire = FaultyWire(random.Random(7), insert=0.25)
    out = wire.carry(bytes(4000))
    assert 850 < wire.stats.inserted < 1150               # 1000 expected; 5 standard deviations
    assert len(out) == 4000 + wire.stats.inserted
    assert wire.stats.dropped == wire.stats.flipped == 0


def test_a_wire_that_drops_and_inserts_does_both_at_their_rates():
    wire = FaultyWire(random.Random(7), drop=0.1, insert=0.1)
    out = wire.carry(bytes(4000))
    assert 300 < wire.stats.dropped < 500 and 300 < wire.stats.inserted < 500     # 400 each expected
    assert len(out) == 4000 - wire.stats.dropped + wire.stats.inserted


def test_a_scripted_hosts_first_command_opens_its_session_then_follows_bound():
    machine = load_machine("chivu-lathe")
    data = ScriptedHost(machine).frame("PMOV X12.5 Z-3")
    frames = list(FrameDecoder(lambda seq: SIMAVR_FIRST_SESSION if seq == 1 else None).events(data))
    assert [(f.seq, f.payload[0], f.bound) for f in frames] == [(0, SYNC, False)] * SYNC_COPIES + [(1, OPCODES[PMov], True)]
    assert decode_command(frames[-1].payload, machine) == PMov((("X", 12.5), ("Z", -3.0)))


def test_a_scripted_host_renews_its_session_before_the_numbers_wrap_and_reads_the_answers_back():
    # 200 moves on the queued channel: numbers 1..127 of the first session, then a new SYNC
    # (three copies, all answered with the second session) and 1..73 of the second
    from retrofit.link.device import DeviceEndpoint, SessionNumbers
    from retrofit.link.framing import IMMEDIATE, QUEUED
    from retrofit.link.replies import Ack, Err, Session
    machine = load_machine("chivu-lathe")
    host = ScriptedHost(machine)
    delivered = []
    device = DeviceEndpoint(machine, delivered.append, sessions=SessionNumbers(SIMAVR_FIRST_SESSION))
    moves = [PMov((("Z", -float(k)),)) for k in range(200)]
    script = b"".join(host.frame(m) for m in moves) + host.keepalive()
    device.receive(script)
    assert delivered == moves                                    # each once, in order
    assert host.sessions[QUEUED] == SIMAVR_FIRST_SESSION + 1 and host.sessions[IMMEDIATE] is None
    assert host.next[QUEUED] == 74
    out = device.take_output()
    answers = host.replies(out)
    sess = [Session(SIMAVR_FIRST_SESSION)] * SYNC_COPIES
    renewed = [Session(SIMAVR_FIRST_SESSION + 1)] * SYNC_COPIES
    assert answers == sess + [Ack()] * 127 + renewed + [Ack()] * 73
    assert host.replies(out, keepalives=True) == answers + [Err(4, 0)]    # the keep-alive: no session
    with pytest.raises(ValueError, match="a raw payload needs its channel"):
        host.frame(payload=b"\x01")
    raw = host.frame(payload=bytes((OPCODES[PMov],)) + bytes(1), channel=QUEUED)
    assert [f.seq for f in FrameDecoder(lambda seq: host.sessions[QUEUED]).events(raw)] == [74]



class DevicePort:
    """pyserial's interface over a device endpoint in the same process; ``dead`` stops it answering."""

    def __init__(self, machine):
        from retrofit.link.device import DeviceEndpoint
        self.delivered, self.dead, self.timeout, self.out = [], False, None, b""
        self.device = DeviceEndpoint(machine, self.delivered.append)

    @property
    def in_waiting(self):
        return len(self.out)

    def write(self, data):
        if not self.dead:
            self.device.receive(data)
            self.out += self.device.take_output()
        return len(data)

    def read(self, size=1):
        data, self.out = self.out[:size], self.out[size:]
        return data


def test_a_host_link_over_a_port_delivers_and_names_a_dead_device_and_the_unknown_position():
    from retrofit.errors import LinkError
    from retrofit.link.replies import Ack
    from retrofit.link.transport import HostLink
    machine = load_machine("chivu-lathe")
    port, now = DevicePort(machine), [0.0]

    def clock():
        now[0] += 0.01
        return now[0]
    link = HostLink(port, machine, clock=clock, poll_s=0.5, name="bench", timeout_s=0.05, max_tries=2)
    assert port.timeout == 0.5
    assert link.request(PMov((("X", 1.0),))) == Ack() and port.delivered == [PMov((("X", 1.0),))]
    port.dead = True
    with pytest.raises(LinkError, match=r"PMOV Z-2 .*may have run; RDPS says nothing either \(no answer\)"):
        link.request(PMov((("Z", -2.0),)))


class BrokenPort:
    timeout = None
    in_waiting = 3

    def __init__(self, data=b""):
        self.data = data

    def read(self, size=1):
        if not self.data:
            raise OSError(5, "Input/output error")
        data, self.data = self.data[:size], self.data[size:]
        return data

    def write(self, data):
        raise OSError(5, "Input/output error")


def test_a_port_that_fails_is_a_link_error_naming_it_and_waiting_bytes_are_taken_at_once():
    from retrofit.errors import LinkError
    from retrofit.link.transport import read_some, write_all
    assert read_some(BrokenPort(b"abcdef"), "p") == b"abcd"      # one byte, then the 3 waiting
    with pytest.raises(LinkError, match=r"serial link /dev/ttyUSB0: read failed: .*Input/output error"):
        read_some(BrokenPort(), "/dev/ttyUSB0")
    with pytest.raises(LinkError, match=r"serial link COM3: write failed: .*Input/output error"):
        write_all(BrokenPort(), b"\x7e", "COM3")
    write_all(BrokenPort(), b"", "COM3")                          # nothing to write: no call


def test_a_simulated_line_takes_a_byte_time_for_every_byte_each_way():
    from retrofit.commands import Init
    from retrofit.link.device import DeviceEndpoint
    from retrofit.link.host import HostEndpoint
    from retrofit.link.simwire import LinkBench
    machine = load_machine("chivu-lathe")
    host, device = HostEndpoint(machine), DeviceEndpoint(machine, lambda cmd: None)
    carried = []
    for end in (host, device):
        def counted(take=end.take_output):
            data = take()
            carried.append(len(data))
            return data
        end.take_output = counted
    seen = []
    bench = LinkBench(host, device, byte_time_s=0.001, on_time=seen.append)
    host.send(Init(), 0.0)
    host.send(PMov((("X", 1.0),)), 0.0)
    bench.run()
    assert host.idle and sum(carried) > 40                    # SYNC, SESS, INIT, ACK, PMOV, ACK
    assert bench.now == pytest.approx(0.001 * sum(carried))
    assert seen and seen[-1] <= bench.now


def test_a_host_resends_on_an_answer_it_cannot_read_and_ignores_one_of_no_session():
    from retrofit.commands import Init
    from retrofit.link.device import DeviceEndpoint
    from retrofit.link.host import HostEndpoint
    from retrofit.link.replies import Ack, encode_reply
    machine = load_machine("chivu-lathe")
    host, device = HostEndpoint(machine), DeviceEndpoint(machine, lambda cmd: None)
    host.send(Init(), 0.0)
    device.receive(host.take_output())
    host.receive(device.take_output(), 0.0)                 # SESS: the INIT goes out
    sent = host.stats.frames_sent
    init = host.take_output()
    session = device.session(0)
    garbled = encode_frame(list(FrameDecoder(lambda seq: session).events(init))[0].seq, b"\xee\x01", session)
    host.receive(garbled, 0.01)                              # intact frame, unreadable answer
    assert host.stats.bad_frames == 1 and host.stats.frames_sent == sent + 1
    host.receive(encode_frame(0x01, encode_reply(Ack())), 0.02)   # an ACK bound to no session
    assert host.stats.unbound == 1 and not host.idle
    device.receive(host.take_output())
    host.receive(device.take_output(), 0.03)
    assert host.idle


def test_a_host_needs_positive_timeouts_and_at_least_one_try():
    from retrofit.link.host import HostEndpoint
    machine = load_machine("chivu-lathe")
    for options in ({"timeout_s": 0.0}, {"busy_retry_s": 0.0}, {"max_tries": 0}):
        with pytest.raises(ValueError, match="timeout_s and busy_retry_s must be > 0, max_tries >= 1"):
            HostEndpoint(machine, **options)
    assert HostEndpoint(machine, max_tries=1, timeout_s=1e-6).max_tries == 1


def test_a_zmov_with_a_stray_byte_is_refused_for_its_length_and_homes_nothing():
    # docs/protocol.md: ZMOV is n, then n axis bit numbers (X 0, Z 2): 2 + n bytes. 03 01 00 02
    # counts one axis but carries two, 03 02 00 counts two and carries one: ERR 2 (wrong length)
    # with the opcode as detail, each
    machine = load_machine("chivu-lathe")
    from retrofit.commands import ZMov
    from retrofit.link.device import DeviceEndpoint, SessionNumbers
    from retrofit.link.framing import QUEUED
    from retrofit.link.replies import Ack, Err, Session
    host, delivered = ScriptedHost(machine), []
    device = DeviceEndpoint(machine, delivered.append, sessions=SessionNumbers(SIMAVR_FIRST_SESSION))
    device.receive(host.frame("ZMOV X") + host.frame(payload=bytes((0x03, 1, 0, 2)), channel=QUEUED)
                   + host.frame(payload=bytes((0x03, 2, 0)), channel=QUEUED))
    assert delivered == [ZMov(("X",))]
    answers = [Session(SIMAVR_FIRST_SESSION)] * SYNC_COPIES + [Ack(), Err(2, 0x03), Err(2, 0x03)]
    assert host.replies(device.take_output()) == answers
    assert Err(2, 0x03).text() == "wrong payload length for the opcode (detail 0x03)"


def test_a_decoder_counts_the_bytes_outside_its_frames_as_noise():
    # 2 bytes before the first frame and 8 after it; then a frame refused for its length byte
    # (0x00), the 1 byte after that byte noise too: 2 + 8, then + 1
    frame = encode_frame(0x01, b"\x04\x05", None)
    decoder = FrameDecoder()
    events = decoder.feed(b"\x11\x22" + frame + bytes(range(1, 9)))
    assert [e.payload for e in events] == [b"\x04\x05"] and decoder.noise_bytes == 10
    events = decoder.feed(b"\x7e\x00\x66" + frame)
    assert [type(e).__name__ for e in events] == ["BadFrame", "Frame"] and decoder.noise_bytes == 11


def test_a_dwell_reads_as_status_bit_11_on_the_link_as_the_firmware_sends_it():
    # docs/protocol.md's status word: bit 0 MOVING, bit 11 DWELLING; a STAT answer is 85, the
    # word in 3 bytes (most significant first), then the queue's length
    from retrofit.commands import Dely, Rdst
    from retrofit.controller import Controller
    from retrofit.link.replies import decode_reply, encode_reply, flag_names
    machine = load_machine("chivu-lathe")
    ctl = Controller(machine)
    ctl.submit(Dely(0.01))
    for _ in range(5):
        ctl.tick()
    assert encode_reply(ctl.submit(Rdst())) == bytes.fromhex("85 00 08 01 00")
    assert flag_names(decode_reply(bytes.fromhex("85 00 08 00 00")).flags) == ["DWELLING"]
