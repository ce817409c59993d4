"""Checks of lab 09 (the serial link): run with `retrofit lab check 09`, or pytest on this file.

The oracles are retrofit's own link (``retrofit.link``): its frame encoder, its decoder, its
endpoints. Whatever the link's CRC is, the frames are compared with what the library sends.
"""

import random

import pytest

from retrofit.commands import PMov
from retrofit.config import load_machine
from retrofit.labs import expect, load_target
from retrofit.link import Frame, FrameDecoder, encode_command, encode_frame
from retrofit.link.framing import ESC, SOF
from retrofit.link.simwire import FaultyWire

LATHE = load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def _bodies():
    rng = random.Random(9)
    yield bytes((0x01, 0x02, 0x03))
    yield bytes((SOF,)), bytes((ESC,)), bytes((SOF, ESC, SOF)), bytes((ESC ^ 0x20, SOF ^ 0x20))
    for _ in range(40):
        yield bytes(rng.choice((SOF, ESC, rng.randrange(256))) for _ in range(rng.randint(1, 32)))


def test_stuffing_escapes_sof_and_esc(lab):
    """TODO 1: stuff() escapes SOF and ESC, and nothing else"""
    from retrofit.link.framing import stuff as library
    for body in [b for group in _bodies() for b in (group if isinstance(group, tuple) else (group,))]:
        got = lab.stuff(body)
        hint = ("ESC must be escaped too, or a data byte 0x7D would swallow the next byte" if ESC in body and
                got == body.replace(bytes((ESC,)), bytes((ESC,))) else
                "each SOF or ESC becomes two bytes: ESC, then the byte XOR ESC_XOR (0x20)")
        expect(got == library(body), f"stuff({body.hex(' ')})", expected=library(body).hex(" "),
               got=got.hex(" ") if isinstance(got, (bytes, bytearray)) else repr(got), hint=hint)
        expect(SOF not in got, f"stuff({body.hex(' ')}) holds no SOF", expected="no 7e byte", got=got.hex(" "))


def test_frames_are_the_librarys_bytes(lab):
    """TODO 2: frame(seq, payload) gives the same bytes as retrofit's link, for any seq and payload"""
    rng = random.Random(2)
    cases = [(0, b"\x01"), (127, bytes((SOF, ESC))), (0x80 | 5, bytes(range(0x70, 0x80))), (SOF, b"\x00" * 32)]
    cases += [(rng.randrange(256), bytes(rng.randrange(256) for _ in range(rng.randint(1, 32)))) for _ in range(60)]
    for seq, payload in cases:
        got, want = bytes(lab.frame(seq, payload)), encode_frame(seq, payload)
        if got == want:
            continue
        body = got[1:]
        hint = ("the CRC goes high byte first" if len(got) == len(want) and got[:-4] == want[:-4] else
                "the CRC covers LEN and SEQ as well as the payload, and is stuffed with them"
                if len(got) == len(want) else
                "LEN is the payload's length (1..32), before SEQ; stuff everything after the SOF")
        expect(False, f"frame({seq}, {payload.hex(' ')})", expected=want.hex(" "), got=body.hex(" "), hint=hint)


def test_frames_decode_to_what_was_sent(lab):
    """TODO 2: a receiver's FrameDecoder reads every frame back, even cut into single bytes"""
    rng = random.Random(3)
    for _ in range(30):
        seq, payload = rng.randrange(256), bytes(rng.choice((SOF, ESC, rng.randrange(256))) for _ in range(8))
        decoder, events = FrameDecoder(), []
        for byte in bytes(lab.frame(seq, payload)):
            events += decoder.feed(bytes((byte,)))
        events += decoder.feed(bytes((SOF,)))
        expect(events[:1] == [Frame(seq, payload)], f"decoding frame({seq}, {payload.hex(' ')})",
               expected=f"Frame(seq={seq}, payload={payload.hex(' ')})", got=repr(events[:1]))


def _payloads(count=60):
    return [encode_command(PMov((("X", round(0.025 * i, 3)), ("Z", -0.02 * i))), LATHE) for i in range(count)]


@pytest.mark.parametrize("flip,drop", [(0.0, 0.0), (0.02, 0.0), (0.0, 0.02), (0.05, 0.01)])
def test_raw_sending_loses_what_the_wire_damages(lab, flip, drop):
    """TODO 3: without a protocol, send_raw and count_wrong count the commands the wire changed"""
    payloads = _payloads()
    got = [bytes(r) for r in lab.send_raw(payloads, FaultyWire(random.Random(5), flip=flip, drop=drop))]
    oracle = FaultyWire(random.Random(5), flip=flip, drop=drop)
    want = [oracle.carry(p) for p in payloads]
    expect(got == want, "what arrives of each command (one write per command, in order)",
           expected=f"{len(want)} arrivals, the wire's own", got=f"{len(got)} arrivals, "
           f"{sum(a != b for a, b in zip(got, want))} of them different", hint="wire.carry(payload) for each payload")
    wrong = sum(a != b for a, b in zip(payloads, want))
    counted = lab.count_wrong(payloads, want)
    cut = sum(len(a) != len(b) for a, b in zip(payloads, want))
    expect(counted == wrong, f"count_wrong at {flip:.0%} flipped and {drop:.0%} dropped bytes",
           expected=f"{wrong} commands changed ({cut} of them cut short)", got=counted,
           hint="a command is wrong if any byte differs, not only when bytes are missing")


def test_crc_refuses_every_single_bit_flip(lab):
    """TODO 4: crc_catches tries every bit of the frame and the receiver refuses every flip"""
    for seq, payload in [(5, bytes(range(0x70, 0x80))), (0x81, b"\x10\x20"), (3, bytes((SOF, ESC, 0)))]:
        tried = 8 * len(encode_frame(seq, payload))
        got = tuple(lab.crc_catches(seq, payload))
        expect(got == (tried, tried), f"crc_catches({seq}, {payload.hex(' ')})",
               expected=f"({tried}, {tried}): every bit of the {tried // 8} wire bytes, SOF included, and "
                        "all refused", got=repr(got),
               hint="a flip is caught when the decoder does not give back the very frame that was sent: "
                    "a refused frame of any reason (length, crc, escape, truncated) counts")


@pytest.mark.parametrize("flip", [0.0, 0.02, 0.04])
def test_the_protocol_delivers_every_command_once_in_order(lab, flip):
    """TODO 5: with the protocol every command arrives once, in order, and faults cost resends"""
    commands = [PMov((("X", round(0.025 * i, 3)),)) for i in range(1, 41)]
    delivered, stats = lab.run_protocol(commands, flip, seed=7)
    expect(list(delivered) == commands, f"the commands the device delivered at {flip:.0%} flipped bytes",
           expected="all 40, once each, in order", got=f"{len(delivered)} delivered, "
           f"{sum(a == b for a, b in zip(delivered, commands))} in their place",
           hint="send every command, then bench.run() until the host is idle")
    if flip:
        expect(stats.resends > 0 and stats.frames_sent > 41, f"the host's stats at {flip:.0%}",
               expected="resends > 0: the wires must really flip bits (FaultyWire(rng, flip=flip) both ways)",
               got=f"{stats.resends} resends, {stats.frames_sent} frames sent")
    else:
        expect(stats.resends == 0, "the host's stats on a perfect line", expected="no resends",
               got=f"{stats.resends} resends")
