"""A seeded random stress run of the firmware in simavr, held to its plan on the pins and on RDPS.

Moves on 1 to 4 axes at random ratios and at every rate up to (and past) the firmware's own limit
go through the host's link endpoint (:class:`retrofit.link.host.HostEndpoint`: BUSY waited out,
NAKs and timeouts resent) to the harness over TCP, in batches that fill the queue; RDST is polled
every 2-20 ms while they run; random garbage goes on the line between frames and bytes are
dropped from frames. After each batch, at rest, RDPS is read: the answer must be the sum of the
commanded moves, and so must the harness's count of the step pins at the cycle the answer left
the board. :func:`check` lists every mismatch (empty: the run held).

    >>> run = stress_run(elf, machine, seed=7, moves=40)      # doctest: +SKIP
    >>> check(run, machine)                                   # doctest: +SKIP
    []
"""

from __future__ import annotations

import random
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..commands import parse_command
from ..link import BadFrame, FrameDecoder, decode_reply
from ..link.codec import PayloadError
from ..link.host import HostEndpoint
from ..link.replies import Position, Session, Status, StatusFlags, flag_names
from ..machine.config import Machine
from .sim import Harness, HarnessLog, step_times


def keep_rates(firmware: Path | None = None) -> dict[str, list[float]]:
    """The firmware's own ceiling on a line's base rate (steps/s) by the number of moving axes
    (1 to 5), for lines whose axes all step at every event ("plain") and for lines with Bresenham
    axes ("bres"): the KEEP_RATE tables of firmware/planner.c."""
    import re

    from .sim import FIRMWARE
    text = ((firmware or FIRMWARE) / "planner.c").read_text()
    out = {}
    for kind, name in (("plain", "KEEP_RATE_PLAIN"), ("bres", "KEEP_RATE_BRES"),
                       ("steps", "KEEP_RATE_STEPS_BRES")):
        m = re.search(rf"#define {name}\s+\{{([^}}]*)\}}", text)
        out[kind] = [float(v.strip().rstrip("f")) for v in m.group(1).split(",")]
    return out


def keep_rate(ratios) -> float:
    """The firmware's ceiling for a line whose axes step at ``ratios`` of its base axis (three or
    more axes in Bresenham ratios: also the sum of steps a second, KEEP_RATE_STEPS_BRES)."""
    rates = keep_rates()
    if all(r == 1 for r in ratios):
        return rates["plain"][len(ratios) - 1]
    keep = rates["bres"][len(ratios) - 1]
    if len(ratios) >= 3:
        keep = min(keep, rates["steps"][len(ratios) - 1] / sum(ratios))
    return keep


@dataclass
class Move:
    """One commanded move: its end point (steps, machine axes in order) and base-axis rate."""

    target: tuple[int, ...]
    rate: float                       # steps/s of its base axis asked for (the firmware may clamp)


@dataclass
class StressRun:
    """What a run commanded and saw."""

    seed: int
    moves: list[Move] = field(default_factory=list)
    expected: list[dict] = field(default_factory=list)      # planned position at each RDPS
    checkpoints: list[dict] = field(default_factory=list)   # what RDPS answered there
    statuses: list[int] = field(default_factory=list)                  # RDST flags seen
    garbage_bytes: int = 0
    dropped_bytes: int = 0
    log: HarnessLog | None = None
    link: dict = field(default_factory=dict)
    error: str = ""
    host_gap_s: float = 0.0        # the longest wall-clock time between two of the host's writes


def random_moves(machine: Machine, rng: random.Random, n: int, top_rate: float,
                 span_steps: int = 40_000, start: tuple[int, ...] | None = None) -> list[Move]:
    """``n`` moves from ``start`` (0) on: 1 to all axes, each a random share of the base axis's
    steps (or all of them), base rates from 500 steps/s to ``top_rate``; an axis that would leave
    +-``span_steps`` moves back towards 0 instead."""
    axes = len(machine.axes)
    pos = list(start or [0] * axes)
    out = []
    for _ in range(n):
        k = rng.randint(1, axes)
        chosen = rng.sample(range(axes), k)
        base = rng.choice([1, 2, 7, rng.randint(1, 300), rng.randint(300, 4000)])
        new = list(pos)
        for j, i in enumerate(chosen):
            share = 1.0 if j == 0 or rng.random() < 0.3 else rng.random()
            d = max(1, round(base * share)) * rng.choice((-1, 1))
            if abs(pos[i] + d) > span_steps:
                d = -abs(d) if pos[i] > 0 else abs(d)
            new[i] = pos[i] + d
        rate = rng.choice([rng.uniform(500, top_rate), top_rate, rng.uniform(0.8, 1.1) * top_rate])
        out.append(Move(tuple(new), rate))
        pos = new
    return out


def _text(machine: Machine, move: Move, before: tuple[int, ...]) -> list[str]:
    """PFDR for the move's base rate along its path, and its PMOV (mm, exact in steps)."""
    d = [(t - b) / a.steps_per_mm for t, b, a in zip(move.target, before, machine.axes)]
    steps = [abs(t - b) for t, b in zip(move.target, before)]
    base_mm = max(steps) / machine.axes[steps.index(max(steps))].steps_per_mm
    length = sum(x * x for x in d) ** 0.5
    feed = move.rate * length / max(steps) * 60 if base_mm else 0
    axes = " ".join(f"{a.name}{t / a.steps_per_mm:.6f}" for a, t in zip(machine.axes, move.target))
    return [f"PFDR F{feed:.4f}", f"PMOV {axes}"]


class _Line:
    """The host's bytes to the harness, with garbage put in and bytes dropped at random."""

    def __init__(self, sock: socket.socket, rng: random.Random, garbage: float, drop: float,
                 run: StressRun):
        self.sock, self.rng, self.garbage, self.drop, self.run = sock, rng, garbage, drop, run
        self.last = time.monotonic()

    def write(self, data: bytes) -> None:
        if not data:
            return
        now = time.monotonic()
        self.run.host_gap_s = max(self.run.host_gap_s, now - self.last)
        self.last = now
        out = bytearray(data)
        if self.rng.random() < self.drop:
            del out[self.rng.randrange(len(out))]
            self.run.dropped_bytes += 1
        if self.rng.random() < self.garbage:
            noise = bytes(self.rng.randrange(256) for _ in range(self.rng.randint(1, 12)))
            out = bytearray(noise) + out
            self.run.garbage_bytes += len(noise)
        self.sock.sendall(bytes(out))


def _wait(host: HostEndpoint, sock: socket.socket, line: _Line, t, poll, deadline: float):
    """Pump the link until transaction ``t`` is done; ``poll()`` is called as time goes by."""
    while not t.done:
        now = time.monotonic()
        if now > deadline:
            raise TimeoutError(f"no answer to {t.name} in time")
        poll(now)
        host.poll(now)
        line.write(host.take_output())
        try:
            data = sock.recv(4096)
        except TimeoutError:
            data = b""
        if data:
            host.receive(data, time.monotonic())
        line.write(host.take_output())


def stress_run(elf: Path, machine: Machine, *, seed: int, moves: int, top_rate: float,
               batch: tuple[int, int] = (1, 8), garbage: float = 0.05, drop: float = 0.02,
               poll_ms: tuple[float, float] = (2.0, 20.0), limit_s: float = 300.0) -> StressRun:
    """Stream ``moves`` random moves (seeded) to the firmware in simavr; see the module's text."""
    rng = random.Random(seed)
    run = StressRun(seed, random_moves(machine, rng, moves, top_rate))
    # the AVR's time at most the wall clock's, as on the board: unpaced, a host slowed by a
    # loaded machine fell silent for 500 ms of AVR time and the heartbeat stopped the run
    harness = Harness(elf, machine, listen="127.0.0.1:0", speed=1.0).start()
    deadline = time.monotonic() + limit_s
    try:
        host_addr, port = harness.address.rsplit(":", 1)
        sock = socket.create_connection((host_addr, int(port)), timeout=5)
        sock.settimeout(0.002)
        host = HostEndpoint(machine, timeout_s=0.05, max_tries=50, nonce=seed)
        line = _Line(sock, rng, garbage, drop, run)
        last = [0.0, None]                         # when the next poll is due, the last one

        def poll(now: float) -> None:
            if now >= last[0] and (last[1] is None or last[1].done):
                last[0] = now + rng.uniform(*poll_ms) / 1000
                last[1] = host.send(parse_command("RDST"), now)

        def rest() -> None:
            """Poll RDST until nothing moves or waits, then RDPS: a checkpoint."""
            while True:
                t = host.send(parse_command("RDST"), time.monotonic())
                _wait(host, sock, line, t, lambda now: None, deadline)
                flags = int(t.reply.flags)
                run.statuses.append(flags)
                if flags & (StatusFlags.ERROR | StatusFlags.STOPPED | StatusFlags.STEP_ERROR):
                    raise RuntimeError(f"status {StatusFlags(flags)!r}")
                if not flags & StatusFlags.MOVING and t.reply.queued == 0:
                    break
            t = host.send(parse_command("RDPS"), time.monotonic())
            _wait(host, sock, line, t, lambda now: None, deadline)
            run.checkpoints.append(dict(t.reply.steps))

        before = tuple(0 for _ in machine.axes)
        i = 0
        while i < len(run.moves):
            for move in run.moves[i:i + rng.randint(*batch)]:
                for text in _text(machine, move, before):
                    _wait(host, sock, line, host.send(parse_command(text), time.monotonic()),
                          poll, deadline)
                before = move.target
                i += 1
            run.expected.append({a.name: p for a, p in zip(machine.axes, before)})
            rest()
        run.link = vars(host.stats).copy()
        sock.close()
    except Exception as exc:                       # the check below reports it with the seed
        run.error = f"{type(exc).__name__}: {exc}" + _aftermath(run, locals(), deadline)
    finally:
        run.log = harness.stop(5)
    return run


def _aftermath(run: StressRun, scope: dict, deadline: float) -> str:
    """What the device's status says after a failure (a refusal, ERR 6, comes of STOPPED,
    HOST_LOST or ERROR), and the host's longest silence when it passed half the heartbeat's
    500 ms (a host held back by a loaded machine is taken for a dead one)."""
    out = ""
    if "host" in scope and "sock" in scope and "line" in scope:
        try:
            t = scope["host"].send(parse_command("RDST"), time.monotonic())
            _wait(scope["host"], scope["sock"], scope["line"], t, lambda now: None,
                  min(deadline, time.monotonic() + 2.0))
            out += f"; RDST then: {'|'.join(flag_names(int(t.reply.flags))) or 'no flags'}"
        except Exception as exc:                   # the link itself is gone: say so
            out += f"; no RDST after it ({type(exc).__name__})"
    if run.host_gap_s > 0.25:
        out += f"; the host fell silent for {run.host_gap_s:.2f} s"
    return out


def answer_cycles(log: HarnessLog, machine: Machine) -> list[tuple[int, object]]:
    """(cycle its last byte left the board, reply) of every intact answer the firmware sent, each
    checked against the session it is bound to (learnt from the SESS answers as they come)."""
    sessions: dict[int, int | None] = {0: None, 1: None}
    decoder, out = FrameDecoder(lambda seq: sessions[seq >> 7]), []
    for cycle, byte in log.uart:
        for frame in decoder.feed(bytes((byte,))):
            if isinstance(frame, BadFrame):
                continue
            try:
                reply = decode_reply(frame.payload, machine)
            except PayloadError:                   # a damaged answer: the host resent
                continue
            if isinstance(reply, Session):
                sessions[frame.seq >> 7] = reply.number
            out.append((cycle, reply))
    return out


def pin_positions(log: HarnessLog, machine: Machine, cycles) -> np.ndarray:
    """Each axis's position counted on its step and direction pins at each of ``cycles``."""
    out = []
    for a in machine.axes:
        rises, _, dirs = step_times(log, machine, a.name)
        sign = np.where(dirs == (0 if a.invert_dir else 1), 1, -1)
        total = np.concatenate(([0], np.cumsum(sign)))
        out.append(total[np.searchsorted(rises, np.asarray(cycles), side="right")])
    return np.array(out).T


def check(run: StressRun, machine: Machine) -> list[str]:
    """What went wrong, each naming the seed (empty: every checkpoint held)."""
    bad = [f"seed {run.seed}: {run.error}"] if run.error else []
    if len(run.checkpoints) != len(run.expected):
        bad.append(f"seed {run.seed}: {len(run.checkpoints)} RDPS answers, "
                   f"{len(run.expected)} checkpoints planned")
    for k, (got, want) in enumerate(zip(run.checkpoints, run.expected)):
        if got != want:
            bad.append(f"seed {run.seed}: checkpoint {k}: RDPS {got}, planned {want}")
    answers = answer_cycles(run.log, machine)
    positions = [(c, r) for c, r in answers if isinstance(r, Position)]
    if positions:
        pins = pin_positions(run.log, machine, [c for c, _ in positions])
        for (cycle, reply), counted in zip(positions, pins):
            on_pins = {a.name: int(x) for a, x in zip(machine.axes, counted)}
            if on_pins != dict(reply.steps):
                bad.append(f"seed {run.seed}: cycle {cycle}: RDPS {dict(reply.steps)}, "
                           f"the pins {on_pins}")
    if any(int(r.flags) & (StatusFlags.ERROR | StatusFlags.STEP_ERROR)
           for _, r in answers if isinstance(r, Status)):
        bad.append(f"seed {run.seed}: an RDST answered ERROR or STEP_ERROR")
    return bad
