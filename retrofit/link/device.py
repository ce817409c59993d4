"""The device end of the link: validate frames, answer them, deliver each command exactly once.

A pure state machine with no clock: bytes go in through ``receive``, the answers come out of
``take_output``. The application is a handler called once per delivered command::

    device = DeviceEndpoint(machine, handler)   # handler(cmd) -> Reply | None (None means ACK)
    device.receive(port.read(64)); port.write(device.take_output())

The handler answers ``Busy()`` when its queue is full (the command is then *not* delivered and
the host resends it later), ``Position``/``Status`` for RDPS/RDST, ``Err`` to refuse. A handler
that raises a RetrofitError, or an answer that its payload cannot carry (a position outside the
24-bit space), is answered ERR: the device never stops serving because of what a frame asked.

Sessions are the device's: a SYNC is answered SESS with a number this device never issued before
(``SessionNumbers``: a counter from a random start), and only frames bound to it (their CRC covers
it) are taken on that channel, so a recorded or foreign byte stream is refused. ``on_frame`` is
called for every intact frame (its CRC checks out, bound or not): the heartbeat's sign of life.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

from ..commands import Command
from ..errors import RetrofitError
from ..machine.config import Machine
from .codec import (
    ERR_LENGTH,
    ERR_NOT_SYNCED,
    ERR_REFUSED,
    ERR_SEQUENCE,
    ERR_VALUE,
    SYNC,
    SYNC_LEN,
    PayloadError,
    decode_command,
)
from .framing import SEQ_MOD, BadFrame, Frame, FrameDecoder, encode_frame, split_seq
from .replies import Ack, Busy, Err, Nak, Reply, Session, encode_reply

Handler = Callable[[Command], "Reply | None"]


@dataclass
class DeviceStats:
    """What the device saw: frames, refusals, duplicates and deliveries."""

    frames: int = 0           # frames with a good CRC
    bad_frames: int = 0       # refused by the framing (length, CRC, escape, truncated)
    naks_sent: int = 0
    duplicates: int = 0       # resends of the last answered frame: answered again, not delivered
    stale_syncs: int = 0      # the SYNC of the running session again: same SESS, nothing rewound
    unbound: int = 0          # intact frames of no running session (replayed, foreign): ERR 4
    busy_sent: int = 0
    errors_sent: int = 0
    delivered: int = 0        # commands handed to the handler and taken by it


class SessionNumbers:
    """Session numbers a device never issued before: a 32-bit counter from a random start."""

    def __init__(self, start: int | None = None):
        self.next = (int.from_bytes(os.urandom(4), "big") if start is None else start) & 0xFFFFFFFF
        self.random_start = start is None

    def __call__(self) -> int:
        number, self.next = self.next, (self.next + 1) & 0xFFFFFFFF
        return number


class DeviceEndpoint:
    """The device side of the link for one machine (whose axes decode the positions)."""

    def __init__(self, machine: Machine, handler: Handler, *,
                 sessions: Callable[[], int] | None = None,
                 on_frame: Callable[[], None] | None = None):
        self.machine = machine
        self.handler = handler
        self.sessions = sessions or SessionNumbers()
        self.on_frame = on_frame
        self.stats = DeviceStats()
        self._last: list[int | None] = [None, None]     # last answered sequence number per channel
        self._answer: list[bytes] = [b"", b""]          # payload of that answer, for duplicates
        self._session: list[int | None] = [None, None]  # the number this device issued the channel
        self._nonce: list[bytes | None] = [None, None]  # the host's nonce in the SYNC that opened it
        self._decoder = FrameDecoder(self._binding)
        self._out = bytearray()

    def _binding(self, seq: int) -> int | None:
        return self._session[seq >> 7]

    def session(self, channel: int) -> int | None:
        """The session number this device issued the channel (None: no session yet)."""
        return self._session[channel]

    def receive(self, data: bytes) -> None:
        """Consume bytes from the host; answers accumulate for ``take_output``."""
        for event in self._decoder.events(data):
            if isinstance(event, BadFrame):
                self.stats.bad_frames += 1
                if event.complete:          # a truncated frame's sender has already moved on
                    self.stats.naks_sent += 1
                    self._send(0, Nak())
            else:
                self.stats.frames += 1
                self._frame(event)

    def take_output(self) -> bytes:
        """The bytes to write to the host since the last call."""
        out, self._out = bytes(self._out), bytearray()
        return out

    def reset(self) -> None:
        """Forget the link state, as a power-up does: the host must SYNC again."""
        self._last, self._answer = [None, None], [b"", b""]
        self._session, self._nonce = [None, None], [None, None]
        self._decoder = FrameDecoder(self._binding)

    def _frame(self, frame: Frame) -> None:
        channel, number = split_seq(frame.seq)
        last = self._last[channel]
        if self.on_frame is not None:
            self.on_frame()                     # an intact frame: a sign of life of a host
        if frame.payload[0] == SYNC and not frame.bound:
            self._sync(channel, number, frame)
        elif not frame.bound or last is None:   # rule 2: of no session this device runs
            self.stats.unbound += 1
            self._error(frame.seq, ERR_NOT_SYNCED, 0, bound=False)
        elif number == last:
            self.stats.duplicates += 1
            self._out += encode_frame(frame.seq, self._answer[channel], self._session[channel])
        elif number != (last + 1) % SEQ_MOD or number == 0:   # a session's numbers never wrap
            self._error(frame.seq, ERR_SEQUENCE if number else ERR_NOT_SYNCED,
                        last if number else 0)
        else:
            self._deliver(channel, number, frame)

    def _sync(self, channel: int, number: int, frame: Frame) -> None:
        """Rule 1: a SYNC opens a new session on the channel, with a number this device never
        issued before; the host's resend of it (its nonce, its sequence number, nothing taken
        since) gets the same SESS again and changes nothing, and so does a late copy of it (frames
        taken since): only a new nonce opens a new session."""
        if len(frame.payload) != SYNC_LEN:
            self._error(frame.seq, ERR_LENGTH, SYNC, bound=False)
        elif frame.payload[1:] == self._nonce[channel] and (session := self._session[channel]) is not None:
            self.stats.stale_syncs += 1          # the running session's SESS again, unbound
            self._out += encode_frame(frame.seq, encode_reply(Session(session), self.machine))
        else:
            self._nonce[channel] = frame.payload[1:]
            self._session[channel] = None          # the SESS answer itself is not bound
            self._answered(channel, number, Session(self.sessions()), frame.seq)
            self._session[channel] = decode_session(self._answer[channel])

    def _deliver(self, channel: int, number: int, frame: Frame) -> None:
        opcode = frame.payload[0]
        try:
            cmd = decode_command(frame.payload, self.machine)
        except PayloadError as exc:
            self.stats.errors_sent += 1
            self._answered(channel, number, Err(exc.code, opcode), frame.seq)
            return
        try:
            reply = self.handler(cmd) or Ack()
        except RetrofitError:                   # the controller refused it
            reply = Err(ERR_REFUSED, opcode)
        try:
            encode_reply(reply)
        except (RetrofitError, ValueError):     # an answer its payload cannot carry
            reply = Err(ERR_VALUE, opcode)
        if isinstance(reply, Busy):
            self.stats.busy_sent += 1
            self._send(frame.seq, reply)
            return
        if isinstance(reply, Err):
            self.stats.errors_sent += 1
        else:
            self.stats.delivered += 1
        self._answered(channel, number, reply, frame.seq)

    def _answered(self, channel: int, number: int, reply: Reply, seq: int) -> None:
        """Record the answer that consumes this sequence number, and send it (bound)."""
        self._last[channel] = number
        self._answer[channel] = encode_reply(reply, self.machine)
        self._out += encode_frame(seq, self._answer[channel], self._session[channel])

    def _error(self, seq: int, code: int, detail: int, bound: bool = True) -> None:
        self.stats.errors_sent += 1
        self._send(seq, Err(code, detail), bound)

    def _send(self, seq: int, reply: Reply, bound: bool = True) -> None:
        session = self._session[seq >> 7] if bound and reply.opcode != Nak.opcode else None
        self._out += encode_frame(seq, encode_reply(reply, self.machine), session)


def decode_session(payload: bytes) -> int:
    """The number in a SESS answer's payload."""
    return int.from_bytes(payload[1:5], "big")
