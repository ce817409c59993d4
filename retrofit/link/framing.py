"""Frames on the byte stream: start byte, length, sequence byte, payload, CRC, with byte stuffing.

On the wire a frame is ``SOF`` followed by the stuffed body ``LEN SEQ PAYLOAD[LEN] CRC[4]``
(CRC-32 over LEN, SEQ and PAYLOAD, most significant byte first; in a session, over the session's
32-bit number first, which binds the frame to it). Inside the body every ``0x7E``
or ``0x7D`` is sent as ``0x7D`` followed by the byte XOR ``0x20``, so ``0x7E`` on the wire always
starts a frame: a receiver that lost, gained or garbled bytes is back in step at the next frame.

    >>> encode_frame(0x01, bytes([0x80])).hex(" ")
    '7e 01 01 80 0a 20 01 44'
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
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
    """A frame whose length and CRC checked out: its sequence byte and payload; ``bound`` when
    its CRC covers the session number of its channel (docs/protocol.md §4)."""

    seq: int
    payload: bytes
    bound: bool = False


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
    return bytes(body).replace(b"\x7d", b"\x7d\x5d").replace(b"\x7e", b"\x7d\x5e")   # ESC first


def session_prefix(session: int | None) -> bytes:
    """The bytes a bound frame's CRC covers before its body: the session number, big-endian."""
    return b"" if session is None else (session & 0xFFFFFFFF).to_bytes(4, "big")


def encode_frame(seq: int, payload: bytes, session: int | None = None) -> bytes:
    """The wire bytes of one frame (SOF, then the stuffed body with its CRC); with ``session``
    the CRC covers that 32-bit number first (a frame bound to the session)."""
    if not 0 <= seq <= 0xFF:
        raise ValueError(f"frame sequence byte {seq}: must be 0..255")
    if not 1 <= len(payload) <= MAX_PAYLOAD:
        raise ValueError(f"frame payload of {len(payload)} bytes: must be 1..{MAX_PAYLOAD}")
    body = bytes((len(payload), seq)) + bytes(payload)
    crc = crc32(session_prefix(session) + body)
    return bytes((SOF,)) + stuff(body + crc.to_bytes(CRC_BYTES, "big"))


class FrameDecoder:
    """Turns byte chunks of any size into Frame and BadFrame events, in order.

    Bytes outside a frame (before the first SOF, after a refused frame) are counted in
    ``noise_bytes`` and otherwise ignored. The rules are those of docs/protocol.md §2.4, applied
    byte by byte (``_walk``); a frame without escapes takes a shortcut with the same outcome.
    """

    crc_bytes = CRC_BYTES                       # the check ending a body, and its function
    check = staticmethod(crc32)

    def __init__(self, binding: Callable[[int], int | None] | None = None) -> None:
        self.binding = binding
        self._raw: bytearray | None = None      # stuffed bytes since the SOF; None: hunting
        self._overhead = 2 + self.crc_bytes
        self.noise_bytes = 0

    def feed(self, data: bytes) -> list[Frame | BadFrame]:
        """Consume ``data``; return the frames it completed or refused."""
        return list(self.events(data))

    def events(self, data: bytes) -> Iterator[Frame | BadFrame]:
        """Consume ``data`` frame by frame: each frame is checked when the caller asks for it,
        so a SYNC handled before the next frame is checked binds that frame to its session."""
        pos, n = 0, len(data)
        while pos < n:
            nxt = data.find(SOF, pos)
            end = n if nxt < 0 else nxt
            if self._raw is None:
                self.noise_bytes += end - pos
            else:
                self._raw += data[pos:end]
                event = self._parse()
                if event is not None:
                    yield event
            if nxt < 0:
                break
            if self._raw:                        # a SOF inside a frame: that frame was cut
                yield BadFrame("truncated", self._walk(bytes(self._raw))[1])
            self._raw, pos = bytearray(), nxt + 1

    def _parse(self) -> Frame | BadFrame | None:
        """A complete or refused frame at the start of the buffer, or None (need more bytes)."""
        raw = self._raw
        if not raw:
            return None
        if ESC in raw:
            event, body, used = self._walk(bytes(raw))
        elif not 1 <= raw[0] <= MAX_PAYLOAD:
            event, body, used = "length", bytes(raw[:1]), 1
        elif len(raw) >= raw[0] + self._overhead:
            used = raw[0] + self._overhead
            event, body = "complete", bytes(raw[:used])
        else:
            return None
        if event is None:
            return None
        self._raw = None
        self.noise_bytes += len(raw) - used
        return self._finish(body) if event == "complete" else BadFrame(event, body)

    def _walk(self, raw: bytes) -> tuple[str | None, bytes, int]:
        """§2.4 byte by byte over a frame's stuffed bytes: (outcome or None, body, bytes used)."""
        body, escaped = bytearray(), False
        for used, byte in enumerate(raw, 1):
            if escaped:
                escaped = False
                byte ^= ESC_XOR
                if byte not in (SOF, ESC):
                    return "escape", bytes(body), used
            elif byte == ESC:
                escaped = True
                continue
            body.append(byte)
            if len(body) == 1 and not 1 <= byte <= MAX_PAYLOAD:
                return "length", bytes(body), used
            if len(body) >= self._overhead and len(body) == body[0] + self._overhead:
                return "complete", bytes(body), used
        return None, bytes(body), len(raw)

    def _finish(self, body: bytes) -> Frame | BadFrame:
        n = self.crc_bytes
        crc = int.from_bytes(body[-n:], "big")
        session = self.binding(body[1]) if self.binding is not None else None
        if session is not None and self.check(session_prefix(session) + body[:-n]) == crc:
            return Frame(body[1], body[2:-n], bound=True)
        if self.check(body[:-n]) != crc:
            return BadFrame("crc", body)
        return Frame(body[1], body[2:-n])
