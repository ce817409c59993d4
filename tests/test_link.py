"""The serial link: CRC, frames, payloads of every command, the endpoints' rules, a real port."""

import doctest
import os
import socket
import subprocess
import sys
import threading
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import retrofit.link as link
from retrofit.commands import (
    DEVICE_COMMANDS,
    CommandError,
    Cool,
    CStp,
    Dely,
    FFdr,
    FMov,
    Init,
    IStp,
    MFdr,
    PFdr,
    PMov,
    Prob,
    Pstn,
    Rdps,
    Rdst,
    Spin,
    Stop,
    ZMov,
    parse_command,
)
from retrofit.errors import LinkError, MotionError
from retrofit.link import (
    FEED_UNIT_MM,
    IMMEDIATE,
    POS_MAX,
    QUEUED,
    Ack,
    BadFrame,
    Busy,
    DeviceEndpoint,
    DeviceLink,
    Err,
    Frame,
    FrameDecoder,
    HostLink,
    Nak,
    PayloadError,
    Position,
    Session,
    SessionNumbers,
    Status,
    StatusFlags,
    decode_command,
    decode_reply,
    encode_command,
    encode_frame,
    encode_reply,
    seq_byte,
)
from retrofit.link.crc import CHECK, crc16_ccitt_false, crc32, crc32_bitwise
from retrofit.machine.config import load_machine

LATHE = load_machine("chivu-lathe")
DOCS = Path(__file__).resolve().parents[1] / "docs" / "protocol.md"


def mill():
    """The lathe with a Y axis added (80 steps/mm): a 3-axis machine for the codec."""
    x = LATHE.axis("X")
    return replace(LATHE, name="test-mill", axes=(x, replace(x, name="Y", steps_per_mm=80.0),
                                                    LATHE.axis("Z")))


def hexs(data: bytes) -> str:
    return data.hex(" ").upper()


# -- CRC ---------------------------------------------------------------------------------------

def test_crc_is_crc32_iso_hdlc_with_its_catalogue_check_value():
    assert crc32(b"123456789") == CHECK == 0xCBF43926
    assert crc32_bitwise(b"123456789") == 0xCBF43926
    assert crc16_ccitt_false(b"123456789") == 0x29B1      # version 1's check, kept for the bench


@given(st.binary(max_size=64))
def test_crc_bitwise_form_matches_zlib_and_appended_crc_gives_the_residue(data):
    crc = crc32(data)
    assert crc == crc32_bitwise(data)
    # the CRC-32 residue: the CRC of data followed by its CRC (little-endian) is constant
    assert crc32(data + crc.to_bytes(4, "little")) == 0x2144DF1C


# -- worked examples of docs/protocol.md ------------------------------------------------------

SQ, SI = 0x00010000, 0x00010001    # the sessions of the worked example (a second boot's first)

EXAMPLES = [
    ("SYNC queued", lambda: encode_frame(0x00, bytes.fromhex("7F 00000001")),
     "7E 05 00 7F 00 00 00 01 C3 D1 B7 51"),
    ("SESS queued", lambda: encode_frame(0x00, encode_reply(Session(SQ))),
     "7E 05 00 86 00 01 00 00 F0 30 DF DC"),
    ("SYNC immediate", lambda: encode_frame(0x80, bytes.fromhex("7F 00000002")),
     "7E 05 80 7F 00 00 00 02 44 68 F2 33"),
    ("SESS immediate", lambda: encode_frame(0x80, encode_reply(Session(SI))),
     "7E 05 80 86 00 01 00 01 99 87 FB 92"),
    ("PMOV", lambda: encode_frame(seq_byte(QUEUED, 1),
                                  encode_command(parse_command("PMOV X12.5 Z-3"), LATHE), SQ),
     "7E 08 01 04 05 00 01 F4 FF FF 6A 6A 4C 3C 31"),
    ("ACK", lambda: encode_frame(0x01, encode_reply(Ack()), SQ), "7E 01 01 80 A3 51 D4 8D"),
    ("stuffed FMOV", lambda: encode_frame(seq_byte(QUEUED, 5),
                                          encode_command(parse_command("FMOV X-3.25 Z2.52"), LATHE), SQ),
     "7E 08 05 02 05 FF FF 7D 5E 00 00 7D 5E 57 8D 6A F7"),
    ("RDPS", lambda: encode_frame(seq_byte(IMMEDIATE, 1), encode_command(Rdps(), LATHE), SI),
     "7E 01 81 0D B3 67 D4 3E"),
    ("POS", lambda: encode_frame(0x81, encode_reply(Position((("X", 500), ("Z", -150)))), SI),
     "7E 08 81 84 05 00 01 F4 FF FF 6A 9E AC 66 64"),
    ("ERR 3", lambda: encode_frame(0x82, encode_reply(Err(3, 0x0D)), SI), "7E 03 82 83 03 0D 57 E0 49 52"),
    ("STAT", lambda: encode_frame(0x82, encode_reply(Status(
        StatusFlags.MOVING | StatusFlags.QUEUE_FULL | StatusFlags.HOMED, 3)), SI),
     "7E 05 82 85 00 00 83 03 B9 0E E5 E8"),
    ("STAT host lost", lambda: encode_frame(0x83, encode_reply(Status(
        StatusFlags.STOPPED | StatusFlags.HOST_LOST, 0)), SI),
     "7E 05 83 85 01 04 00 00 44 40 63 C6"),
    ("NAK", lambda: encode_frame(0x00, encode_reply(Nak())), "7E 01 00 81 64 3C 00 93"),
    ("BUSY", lambda: encode_frame(0x02, encode_reply(Busy()), SQ), "7E 01 02 82 66 72 E6 62"),
    ("ERR 4", lambda: encode_frame(0x02, encode_reply(Err(4, 0))), "7E 03 02 83 04 00 AC 94 25 9B"),
    ("PMOV unbound", lambda: encode_frame(seq_byte(QUEUED, 1),
                                          encode_command(parse_command("PMOV X12.5 Z-3"), LATHE)),
     "7E 08 01 04 05 00 01 F4 FF FF 6A 85 EB F4 05"),
    ("SESS again", lambda: encode_frame(0x00, encode_reply(Session(SQ + 2))),
     "7E 05 00 86 00 01 00 02 1E 3E BE F0"),
]


@pytest.mark.parametrize("make, wire", [e[1:] for e in EXAMPLES], ids=[e[0] for e in EXAMPLES])
def test_worked_examples_in_the_spec_are_what_the_encoder_sends(make, wire):
    assert hexs(make()) == wire
    assert wire in DOCS.read_text(), "docs/protocol.md must show this exact frame"


def test_spec_crc_of_the_worked_example_body():
    body = bytes.fromhex("00 01 00 00 08 01 04 05 00 01 F4 FF FF 6A")    # the session, then LEN ...
    assert crc32_bitwise(body) == 0x6A4C3C31
    assert "0x6A4C3C31" in DOCS.read_text()


def test_the_worked_example_session_runs_on_a_device_and_a_replay_of_it_is_refused():
    """The worked example's bytes, sent to a device whose next session numbers are SQ, SI: the
    PMOV runs once; the same bytes again, after another session opened, run nothing."""
    delivered = []
    device = DeviceEndpoint(LATHE, lambda cmd: delivered.append(cmd), sessions=SessionNumbers(SQ))
    wire = bytes.fromhex("7E 05 00 7F 00 00 00 01 C3 D1 B7 51 7E 05 80 7F 00 00 00 02 44 68 F2 33"
                         " 7E 08 01 04 05 00 01 F4 FF FF 6A 6A 4C 3C 31")
    device.receive(wire)
    assert hexs(device.take_output()) == ("7E 05 00 86 00 01 00 00 F0 30 DF DC "
                                          "7E 05 80 86 00 01 00 01 99 87 FB 92 "
                                          "7E 01 01 80 A3 51 D4 8D")
    device.receive(encode_frame(0x00, bytes.fromhex("7F 00000009")))     # another host's SYNC
    device.receive(wire)                                                  # the replay
    assert delivered == [PMov((("X", 12.5), ("Z", -3.0)))]
    out = FrameDecoder().feed(device.take_output())
    assert [decode_reply(f.payload, LATHE) for f in out][-1] == Nak()


# -- framing -----------------------------------------------------------------------------------

frames = st.lists(st.tuples(st.integers(0, 255), st.binary(min_size=1, max_size=32)), max_size=8)
noise = st.binary(max_size=6).map(lambda b: b.replace(b"\x7e", b"\x00"))


@given(frames, st.lists(noise, min_size=9, max_size=9), st.lists(st.integers(1, 9), min_size=1))
def test_decoder_finds_every_frame_in_noise_whatever_the_chunk_sizes(items, gaps, cuts):
    wire = b"".join(gaps[i] + encode_frame(seq, p) for i, (seq, p) in enumerate(items)) + gaps[-1]
    decoder, events, i, k = FrameDecoder(), [], 0, 0
    while i < len(wire):
        events += decoder.feed(wire[i:i + cuts[k % len(cuts)]])
        i, k = i + cuts[k % len(cuts)], k + 1
    assert events == [Frame(seq, p) for seq, p in items]


def test_decoder_reports_each_kind_of_bad_frame_and_recovers():
    good = encode_frame(0x05, b"\x04\x7e\x7d")
    flipped = bytearray(good)
    flipped[3] ^= 0x10
    events = FrameDecoder().feed(
        b"\x7e\x00" + b"\x7e\x21" + bytes(flipped) + b"\x7e\x03\x7d\x00" + good[:5] + good)
    assert [e.reason for e in events if isinstance(e, BadFrame)] == [
        "length", "length", "crc", "escape", "truncated"]
    assert events[-1] == Frame(0x05, b"\x04\x7e\x7d")
    assert [e.complete for e in events[:-1]] == [True, True, True, True, False]


def test_encode_frame_refuses_what_a_receiver_could_not_take():
    with pytest.raises(ValueError, match="1..32"):
        encode_frame(0, bytes(33))
    with pytest.raises(ValueError, match="0..255"):
        encode_frame(256, b"\x01")


# -- codec: every command round-trips in steps ------------------------------------------------

pos_steps = st.integers(-POS_MAX, POS_MAX)


def axes_cmd(cls, machine):
    names = machine.axis_names
    return st.lists(st.sampled_from(names), min_size=1, unique=True).flatmap(
        lambda chosen: st.tuples(*[pos_steps for _ in chosen]).map(
            lambda steps: cls(tuple((n, s / machine.axis(n).steps_per_mm)
                                    for n, s in zip(chosen, steps)))))


def command_strategies(machine):
    feed = st.integers(0, 0xFFFFFFFF).map(lambda n: n * FEED_UNIT_MM)
    return {
        Init: st.just(Init()), Stop: st.just(Stop()), CStp: st.just(CStp()), IStp: st.just(IStp()),
        Rdps: st.just(Rdps()), Rdst: st.just(Rdst()),
        FMov: axes_cmd(FMov, machine), PMov: axes_cmd(PMov, machine), Pstn: axes_cmd(Pstn, machine),
        ZMov: st.permutations(machine.axis_names).flatmap(
            lambda p: st.integers(0, len(p)).map(lambda n: ZMov(tuple(p[:n])))),
        FFdr: feed.map(FFdr), MFdr: feed.map(MFdr), PFdr: feed.map(PFdr),
        Dely: st.integers(0, 0xFFFFFFFF).map(lambda ms: Dely(ms / 1000)),
        Spin: st.builds(Spin, st.integers(0, 0xFFFF).map(float), st.sampled_from((-1, 0, 1))),
        Cool: st.sampled_from((0, 7, 8)).map(Cool),
        Prob: st.tuples(axes_cmd(Prob, machine), st.booleans()).map(lambda t: replace(t[0], away=t[1])),
    }


def test_the_round_trip_covers_every_command_of_the_instruction_set():
    assert set(command_strategies(LATHE)) == set(DEVICE_COMMANDS.values())


def steps_of(cmd, machine):
    return {n: machine.axis(n).to_steps(mm) for n, mm in getattr(cmd, "axes", ())}


@pytest.mark.parametrize("machine", [LATHE, mill()], ids=["lathe-XZ", "mill-XYZ"])
@given(data=st.data())
def test_every_command_round_trips_through_its_payload(machine, data):
    cls = data.draw(st.sampled_from(sorted(DEVICE_COMMANDS.values(), key=lambda c: c.mnemonic)))
    cmd = data.draw(command_strategies(machine)[cls])
    payload = encode_command(cmd, machine)
    back = decode_command(payload, machine)
    assert type(back) is cls
    assert encode_command(back, machine) == payload
    assert steps_of(back, machine) == steps_of(cmd, machine)
    assert getattr(back, "away", None) == getattr(cmd, "away", None)
    if not hasattr(cmd, "axes"):
        assert back == cmd


def test_decoded_positions_are_steps_over_steps_per_mm_in_axis_letter_order():
    back = decode_command(encode_command(PMov((("Z", -3.0), ("X", 12.5))), LATHE), LATHE)
    assert back == PMov((("X", 500 / 40), ("Z", -150 / 50)))
    nearest = decode_command(encode_command(PMov((("X", 0.0374),)), LATHE), LATHE)
    assert nearest.axes == (("X", 0.025),)          # 1.496 steps -> 1 step


@pytest.mark.parametrize("steps", [POS_MAX + 1, -POS_MAX - 1, 10**9], ids=["above", "below", "far"])
def test_a_position_outside_the_24_bit_space_is_refused_by_name(steps):
    cmd = PMov((("X", 1.0), ("Z", steps / 50)))
    with pytest.raises(MotionError, match=r"PMOV Z: .* steps is outside the link's 24-bit step "
                                          r"space \(-8388607..8388607\)"):
        encode_command(cmd, LATHE)


@pytest.mark.parametrize("text, wire", [
    ("PROB X12.5 Z-3", "11 00 05 00 01 F4 FF FF 6A"),           # X 500, Z -150 steps, as PMOV
    ("PROB AWAY X12.5 Z-3", "11 01 05 00 01 F4 FF FF 6A"),      # flags bit 0: until it opens
    ("PROB AWAY Z-3", "11 01 04 FF FF 6A"),
], ids=["towards", "away", "one-axis"])
def test_prob_is_a_flags_byte_then_positions_as_pmov(text, wire):
    payload = encode_command(parse_command(text), LATHE)
    assert hexs(payload) == wire
    assert len(payload) == 3 + 3 * bin(payload[2]).count("1")        # LEN = 3 + 3k, opcode included
    assert str(decode_command(payload, LATHE)) == text


def test_probed_is_bit_15_of_the_status_word():
    assert StatusFlags.PROBED == 1 << 15
    assert hexs(encode_reply(Status(StatusFlags.PROBED | StatusFlags.HOMED, 0))) == "85 00 80 80 00"
    assert StatusFlags.HOST_LOST == 1 << 16
    assert hexs(encode_reply(Status(StatusFlags.HOST_LOST | StatusFlags.STOPPED, 0))) == "85 01 04 00 00"


@pytest.mark.parametrize("cmd, message", [
    (PMov((("Y", 1.0),)), r"axis 'Y' is not on machine chivu-lathe \(axes X, Z"),
    (FMov((("X", 1.0), ("X", 2.0))), "axis X given twice"),
    (FFdr(-1.0), "feed -1.0 must be a finite number >= 0"),
    (PFdr(1e6), "too large for the link"),
    (Dely(float("nan")), "must be a finite number"),
    (Spin(70000.0, 1), "rpm must be 0..65535"),
    (Cool(9), "mode must be 0, 7 or 8"),
    (ZMov(("X", "X")), "named twice"),
], ids=["axis", "twice", "negative-feed", "huge-feed", "nan-dwell", "rpm", "coolant", "zmov"])
def test_values_a_field_cannot_hold_are_refused_before_sending(cmd, message):
    with pytest.raises(CommandError, match=message):
        encode_command(cmd, LATHE)


@pytest.mark.parametrize("payload, code, message", [
    ("20", 1, "opcode 0x20 is not a command; known: 0x01 INIT"),
    ("", 2, "empty payload"),
    ("01 00", 2, "INIT: 1 argument bytes; expected 0"),
    ("04 05 00 01 f4", 2, "mask 0x05 names 2 axes, needs 7"),
    ("04 01 80 00 00", 3, "0x800000 is reserved"),
    ("04 02 00 00 01", 3, r"mask bit 1 \(Y\) is not an axis of chivu-lathe"),
    ("03 01 01", 3, "ZMOV: axis bit 1"),
    ("0f 00 10 05", 3, "direction byte 0x05"),
    ("11", 2, "PROB: no argument bytes"),
    ("11 00", 2, "PROB: missing axis mask"),
    ("11 00 05 00 01 f4", 2, "mask 0x05 names 2 axes, needs 8 argument bytes, got 5"),
    ("11 02 01 00 00 01", 3, r"PROB: flags 0x02; only bit 0 \(0x01"),
    ("11 81 01 00 00 01", 3, "PROB: flags 0x81"),
    ("11 00 02 00 00 01", 3, r"PROB: mask bit 1 \(Y\) is not an axis"),
], ids=["opcode", "empty", "init-extra", "short", "reserved", "no-y", "zmov-y", "spin-dir",
        "prob-empty", "prob-no-mask", "prob-short", "prob-flag-1", "prob-flag-7", "prob-y"])
def test_malformed_payloads_are_refused_with_the_err_code_to_answer(payload, code, message):
    with pytest.raises(PayloadError, match=message) as info:
        decode_command(bytes.fromhex(payload), LATHE)
    assert info.value.code == code and isinstance(info.value, LinkError)


@given(st.one_of(
    st.builds(Position, st.tuples(st.tuples(st.just("X"), pos_steps), st.tuples(st.just("Z"), pos_steps))),
    st.builds(Status, st.integers(0, 0xFFFF).map(StatusFlags), st.integers(0, 255)),
    st.builds(Err, st.integers(0, 255), st.integers(0, 255)),
    st.sampled_from((Ack(), Nak(), Busy()))))
def test_replies_round_trip(reply):
    assert decode_reply(encode_reply(reply), LATHE) == reply


def test_position_reply_in_mm_and_a_bad_reply():
    assert Position((("X", 500), ("Z", -150))).mm(LATHE) == {"X": 12.5, "Z": -3.0}
    with pytest.raises(PayloadError, match="not a reply opcode"):
        decode_reply(b"\x04", LATHE)


def test_importing_the_link_does_not_import_pyserial():
    code = "import sys, retrofit.link; print('serial' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("module", ["crc", "framing", "codec", "replies"])
def test_docstring_examples_run(module):
    mod = __import__(f"retrofit.link.{module}", fromlist=["_"])
    result = doctest.testmod(mod)
    assert result.failed == 0 and result.attempted > 0


def test_every_link_module_is_short():
    for path in Path(link.__file__).parent.glob("*.py"):
        assert len(path.read_text().splitlines()) <= 400, path.name


# -- over real ports ---------------------------------------------------------------------------

class SocketPort:
    """A connected socket with pyserial's read / write / timeout / in_waiting."""

    def __init__(self, sock):
        self.sock, self.timeout = sock, None

    def read(self, size=1):
        self.sock.settimeout(self.timeout)
        try:
            return self.sock.recv(size)
        except (TimeoutError, BlockingIOError):
            return b""

    @property
    def in_waiting(self):
        try:
            return len(self.sock.recv(4096, socket.MSG_PEEK | socket.MSG_DONTWAIT))
        except BlockingIOError:
            return 0

    def write(self, data):
        self.sock.sendall(data)


class FdPort:
    """The master side of a pty with pyserial's read / write / timeout."""

    def __init__(self, fd):
        self.fd, self.timeout = fd, None

    def read(self, size=1):
        import select
        ready, _, _ = select.select([self.fd], [], [], self.timeout)
        return os.read(self.fd, size) if ready else b""

    def write(self, data):
        os.write(self.fd, data)


class Recorder:
    """A device application that records deliveries and answers RDPS at X 500, Z -150 steps."""

    def __init__(self):
        self.delivered = []

    def __call__(self, cmd):
        self.delivered.append(cmd)
        return Position((("X", 500), ("Z", -150))) if isinstance(cmd, Rdps) else None


def drive(host_port, device_port):
    """Serve a device on one port in a thread; send a few commands and RDPS on the other."""
    app, stop = Recorder(), threading.Event()
    device_port.timeout = 0.01
    server = threading.Thread(target=DeviceLink(device_port, LATHE, app).serve, args=(stop,))
    server.start()
    try:
        with HostLink(host_port, LATHE, timeout_s=10.0) as host:       # a ceiling: the answers come at once
            answers = [host.request(parse_command(t)) for t in
                       ("INIT", "FFDR F1200", "PMOV X12.5 Z-3", "FMOV X-3.25 Z2.52", "RDPS")]
    finally:
        stop.set()
        server.join(5)
    assert answers == [Ack()] * 4 + [Position((("X", 500), ("Z", -150)))]
    assert app.delivered == [Init(), FFdr(1200.0), PMov((("X", 12.5), ("Z", -3.0))),
                             FMov((("X", -3.25), ("Z", 2.52))), Rdps()]


def test_end_to_end_over_a_loopback_tcp_socket_with_pyserial():
    import serial
    listener = socket.create_server(("127.0.0.1", 0))
    port_number = listener.getsockname()[1]
    accepted = {}
    acceptor = threading.Thread(target=lambda: accepted.setdefault("s", listener.accept()[0]))
    acceptor.start()
    client = serial.serial_for_url(f"socket://127.0.0.1:{port_number}", timeout=0.01)
    acceptor.join(5)
    try:
        drive(client, SocketPort(accepted["s"]))
    finally:
        accepted["s"].close()
        listener.close()


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pty (POSIX)")
def test_end_to_end_over_a_pty_with_pyserial():
    import serial
    master, slave = os.openpty()
    try:
        drive(serial.Serial(os.ttyname(slave), 115200, timeout=0.01), FdPort(master))
    finally:
        os.close(slave)
        os.close(master)


def test_open_port_names_the_url_and_the_accepted_forms():
    with pytest.raises(LinkError, match=r"serial link '/dev/no-such-tty': cannot open it .*"
                                        r"expected a device such as /dev/ttyUSB0"):
        link.open_port("/dev/no-such-tty")
