"""The serial link of 002: framed, CRC-checked, sequenced commands with ACK/NAK/BUSY and resend.

The wire format is specified in docs/protocol.md. Layers, bottom up:

- ``crc``: CRC-32 (zlib's);
- ``framing``: SOF, length, sequence byte, payload, CRC, byte stuffing; ``FrameDecoder``;
- ``codec`` / ``replies``: the payload of every command and reply;
- ``host`` / ``device``: the two endpoints as clock-free state machines;
- ``transport``: the endpoints over a pyserial-like port (pyserial imported only there, lazily);
- ``probing``: a probing move (PROB) over a HostLink: sent, waited for, PROBED and RDPS read;
- ``simwire``: a seeded noisy line joining both endpoints on a simulated clock (tests, labs).
"""

from .codec import AXIS_LETTERS, FEED_UNIT_MM, OPCODES, POS_MAX, PayloadError, decode_command, encode_command
from .crc import crc32
from .device import DeviceEndpoint, DeviceStats, SessionNumbers
from .framing import IMMEDIATE, MAX_PAYLOAD, QUEUED, BadFrame, Frame, FrameDecoder, encode_frame, seq_byte
from .host import HostEndpoint, HostStats, Transaction
from .probing import ProbeResult, probe_over_link
from .replies import Ack, Busy, Err, Nak, Position, Reply, Session, Status, StatusFlags, decode_reply, encode_reply
from .transport import DeviceLink, HostLink, open_port

__all__ = [
    "AXIS_LETTERS", "FEED_UNIT_MM", "OPCODES", "POS_MAX", "PayloadError", "decode_command",
    "encode_command", "crc32", "DeviceEndpoint", "DeviceStats", "SessionNumbers", "IMMEDIATE",
    "MAX_PAYLOAD", "QUEUED", "BadFrame", "Frame", "FrameDecoder", "encode_frame", "seq_byte",
    "HostEndpoint", "HostStats", "Transaction", "Ack", "Busy", "Err", "Nak", "Position", "Reply",
    "Session", "Status", "StatusFlags", "decode_reply", "encode_reply", "DeviceLink", "HostLink", "open_port",
    "ProbeResult", "probe_over_link",
]
