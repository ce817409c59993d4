"""The CAM link's line protocol (001, SPEC section 7): messages, replies, and the `@` line splitter.

Client -> controller: ASCII messages, each ended by ``@`` (whitespace around a message, such as
a newline after the ``@``, is ignored)::

    A  JX JY JZ  M1 M0  P1 P0  #  S150  F150  T1 34  H  and rows "fx px fy py fz pz"

Controller -> client: one reply per line, ended by ``\\n`` (the CAM side reads whole lines)::

    E1 E0  A  JX JY JZ  "px py pz"  H        and "!<what was wrong; what is accepted>"

The ``!`` error reply is this toolkit's addition; no reply of the paper starts with ``!``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import LinkError

#: a message may hold at most this many bytes before its `@`
MAX_MESSAGE_BYTES = 256
#: the three axes of a row, in order
ROW_AXES = ("X", "Y", "Z")
FEED_LIMIT = 255
#: positions on the link are 32-bit signed pulses
POSITION_LIMIT = 2**31 - 1
MAX_TOOL = 9999
MAX_TOOL_LENGTH_MM = 999
ACCEPTED = ("A, JX/JY/JZ, M1/M0, P1/P0, S<0..255>, F<0..255>, T<tool> <length mm>, H, # "
            "or a row 'fx px fy py fz pz' (feeds -255..255, positions in pulses)")


@dataclass(frozen=True)
class Auto:
    """``A@``: auto mode."""
    def __str__(self) -> str:
        return "A"


@dataclass(frozen=True)
class Jog:
    """``JX@``: jog mode on one axis (ignored while machining)."""
    axis: str
    def __str__(self) -> str:
        return f"J{self.axis}"


@dataclass(frozen=True)
class Machining:
    """``M1@`` machining starts (jog blocked); ``M0@`` it ends (spindle stopped)."""
    on: bool
    def __str__(self) -> str:
        return f"M{int(self.on)}"


@dataclass(frozen=True)
class Operation:
    """``P1@`` / ``P0@``: an operation starts, with / without coolant; rows follow."""
    coolant: bool
    def __str__(self) -> str:
        return f"P{int(self.coolant)}"


@dataclass(frozen=True)
class EndOperation:
    """``#@``: the operation's rows are over (coolant off)."""
    def __str__(self) -> str:
        return "#"


@dataclass(frozen=True)
class Spindle:
    """``S150@``: spindle speed 0..255, clockwise."""
    speed: int
    def __str__(self) -> str:
        return f"S{self.speed}"


@dataclass(frozen=True)
class JogFeed:
    """``F150@``: the jog feedrate 0..255, for every axis."""
    feed: int
    def __str__(self) -> str:
        return f"F{self.feed}"


@dataclass(frozen=True)
class ToolChange:
    """``T1 34@``: change to tool 1, 34 mm long."""
    tool: int
    length_mm: int
    def __str__(self) -> str:
        return f"T{self.tool} {self.length_mm}"


@dataclass(frozen=True)
class Home:
    """``H@``: go to the home position; answered by ``H``."""
    def __str__(self) -> str:
        return "H"


@dataclass(frozen=True)
class Row:
    """One 1 ms trajectory row: feedrate (-255..255) and position (pulses) per axis X, Y, Z."""
    feeds: tuple[int, int, int]
    positions: tuple[int, int, int]

    def __str__(self) -> str:
        return " ".join(f"{f} {p}" for f, p in zip(self.feeds, self.positions))


Message = Auto | Jog | Machining | Operation | EndOperation | Spindle | JogFeed | ToolChange | Home | Row


def format_message(message: Message) -> bytes:
    """The bytes a client sends for ``message``: its text and the closing ``@``."""
    return f"{message}@".encode("ascii")


def _shown(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:37] + "...")


def _int(text: str, what: str, token: str, lo: int, hi: int) -> int:
    if not re.fullmatch(r"[-+]?[0-9]{1,12}", token):
        raise LinkError(f"{_shown(text)}: {what} {_shown(token)} is not a whole number; "
                        f"expected {lo}..{hi}")
    value = int(token)
    if not lo <= value <= hi:
        raise LinkError(f"{_shown(text)}: {what} {value} out of range; accepted {lo}..{hi}")
    return value


def _decode(raw: bytes | str) -> str:
    """The message as text: printable ASCII, surrounding whitespace removed, not empty."""
    data = raw.encode("utf-8") if isinstance(raw, str) else bytes(raw)
    data = data.strip(b" \t\r\n")
    for column, byte in enumerate(data, 1):
        if not 0x20 <= byte <= 0x7E and byte != 0x09:
            raise LinkError(f"byte 0x{byte:02x} at column {column} is not printable ASCII; "
                            "messages are letters, digits, '-', '#' and spaces, ended by '@'")
    if not data:
        raise LinkError(f"empty message before '@'; expected {ACCEPTED}")
    return data.decode("ascii")


def parse_message(raw: bytes | str) -> Message:
    """The message of one line (the bytes before its ``@``); LinkError saying what is wrong."""
    text = _decode(raw)
    head, rest = text[0].upper(), text[1:]
    if head in "0123456789+-":
        return _parse_row(text)
    if head in "AH#" and rest == "":
        return {"A": Auto(), "H": Home(), "#": EndOperation()}[head]
    if head == "J" and rest.upper() in ROW_AXES:
        return Jog(rest.upper())
    if head in "MP" and rest in ("0", "1"):
        return Machining(rest == "1") if head == "M" else Operation(rest == "1")
    if head == "S" and rest:
        return Spindle(_int(text, "spindle speed", rest, 0, FEED_LIMIT))
    if head == "F" and rest:
        return JogFeed(_int(text, "jog feedrate", rest, 0, FEED_LIMIT))
    if head == "T" and rest:
        return _parse_tool(text, rest)
    if head in "AHJMPSFT#":
        forms = {"A": "A", "H": "H", "#": "#", "J": "JX, JY or JZ", "M": "M1 or M0",
                 "P": "P1 or P0", "S": "S<0..255>", "F": "F<0..255>", "T": "T<tool> <length mm>"}
        raise LinkError(f"{_shown(text)}: malformed; expected {forms[head]}")
    raise LinkError(f"unknown command {_shown(text)}; accepted: {ACCEPTED}")


def _parse_tool(text: str, rest: str) -> ToolChange:
    parts = rest.split()
    if len(parts) != 2 or rest[0].isspace():
        raise LinkError(f"{_shown(text)}: malformed; expected T<tool> <length mm>, e.g. T1 34")
    return ToolChange(_int(text, "tool number", parts[0], 0, MAX_TOOL),
                      _int(text, "tool length", parts[1], 0, MAX_TOOL_LENGTH_MM))


def _parse_row(text: str) -> Row:
    parts = text.split()
    if len(parts) != 6:
        raise LinkError(f"{_shown(text)}: a row has 6 numbers 'fx px fy py fz pz', not {len(parts)}")
    feeds = tuple(_int(text, f"feedrate {a}", parts[2 * i], -FEED_LIMIT, FEED_LIMIT)
                  for i, a in enumerate(ROW_AXES))
    positions = tuple(_int(text, f"position {a}", parts[2 * i + 1], -POSITION_LIMIT, POSITION_LIMIT)
                      for i, a in enumerate(ROW_AXES))
    return Row(feeds, positions)


class LineSplitter:
    """Rebuilds ``@``-ended messages from the byte stream of a TCP socket.

    :meth:`feed` returns, in order, each complete message's bytes (without the ``@``) or a
    LinkError for a message longer than :data:`MAX_MESSAGE_BYTES`; the rest of that over-long
    message, up to its ``@``, is dropped.
    """

    def __init__(self, limit: int = MAX_MESSAGE_BYTES):
        self.limit = limit
        self.buffer = bytearray()
        self.skipping = False      # inside an over-long message, waiting for its '@'

    def feed(self, data: bytes) -> list[bytes | LinkError]:
        """Add received bytes; return the messages (and errors) they complete."""
        out: list[bytes | LinkError] = []
        self.buffer += data
        while True:
            at = self.buffer.find(b"@")
            if at < 0:
                if len(self.buffer) > self.limit:
                    if not self.skipping:
                        out.append(self._too_long())
                        self.skipping = True
                    self.buffer.clear()
                return out
            message = bytes(self.buffer[:at])
            del self.buffer[:at + 1]
            if self.skipping:
                self.skipping = False
            elif len(message) > self.limit:
                out.append(self._too_long())
            else:
                out.append(message)

    def _too_long(self) -> LinkError:
        return LinkError(f"message longer than {self.limit} bytes before its '@' (dropped up to the "
                         f"next '@'); messages are at most {self.limit} bytes")


# -- replies (controller -> client) --------------------------------------------------------------

REPLY_END = b"\n"
_REPLY = re.compile(r"E[01]|A|J[XYZ]|H|-?[0-9]+ -?[0-9]+ -?[0-9]+|![^\n]*")


def format_reply(text: str) -> bytes:
    """A reply line as sent: its text and ``\\n``."""
    return text.replace("\n", " ").encode("ascii", "replace") + REPLY_END


def format_position(positions) -> str:
    """The ``PosX PosY PosZ`` reply, in pulses."""
    return " ".join(str(int(p)) for p in positions)


def error_reply(error: Exception) -> str:
    """The ``!`` reply for a refused message."""
    return "!" + str(error).replace("\n", " ")


def is_reply(line: str) -> bool:
    """True if ``line`` (without its newline) is one of the controller's replies."""
    return _REPLY.fullmatch(line) is not None


def parse_position(line: str) -> tuple[int, int, int] | None:
    """The pulses of a ``PosX PosY PosZ`` reply, or None if ``line`` is another reply."""
    if re.fullmatch(r"-?[0-9]+ -?[0-9]+ -?[0-9]+", line):
        x, y, z = (int(v) for v in line.split())
        return x, y, z
    return None
