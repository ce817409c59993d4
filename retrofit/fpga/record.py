"""The pulse record the processor sends the FPGA for each event of an axis (004, §3, Figure 6).

One record is ``delay`` (ticks since the axis's previous event; the first record counts from
tick 0), ``dir`` (the level the direction pin takes at the event) and ``width`` (ticks the step
pin stays high from the event; 0 = no pulse: a direction turn alone, or a filler that only
carries time across a gap longer than ``delay`` can hold). Packed as one word:
``delay`` in bits 0..15, ``width`` in bits 16..23, ``dir`` in bit 24.
"""

# no 'from __future__ import annotations': amaranth reads the Struct's annotations as shapes
from amaranth.lib import data

DELAY_BITS = 16
WIDTH_BITS = 8
MAX_DELAY = (1 << DELAY_BITS) - 1
MAX_WIDTH = (1 << WIDTH_BITS) - 1


class PulseRecord(data.Struct):
    """One event of one axis, as it travels over the bus and waits in the axis's FIFO."""

    delay: DELAY_BITS
    width: WIDTH_BITS
    dir: 1


RECORD_BITS = PulseRecord.as_shape().size


def pack(delay: int, direction: int, width: int) -> int:
    """The word of one record (host side); ranges are checked by the caller (``retrofit.fpga.host``)."""
    return delay | (width << DELAY_BITS) | (direction << (DELAY_BITS + WIDTH_BITS))


def unpack(word: int) -> tuple[int, int, int]:
    """(delay, dir, width) of a packed record."""
    return word & MAX_DELAY, (word >> (DELAY_BITS + WIDTH_BITS)) & 1, (word >> DELAY_BITS) & MAX_WIDTH
