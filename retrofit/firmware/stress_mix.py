"""The mixed stress run: random moves, homing and thread passes on the firmware in simavr, in lockstep.

A seeded program on ``bench/stressmix.toml`` (four axes without speed limits of their own, home
switches on X and Z, a 1000-line spindle encoder with the spindle model in the loop) goes through
the host's link endpoint (:class:`retrofit.link.host.HostEndpoint`: BUSY waited out, NAKs and
timeouts resent) to the harness in lockstep (:mod:`retrofit.firmware.lockstep`: the AVR's time is
the host's clock, so a loaded machine changes nothing). Its parts, in random order:

- batches of moves on 1-4 axes at random ratios and base rates up to ``top_rate`` (above the
  firmware's ceiling, which clamps them), filling the queue;
- homing (ZMOV of X, Z or both): RDPS must then say the home position, the step pins must put the
  carriage at its switch within the latch's resolution, and from then on pins and RDPS differ by
  that same amount (no step lost or added);
- thread passes: SPIN, ISTP, PFDR in mm a turn, a PMOV of 1-2 axes, CSTP: the steps follow the
  encoder of a spindle that ramps and varies with its load.

RDST is polled every 2-20 ms while anything runs, garbage goes on the line between frames and bytes
are dropped from frames. After every part, at rest, RDPS is read: it must equal the plan (the sum
of the commanded moves, the home positions), and so must the step pins at the cycle the answer
left the board. :func:`check` lists every mismatch (empty: the run held).

    >>> run = mix_run(elf, machine, seed=3, parts=12)          # doctest: +SKIP
    >>> check(run, machine)                                     # doctest: +SKIP
    []
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from pathlib import Path

from ..commands import parse_command
from ..link.host import HostEndpoint
from ..link.replies import Position, Status, StatusFlags, flag_names
from ..machine.config import Machine
from .lockstep import Lockstep
from .sim import F_CPU, ROOT, HarnessLog, firmware_axes
from .stress import _Line, _text, answer_cycles, pin_positions, random_moves

MACHINE = ROOT / "bench" / "stressmix.toml"
SPAN = 40_000                                      # steps from zero the moves keep within
QUANTUM = 32_000                                   # cycles of a pause at rest: 2 ms
LONGEST = 320_000                                  # cycles the host lets pass at most between looks
BAD = StatusFlags.ERROR | StatusFlags.STOPPED | StatusFlags.STEP_ERROR


@dataclass
class Part:
    """One part of the program: its command texts and where it leaves each axis (steps)."""

    kind: str                                       # "moves", "home" or "thread"
    texts: list[str]
    end: dict[str, int]
    homed: tuple[str, ...] = ()


@dataclass
class MixRun:
    seed: int
    parts: list[Part] = field(default_factory=list)
    checkpoints: list[dict] = field(default_factory=list)      # what RDPS answered, part by part
    homed_at: list[tuple[int, tuple[str, ...]]] = field(default_factory=list)   # (cycle RDPS sent, axes)
    garbage_bytes: int = 0
    dropped_bytes: int = 0
    log: HarnessLog | None = None
    sent: list[tuple[int, int, tuple[int, ...]]] = field(default_factory=list)   # Lockstep.sent
    link: dict = field(default_factory=dict)
    error: str = ""
    host_gap_s: float = 0.0                          # (for firmware_stress._Line; no wall clock here)


def _homing(machine: Machine, rng: random.Random, pos: dict[str, int]) -> Part:
    homing = machine.parts["homing"]
    axes = rng.choice([homing.order[:1], homing.order[1:], homing.order])
    axes = tuple(a.upper() for a in axes)
    end = dict(pos)
    for a in axes:
        end[a] = round(homing.home_mm(a) * machine.axis(a).steps_per_mm)
    return Part("home", ["ZMOV " + " ".join(axes)], end, axes)


def _thread(machine: Machine, rng: random.Random, pos: dict[str, int]) -> Part:
    """A pass of 200-3000 steps on its base axis at 50-600 steps a turn (under one a count)."""
    spindle = machine.parts["spindle"]
    rpm = round(rng.uniform(200, spindle.max_rpm))
    axes = rng.sample(machine.axis_names, rng.choice((1, 1, 2)))
    share = rng.uniform(0.05, 0.6)                 # base steps a count (a path's pitch: < 0.85)
    base = min(rng.randint(200, 3000), int(8000 * share))        # at most 8000 counts a pass
    end = dict(pos)
    for j, a in enumerate(axes):
        d = (base if j == 0 else rng.randint(1, base)) * rng.choice((-1, 1))
        if abs(pos[a] + d) > SPAN:                 # back towards the middle
            d = -abs(d) if pos[a] > 0 else abs(d)
        end[a] = pos[a] + d
    spm = machine.axes[0].steps_per_mm
    per_turn = share * spindle.encoder_counts_per_rev / spm      # mm of the base axis a turn
    length = sum(((end[a] - pos[a]) / spm) ** 2 for a in axes) ** 0.5
    pitch = per_turn * length / (base / spm)
    target = " ".join(f"{a}{end[a] / machine.axis(a).steps_per_mm:.6f}" for a in axes)
    return Part("thread", [f"SPIN S{rpm} D1", "ISTP", f"PFDR F{pitch:.6f}", f"PMOV {target}",
                           "CSTP"], end)


def random_parts(machine: Machine, rng: random.Random, n: int, top_rate: float) -> list[Part]:
    """``n`` parts from machine zero: batches of 1-30 moves, homings and thread passes."""
    pos = {a: 0 for a in machine.axis_names}
    out = []
    for _ in range(n):
        kind = rng.choices(("moves", "home", "thread"), (6, 1, 2))[0]
        if kind == "home":
            part = _homing(machine, rng, pos)
        elif kind == "thread":
            part = _thread(machine, rng, pos)
        else:
            before = tuple(pos[a] for a in machine.axis_names)
            moves = random_moves(machine, rng, rng.randint(1, 30), top_rate, SPAN, before)
            texts = []
            for m in moves:
                texts += _text(machine, m, before)
                before = m.target
            part = Part("moves", texts, dict(zip(machine.axis_names, moves[-1].target)))
        out.append(part)
        pos = part.end
    return out


class _Host:
    """The host endpoint on the AVR's time, with the board one millisecond a look."""

    def __init__(self, board: Lockstep, machine: Machine, rng: random.Random, run: MixRun,
                 garbage: float, drop: float, poll_ms: tuple[float, float], limit_s: float):
        self.board, self.rng, self.poll_ms, self.limit_s = board, rng, poll_ms, limit_s
        self.host = HostEndpoint(machine, timeout_s=0.05, max_tries=50, nonce=run.seed)
        self.line = _Line(board, rng, garbage, drop, run)
        self.next_poll, self.last_poll = 0.0, None

    def wait(self, t, polling: bool = True) -> None:
        """Run the board until transaction ``t`` is answered, polling RDST if ``polling``."""
        while not t.done:
            now = self.board.now
            if now > self.limit_s:
                raise TimeoutError(f"no answer to {t.name} in {self.limit_s:g} simulated s")
            if polling and now >= self.next_poll and (self.last_poll is None or self.last_poll.done):
                self.next_poll = now + self.rng.uniform(*self.poll_ms) / 1000
                self.last_poll = self.host.send(parse_command("RDST"), now)
            self.host.poll(now)
            self.line.write(self.host.take_output())
            due = [d for d in (self.host.next_deadline(), self.next_poll if polling else None,
                               getattr(t, "until", 0) / F_CPU) if d]
            ahead = min([LONGEST / F_CPU] + [d - now for d in due])
            data = self.board.advance(max(QUANTUM // 8, int(ahead * F_CPU)), early=True)
            if data:
                self.host.receive(data, self.board.now)

    def send(self, text: str, polling: bool = True):
        t = self.host.send(parse_command(text), self.board.now)
        self.wait(t, polling)
        return t

    def rest(self) -> tuple[int, dict]:
        """RDST until nothing moves, dwells or waits, then RDPS: (the cycle it was sent at,
        its answer), a checkpoint."""
        while True:
            t = self.send("RDST", polling=False)
            flags = int(t.reply.flags)
            if flags & BAD:
                raise RuntimeError(f"RDST: {'|'.join(flag_names(flags))}")
            if not flags & (StatusFlags.MOVING | StatusFlags.DWELLING) and t.reply.queued == 0:
                break
            self.wait(_Later(self.board, 2 * QUANTUM), polling=False)
        sent = self.board.cycle
        return sent, dict(self.send("RDPS", polling=False).reply.steps)


class _Later:
    """A transaction-like wait of a few cycles."""

    def __init__(self, board: Lockstep, cycles: int):
        self.board, self.until, self.name = board, board.cycle + cycles, "a pause"

    @property
    def done(self) -> bool:
        return self.board.cycle >= self.until


def mix_run(elf: Path, machine: Machine, *, seed: int, parts: int, top_rate: float = 60_000.0,
            garbage: float = 0.05, drop: float = 0.02, poll_ms: tuple[float, float] = (2.0, 20.0),
            limit_s: float = 600.0, spindle_rpm: float = 0.0, min_s: float = 0.0,
            pins: bool = True) -> MixRun:
    """Run ``parts`` random parts (seeded) on the firmware in simavr; see the module's text.
    ``min_s``: stop after the part that brings the AVR's time to it (the parts not run are
    dropped); ``spindle_rpm``: an encoder at that fixed speed instead of the spindle model;
    ``pins=False``: no log of the pins, the harness's step counts as each byte left are checked."""
    rng = random.Random(seed)
    run = MixRun(seed, random_parts(machine, rng, parts, top_rate))
    board = Lockstep(elf, machine, spindle_rpm=spindle_rpm, port_log=pins).start()
    try:
        host = _Host(board, machine, rng, run, garbage, drop, poll_ms, limit_s)
        for part in run.parts:
            for text in part.texts:
                host.send(text)
            sent, checkpoint = host.rest()
            if part.homed:
                run.homed_at.append((sent, part.homed))
            run.checkpoints.append(checkpoint)
            if min_s and board.now >= min_s:
                del run.parts[len(run.checkpoints):]
                break
        run.link = vars(host.host.stats).copy()
    except Exception as exc:                       # the check below reports it with the seed
        run.error = f"{type(exc).__name__}: {exc} (at {board.now:.3f} simulated s)"
    finally:
        run.log = board.stop()
        run.sent = board.sent
    return run


def latch_steps(machine: Machine, axis: str) -> int:
    """How far past its switch a homed carriage may rest: the latch feed for the switch's
    reading (1 ms) and debouncing (3 readings) and a step, each way."""
    how = machine.parts["homing"].axes[axis.upper()]
    return int(how.latch_mm_min / 60 * machine.axis(axis).steps_per_mm * 0.004) + 1


def check(run: MixRun, machine: Machine) -> list[str]:
    """What went wrong, each naming the seed (empty: every checkpoint held)."""
    bad = [f"seed {run.seed}: {run.error}"] if run.error else []
    if len(run.checkpoints) != len(run.parts):
        bad.append(f"seed {run.seed}: {len(run.checkpoints)} rests checked of {len(run.parts)} parts")
    for k, (got, part) in enumerate(zip(run.checkpoints, run.parts)):
        if got != part.end:
            bad.append(f"seed {run.seed}: part {k} ({part.kind}): RDPS {got}, planned {part.end}")
    answers = answer_cycles(run.log, machine)
    positions = [(c, r) for c, r in answers if isinstance(r, Position)]
    offset = {a: 0 for a in machine.axis_names}       # pins - RDPS: the latch's error once homed
    homings = list(run.homed_at)
    for (cycle, reply), on_pins in zip(positions, steps_at(run, machine, [c for c, _ in positions])):
        said = dict(reply.steps)
        while homings and homings[0][0] <= cycle:      # the first RDPS after a homing
            for a in homings.pop(0)[1]:
                offset[a] = on_pins[a] - said[a]
                if abs(offset[a]) > latch_steps(machine, a):
                    bad.append(f"seed {run.seed}: cycle {cycle}: {a} homed {offset[a]} steps "
                               f"from its switch (at most {latch_steps(machine, a)})")
        if {a: on_pins[a] - offset[a] for a in on_pins} != said:
            bad.append(f"seed {run.seed}: cycle {cycle}: RDPS {said}, the pins {on_pins} "
                       f"(less the homing offsets {offset})")
    if any(int(r.flags) & (StatusFlags.ERROR | StatusFlags.STEP_ERROR)
           for _, r in answers if isinstance(r, Status)):
        bad.append(f"seed {run.seed}: an RDST answered ERROR or STEP_ERROR")
    if run.log.answer_bytes().count(b"retrofit firmware") != 1:
        bad.append(f"seed {run.seed}: the board restarted")
    return bad


def steps_at(run: MixRun, machine: Machine, cycles: list[int]) -> list[dict[str, int]]:
    """Each axis's position on the step pins at each of ``cycles`` (cycles a byte was sent at):
    decoded from the pin log when there is one (:func:`pins_at`), else the harness's own counts
    (:func:`counts_at`)."""
    return pins_at(run, machine, cycles) if run.log.ports else counts_at(run, machine, cycles)


def pins_at(run: MixRun, machine: Machine, cycles: list[int]) -> list[dict[str, int]]:
    """The positions decoded here from the pin log's step and direction edges."""
    counted = pin_positions(run.log, machine, cycles) if cycles else []
    return [{a.name: int(x) for a, x in zip(machine.axes, row)} for row in counted]


def counts_at(run: MixRun, machine: Machine, cycles: list[int]) -> list[dict[str, int]]:
    """The harness's count of each axis's step edges as the byte of each cycle left the board."""
    names = [a.name for a in firmware_axes(machine)]
    at = {cycle: counts for cycle, _, counts in run.sent}
    return [dict(zip(names, at[c])) for c in cycles]


def simulated_s(run: MixRun) -> float:
    return run.log.end_cycle / F_CPU
