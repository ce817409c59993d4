"""A host written in advance: frames for a device whose session numbers are known ahead.

A test or a benchmark that feeds the firmware in simavr a script of timed bytes cannot wait for
the SESS answer before it binds the next frame (docs/protocol.md §4). It need not: simavr starts
the firmware with a zeroed EEPROM, so its sessions are ``0x00010000``, ``0x00010001``, ... in the
order it answers the SYNCs. ``ScriptedHost`` numbers and binds frames on that assumption, opens a
new session before a channel's numbers would wrap, and makes keep-alive frames (an RDST bound to
no session: answered ERR 4, no state changes) that hold off the heartbeat over a long silent move.
``replies`` reads the answers back, following the sessions the SESS answers name.

    >>> from retrofit.machine.config import load_machine
    >>> host = ScriptedHost(load_machine("chivu-lathe"))
    >>> host.sync(QUEUED).hex(" ")
    '7e 05 00 7f 5e ed 00 01 49 39 8c 33'
    >>> host.frame("PMOV X12.5 Z-3").hex(" ")
    '7e 08 01 04 05 00 01 f4 ff ff 6a 6a 4c 3c 31'
"""

from __future__ import annotations

from ..commands import Command, Rdst, parse_command
from ..machine.config import Machine
from .codec import ERR_NOT_SYNCED, SYNC, encode_command
from .framing import IMMEDIATE, QUEUED, SEQ_MOD, BadFrame, FrameDecoder, encode_frame, seq_byte
from .replies import Err, Reply, Session, decode_reply

#: the first session number of the firmware in simavr (boot 1: a zeroed EEPROM, counted up)
SIMAVR_FIRST_SESSION = 0x00010000
#: how often keep-alive frames come (s): well inside the heartbeat's 500 ms
KEEPALIVE_S = 0.2
#: copies of the SYNC that opens a channel's next session inside a script: the host cannot see
#: whether it arrived (on a line that drops frames a lost SYNC would leave the script's sessions
#: one ahead of the device's), and the device answers a copy with the same SESS
SYNC_COPIES = 3


class ScriptedHost:
    """Frames numbered and bound as a host would send them, the device's answers not awaited."""

    def __init__(self, machine: Machine, *, first_session: int = SIMAVR_FIRST_SESSION,
                 nonce: int = 0x5EED0000):
        self.machine = machine
        self.next = {QUEUED: 0, IMMEDIATE: 0}
        self.sessions: dict[int, int | None] = {QUEUED: None, IMMEDIATE: None}
        self._issue, self.nonce = first_session, nonce

    def sync(self, channel: int) -> bytes:
        """The SYNC that opens the channel's next session (the device's next number)."""
        self.nonce = (self.nonce + 1) & 0xFFFFFFFF
        number = self.next[channel]
        frame = encode_frame(seq_byte(channel, number), bytes((SYNC,)) + self.nonce.to_bytes(4, "big"))
        self.sessions[channel], self._issue = self._issue, self._issue + 1
        self.next[channel] = (number + 1) % SEQ_MOD
        return frame

    def frame(self, cmd: Command | str | None = None, *, payload: bytes | None = None,
              channel: int | None = None) -> bytes:
        """The next frame of ``cmd`` (or of a raw ``payload``, on ``channel``), bound to its
        channel's session; preceded by a SYNC when the channel has none or its numbers ran out."""
        if payload is None:
            cmd = parse_command(cmd) if isinstance(cmd, str) else cmd
            assert cmd is not None               # a frame carries a command or a payload
            payload = encode_command(cmd, self.machine)
            channel = (IMMEDIATE if cmd.immediate else QUEUED) if channel is None else channel
        elif channel is None:
            raise ValueError("ScriptedHost.frame: a raw payload needs its channel")
        opened = b""
        if self.sessions[channel] is None or self.next[channel] == 0:
            opened = self.sync(channel)
            opened *= SYNC_COPIES       # a copy is answered the same SESS: a lost one costs nothing
        number = self.next[channel]
        self.next[channel] = (number + 1) % SEQ_MOD
        return opened + encode_frame(seq_byte(channel, number), payload, self.sessions[channel])

    def keepalive(self) -> bytes:
        """A frame of no session: the device answers ERR 4 and counts it a sign of life."""
        return encode_frame(seq_byte(IMMEDIATE, 0), encode_command(Rdst(), self.machine))

    def replies(self, data: bytes, *, keepalives: bool = False) -> list[Reply]:
        """The device's answers in ``data``, each checked against the session it was bound to
        (learnt from the SESS answers as they come); the keep-alives' ERR 4 left out unless
        ``keepalives``. Damaged answers are left out."""
        sessions: dict[int, int | None] = {QUEUED: None, IMMEDIATE: None}
        out = []
        for f in FrameDecoder(lambda seq: sessions[seq >> 7]).events(data):
            if isinstance(f, BadFrame):
                continue
            reply = decode_reply(f.payload, self.machine)
            if isinstance(reply, Session):
                sessions[f.seq >> 7] = reply.number
            if keepalives or f.bound or reply != Err(ERR_NOT_SYNCED, 0):
                out.append(reply)
        return out
