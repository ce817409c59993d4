"""The device end of the link: validate frames, answer them, deliver each command exactly once.

A pure state machine with no clock: bytes go in through ``receive``, the answers come out of
``take_output``. The application is a handler called once per delivered command::

    device = DeviceEndpoint(machine, handler)   # handler(cmd) -> Reply | None (None means ACK)
    device.receive(port.read(64)); port.write(device.take_output())

The handler answers ``Busy()`` when its queue is full (the command is then *not* delivered and
the host resends it later), ``Position``/``Status`` for RDPS/RDST, ``Err`` to refuse. A handler
that raises a RetrofitError, or an answer that its payload cannot carry (a position outside the
24-bit space), is answered ERR: the device never stops serving because of what a frame asked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..commands import Command
from ..config import Machine
from ..errors import RetrofitError
from .codec import (ERR_LENGTH, ERR_NOT_SYNCED, ERR_REFUSED, ERR_SEQUENCE, ERR_VALUE, SYNC,
                    SYNC_LEN, PayloadError, decode_command)
from .framing import SEQ_MOD, BadFrame, Frame, FrameDecoder, encode_frame, split_seq
from .replies import Ack, Busy, Err, Nak, Reply, encode_reply

Handler = Callable[[Command], "Reply | None"]


@dataclass
class DeviceStats:
    """What the device saw: frames, refusals, duplicates and deliveries."""

    frames: int = 0           # frames with a good CRC
    bad_frames: int = 0       # refused by the framing (length, CRC, escape, truncated)
    naks_sent: int = 0
    duplicates: int = 0       # resends of the last answered frame: answered again, not delivered
    stale_syncs: int = 0      # SYNC of the running session again: answered ACK, nothing rewound
    busy_sent: int = 0
    errors_sent: int = 0
    delivered: int = 0        # commands handed to the handler and taken by it


class DeviceEndpoint:
    """The device side of the link for one machine (whose axes decode the positions)."""

    def __init__(self, machine: Machine, handler: Handler):
        self.machine = machine
        self.handler = handler
        self.stats = DeviceStats()
        self._decoder = FrameDecoder()
        self._last: list[int | None] = [None, None]     # last answered sequence number per channel
        self._answer: list[bytes] = [b"", b""]          # payload of that answer, for duplicates
        self._session: list[bytes | None] = [None, None]  # session of the channel's last SYNC
        self._out = bytearray()

    def receive(self, data: bytes) -> None:
        """Consume bytes from the host; answers accumulate for ``take_output``."""
        for event in self._decoder.feed(data):
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
        self._last, self._answer, self._session = [None, None], [b"", b""], [None, None]
        self._decoder = FrameDecoder()

    def _frame(self, frame: Frame) -> None:
        channel, number = split_seq(frame.seq)
        last = self._last[channel]
        if frame.payload[0] == SYNC:
            self._sync(channel, number, frame)
        elif last is None:
            self._error(frame.seq, ERR_NOT_SYNCED, 0)
        elif number == last:
            self.stats.duplicates += 1
            self._out += encode_frame(frame.seq, self._answer[channel])
        elif number != (last + 1) % SEQ_MOD:
            self._error(frame.seq, ERR_SEQUENCE, last)
        else:
            self._deliver(channel, number, frame)

    def _sync(self, channel: int, number: int, frame: Frame) -> None:
        """Rule 1: a SYNC of a new session restarts the channel; one of the running session
        (a resend or a stale copy) is answered ACK and changes nothing, so it cannot rewind."""
        if len(frame.payload) != SYNC_LEN:
            self._error(frame.seq, ERR_LENGTH, SYNC)
        elif self._last[channel] is not None and frame.payload[1:] == self._session[channel]:
            self.stats.stale_syncs += 1
            self._send(frame.seq, Ack())
        else:
            self._session[channel] = frame.payload[1:]
            self._answered(channel, number, Ack(), frame.seq)

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
        """Record the answer that consumes this sequence number, and send it."""
        self._last[channel] = number
        self._answer[channel] = encode_reply(reply, self.machine)
        self._out += encode_frame(seq, self._answer[channel])

    def _error(self, seq: int, code: int, detail: int) -> None:
        self.stats.errors_sent += 1
        self._send(seq, Err(code, detail))

    def _send(self, seq: int, reply: Reply) -> None:
        self._out += encode_frame(seq, encode_reply(reply, self.machine))
