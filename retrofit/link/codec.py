"""Binary payloads of the commands: one opcode byte, then fixed big-endian fields (docs/protocol.md).

Positions travel as signed 24-bit step counts (002's 24-bit space), feeds as unsigned 32-bit
counts of 0.1 um per minute (per spindle revolution under ISTP), dwell as 32-bit milliseconds.
Axes are named by a mask whose bit number is fixed by the axis letter (``AXIS_LETTERS``), so a
firmware for a lathe knows X is bit 0 and Z bit 2 whatever order its machine file lists them.
A machine may have up to ``MAX_AXES`` axes; an axis whose letter is not in ``AXIS_LETTERS``
(the mill's carousel, E) takes the highest bit whose letter the machine does not use, in the
order of the machine file (:func:`axis_bits`).

    >>> from retrofit.machine.config import load_machine
    >>> from retrofit.commands import PMov
    >>> lathe = load_machine("chivu-lathe")
    >>> encode_command(PMov((("X", 12.5), ("Z", -3.0))), lathe).hex(" ")
    '04 05 00 01 f4 ff ff 6a'
    >>> decode_command(bytes.fromhex("0405 0001f4 ffff6a"), lathe)
    PMov(axes=(('X', 12.5), ('Z', -3.0)))
"""

from __future__ import annotations

import math

from ..commands import (
    Command,
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
)
from ..errors import LinkError, MotionError
from ..machine.config import Machine

#: axis letter of each mask bit: bit 0 = X, bit 1 = Y, bit 2 = Z, ...
AXIS_LETTERS = "XYZABCUV"
MAX_AXES = 6
POS_MAX = (1 << 23) - 1     # +8 388 607 steps; -8 388 608 (0x800000) is reserved
FEED_UNIT_MM = 1e-4         # one feed count: 0.1 um (per minute, or per revolution under ISTP)
U32_MAX = 0xFFFFFFFF

#: opcode of every command; 0x7F is the link's own SYNC, 0x80..0xFF are replies
OPCODES: dict[type[Command], int] = {
    Init: 0x01, FMov: 0x02, ZMov: 0x03, PMov: 0x04, Stop: 0x05, FFdr: 0x06, MFdr: 0x07,
    PFdr: 0x08, Dely: 0x09, CStp: 0x0A, IStp: 0x0B, Pstn: 0x0C, Rdps: 0x0D, Rdst: 0x0E,
    Spin: 0x0F, Cool: 0x10, Prob: 0x11,
}
#: PROB's flags byte: bit 0 set = move until the probe input opens (G38.4/5); no other bit is used
PROB_AWAY = 0x01
COMMAND_OF: dict[int, type[Command]] = {op: cls for cls, op in OPCODES.items()}
SYNC = 0x7F
SYNC_LEN = 5        # SYNC carries the host's 32-bit nonce; the device answers SESS (docs/protocol.md §4)

#: a device with work whose host has sent no frame of its session for this long brakes to a stop
HEARTBEAT_MS = 500

# error codes a device sends in ERR (and PayloadError.code carries)
ERR_OPCODE, ERR_LENGTH, ERR_VALUE, ERR_NOT_SYNCED, ERR_SEQUENCE, ERR_REFUSED = 1, 2, 3, 4, 5, 6
ERR_TEXT = {ERR_OPCODE: "unknown opcode", ERR_LENGTH: "wrong payload length for the opcode",
            ERR_VALUE: "value out of range", ERR_NOT_SYNCED: "not in a session of this device (reset, or another host opened one?)",
            ERR_SEQUENCE: "sequence number out of step", ERR_REFUSED: "refused by the controller"}


class PayloadError(LinkError):
    """A payload that framed correctly but breaks the layout; ``code`` is the ERR code to answer."""

    def __init__(self, message: str, code: int):
        super().__init__(message)
        self.code = code


def axis_bits(machine: Machine | None) -> dict[str, int]:
    """Letter -> mask bit of each axis of ``machine`` (``AXIS_LETTERS`` without a machine).

    >>> from retrofit.machine.config import load_machine
    >>> axis_bits(load_machine("tul-mill"))
    {'X': 0, 'Y': 1, 'Z': 2, 'E': 7}
    """
    if machine is None:
        return {letter: bit for bit, letter in enumerate(AXIS_LETTERS)}
    names = machine.axis_names
    if len(names) > MAX_AXES:
        raise CommandError(f"{machine.source}: {len(names)} axes ({', '.join(names)}); the link "
                           f"carries at most {MAX_AXES}")
    bits = {n: AXIS_LETTERS.index(n) for n in names if n in AXIS_LETTERS}
    free = [b for b in reversed(range(len(AXIS_LETTERS))) if AXIS_LETTERS[b] not in names]
    for n in names:
        if n not in bits:
            bits[n] = free.pop(0)
    return dict(sorted(bits.items(), key=lambda kv: kv[1]))


def letter_of(bit: int, machine: Machine | None) -> str | None:
    """The axis letter of a mask bit on ``machine``; None if no axis has it."""
    for letter, b in axis_bits(machine).items():
        if b == bit:
            return letter
    return None


def axis_bit(name: str, machine: Machine, head: str) -> int:
    """Mask bit of an axis the machine has; CommandError naming the command otherwise."""
    letter = name.upper()
    bits = axis_bits(machine)
    if letter not in bits:
        raise CommandError(f"{head}: axis {name!r} is not on machine {machine.name} "
                           f"(axes {', '.join(machine.axis_names)})")
    return bits[letter]


def pack_s24(value: int, where: str) -> bytes:
    """Three bytes, big-endian two's complement; MotionError outside +-POS_MAX."""
    if not -POS_MAX <= value <= POS_MAX:
        raise MotionError(f"{where}: {value} steps is outside the link's 24-bit step space "
                          f"(-{POS_MAX}..{POS_MAX})")
    return (value & 0xFFFFFF).to_bytes(3, "big")


def unpack_s24(raw: bytes, where: str) -> int:
    """The signed value of three big-endian bytes; PayloadError for the reserved 0x800000."""
    value = int.from_bytes(raw, "big")
    if value == 0x800000:
        raise PayloadError(f"{where}: 0x800000 is reserved; positions are -{POS_MAX}..{POS_MAX}",
                           ERR_VALUE)
    return value - (1 << 24) if value & 0x800000 else value


def pack_positions(head: str, steps: dict[int, int], machine: Machine | None = None) -> bytes:
    """Axis mask, then one s24 per set bit in ascending bit order. ``steps`` maps bit -> steps."""
    mask = sum(1 << bit for bit in steps)
    out = bytearray((mask,))
    for bit in sorted(steps):
        out += pack_s24(steps[bit], f"{head} {letter_of(bit, machine) or f'bit {bit}'}")
    return bytes(out)


def unpack_positions(head: str, args: bytes, machine: Machine | None,
                     lead: int = 0) -> list[tuple[str, int]]:
    """(letter, steps) pairs of a mask-and-values field; checks length and the machine's axes.
    ``lead``: argument bytes before the field (PROB's flags), counted in the length message."""
    if not args:
        raise PayloadError(f"{head}: missing axis mask", ERR_LENGTH)
    mask, bits = args[0], [b for b in range(8) if args[0] >> b & 1]
    if len(args) != 1 + 3 * len(bits):
        raise PayloadError(f"{head}: mask 0x{mask:02x} names {len(bits)} axes, needs "
                           f"{lead + 1 + 3 * len(bits)} argument bytes, got {lead + len(args)}",
                           ERR_LENGTH)
    pairs = []
    for i, bit in enumerate(bits):
        letter = letter_of(bit, machine)
        if letter is None:
            assert machine is not None           # without a machine every bit has a letter
            raise PayloadError(f"{head}: mask bit {bit} ({AXIS_LETTERS[bit]}) is not an axis of "
                               f"{machine.name} ({', '.join(machine.axis_names)})", ERR_VALUE)
        pairs.append((letter, unpack_s24(args[1 + 3 * i:4 + 3 * i], f"{head} {letter}")))
    return pairs


def _u32(value: float, unit: float, head: str, what: str) -> bytes:
    if not math.isfinite(value) or value < 0:
        raise CommandError(f"{head}: {what} {value} must be a finite number >= 0")
    count = round(value / unit)
    if count > U32_MAX:
        raise CommandError(f"{head}: {what} {value} is too large for the link "
                           f"(at most {U32_MAX * unit:g})")
    return count.to_bytes(4, "big")


def encode_command(cmd: Command, machine: Machine) -> bytes:
    """The payload (opcode first) of a command; positions mm -> steps with each axis' steps_per_mm.

    Raises MotionError for a position outside the 24-bit step space and CommandError for an
    axis the machine lacks or a value its field cannot hold.
    """
    head = cmd.mnemonic
    op = bytes((OPCODES[type(cmd)],))
    if isinstance(cmd, (FMov, PMov, Pstn)):
        return op + _axes_args(cmd, machine)
    if isinstance(cmd, Prob):
        return op + bytes((PROB_AWAY if cmd.away else 0,)) + _axes_args(cmd, machine)
    if isinstance(cmd, ZMov):
        bits = [axis_bit(name, machine, head) for name in cmd.names]
        if len(set(bits)) != len(bits):
            raise CommandError(f"{head}: an axis is named twice in {' '.join(cmd.names)}")
        return op + bytes([len(bits)] + bits)
    if isinstance(cmd, (FFdr, MFdr, PFdr)):
        return op + _u32(cmd.feed, FEED_UNIT_MM, head, "feed")
    if isinstance(cmd, Dely):
        return op + _u32(cmd.seconds, 1e-3, head, "dwell seconds")
    if isinstance(cmd, Spin):
        return op + _spin_args(cmd)
    if isinstance(cmd, Cool):
        if cmd.mode not in (0, 7, 8):
            raise CommandError(f"COOL M{cmd.mode}: mode must be 0, 7 or 8")
        return op + bytes((cmd.mode,))
    return op


def _axes_args(cmd, machine: Machine) -> bytes:
    """The mask-and-positions field of a command with axis words (mm -> steps)."""
    head, steps = cmd.mnemonic, {}
    for name, mm in cmd.axes:
        bit = axis_bit(name, machine, head)
        if bit in steps:
            raise CommandError(f"{head}: axis {name} given twice")
        if not math.isfinite(mm):
            raise CommandError(f"{head} {name}: {mm} is not a finite number")
        steps[bit] = machine.axis(name).to_steps(mm)
    return pack_positions(head, steps, machine)


def _spin_args(cmd: Spin) -> bytes:
    if not math.isfinite(cmd.rpm) or not 0 <= round(cmd.rpm) <= 0xFFFF:
        raise CommandError(f"SPIN S{cmd.rpm}: rpm must be 0..65535")
    if cmd.direction not in (-1, 0, 1):
        raise CommandError(f"SPIN D{cmd.direction}: direction must be -1, 0 or 1")
    return round(cmd.rpm).to_bytes(2, "big") + (cmd.direction & 0xFF).to_bytes(1, "big")


#: argument bytes of the fixed-length opcodes (positions and ZMOV are checked on their own)
_FIXED_ARGS = {Init: 0, Stop: 0, CStp: 0, IStp: 0, Rdps: 0, Rdst: 0,
               FFdr: 4, MFdr: 4, PFdr: 4, Dely: 4, Spin: 3, Cool: 1}


def decode_command(payload: bytes, machine: Machine) -> Command:
    """The command of a payload; positions steps -> mm as steps / steps_per_mm, in X, Y, Z order.

    Raises PayloadError (a LinkError) with the ERR code a device answers.
    """
    if not payload:
        raise PayloadError("empty payload; expected an opcode byte", ERR_LENGTH)
    cls = COMMAND_OF.get(payload[0])
    if cls is None:
        raise PayloadError(f"opcode 0x{payload[0]:02x} is not a command; known: "
                           + ", ".join(f"0x{op:02x} {c.mnemonic}" for c, op in OPCODES.items()),
                           ERR_OPCODE)
    head, args = cls.mnemonic, payload[1:]
    if cls in (FMov, PMov, Pstn):
        pairs = unpack_positions(head, args, machine)
        return cls(tuple((n, machine.axis(n).to_mm(s)) for n, s in pairs))
    if cls is ZMov:
        return _decode_zmov(args, machine)
    if cls is Prob:
        return _decode_prob(args, machine)
    if len(args) != _FIXED_ARGS[cls]:
        raise PayloadError(f"{head}: {len(args)} argument bytes; expected {_FIXED_ARGS[cls]}",
                           ERR_LENGTH)
    if cls in (FFdr, MFdr, PFdr):
        return cls(int.from_bytes(args, "big") * FEED_UNIT_MM)
    if cls is Dely:
        return Dely(int.from_bytes(args, "big") / 1000)
    if cls is Spin:
        direction = int.from_bytes(args[2:], "big", signed=True)
        if direction not in (-1, 0, 1):
            raise PayloadError(f"SPIN: direction byte 0x{args[2]:02x}; expected 0xff, 0 or 1",
                               ERR_VALUE)
        return Spin(float(int.from_bytes(args[:2], "big")), direction)
    if cls is Cool:
        if args[0] not in (0, 7, 8):
            raise PayloadError(f"COOL: mode {args[0]}; expected 0, 7 or 8", ERR_VALUE)
        return Cool(args[0])
    return cls()


def _decode_prob(args: bytes, machine: Machine) -> Prob:
    """Flags byte, then positions as PMOV: LEN = 3 + 3k; a flag bit other than bit 0 is ERR 3."""
    if not args:
        raise PayloadError("PROB: no argument bytes; expected a flags byte, an axis mask, then "
                           "3 bytes per axis", ERR_LENGTH)
    pairs = unpack_positions("PROB", args[1:], machine, lead=1)
    if args[0] & ~PROB_AWAY:
        raise PayloadError(f"PROB: flags 0x{args[0]:02x}; only bit 0 (0x01: until the probe "
                           "input opens) may be set", ERR_VALUE)
    return Prob(tuple((n, machine.axis(n).to_mm(s)) for n, s in pairs), bool(args[0]))


def _decode_zmov(args: bytes, machine: Machine) -> ZMov:
    if not args or len(args) != 1 + args[0]:
        raise PayloadError(f"ZMOV: {len(args)} argument bytes; expected a count n, then n axis "
                           "bit numbers", ERR_LENGTH)
    names = []
    for bit in args[1:]:
        letter = letter_of(bit, machine)
        if letter is None or letter in names:
            raise PayloadError(f"ZMOV: axis bit {bit} is not an axis of {machine.name} "
                               f"({', '.join(machine.axis_names)}) or is named twice", ERR_VALUE)
        names.append(letter)
    return ZMov(tuple(names))


__all__ = ["HEARTBEAT_MS", "AXIS_LETTERS", "MAX_AXES", "axis_bits", "letter_of", "OPCODES", "COMMAND_OF", "SYNC", "POS_MAX", "FEED_UNIT_MM",
           "PROB_AWAY",
           "PayloadError", "encode_command", "decode_command", "pack_positions",
           "unpack_positions", "ERR_TEXT"]
