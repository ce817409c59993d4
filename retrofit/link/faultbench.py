"""Many commands through a noisy simulated line, and the tally a user cares about.

``run_faults`` sends a seeded program of distinct commands from a HostEndpoint through two
FaultyWires to a DeviceEndpoint whose controller model holds three commands (BUSY beyond), on
the simulated clock of LinkBench, and counts per channel what the device delivered against what
the host sent: lost, duplicated, corrupted (delivered but never sent), out of order.

    >>> tally = run_faults(300, seed=1, flip=0.02, drop=0.01, duplicate=0.01, insert=0.005)
    >>> (tally.commands, tally.lost, tally.duplicated, tally.corrupted, tally.in_order)
    (300, 0, 0, 0, True)
"""

from __future__ import annotations

import random
from collections import Counter, deque
from dataclasses import dataclass, field

from ..commands import FFdr, FMov, Init, MFdr, PMov, Rdps, Rdst
from ..errors import LinkError
from ..machine.config import Machine, load_machine
from .codec import FEED_UNIT_MM, encode_command
from .crc import crc16_ccitt_false
from .device import DeviceEndpoint, SessionNumbers
from .framing import IMMEDIATE, QUEUED, SOF, Frame, FrameDecoder, encode_frame, stuff
from .host import HostEndpoint
from .replies import Busy, Position, Status, StatusFlags
from .simwire import FaultyWire, LinkBench


class QueueDevice:
    """002's controller as the link sees it: three queued commands ahead, each runs ``run_s``."""

    def __init__(self, machine: Machine, depth: int = 3, run_s: float = 0.004):
        self.machine, self.depth, self.run_s = machine, depth, run_s
        self.now, self.finish = 0.0, 0.0
        self.queue: deque = deque()
        self.delivered: list = []       # (channel, command) in delivery order
        self.answers: list = []         # what RDPS / RDST were answered, in order
        self.steps = {a.name: 0 for a in machine.axes}

    def advance(self, now: float) -> None:
        """Simulated time ``now``: finish the commands whose run has ended."""
        self.now = now
        while self.queue and self.finish <= now:
            self.queue.popleft()
            self.finish += self.run_s

    def handle(self, cmd):
        """The device handler: BUSY when three wait, POS / STAT for the reads, else take it."""
        if isinstance(cmd, (Rdps, Rdst)):
            answer = (Position(tuple(self.steps.items())) if isinstance(cmd, Rdps)
                      else Status(StatusFlags.MOVING if self.queue else StatusFlags(0),
                                  len(self.queue)))
            self.delivered.append((IMMEDIATE, cmd))
            self.answers.append(answer)
            return answer
        if len(self.queue) >= self.depth:
            return Busy()
        if not self.queue:
            self.finish = self.now + self.run_s
        self.queue.append(cmd)
        if isinstance(cmd, (PMov, FMov)):
            self.steps.update({n: self.machine.axis(n).to_steps(mm) for n, mm in cmd.axes})
        self.delivered.append((QUEUED, cmd))
        return None


def program(machine: Machine, n: int, rng: random.Random) -> list:
    """``n`` commands, nearly all distinct: mostly moves on whole steps, some feeds and reads."""
    x, z = machine.axis("X"), machine.axis("Z")
    cmds: list = [Init()]
    for _ in range(1, n):
        r = rng.random()
        if r < 0.05:
            cmds.append(Rdps())
        elif r < 0.07:
            cmds.append(Rdst())
        elif r < 0.09:
            cmds.append(rng.choice((FFdr, MFdr))(rng.randrange(1, 10**8) * FEED_UNIT_MM))
        else:
            xs, zs = rng.randrange(-400_000, 400_000), rng.randrange(-400_000, 400_000)
            cls = PMov if r < 0.8 else FMov
            cmds.append(cls((("X", xs / x.steps_per_mm), ("Z", zs / z.steps_per_mm))))
    return cmds


@dataclass
class Tally:
    """What arrived, against what was sent."""

    commands: int = 0
    given_up: int = 0               # commands the host gave up on ("may have run")
    lost: int = 0                   # sent, answered, never delivered
    duplicated: int = 0             # delivered more often than sent
    corrupted: int = 0              # delivered but never sent
    in_order: bool = True           # each channel delivered exactly the sent sequence
    wrong_answers: int = 0          # RDPS / RDST answers that were not the device's
    simulated_s: float = 0.0
    frames_sent: int = 0
    bad_frames_seen: int = 0        # damaged frames both ends refused
    wire: dict = field(default_factory=dict)

    def add(self, other: Tally) -> None:
        """Accumulate another shard's tally."""
        for name in ("commands", "given_up", "lost", "duplicated", "corrupted", "wrong_answers",
                     "frames_sent", "bad_frames_seen"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.simulated_s += other.simulated_s
        self.in_order = self.in_order and other.in_order
        for key, value in other.wire.items():
            self.wire[key] = self.wire.get(key, 0) + value


def run_faults(n: int, *, seed: int, flip: float, drop: float, duplicate: float, insert: float,
               late: int = 3, max_tries: int = 60, machine: Machine | None = None) -> Tally:
    """Send ``n`` commands through two faulty wires; the Tally of what the device delivered."""
    machine = machine or load_machine("chivu-lathe")
    rng = random.Random(seed)
    ctl = QueueDevice(machine)
    host = HostEndpoint(machine, timeout_s=0.02, max_tries=max_tries, busy_retry_s=0.005,
                        nonce=rng.getrandbits(32))
    device = DeviceEndpoint(machine, ctl.handle, sessions=SessionNumbers(rng.getrandbits(32)))
    wires = [FaultyWire(random.Random(seed * 7 + k), flip=flip, drop=drop, insert=insert,
                        duplicate=duplicate, late=late) for k in (1, 2)]
    bench = LinkBench(host, device, to_device=wires[0], to_host=wires[1], rng=rng,
                      on_time=ctl.advance)
    todo, sent = deque(program(machine, n, rng)), []
    active: list = []
    while todo or not host.idle:
        while todo and len(active) < 2:          # a front end feeding the host as it drains
            active.append(host.send(todo.popleft(), bench.now))
            sent.append(active[-1])
        try:
            bench.step()
        except LinkError:                        # a give-up: counted in the tally, the run goes on
            pass
        active = [t for t in active if not t.done]
    return _tally(sent, ctl, host, device, wires, bench.now)


def _tally(sent, ctl, host, device, wires, now) -> Tally:
    t = Tally(commands=len(sent), simulated_s=now, frames_sent=host.stats.frames_sent,
              bad_frames_seen=host.stats.bad_frames + device.stats.bad_frames)
    t.given_up = sum(1 for tr in sent if tr.error is not None)
    for channel in (QUEUED, IMMEDIATE):
        wanted = [tr.cmd for tr in sent if tr.channel == channel and tr.error is None]
        got = [c for ch, c in ctl.delivered if ch == channel]
        for tr in sent:                          # a command given up on may have run: not counted
            if tr.channel == channel and tr.unacknowledged and tr.cmd in got:
                got.remove(tr.cmd)
        w, g = Counter(wanted), Counter(got)
        t.lost += sum((w - g).values())
        t.corrupted += sum(count for cmd, count in g.items() if cmd not in w)
        t.duplicated += sum(count - w[cmd] for cmd, count in g.items() if cmd in w and
                            count > w[cmd])
        t.in_order = t.in_order and got == wanted
    reads = [tr.reply for tr in sent if isinstance(tr.cmd, (Rdps, Rdst)) and tr.error is None]
    t.wrong_answers = sum(a != b for a, b in zip(reads, ctl.answers)) + abs(len(reads)
                                                                             - len(ctl.answers))
    for w in wires:
        for key, value in vars(w.stats).items():
            t.wire[key] = t.wire.get(key, 0) + value
    return t


class Crc16Decoder(FrameDecoder):
    """The receiver of protocol version 1 (CRC-16/CCITT-FALSE), to compare what it lets through."""

    crc_bytes = 2
    check = staticmethod(crc16_ccitt_false)


def crc16_frame(seq: int, payload: bytes) -> bytes:
    """A version 1 frame: the body ends in a CRC-16 instead of the CRC-32."""
    body = bytes((len(payload), seq)) + payload
    return bytes((SOF,)) + stuff(body + crc16_ccitt_false(body).to_bytes(2, "big"))


@dataclass
class CrcEscapes:
    """Damaged frames, and how many each check accepted as good with changed contents."""

    frames: int = 0
    damaged: int = 0
    passed: dict = field(default_factory=lambda: {"CRC-16": 0, "CRC-32": 0})


def crc_escapes(frames: int, *, seed: int, flip: float, drop: float, insert: float,
                machine: Machine | None = None) -> CrcEscapes:
    """Send ``frames`` command frames, each as version 1 and as version 2, through the same faults.

    A frame is *damaged* when its bytes changed; it *passed* a check when the receiver took it as
    a good frame whose sequence byte or payload differs from what was sent.
    """
    machine = machine or load_machine("chivu-lathe")
    rng = random.Random(seed)
    payloads = [encode_command(c, machine) for c in program(machine, 4096, rng)]
    out = CrcEscapes()
    for kind, encode, decoder_class in (("CRC-16", crc16_frame, Crc16Decoder),
                                        ("CRC-32", encode_frame, FrameDecoder)):
        wire = FaultyWire(random.Random(seed + 1), flip=flip, drop=drop, insert=insert)
        decoder, damaged = decoder_class(), 0
        for i in range(frames):
            seq, payload = i & 0xFF, payloads[i % len(payloads)]
            sent = encode(seq, payload)
            got = wire.carry(sent)
            damaged += got != sent
            for event in decoder.feed(got + bytes((SOF,))):     # the next frame's start
                if isinstance(event, Frame) and (event.seq, event.payload) != (seq, payload):
                    out.passed[kind] += 1
        out.frames, out.damaged = frames, damaged
    return out
