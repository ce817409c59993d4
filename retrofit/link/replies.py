"""What a device answers: ACK, NAK, BUSY, ERR, the position (RDPS), the status word (RDST) and
the session number a SYNC opens (SESS).

Every reply echoes the sequence byte of the frame it answers (NAK excepted: it answers a frame
whose sequence byte cannot be trusted). ``encode_reply`` and ``decode_reply`` give the payloads.

    >>> encode_reply(Status(StatusFlags.MOVING | StatusFlags.HOMED, queued=2)).hex(" ")
    '85 00 00 81 02'
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntFlag
from typing import ClassVar

from ..machine.config import Machine
from .codec import ERR_LENGTH, ERR_TEXT, PayloadError, axis_bits, pack_positions, unpack_positions

ACK, NAK, BUSY, ERR, POS, STAT, SESS = 0x80, 0x81, 0x82, 0x83, 0x84, 0x85, 0x86


class StatusFlags(IntFlag):
    """Bits of the 24-bit status word of a STAT reply (bit 0 is the least significant)."""

    MOVING = 1 << 0         # a motion command (or dwell) is executing
    QUEUE_FULL = 1 << 1     # three commands wait ahead: a queued command now gets BUSY
    X_NEG_LIMIT = 1 << 2    # NLSX: X negative limit switch closed
    X_POS_LIMIT = 1 << 3    # PLSX: X positive limit switch closed
    Z_POS_LIMIT = 1 << 4    # PLSZ: Z positive limit switch closed
    X_PRECISE = 1 << 5      # PPSX: X precise-position switch closed
    Z_PRECISE = 1 << 6      # PPSZ: Z precise-position switch closed
    HOMED = 1 << 7          # ZMOV has completed since INIT
    ERROR = 1 << 8          # a limit was hit while moving, or a command failed; INIT clears it
    INDEXER = 1 << 9        # step source is the spindle indexer (ISTP); 0 = clock (CSTP)
    STOPPED = 1 << 10       # STOP was received; queue cleared, motion halted
    DWELLING = 1 << 11      # a DELY is running
    SPINDLE_ON = 1 << 12    # SPIN with a direction other than 0
    COOLANT_ON = 1 << 13    # COOL M7 or M8
    INDEX_SEEN = 1 << 14    # an indexer start pulse (SIND) arrived since the spindle started
    PROBED = 1 << 15        # the last PROB stopped on the probe; cleared when a PROB starts, by INIT
    HOST_LOST = 1 << 16     # the host fell silent while the machine had work: braked, then STOPPED
    STEP_ERROR = 1 << 17    # a line ended with steps other than its own: stopped, ERROR set


def flag_names(flags: int) -> list[str]:
    """Names of the set status flags, bit 0 first (``["MOVING", "HOMED"]``)."""
    return [f.name for f in StatusFlags if f in StatusFlags(flags) and f.name]


@dataclass(frozen=True)
class Reply:
    """Base of the replies; ``opcode`` is the first payload byte."""

    opcode: ClassVar[int] = 0


@dataclass(frozen=True)
class Ack(Reply):
    """The command with this sequence byte was delivered (now, or earlier if it was a resend)."""
    opcode: ClassVar[int] = ACK


@dataclass(frozen=True)
class Nak(Reply):
    """A frame arrived damaged; the sender should resend what it has outstanding."""
    opcode: ClassVar[int] = NAK


@dataclass(frozen=True)
class Busy(Reply):
    """The command queue is full; the command was not taken: resend it later."""
    opcode: ClassVar[int] = BUSY


@dataclass(frozen=True)
class Err(Reply):
    """The frame was intact but refused: ``code`` (ERR_* in codec) and a code-specific ``detail``."""
    opcode: ClassVar[int] = ERR
    code: int = 0
    detail: int = 0

    def text(self) -> str:
        """The reason in words."""
        return f"{ERR_TEXT.get(self.code, f'error code {self.code}')} (detail 0x{self.detail:02x})"


@dataclass(frozen=True)
class Position(Reply):
    """Answer to RDPS: actual position in steps, ((letter, steps), ...) in X, Y, Z order."""
    opcode: ClassVar[int] = POS
    steps: tuple[tuple[str, int], ...] = ()

    def mm(self, machine: Machine) -> dict[str, float]:
        """The position in mm through each axis' steps_per_mm."""
        return {name: machine.axis(name).to_mm(s) for name, s in self.steps}


@dataclass(frozen=True)
class Status(Reply):
    """Answer to RDST: the status word and the number of commands waiting in the queue."""
    opcode: ClassVar[int] = STAT
    flags: StatusFlags = StatusFlags(0)
    queued: int = 0


@dataclass(frozen=True)
class Session(Reply):
    """Answer to SYNC: the session number the device issued for the channel (docs/protocol.md §4);
    every later frame of the channel, both ways, is bound to it."""
    opcode: ClassVar[int] = SESS
    number: int = 0


REPLY_OF: dict[int, type[Reply]] = {c.opcode: c for c in (Ack, Nak, Busy, Err, Position, Status,
                                                          Session)}
_ARGS = {ACK: 0, NAK: 0, BUSY: 0, ERR: 2, STAT: 4, SESS: 4}


def encode_reply(reply: Reply, machine: Machine | None = None) -> bytes:
    """The payload of a reply, opcode first (POS bits from ``machine``'s lettering, codec.axis_bits)."""
    op = bytes((reply.opcode,))
    if isinstance(reply, Err):
        return op + bytes((reply.code & 0xFF, reply.detail & 0xFF))
    if isinstance(reply, Position):
        bits = axis_bits(machine)
        steps = {bits[name]: value for name, value in reply.steps}
        return op + pack_positions("POS", steps, machine)
    if isinstance(reply, Status):
        if not 0 <= reply.queued <= 0xFF:
            raise ValueError(f"STAT queued = {reply.queued}: must be 0..255")
        return op + int(reply.flags).to_bytes(3, "big") + bytes((reply.queued,))
    if isinstance(reply, Session):
        return op + (reply.number & 0xFFFFFFFF).to_bytes(4, "big")
    return op


def decode_reply(payload: bytes, machine: Machine | None = None) -> Reply:
    """The reply of a payload; PayloadError for an unknown opcode or a wrong length."""
    cls = REPLY_OF.get(payload[0]) if payload else None
    if cls is None:
        known = ", ".join(f"0x{op:02x} {c.__name__.upper()}" for op, c in REPLY_OF.items())
        raise PayloadError(f"reply payload {payload.hex(' ')!r}: not a reply opcode; known: {known}",
                           ERR_LENGTH)
    args = payload[1:]
    if cls is Position:
        return Position(tuple(unpack_positions("POS", args, machine)))
    if len(args) != _ARGS[cls.opcode]:
        raise PayloadError(f"{cls.__name__.upper()} reply: {len(args)} argument bytes; expected "
                           f"{_ARGS[cls.opcode]}", ERR_LENGTH)
    if cls is Err:
        return Err(args[0], args[1])
    if cls is Status:
        return Status(StatusFlags(int.from_bytes(args[:3], "big")), args[3])
    if cls is Session:
        return Session(int.from_bytes(args, "big"))
    return cls()
