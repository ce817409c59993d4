"""Execute a plan in windows of bounded size: the fast path's port frames, chunk by chunk.

``execute_fast`` holds the whole run's step schedule at once (bytes per step, the whole
program). :func:`stream_frames` computes the same port frames, bit for bit, a window of moves at a
time, carrying between windows only what the step generator remembers: per axis its direction,
last rise and last turn, and the events not yet merged into the byte stream.

A window's frames can be emitted only up to a tick no later event can precede. For each axis
that bound comes from the plan itself: the next step of the axis rises no earlier than the start
of its next move (and a period after its last rise). If that move turns the direction, the turn's
tick is known already (a tick after the last rise, the hold, and that move's entry into the
look-ahead window, ``motion.stepshape``), so the turn is made at once: a reversal far ahead holds
back no frame. So memory stays at one
window of steps whatever the program's length.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import cast

import numpy as np

from ..frames import PinMap, PortFrames
from ..runlog import RunLog, WaypointTable
from ._jit import compiled
from .bitmerge import merge_pending
from .columns import Columns
from .execute import tick_of
from .fast import _bresenham_requests, _dda_requests, plan_steps
from .planner import Plan
from .stepshape import fresh_state, lag_of, shape_steps

_BIG = cast(int, np.int64(1) << 62)         # NumPy's int64, used as an int
#: the first window holds this share of ``window_steps`` (the run reads that much before its first step)
FIRST_WINDOW_SHARE = 32


@dataclass
class StreamStats:
    """What a streamed run adds up as it goes (the rest of a ``RunLog`` without its frames)."""

    steps: np.ndarray            # steps emitted per axis
    lag: int = 0                 # following error: most steps due but not yet risen
    end_tick: int = 0


class _Axes:
    """Per-axis events computed but not yet merged into port frames."""

    def __init__(self, n_axes: int):
        self.rises = [np.zeros(0, np.int64) for _ in range(n_axes)]
        self.i_rise = np.zeros(n_axes, np.int64)        # next rise to emit (index into rises[a])
        self.turns = [np.zeros(0, np.int64) for _ in range(n_axes)]
        self.turn_dirs = [np.zeros(0, np.int8) for _ in range(n_axes)]
        self.wanted = [np.zeros(0, np.int64) for _ in range(n_axes)]    # for the following error
        self.open_rises = [np.zeros(0, np.int64) for _ in range(n_axes)]
        self.due_before = np.zeros(n_axes, np.int64)     # wanted ticks dropped from ``wanted``
        self.risen_before = np.zeros(n_axes, np.int64)   # rises dropped from ``open_rises``


#: glibc's mallopt parameters: the size from which an array gets pages of its own, and the free
#: memory kept at the top of the heap
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_KEEP_BYTES = 1 << 25
_kept = False


def keep_freed_memory() -> None:
    """Let the window-sized arrays a stream makes and drops reuse freed memory.

    By default glibc gives each array over 128 kB pages of its own and returns them when it is
    freed, so every window would fault its pages in again (nearly half the CPU of a short
    streamed run); arrays below 32 MB come from the heap instead, which keeps 32 MB free.
    Nothing changes where the C library is not glibc.
    """
    global _kept
    if _kept:
        return
    _kept = True
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, _KEEP_BYTES)
        libc.mallopt(_M_TRIM_THRESHOLD, _KEEP_BYTES)
    except (OSError, AttributeError):           # pragma: no cover - not glibc
        pass


def _window_requests(machine, cols: Columns, lo: int, hi: int, rate: float):
    """Step requests (wanted ticks, dirs) per axis of moves lo..hi-1 and each move's counts."""
    a = cols.arrays
    n_axes, n_moves = a.starts.shape[1], hi - lo
    starts, ends, has_profile = a.starts[lo:hi], a.ends[lo:hi], a.has_profile[lo:hi]
    totals = (np.abs(ends - starts) * has_profile[:, None]).sum(axis=0)
    width = int(totals.max())
    ticks = np.empty((n_axes, width), dtype=np.int64)
    dirs = np.empty((n_axes, width), dtype=np.int8)
    counts = np.empty((n_moves, n_axes), dtype=np.int64)
    requests = _dda_requests if machine.motion.interpolator == "dda" else _bresenham_requests
    requests(starts, ends, a.profiles[lo:hi], a.t0s[lo:hi], has_profile, rate, ticks, dirs, counts)
    return [ticks[k, :int(totals[k])] for k in range(n_axes)], [dirs[k, :int(totals[k])] for k in range(n_axes)], counts


class _StepGen:
    """The step generator of every axis, carried from window to window: its counters' state, the
    events not yet merged into port frames, and the last byte written."""

    def __init__(self, machine):
        pins = PinMap(machine)
        self.axes, self.invert = machine.axes, pins.invert
        self.period = np.array([a.pulse_high_ticks + a.pulse_low_ticks for a in machine.axes], np.int64)
        self.high = np.array([a.pulse_high_ticks for a in machine.axes], np.int64)
        self.step_mask = np.array(pins.step_masks, np.int64)
        self.dir_mask = np.array(pins.dir_masks, np.int64)
        self.state = fresh_state(len(machine.axes))
        self.pending = _Axes(len(machine.axes))
        self.bits_last = np.array([0, -1], np.int64)

    def shape(self, wanted, dirs, counts, seen) -> tuple[list[np.ndarray], int]:
        """Rise ticks per axis of a window's step requests (kept pending for the frames) and the
        last tick any of their pulses holds (-1 for none); ``counts`` / ``seen`` are the window's
        moves' (``stepshape.shape_steps``)."""
        window_rises, last = [], -1
        for a, axis in enumerate(self.axes):
            size = len(wanted[a]) if wanted else 0
            rises, turn_ticks = np.empty(size, np.int64), np.empty(size, np.int64)
            turn_dirs = np.empty(size, np.int8)
            if size:
                k = shape_steps(self.state[a], wanted[a], dirs[a], counts[:, a], seen, self.period[a],
                                axis.dir_setup_ticks, axis.dir_hold_ticks, rises, turn_ticks, turn_dirs)
                _append(self.pending, a, rises, turn_ticks[:k], turn_dirs[:k], wanted[a])
                last = max(last, int(rises[-1]) + int(self.period[a]) - 1)
            window_rises.append(rises)
        return window_rises, last

    def turn_ahead(self, cols: Columns, hi: int) -> None:
        """Turn now each direction the next move from ``hi`` reverses: no step of the axis comes
        before it, so its tick is known (``stepshape.shape_steps``'s rule) and the frames before
        that move need not wait for its window."""
        for a, axis in enumerate(self.axes):
            heading = int(cols.next_dir[hi, a])
            direction, last_rise, _, done = (int(v) for v in self.state[a])
            if heading in (0, direction):
                continue
            first = last_rise + 1 if done > 0 else 1
            turn = max(last_rise + axis.dir_hold_ticks, first, int(cols.seen[cols.next_move[hi, a]]))
            self.state[a, 0], self.state[a, 2] = heading, turn
            pending = self.pending
            pending.turns[a] = _joined(pending.turns[a], np.array([turn], np.int64))
            pending.turn_dirs[a] = _joined(pending.turn_dirs[a], np.array([heading], np.int8))

    def frames(self, limit: int, first: bool) -> PortFrames:
        """Port frames of the pending events before ``limit``."""
        return merge_pending(self.pending, limit, self.high, self.step_mask, self.dir_mask, self.invert,
                      self.bits_last, first)


def stream_frames(plan: Plan, window_steps: int = 1 << 20,
                  on_waypoints: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
                  progress: Callable[[float], None] | None = None) -> Generator[PortFrames, None, StreamStats]:
    """The plan's port frames in consecutive chunks (equal, joined, to ``execute_fast``'s).

    Moves are taken in windows of about ``window_steps`` steps. ``on_waypoints(steps, loaded,
    reached)`` gets the waypoints of each window's moves (arrays) as soon as their last steps are
    known; ``progress`` the fraction of moves done. The generator's return value
    (``StopIteration.value``) is a :class:`StreamStats`.
    """
    rate = 1e6 / plan.machine.tick_us
    if not compiled(plan_steps(plan)):           # a small run: one chunk by NumPy, no compiler to load
        return (yield from _whole_run(plan, on_waypoints, progress))
    return (yield from stream_columns(Columns.of_plan(plan, rate), window_steps, on_waypoints, progress))


def stream_blocks(machine, start_steps, blocks, window_steps: int = 1 << 20,
                  on_waypoints=None, progress=None) -> Generator[PortFrames, None, StreamStats]:
    """:func:`stream_frames` of a plan handed on block by block (``blocks``: (PlanArrays, None)
    until the last, (PlanArrays, end time) for the last): the same frames, while only the moves
    of the window being made and those the planner has handed on beyond it are held;
    ``progress`` gets the index of the command after the last one stepped."""
    rate = 1e6 / machine.tick_us
    cols = Columns.rolling(machine, rate, blocks)
    cols.more(0, _first(window_steps))
    if cols.final and not compiled(int(cols.steps_from(0))):     # small: one chunk by NumPy
        assert cols.end_s is not None                             # final: the end is known
        plan = Plan(machine, tuple(start_steps), end_s=cols.end_s, arrays=cols.arrays)
        index = cols.arrays.index

        def done(share: float) -> None:           # the share of moves made, as a command index
            made = int(round(share * len(index)))
            progress(int(index[made - 1]) + 1 if made else 0)
        return (yield from _whole_run(plan, on_waypoints, None if progress is None else done))
    return (yield from stream_columns(cols, window_steps, on_waypoints, progress))


def _first(window_steps: int) -> int:
    """Steps of the first window: a share of the others, so the first step leaves early."""
    return max(window_steps // FIRST_WINDOW_SHARE, 1)


def stream_columns(cols: Columns, window_steps: int, on_waypoints,
                   progress) -> Generator[PortFrames, None, StreamStats]:
    """The frames of the moves of ``cols`` (whole or rolling), window by window."""
    machine = cols.machine
    keep_freed_memory()
    rate = cols.rate
    gen = _StepGen(machine)
    stats = StreamStats(np.zeros(len(machine.axes), np.int64))
    end = -1
    lo, chunk_end, first = 0, 0, True
    while True:
        size = _first(window_steps) if first else window_steps
        lo = cols.more(lo, size)
        n_moves = len(cols)
        hi = cols.window_end(lo, size) if n_moves else 0
        last_window = cols.final and hi >= n_moves
        if last_window:
            assert cols.end_s is not None                         # final: the end is known
            end = max(end, tick_of(cols.end_s, rate))
        wanted, dirs, counts = _window_requests(machine, cols, lo, hi, rate) if hi > lo else ([], [], None)
        window_rises, last = gen.shape(wanted, dirs, counts, cols.seen[lo:hi])
        end = max(end, last)
        stats.steps += [len(r) for r in window_rises]
        if on_waypoints is not None and hi > lo:
            on_waypoints(cols.arrays.targets[lo:hi], cols.loaded[lo:hi],
                         _reached(counts, window_rises, cols.ends[lo:hi]))
        stats.lag = max(stats.lag, _settle_lag(gen.pending, final=last_window))
        limit = _BIG
        if not last_window:      # no later event, and no later waypoint, comes before the limit
            gen.turn_ahead(cols, hi)
            limit = min(_limit(gen.state, cols, hi, gen.period, machine), int(cols.loaded[hi]))
        chunk = gen.frames(limit, first=first)
        first = False
        chunk_end = max(chunk_end, limit) if not last_window else max(end, 0) + 1
        yield PortFrames(chunk.ticks, chunk.values, chunk_end)
        if progress is not None:     # rolling columns: the command index reached (their length is not known)
            progress((int(cols.arrays.index[hi - 1]) + 1 if hi else 0) if cols.blocks is not None
                     else hi / n_moves if n_moves else 1.0)
        lo = hi
        if last_window:
            break
    stats.end_tick = max(end, 0) + 1
    return stats


def _reached(counts, window_rises, move_ends) -> np.ndarray:
    """Each move's reached tick: its last rising edge (``execute.run_log``'s rule), else its end."""
    reached = np.full(len(counts), -1, np.int64)
    for a, rises in enumerate(window_rises):
        c = counts[:, a]
        stepped = c > np.concatenate(([0], c[:-1]))
        if stepped.any():
            reached[stepped] = np.maximum(reached[stepped], rises[c[stepped] - 1])
    return np.where(reached >= 0, reached, move_ends)


def _whole_run(plan: Plan, on_waypoints, progress):
    """The whole run as one chunk (``execute_numpy``, the same frames), for small programs."""
    from .vectorised import execute_numpy
    log = execute_numpy(plan)
    if on_waypoints is not None and log.waypoints:
        on_waypoints(np.array([w.steps for w in log.waypoints], np.int64),
                     np.array([w.loaded_tick for w in log.waypoints], np.int64),
                     np.array([w.reached_tick for w in log.waypoints], np.int64))
    yield log.frames
    if progress is not None:
        progress(1.0)
    steps = np.array([log.steps_emitted.get(a.name, 0) for a in plan.machine.axes], np.int64)
    return StreamStats(steps, int(log.max_following_error_steps), int(log.frames.end_tick))


def _append(pending: _Axes, a: int, rises, turn_ticks, turn_dirs, wanted) -> None:
    pending.rises[a] = _joined(pending.rises[a], rises)
    pending.turns[a] = _joined(pending.turns[a], turn_ticks)
    pending.turn_dirs[a] = _joined(pending.turn_dirs[a], turn_dirs)
    pending.wanted[a] = _joined(pending.wanted[a], wanted)
    pending.open_rises[a] = _joined(pending.open_rises[a], rises)


def _joined(kept: np.ndarray, new: np.ndarray) -> np.ndarray:
    """``kept`` followed by ``new`` (``new`` itself when nothing is kept: the arrays pending are
    only read and sliced, never written)."""
    return np.concatenate((kept, new)) if len(kept) else new


def _settle_lag(pending: _Axes, final: bool) -> int:
    """The following error over the rises whose count of due steps can no longer change."""
    lag = 0
    for a in range(len(pending.rises)):
        wanted, rises = pending.wanted[a], pending.open_rises[a]
        if not len(rises):
            continue
        ready = len(rises) if final or not len(wanted) else int(np.searchsorted(rises, wanted[-1], side="left"))
        if ready:
            lag = max(lag, int(lag_of(wanted, rises[:ready], pending.due_before[a], pending.risen_before[a])))
            keep_from = rises[ready] if ready < len(rises) else rises[ready - 1] + 1
            cut = int(np.searchsorted(wanted, keep_from, side="left"))
            pending.wanted[a] = wanted[cut:]
            pending.due_before[a] += cut
            pending.open_rises[a] = rises[ready:]
            pending.risen_before[a] += ready
    return lag


def _limit(shape_state, cols: Columns, hi: int, period, machine) -> int:
    """The earliest tick any event of the windows from move ``hi`` on can have (see the module doc;
    the direction each axis needs next is already turned, ``_StepGen.turn_ahead``; an axis whose
    next move is not planned yet waits for it to enter the look-ahead window)."""
    limit = _BIG
    for a in range(len(machine.axes)):
        if cols.next_dir[hi, a] == 0:
            if not cols.final:
                limit = min(limit, cols.horizon_seen)
            continue
        _, last_rise, _, done = (int(v) for v in shape_state[a])
        first = last_rise + 1 if done > 0 else 1
        limit = min(limit, max(int(cols.loaded[cols.next_move[hi, a]]), first, last_rise + int(period[a])))
    return int(limit)


def execute_streamed(plan: Plan, window_steps: int = 1 << 20) -> RunLog:
    """The whole run through :func:`stream_frames`, joined into one ``RunLog`` (for tests and
    small programs; a long run should consume the chunks as they come)."""
    table = WaypointTable(len(plan.machine.axes))
    chunks = []
    gen = stream_frames(plan, window_steps, on_waypoints=table.add)
    while True:
        try:
            chunks.append(next(gen))
        except StopIteration as stop:
            stats = stop.value
            break
    frames = PortFrames(np.concatenate([c.ticks for c in chunks]), np.concatenate([c.values for c in chunks]),
                        stats.end_tick)
    log = RunLog(plan.machine, frames, waypoints=list(table), start_steps=plan.start_steps)
    log.steps_emitted = {a.name: int(n) for a, n in zip(plan.machine.axes, stats.steps)}
    log.max_following_error_steps = int(stats.lag)
    return log
