"""The host end of the link: send each command, resend on NAK or timeout, wait out BUSY.

A pure state machine; time is the ``now`` (seconds, any origin) each call passes in, so a test
runs it on a fake clock and the transport on ``time.monotonic``. Two channels run side by side,
each stop-and-wait: queued commands in order on one, and STOP / RDPS / RDST on the other so they
are never held behind a full queue. A channel's first frame is a SYNC carrying a nonce of the
host's (a new one for every SYNC); the device answers SESS with a session number of its own, and
every later frame of the channel, both ways, is bound to it (its CRC covers the number first).
A session's sequence numbers never wrap: after number 127 the channel opens a new session.

    host = HostEndpoint(machine)
    t = host.send(PMov((("X", 1.0),)), now)
    port.write(host.take_output())
    host.receive(port.read(64), now); host.poll(now)   # until t.done; t.reply is the answer
"""

from __future__ import annotations

import os
import re
from collections import deque
from dataclasses import dataclass, field

from ..commands import Command, Rdps, Rdst
from ..errors import LinkError
from ..machine.config import Machine
from .codec import ERR_LENGTH, ERR_NOT_SYNCED, ERR_SEQUENCE, SYNC, PayloadError, encode_command

#: what the host says of a command it gave up on: the device may have executed it
MAY_HAVE_RUN = "not acknowledged — may have run"
#: the line the firmware sends when it starts, before any frame (docs/protocol.md §1); after a
#: session it means the device restarted: its sessions, queue and position are gone
BANNER = re.compile(rb"retrofit firmware machine=(\S+) link=(\d+) reset=(\S+)\r?\n")
from .framing import IMMEDIATE, QUEUED, SEQ_MOD, BadFrame, FrameDecoder, encode_frame, seq_byte
from .replies import Ack, Busy, Err, Nak, Position, Reply, Session, Status, decode_reply


@dataclass(eq=False)
class Transaction:
    """One command on its way: its answer (``reply``) or why it failed (``error``) once done."""

    cmd: Command | None             # None for the link's own SYNC
    channel: int
    payload: bytes
    reply: Reply | None = None
    error: LinkError | None = None
    sends: int = 0                  # frames sent for it, the first included
    unacknowledged: bool = False    # given up without an answer: it may or may not have run

    @property
    def done(self) -> bool:
        """True once answered or failed."""
        return self.reply is not None or self.error is not None

    @property
    def name(self) -> str:
        """The command's text form (``SYNC`` for the link's own frame)."""
        return "SYNC" if self.cmd is None else str(self.cmd)

    @property
    def expected(self) -> type[Reply]:
        """The kind of answer that completes it: Session for SYNC, Position for RDPS, Status for
        RDST, else Ack."""
        if self.cmd is None:
            return Session
        return {Rdps: Position, Rdst: Status}.get(type(self.cmd), Ack)


@dataclass
class HostStats:
    """What the host did and saw."""

    frames_sent: int = 0
    resends: int = 0
    timeouts: int = 0
    naks: int = 0
    busy: int = 0
    bad_frames: int = 0       # damaged replies (each triggers a resend)
    stale: int = 0            # intact replies to a frame no longer outstanding (ignored)
    unbound: int = 0          # intact replies bound to no session of this host (ignored)
    sessions: int = 0         # sessions the device opened for this host (SESS answers taken)
    restarts: int = 0         # start lines of the device after a session: it restarted


@dataclass(eq=False)
class _Channel:
    number: int
    seq: int = 0                      # sequence number of the current / next frame
    synced: bool = False
    session: int | None = None        # the device's number for the channel (SESS), once synced
    queue: deque = field(default_factory=deque)
    current: Transaction | None = None
    frame: bytes = b""
    tries: int = 0                    # sends since the last sign of life (BUSY resets it)
    deadline: float = 0.0             # resend if no answer by then
    busy_wait: bool = False           # True while waiting out a BUSY before resending
    busy_since: float | None = None   # first BUSY for the current frame


def _current(ch: _Channel) -> Transaction:
    """The channel's frame in flight; a channel asked for one with none is the link's own fault."""
    if ch.current is None:
        raise LinkError(f"serial link, channel {ch.number}: no frame in flight (sequence {ch.seq})")
    return ch.current


class HostEndpoint:
    """The host side of the link for one machine (its axes turn mm into steps)."""

    def __init__(self, machine: Machine, *, timeout_s: float = 0.1, max_tries: int = 10,
                 busy_retry_s: float = 0.05, busy_limit_s: float | None = None,
                 nonce: int | None = None):
        if timeout_s <= 0 or busy_retry_s <= 0 or max_tries < 1:
            raise ValueError("HostEndpoint: timeout_s and busy_retry_s must be > 0, max_tries >= 1")
        self.machine = machine
        self.timeout_s, self.max_tries = timeout_s, max_tries
        self.busy_retry_s, self.busy_limit_s = busy_retry_s, busy_limit_s
        self.stats = HostStats()
        self._channels = (_Channel(QUEUED), _Channel(IMMEDIATE))
        self._decoder = FrameDecoder(lambda seq: self._channels[seq >> 7].session)
        self._out = bytearray()
        self._seen = b""                  # the last bytes received: a start line split in two
        self._failures: list[LinkError] = []
        #: 32-bit nonce of the last SYNC (random by default, so that two host runs differ); each
        #: SYNC takes the next, so the device tells a resend of a SYNC from a new one
        self.nonce = (int.from_bytes(os.urandom(4), "big") if nonce is None else nonce) & 0xFFFFFFFF
        #: True while the nonce is the random default (a seeded LinkBench replaces it)
        self.nonce_is_random = nonce is None

    # -- public API --------------------------------------------------------------------------

    def send(self, cmd: Command, now: float, *, urgent: bool | None = None) -> Transaction:
        """Queue ``cmd`` (encoded at once, so a bad value raises here) and return its Transaction.

        ``urgent`` puts it on the immediate channel; by default STOP, RDPS and RDST go there.
        """
        channel = self._channels[IMMEDIATE if (cmd.immediate if urgent is None else urgent)
                                 else QUEUED]
        t = Transaction(cmd, channel.number, encode_command(cmd, self.machine))
        channel.queue.append(t)
        self._start(channel, now)
        return t

    def receive(self, data: bytes, now: float) -> None:
        """Consume bytes from the device; raises LinkError when a command failed."""
        self._restart_line(data, now)
        for event in self._decoder.events(data):
            if isinstance(event, BadFrame):
                if event.complete:
                    self.stats.bad_frames += 1
                    self._resend_all(now)
                continue
            try:
                reply = decode_reply(event.payload, self.machine)
            except PayloadError:
                self.stats.bad_frames += 1
                self._resend_all(now)
                continue
            if isinstance(reply, Nak):
                self.stats.naks += 1
                self._resend_all(now)
            elif event.bound or isinstance(reply, Session) or (
                    isinstance(reply, Err) and reply.code in (ERR_LENGTH, ERR_NOT_SYNCED)):
                self._answer(event.seq, reply, now)
            else:                       # an answer of no session of ours: replayed or foreign
                self.stats.unbound += 1
        self._raise_failures()

    def _restart_line(self, data: bytes, now: float) -> None:
        """The device's start line after a session: it restarted (a watchdog, a power dip), so
        whatever was outstanding fails at once - its frames, bound to a session the device no
        longer knows, would only be NAKed until the tries ran out."""
        seen = self._seen + data
        found = BANNER.search(seen)
        self._seen = (seen[found.end():] if found else seen)[-80:]
        if not found or not self.stats.sessions:
            return
        self.stats.restarts += 1
        why = (f"the device restarted (reset={found[3].decode('ascii', 'replace')}) — "
               f"{MAY_HAVE_RUN}; its queue and position are lost")
        for ch in self._channels:
            ch.synced = False
            if ch.current is not None:
                ch.current.unacknowledged = True
                self._fail(ch, why, now)

    def poll(self, now: float) -> None:
        """Resend what timed out or waited out its BUSY; raises LinkError when tries run out."""
        for ch in self._channels:
            if ch.current is None:
                continue
            if ch.busy_wait:
                waited = now - (now if ch.busy_since is None else ch.busy_since)
                if self.busy_limit_s is not None and waited >= self.busy_limit_s:
                    self._fail(ch, f"the device answered BUSY for {waited:.3g} s "
                               f"(limit {self.busy_limit_s:g} s)", now)
                elif now >= ch.deadline:
                    ch.busy_wait = False
                    self._transmit(ch, now)
            elif now >= ch.deadline:
                self.stats.timeouts += 1
                self._resend(ch, now)
        self._raise_failures()

    def take_output(self) -> bytes:
        """The bytes to write to the device since the last call."""
        out, self._out = bytes(self._out), bytearray()
        return out

    def next_deadline(self) -> float | None:
        """When ``poll`` next has something to do (None: nothing outstanding)."""
        times = [ch.deadline for ch in self._channels if ch.current is not None]
        return min(times) if times else None

    @property
    def idle(self) -> bool:
        """True when nothing is outstanding or queued."""
        return all(ch.current is None and not ch.queue for ch in self._channels)

    # -- state machine -----------------------------------------------------------------------

    def _start(self, ch: _Channel, now: float) -> None:
        if ch.current is not None or not ch.queue:
            return
        if not ch.synced:
            self.nonce = (self.nonce + 1) & 0xFFFFFFFF
            ch.session = None
            ch.queue.appendleft(Transaction(None, ch.number,
                                            bytes((SYNC,)) + self.nonce.to_bytes(4, "big")))
        ch.current = ch.queue.popleft()
        ch.frame = encode_frame(seq_byte(ch.number, ch.seq), ch.current.payload,
                                None if ch.current.cmd is None else ch.session)
        ch.tries, ch.busy_wait, ch.busy_since = 0, False, None
        self._transmit(ch, now)

    def _transmit(self, ch: _Channel, now: float) -> None:
        t = _current(ch)
        ch.tries += 1
        t.sends += 1
        self.stats.frames_sent += 1
        self.stats.resends += t.sends > 1
        ch.deadline = now + self.timeout_s
        self._out += ch.frame

    def _resend(self, ch: _Channel, now: float) -> None:
        if ch.tries >= self.max_tries:
            _current(ch).unacknowledged = True
            self._fail(ch, f"{MAY_HAVE_RUN} ({ch.tries} tries, {self.timeout_s:g} s timeout each; "
                       "is the device on, at the same baud rate, running the same protocol?)", now)
        else:
            self._transmit(ch, now)

    def _resend_all(self, now: float) -> None:
        for ch in self._channels:
            if ch.current is not None and not ch.busy_wait:
                self._resend(ch, now)

    def _answer(self, seq: int, reply: Reply, now: float) -> None:
        ch = self._channels[seq >> 7]
        if ch.current is None or seq != seq_byte(ch.number, ch.seq):
            self.stats.stale += 1
            return
        if isinstance(reply, Busy):
            self.stats.busy += 1
            ch.tries, ch.busy_wait = 0, True
            ch.busy_since = now if ch.busy_since is None else ch.busy_since
            ch.deadline = now + self.busy_retry_s
        elif isinstance(reply, Err):
            if reply.code in (ERR_NOT_SYNCED, ERR_SEQUENCE):
                ch.synced = False
            self._fail(ch, f"the device refused it: {reply.text()}", now)
        elif not isinstance(reply, ch.current.expected):
            self._fail(ch, f"the device answered {type(reply).__name__.upper()}, expected "
                       f"{ch.current.expected.__name__.upper()}; is it running the same protocol?",
                       now)
        else:
            if ch.current.cmd is None and isinstance(reply, Session):
                ch.synced, ch.session = True, reply.number
                self.stats.sessions += 1
            ch.current.reply = reply
            self._next(ch, now)

    def _fail(self, ch: _Channel, why: str, now: float) -> None:
        t = _current(ch)
        t.error = LinkError(f"serial link, {'immediate' if ch.number else 'queued'} channel: "
                            f"{t.name} (sequence {ch.seq}, sent {t.sends} times): {why}")
        self._failures.append(t.error)
        for dropped in ch.queue:
            dropped.error = LinkError(f"serial link: {dropped.name} not sent, because {t.name} "
                                      "before it failed")
        ch.queue.clear()
        ch.synced = False
        self._next(ch, now)

    def _next(self, ch: _Channel, now: float) -> None:
        ch.seq = (ch.seq + 1) % SEQ_MOD
        if ch.seq == 0:
            ch.synced = False           # a session's numbers never wrap: the next opens another
        ch.current = None
        self._start(ch, now)

    def _raise_failures(self) -> None:
        if self._failures:
            first, self._failures = self._failures[0], []
            raise first
