"""A host that sends frames byte by byte with the sequence numbers a test chooses.

The library's HostLink hides resends, BUSY and duplicates; a conformance test needs to see
them, so this client sends exactly the frames it is told to and hands back every answer frame.
"""

from __future__ import annotations

import random
import time

import serial

from retrofit.commands import Command, Rdps, Rdst, parse_command
from retrofit.link import (
    IMMEDIATE,
    QUEUED,
    BadFrame,
    FrameDecoder,
    Position,
    Reply,
    Session,
    Status,
    StatusFlags,
    decode_reply,
    encode_command,
    encode_frame,
    seq_byte,
)
from retrofit.machine.config import Machine

SYNC = bytes((0x7F,))        # then the host's 32-bit nonce; answered SESS with the device's number


class RawLink:
    """A connection to a device with per-channel sequence numbers kept by hand."""

    def __init__(self, url: str, machine: Machine, answer_timeout_s: float = 15.0):
        self.machine = machine
        self.port = _connect(url)
        self.timeout_s = answer_timeout_s
        #: the session number the device gave each channel (its frames are bound to it)
        self.sessions: dict[int, int | None] = {QUEUED: None, IMMEDIATE: None}
        self.decoder = FrameDecoder(lambda seq: self.sessions[seq >> 7])
        self.pending: list = []
        self.next = {QUEUED: 0, IMMEDIATE: 0}
        self.nonce = random.getrandbits(32)      # each connection its own

    def close(self) -> None:
        self.port.close()

    # -- bytes and frames ------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        self.port.write(data)

    def frame(self, channel: int, number: int, payload: bytes) -> bytes:
        """A frame bound to the channel's session (plain before its SYNC, and for a SYNC)."""
        session = None if payload[:1] == SYNC else self.sessions[channel]
        return encode_frame(seq_byte(channel, number), payload, session)

    def answers(self, count: int = 1, timeout_s: float | None = None) -> list:
        """The next ``count`` answer frames (Frame or BadFrame); fewer if the time runs out."""
        end = time.monotonic() + (self.timeout_s if timeout_s is None else timeout_s)
        while len(self.pending) < count and time.monotonic() < end:
            data = self.port.read(256)
            if data:
                self.pending += self.decoder.feed(data)
        out, self.pending = self.pending[:count], self.pending[count:]
        return out

    def answer(self):
        """The next answer frame; AssertionError if none comes."""
        got = self.answers(1)
        assert got, "the device did not answer within the timeout"
        assert not isinstance(got[0], BadFrame), f"a damaged answer: {got[0]}"
        return got[0]

    def answer_bytes(self) -> bytes:
        """The next answer frame as its wire bytes (the decoder checked its CRC)."""
        got = self.answer()
        return encode_frame(got.seq, got.payload, self.sessions[got.seq >> 7] if got.bound else None)

    def silence(self, wait_s: float = 0.3) -> list:
        """Whatever arrives within ``wait_s`` (a test that expects no answer wants [])."""
        return self.answers(1, wait_s)

    # -- exchanges ---------------------------------------------------------------------------

    def exchange(self, channel: int, number: int, payload: bytes) -> tuple[int, Reply]:
        """Send one frame; the sequence byte and the decoded reply of its answer."""
        self.write(self.frame(channel, number, payload))
        got = self.answer()
        return got.seq, decode_reply(got.payload, self.machine)

    def sync(self, channel: int, number: int = 0) -> Reply:
        self.nonce = (self.nonce + 1) & 0xFFFFFFFF         # a new nonce each SYNC, as a host does
        seq, reply = self.exchange(channel, number, SYNC + self.nonce.to_bytes(4, "big"))
        assert seq == seq_byte(channel, number)
        assert isinstance(reply, Session), f"SYNC answered {reply}"
        self.sessions[channel] = reply.number
        self.next[channel] = (number + 1) % 128
        return reply

    def sync_both(self) -> None:
        self.sync(QUEUED)
        self.sync(IMMEDIATE)

    def send(self, cmd: Command | str, channel: int | None = None) -> Reply:
        """Send a command with the channel's next number; its reply (BUSY does not advance)."""
        cmd = parse_command(cmd) if isinstance(cmd, str) else cmd
        channel = (IMMEDIATE if cmd.immediate else QUEUED) if channel is None else channel
        if self.next[channel] == 0 and self.sessions[channel] is not None:
            self.sync(channel)                   # a session's numbers never wrap: a new one
        number = self.next[channel]
        seq, reply = self.exchange(channel, number, encode_command(cmd, self.machine))
        assert seq == seq_byte(channel, number), f"answer to {cmd} carries sequence byte {seq:#x}"
        if type(reply).__name__ != "Busy":
            self.next[channel] = (number + 1) % 128
        return reply

    def status(self) -> Status:
        reply = self.send(Rdst())
        assert isinstance(reply, Status), reply
        return reply

    def position(self) -> dict[str, int]:
        reply = self.send(Rdps())
        assert isinstance(reply, Position), reply
        return dict(reply.steps)

    def wait_idle(self, timeout_s: float = 120.0, poll_s: float = 0.02) -> Status:
        """RDST until nothing moves, dwells or waits in the queue (a ceiling, not a pace: a device
        on a busy host runs its machine slower than the clock on the wall)."""
        end = time.monotonic() + timeout_s
        while True:
            st = self.status()
            if not st.flags & (StatusFlags.MOVING | StatusFlags.DWELLING) and st.queued == 0:
                return st
            assert time.monotonic() < end, f"still busy after {timeout_s} s: {st}"
            time.sleep(poll_s)

    def send_until_accepted(self, cmd: Command | str, timeout_s: float = 120.0) -> Reply:
        """Send, and resend after BUSY, as a host does; the first answer that is not BUSY."""
        end = time.monotonic() + timeout_s
        while True:
            reply = self.send(cmd)
            if type(reply).__name__ != "Busy":
                return reply
            assert time.monotonic() < end, f"{cmd} still BUSY after {timeout_s} s"
            time.sleep(0.02)


def _connect(url: str, timeout_s: float = 20.0):
    """Open the device's socket, retrying while it starts."""
    end = time.monotonic() + timeout_s
    while True:
        try:
            return serial.serial_for_url(url, timeout=0.01)
        except (OSError, serial.SerialException):
            if time.monotonic() > end:
                raise
            time.sleep(0.05)
