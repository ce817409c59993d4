"""Frames on the byte stream: start byte, length, sequence byte, payload, CRC, with byte stuffing.

On the wire a frame is ``SOF`` followed by the stuffed body ``LEN SEQ PAYLOAD[LEN] CRC[4]``
(CRC-32 over LEN, SEQ and PAYLOAD, most significant byte first). Inside the body every ``0x7E``
or ``0x7D`` is sent as ``0x7D`` followed by the byte XOR ``0x20``, so ``0x7E`` on the wire always
starts a frame: a receiver that lost, gained or garbled bytes is back in step at the next frame.

    >>> encode_frame(0x01, bytes([0x80])).hex(" ")
    '7e 01 01 80 0a 20 01 44'
"""

from __future__ import annotations

from dataclasses import dataclass

from .crc import crc32

SOF = 0x7E          # start of frame; never appears inside a stuffed body
ESC = 0x7D          # escape: the next byte is the data byte XOR ESC_XOR
ESC_XOR = 0x20
MAX_PAYLOAD = 32    # bytes of payload a receiver must buffer (LEN is 1..MAX_PAYLOAD)
CRC_BYTES = 4       # the CRC-32 ends the body, most significant byte first
OVERHEAD = 2 + CRC_BYTES    # body bytes besides the payload: LEN, SEQ, CRC

# The sequence byte: bit 7 = channel, bits 6..0 = sequence number (wraps 127 -> 0).
QUEUED, IMMEDIATE = 0, 1    # channel of queued commands / of commands that jump the queue
SEQ_MOD = 128

#: why a frame was refused; all but "truncated" are answered with NAK by a device
BAD_REASONS = ("length", "crc", "escape", "truncated")


@dataclass(frozen=True)
class Frame:
    """A frame whose length and CRC checked out: its sequence byte and payload."""

    seq: int
    payload: bytes


@dataclass(frozen=True)
class BadFrame:
    """A frame that started with SOF but was refused; ``body`` is what arrived unstuffed."""

    reason: str     # one of BAD_REASONS
    body: bytes

    @property
    def complete(self) -> bool:
        """True unless the frame was cut short by the next SOF (its sender has moved on)."""
        return self.reason != "truncated"


def seq_byte(channel: int, number: int) -> int:
    """The sequence byte of a frame on ``channel`` (QUEUED or IMMEDIATE) with ``number``."""
    return (channel << 7) | (number % SEQ_MOD)


def split_seq(byte: int) -> tuple[int, int]:
    """(channel, number) of a sequence byte."""
    return byte >> 7, byte & 0x7F


def stuff(body: bytes) -> bytes:
    """Escape every SOF and ESC byte in ``body``."""
    out = bytearray()
    for byte in body:
        if byte in (SOF, ESC):
            out += bytes((ESC, byte ^ ESC_XOR))
        else:
            out.append(byte)
    return bytes(out)


def encode_frame(seq: int, payload: bytes) -> bytes:
    """The wire bytes of one frame (SOF, then the stuffed body with its CRC)."""
    if not 0 <= seq <= 0xFF:
        raise ValueError(f"frame sequence byte {seq}: must be 0..255")
    if not 1 <= len(payload) <= MAX_PAYLOAD:
        raise ValueError(f"frame payload of {len(payload)} bytes: must be 1..{MAX_PAYLOAD}")
    body = bytes((len(payload), seq)) + bytes(payload)
    return bytes((SOF,)) + stuff(body + crc32(body).to_bytes(CRC_BYTES, "big"))


class FrameDecoder:
    """Turns byte chunks of any size into Frame and BadFrame events, in order.

    Bytes outside a frame (before the first SOF, after a refused frame) are counted in
    ``noise_bytes`` and otherwise ignored.
    """

    def __init__(self) -> None:
        self._body: bytearray | None = None     # None: hunting for SOF
        self._escaped = False
        self.noise_bytes = 0

    def feed(self, data: bytes) -> list[Frame | BadFrame]:
        """Consume ``data``; return the frames it completed or refused."""
        events: list[Frame | BadFrame] = []
        for byte in data:
            event = self._byte(byte)
            if event is not None:
                events.append(event)
        return events

    def _byte(self, byte: int) -> Frame | BadFrame | None:
        if byte == SOF:
            cut = self._body
            self._body, self._escaped = bytearray(), False
            if cut:
                return BadFrame("truncated", bytes(cut))
            return None
        body = self._body
        if body is None:
            self.noise_bytes += 1
            return None
        if self._escaped:
            self._escaped = False
            byte ^= ESC_XOR
            if byte not in (SOF, ESC):
                return self._refuse("escape")
        elif byte == ESC:
            self._escaped = True
            return None
        body.append(byte)
        if len(body) == 1 and not 1 <= byte <= MAX_PAYLOAD:
            return self._refuse("length")
        if len(body) >= OVERHEAD and len(body) == body[0] + OVERHEAD:
            return self._finish(bytes(body))
        return None

    def _refuse(self, reason: str) -> BadFrame:
        body = bytes(self._body or b"")
        self._body = None
        return BadFrame(reason, body)

    def _finish(self, body: bytes) -> Frame | BadFrame:
        self._body = None
        if crc32(body[:-CRC_BYTES]) != int.from_bytes(body[-CRC_BYTES:], "big"):
            return BadFrame("crc", body)
        return Frame(body[1], body[2:-CRC_BYTES])
