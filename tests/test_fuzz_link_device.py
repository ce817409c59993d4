"""The device end of the link fuzzed with hostile frames, behind the real motion controller.

Whatever arrives (well-formed frames with any sequence byte and any payload, payloads of valid
layout with extreme values, garbage between them), the device never raises, answers every
complete frame exactly once, and every answer is a well-formed frame.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.errors import MotionError
from retrofit.firmware.mcu import make_controller
from retrofit.link import DeviceEndpoint, FrameDecoder, encode_frame
from retrofit.link.framing import Frame
from retrofit.machine.config import load_machine

MACHINE = load_machine("mitic-lathe")
S24 = st.integers(-(2**23), 2**23 - 1).map(lambda v: (v & 0xFFFFFF).to_bytes(3, "big"))
U32 = st.integers(0, 2**32 - 1).map(lambda v: v.to_bytes(4, "big"))


def positions(opcode):
    return st.tuples(st.integers(0, 255), st.lists(S24, max_size=3)).map(
        lambda t: bytes((opcode, t[0])) + b"".join(t[1]))


PAYLOADS = st.one_of(
    st.binary(min_size=1, max_size=32),                                   # anything at all
    st.sampled_from([0x02, 0x04, 0x0C]).flatmap(positions),               # FMOV PMOV PSTN
    st.tuples(st.integers(0, 3), positions(0x11)).map(                   # PROB: flags, positions
        lambda t: t[1][:1] + bytes((t[0],)) + t[1][1:]),
    st.sampled_from([0x06, 0x07, 0x08, 0x09]).flatmap(lambda op: U32.map(lambda v: bytes((op,)) + v)),
    st.binary(max_size=4).map(lambda b: b"\x03" + bytes((len(b),)) + b),  # ZMOV
    st.binary(min_size=3, max_size=3).map(lambda b: b"\x0f" + b),         # SPIN
    st.sampled_from([b"\x01", b"\x05", b"\x0a", b"\x0b", b"\x0d", b"\x0e", b"\x10\x07"]),
    U32.map(lambda v: b"\x7f" + v),                                       # SYNC of any session
)
STEP = st.tuples(st.integers(0, 255), PAYLOADS, st.binary(max_size=4), st.integers(0, 3000))


@settings(max_examples=120, deadline=None)
@given(steps=st.lists(STEP, min_size=1, max_size=25))
def test_the_device_answers_every_frame_once_and_never_raises(steps):
    controller = make_controller(MACHINE)
    device = DeviceEndpoint(MACHINE, controller.submit)
    complete = 0
    for seq, payload, garbage, ticks in steps:
        device.receive(encode_frame(seq, payload) + garbage.replace(b"\x7e", b""))
        complete += 1
        try:
            controller.run_until_idle(ticks)
        except MotionError:
            pass                                  # still busy: fine, the next frame comes anyway
    device.receive(b"\x7e")                       # cut whatever the garbage started
    events = FrameDecoder().feed(device.take_output())
    assert all(isinstance(e, Frame) for e in events)
    assert len(events) == complete
