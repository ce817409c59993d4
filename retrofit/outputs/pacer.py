"""The paced real-time loop: each port byte written at its tick boundary, and how late it was.

This is the only Python module of retrofit that reads the wall clock or sleeps (the compiled
writer ``pacer_c.c``, which it drives, is the only other code that does). Frames are computed
ahead (``PortFrames``, run-length); the loop writes at every change tick (or, with
``every_tick``, at every tick, unchanged bytes included, like a base thread). It sleeps for most
of each wait and busy-waits the last ``spin_ns`` on ``time.perf_counter_ns()``, and records each
write's lateness (time after the write returned minus the tick boundary it was due at). A late
write is never skipped: bytes go out in tick order, however late.

Two engines run that loop: ``compiled`` (``pacer_c.c``, built with the system C compiler at
first use by :mod:`.pacer_build` and called through ctypes, so the GIL is released for the whole
chunk) and ``python`` (the loop below, in the interpreter). ``engine="auto"`` takes the compiled
one when it builds and falls back to Python with a note saying why.

Before a paced run, :func:`calibrate` measures what this computer can hold; a tick whose p99
lateness in the trial exceeds half a tick is refused unless forced.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import OutputError
from ..frames import PortFrames
from . import pacer_build

#: a write: (tick, port byte)
Write = Callable[[int, int], None]

FIFO_PRIORITY = 80             # SCHED_FIFO priority asked for (capped at the system's maximum)
MCL_CURRENT, MCL_FUTURE = 1, 2
LEAD_NS = 2_000_000            # the first write is due this long after the loop starts
TRIAL_NS = 200_000_000         # calibration: about 0.2 s of ticks ...
TRIAL_MIN_TICKS, TRIAL_MAX_TICKS = 20, 5000    # ... within these bounds
SPIN_MIN_NS, SPIN_MAX_NS = 20_000, 2_000_000   # busy-wait window bounds
ENGINES = ("auto", "compiled", "python")


def _us(ns: float) -> str:
    return f"{ns / 1000:.1f} us" if abs(ns) >= 1000 else f"{ns:.0f} ns"


@dataclass(frozen=True)
class Lateness:
    """How late the writes of a run were: actual - scheduled, in nanoseconds (paced runs only)."""

    tick_ns: int
    writes: int
    paced: bool
    p50_ns: int = 0
    p99_ns: int = 0
    max_ns: int = 0
    late: int = 0                          # writes later than half a tick
    samples_ns: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64), repr=False,
                                   compare=False)

    @classmethod
    def of(cls, tick_ns: int, writes: int, samples, paced: bool = True) -> Lateness:
        a = np.asarray(samples, dtype=np.int64)
        if not paced or len(a) == 0:
            return cls(tick_ns, writes, paced, samples_ns=a)
        return cls(tick_ns, writes, paced, int(np.percentile(a, 50)), int(np.percentile(a, 99)),
                   int(a.max()), int(np.count_nonzero(a > tick_ns // 2)), a)

    def line(self) -> str:
        """One line for people: writes, tick, p50 / p99 / max and the late count."""
        head = f"{self.writes} writes at a {_us(self.tick_ns)} tick"
        if not self.paced:
            return f"{head}, unpaced (as fast as possible; no lateness measured)"
        return (f"{head}: lateness p50 {_us(self.p50_ns)}, p99 {_us(self.p99_ns)}, "
                f"max {_us(self.max_ns)}; {self.late} later than half a tick ({_us(self.tick_ns / 2)})")

    def as_dict(self) -> dict:
        return {"tick_ns": self.tick_ns, "writes": self.writes, "paced": self.paced,
                "p50_ns": self.p50_ns, "p99_ns": self.p99_ns, "max_ns": self.max_ns,
                "late_writes": self.late}


def _memlock_unlimited() -> bool:
    """Root, or no limit on locked memory (so MCL_FUTURE cannot make an allocation fail)."""
    try:
        import resource
        return os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_MEMLOCK)[0] == resource.RLIM_INFINITY
    except (ImportError, AttributeError):
        return False


class RealtimeMode:
    """SCHED_FIFO and locked memory for the loop's thread when the system permits; undone after."""

    def __init__(self, priority: int = FIFO_PRIORITY):
        self.priority = priority
        self.notes: list[str] = []
        self._old_sched = None
        self._locked = False

    @property
    def fifo(self) -> bool:
        return self._old_sched is not None

    def enter(self) -> list[str]:
        """Try both; return plain notes saying what is on and what was not permitted."""
        self.notes = [self._enter_fifo(), self._enter_mlock()]
        return self.notes

    def _enter_fifo(self) -> str:
        try:
            old = (os.sched_getscheduler(0), os.sched_getparam(0))
            prio = min(self.priority, os.sched_get_priority_max(os.SCHED_FIFO))
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(prio))
        except (OSError, AttributeError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            return (f"SCHED_FIFO not permitted ({reason}): the loop runs at normal priority; "
                    "run as root or grant it (CAP_SYS_NICE, or an 'rtprio' line in /etc/security/limits.conf)")
        self._old_sched = old
        return f"SCHED_FIFO priority {prio} on"

    def _enter_mlock(self) -> str:
        future = _memlock_unlimited()       # else later allocations could fail at the limit
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
            failed = libc.mlockall(MCL_CURRENT | (MCL_FUTURE if future else 0)) != 0
            err = ctypes.get_errno()
        except (OSError, AttributeError) as exc:
            return f"mlockall not available ({exc}): pages may be swapped out during the run"
        if failed:
            return (f"mlockall not permitted ({os.strerror(err)}): pages may be swapped out during the run; "
                    "run as root or raise 'memlock' in /etc/security/limits.conf")
        self._libc, self._locked = libc, True
        return "memory locked (mlockall)" if future else "memory present now locked (mlockall; memlock limit set)"

    def give_up_fifo(self, why: str) -> None:
        """Go back to the normal policy before the run, saying why."""
        self._restore_policy()
        self.notes = [why if n.startswith("SCHED_FIFO") else n for n in self.notes]

    def _restore_policy(self) -> None:
        if self._old_sched is not None:
            policy, param = self._old_sched
            try:
                os.sched_setscheduler(0, policy, param)
            except OSError:
                pass
            self._old_sched = None

    def leave(self) -> None:
        """Give back the scheduling policy and the locked memory."""
        self._restore_policy()
        if self._locked:
            self._libc.munlockall()
            self._locked = False

    def line(self) -> str:
        return "realtime: " + "; ".join(self.notes) if self.notes else "realtime: not asked for"


def choose_engine(engine: str = "auto") -> tuple[ctypes.CDLL | None, str]:
    """(the compiled writer, or None for the Python loop; a note saying which paces and why)."""
    if engine not in ENGINES:
        raise OutputError(f"engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if engine == "python":
        return None, "engine: Python loop (asked for)"
    try:
        lib = pacer_build.load()
    except pacer_build.BuildError as exc:
        if engine == "compiled":
            raise OutputError(f"engine=compiled: the compiled writer is not available: {exc}") from None
        return None, f"engine: Python loop (the compiled writer is not available: {exc})"
    return lib, "engine: compiled writer (C, GIL released during the run)"


class Pacer:
    """Writes port frames at their tick boundaries; chunks continue one schedule.

    ``paced=False`` runs the very same loop without waiting (for tests and conversions).
    ``engine`` is ``auto``, ``compiled`` or ``python`` (see the module docstring).
    """

    def __init__(self, tick_ns: int, *, every_tick: bool = False, paced: bool = True,
                 spin_ns: int = SPIN_MIN_NS, lead_ns: int = LEAD_NS, engine: str = "auto"):
        if tick_ns <= 0:
            raise OutputError(f"tick of {tick_ns} ns: must be > 0")
        self.tick_ns, self.every_tick, self.paced = int(tick_ns), every_tick, paced
        self.spin_ns, self.lead_ns = int(spin_ns), int(lead_ns)
        self._lib, self.engine_note = choose_engine(engine)
        self.engine = "compiled" if self._lib is not None else "python"
        self._now = self._lib.retrofit_now_ns if self._lib is not None else time.perf_counter_ns
        self.end_tick = 0           # one past the last tick played
        self.writes = 0
        self._t0: int | None = None
        self._held = 0              # the byte on the port (0 after opening)
        self._late: list[np.ndarray] = []

    def play(self, frames: PortFrames, write: Write, fd: int | None = None) -> None:
        """Write one chunk of frames, in tick order, each at its tick.

        ``fd``: an open ppdev port the compiled writer writes to itself (``write`` is then not
        called). Without it, the compiled writer keeps the bytes in memory and hands them to
        ``write`` after the chunk, so it suits memory targets only (a recording, a trial).
        """
        ticks, values = self._schedule(frames)
        if len(ticks):
            if self._t0 is None:
                self._t0 = self._now() + self.lead_ns - int(ticks[0]) * self.tick_ns
            if self._lib is not None:
                self._loop_compiled(ticks, values, write, fd)
            else:
                self._loop(ticks.tolist(), values.tolist(), write)
            self._held = int(values[-1])
        self.end_tick = max(self.end_tick, int(frames.end_tick))

    def _schedule(self, frames: PortFrames) -> tuple[np.ndarray, np.ndarray]:
        """The (tick, byte) writes of a chunk: its change ticks, or every tick from the last end."""
        if len(frames) and frames.ticks[0] < self.end_tick:
            raise OutputError(f"frames start at tick {int(frames.ticks[0])}, before the end of the "
                              f"previous chunk ({self.end_tick}); chunks must continue in tick order")
        if not self.every_tick:
            return frames.ticks, frames.values
        start, end = self.end_tick, int(frames.end_tick)
        bounds = np.concatenate(([start], frames.ticks, [end])).astype(np.int64)
        held = np.concatenate(([self._held], frames.values)).astype(np.uint8)
        per_tick = np.repeat(held, np.diff(bounds))
        return np.arange(start, end, dtype=np.int64), per_tick

    def _loop(self, ticks: list[int], values: list[int], write: Write) -> None:
        """The real-time loop: sleep, spin to the boundary, write, note the lateness."""
        lateness: list[int] = []
        clock, sleep, late = time.perf_counter_ns, time.sleep, lateness.append
        t0, tick_ns, spin_ns, paced = self._t0, self.tick_ns, self.spin_ns, self.paced
        for tick, value in zip(ticks, values):
            if paced:
                due = t0 + tick * tick_ns
                wait = due - clock()
                if wait > spin_ns:
                    sleep((wait - spin_ns) * 1e-9)
                while clock() < due:
                    pass
                write(tick, value)
                late(clock() - due)
            else:
                write(tick, value)
        self._late.append(np.array(lateness if paced else [], np.int64))
        self.writes += len(ticks)

    def _loop_compiled(self, ticks: np.ndarray, values: np.ndarray, write: Write, fd: int | None) -> None:
        """The same loop in C (``pacer_c.c``), the GIL released until the chunk is written."""
        ticks = np.ascontiguousarray(ticks, np.int64)
        values = np.ascontiguousarray(values, np.uint8)
        out, late = np.empty(len(ticks), np.uint8), np.empty(len(ticks), np.int64)
        done = self._lib.retrofit_pace(ticks.ctypes.data, values.ctypes.data, len(ticks), self._t0,
                                       self.tick_ns, self.spin_ns, int(self.paced),
                                       -1 if fd is None else fd, out.ctypes.data, late.ctypes.data)
        if done < 0:
            i = -done - 1
            raise OutputError(f"port write {i + 1} of the chunk (tick {int(ticks[i])}) failed: "
                              f"{os.strerror(ctypes.get_errno()) or 'ioctl PPWDATA refused'}")
        if fd is None:
            for tick, value in zip(ticks.tolist(), out.tolist()):
                write(tick, value)
        if self.paced:
            self._late.append(late)
        self.writes += len(ticks)

    def finish(self) -> Lateness:
        """Wait until the last byte has held its ticks (paced runs); return the lateness."""
        if self.paced and self._t0 is not None:
            rest = self._t0 + self.end_tick * self.tick_ns - self._now()
            if rest > 0:
                time.sleep(rest * 1e-9)
        return self.lateness()

    def lateness(self) -> Lateness:
        late = np.concatenate(self._late) if self._late else np.zeros(0, np.int64)
        return Lateness.of(self.tick_ns, self.writes, late, self.paced)


@dataclass(frozen=True)
class Calibration:
    """What this computer held in a short trial at the requested tick."""

    tick_ns: int
    spin_ns: int             # busy-wait window chosen from the measured sleep overshoot
    trial: Lateness          # lateness of the trial (every tick written, to a null port)

    @property
    def holds(self) -> bool:
        """The rule: p99 lateness of the trial within half a tick."""
        return self.trial.p99_ns <= self.tick_ns // 2

    @property
    def shortest_tick_ns(self) -> int:
        """About the shortest tick this computer holds by that rule (twice the trial's p99)."""
        return 2 * self.trial.p99_ns

    def line(self) -> str:
        verdict = "holds" if self.holds else "does NOT hold"
        return (f"calibration: {self.trial.writes} trial ticks at {_us(self.tick_ns)}: p99 lateness "
                f"{_us(self.trial.p99_ns)}, max {_us(self.trial.max_ns)}; this computer {verdict} it "
                f"(rule: p99 <= half a tick); busy-wait window {_us(self.spin_ns)}")

    def refusal(self, where: str) -> str:
        return (f"{where}: this computer cannot hold a {_us(self.tick_ns)} tick: p99 lateness "
                f"{_us(self.trial.p99_ns)} over {self.trial.writes} trial ticks is more than half a tick "
                f"({_us(self.tick_ns / 2)}); the shortest tick it holds is about "
                f"{_us(self.shortest_tick_ns)}; use a longer tick ([machine] tick_us or ?tick_us=) "
                "or add ?force=1 to run anyway")


def sleep_overshoot_ns(samples: int = 50, request_ns: int = 100_000) -> int:
    """The worst time.sleep() overshoot seen over a few short sleeps."""
    clock, worst = time.perf_counter_ns, 0
    for _ in range(samples):
        start = clock()
        time.sleep(request_ns * 1e-9)
        worst = max(worst, clock() - start - request_ns)
    return worst


def spin_window_ns() -> int:
    """How long before a write the loop stops sleeping and busy-waits: worst overshoot + margin."""
    return min(max(sleep_overshoot_ns() * 5 // 4 + 10_000, SPIN_MIN_NS), SPIN_MAX_NS)


def rt_throttle_us() -> tuple[int, int] | None:
    """(runtime, period) of the kernel's real-time throttling, or None when it is off or unknown."""
    try:
        runtime = int(Path("/proc/sys/kernel/sched_rt_runtime_us").read_text())
        period = int(Path("/proc/sys/kernel/sched_rt_period_us").read_text())
    except (OSError, ValueError):
        return None
    return (runtime, period) if 0 <= runtime < period else None


def calibrate(tick_ns: int, realtime: RealtimeMode | None = None, gap_ticks: int = 1,
              engine: str = "auto") -> Calibration:
    """Choose the busy-wait window, then pace a trial of every tick at ``tick_ns`` to a null port.

    ``gap_ticks`` is the usual gap between writes (1 when every tick is written). When the loop
    would busy-wait through whole gaps under SCHED_FIFO, the kernel's real-time throttling would
    stop it for tens of milliseconds every period, so SCHED_FIFO is given up first, with a note.
    """
    spin_ns = spin_window_ns()
    throttle = rt_throttle_us()
    if realtime is not None and realtime.fifo and throttle and spin_ns >= 0.9 * gap_ticks * tick_ns:
        realtime.give_up_fifo(
            f"SCHED_FIFO given up: at a {_us(tick_ns)} tick the loop busy-waits all the time (it must "
            f"stop sleeping {_us(spin_ns)} before each write), and the kernel stops real-time tasks that run more "
            f"than {throttle[0]} us of every {throttle[1]} us (/proc/sys/kernel/sched_rt_runtime_us); "
            "running at normal priority")
        spin_ns = spin_window_ns()
    n = min(max(TRIAL_NS // tick_ns, TRIAL_MIN_TICKS), TRIAL_MAX_TICKS)
    trial = PortFrames.from_per_tick(np.arange(n) % 2)
    pacer = Pacer(tick_ns, every_tick=True, spin_ns=spin_ns, lead_ns=LEAD_NS, engine=engine)
    pacer.play(trial, lambda tick, value: None)
    return Calibration(int(tick_ns), spin_ns, pacer.lateness())


def repeat_frames(frames: PortFrames, end_tick: int) -> PortFrames:
    """The run repeated back to back until ``end_tick`` (for timing runs of a chosen length)."""
    if frames.end_tick <= 0:
        raise OutputError("cannot repeat an empty run")
    per_tick = frames.per_tick()
    copies = -(-end_tick // len(per_tick))
    return PortFrames.from_per_tick(np.tile(per_tick, copies)[:end_tick])
