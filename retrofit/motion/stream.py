"""Execute a plan in windows of bounded size: the fast path's port frames, chunk by chunk.

``execute_fast`` holds the whole run's step schedule at once (bytes per step, the whole
program). :func:`stream_frames` computes the same port frames, bit for bit, a window of moves at a
time, carrying between windows only what the step generator remembers: per axis its direction,
last rise and last turn, and the events not yet merged into the byte stream.

A window's frames can be emitted only up to a tick no later event can precede. For each axis
that bound comes from the plan itself: the next step of the axis rises no earlier than the start
of its next move (and a period after its last rise), and if that move turns the direction, the
turn comes no earlier than a tick after the last rise (the generator turns the pin as soon as the
hold allows). So memory stays at one window of steps whatever the program's length.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from ..frames import PinMap, PortFrames
from ..runlog import RunLog, Waypoint
from ._jit import compiled, kernel
from .execute import tick_of
from .fast import _bresenham_requests, _dda_requests
from .planner import Plan

_NEVER = -(1 << 40)
_BIG = np.int64(1) << 62


@kernel
def _shape_from(state, wanted, dirs, period, setup, hold, rises, turn_ticks, turn_dirs):
    """``fast._shape_axis`` continued from ``state`` = [direction, last rise, last turn, steps so far]."""
    direction, last_rise, last_turn, done = state[0], state[1], state[2], state[3]
    turns = 0
    for j in range(wanted.shape[0]):
        first = last_rise + 1 if done + j > 0 else 1
        if dirs[j] != direction:
            turn = last_rise + hold
            if turn < first:
                turn = first
            direction = dirs[j]
            last_turn = turn
            turn_ticks[turns] = turn
            turn_dirs[turns] = direction
            turns += 1
        rise = wanted[j]
        if rise < first:
            rise = first
        if last_rise + period > rise:
            rise = last_rise + period
        if last_turn + setup > rise:
            rise = last_turn + setup
        rises[j] = rise
        last_rise = rise
    state[0], state[1], state[2], state[3] = direction, last_rise, last_turn, done + wanted.shape[0]
    return turns


@kernel
def _merge_until(limit, rises, rise_start, i_rise, i_fall, turns, turn_dirs, turn_start, i_turn,
                 high, step_mask, dir_mask, invert, bits_last, out_ticks, out_values):
    """``fast._frames`` for the events before ``limit``, from the per-axis positions given.

    ``bits_last`` = [logical bits, last byte written (-1: none)]; positions and bits are updated.
    """
    n_axes = high.shape[0]
    bits, last = bits_last[0], bits_last[1]
    count = 0
    upcoming = np.full(n_axes, -1, np.int64)               # -1: work out this axis's next event
    while True:
        tick = _BIG
        for a in range(n_axes):
            if upcoming[a] < 0:
                nxt = _BIG
                if i_fall[a] < rise_start[a + 1]:
                    nxt = rises[i_fall[a]] + high[a]
                if i_rise[a] < rise_start[a + 1] and rises[i_rise[a]] < nxt:
                    nxt = rises[i_rise[a]]
                if i_turn[a] < turn_start[a + 1] and turns[i_turn[a]] < nxt:
                    nxt = turns[i_turn[a]]
                upcoming[a] = nxt
            if upcoming[a] < tick:
                tick = upcoming[a]
        if tick >= limit:
            break
        for a in range(n_axes):
            if upcoming[a] != tick:
                continue
            if i_fall[a] < rise_start[a + 1] and rises[i_fall[a]] + high[a] == tick:
                bits &= ~step_mask[a]
                i_fall[a] += 1
            if i_turn[a] < turn_start[a + 1] and turns[i_turn[a]] == tick:
                if turn_dirs[i_turn[a]] > 0:
                    bits |= dir_mask[a]
                else:
                    bits &= ~dir_mask[a]
                i_turn[a] += 1
            if i_rise[a] < rise_start[a + 1] and rises[i_rise[a]] == tick:
                bits |= step_mask[a]
                i_rise[a] += 1
            upcoming[a] = -1
        value = bits ^ invert
        if value != last:
            out_ticks[count] = tick
            out_values[count] = value
            last = value
            count += 1
    bits_last[0], bits_last[1] = bits, last
    return count


@kernel
def _lag_of(wanted, rises, due_before, risen_before):
    """Most steps due (wanted by a rise's tick) but not yet risen, over ``rises`` (a merge walk)."""
    lag = 0
    due = 0
    for j in range(rises.shape[0]):
        while due < wanted.shape[0] and wanted[due] <= rises[j]:
            due += 1
        behind = due_before + due - (risen_before + j + 1)
        if behind > lag:
            lag = behind
    return lag


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


def _window_requests(plan: Plan, lo: int, hi: int, rate: float):
    """Step requests (wanted ticks, dirs) per axis of moves lo..hi-1 and each move's counts."""
    machine = plan.machine
    moves = plan.moves[lo:hi]
    n_axes, n_moves = len(machine.axes), len(moves)
    starts = np.array([m.start for m in moves], dtype=np.int64).reshape(n_moves, n_axes)
    ends = np.array([m.end for m in moves], dtype=np.int64).reshape(n_moves, n_axes)
    has_profile = np.array([m.profile is not None for m in moves], dtype=np.bool_)
    profiles = np.zeros((n_moves, 15))
    for i, move in enumerate(moves):
        if move.profile is not None:
            profiles[i] = move.profile
    t0s = np.array([m.t0_s for m in moves], dtype=np.float64)
    totals = np.abs(ends - starts)[has_profile].sum(axis=0) if n_moves else np.zeros(n_axes, np.int64)
    width = int(totals.max()) if n_moves else 0
    ticks = np.zeros((n_axes, width), dtype=np.int64)
    dirs = np.zeros((n_axes, width), dtype=np.int8)
    counts = np.zeros((n_moves, n_axes), dtype=np.int64)
    requests = _dda_requests if machine.motion.interpolator == "dda" else _bresenham_requests
    if n_moves:
        requests(starts, ends, profiles, t0s, has_profile, rate, ticks, dirs, counts)
    return [ticks[a, :int(totals[a])] for a in range(n_axes)], [dirs[a, :int(totals[a])] for a in range(n_axes)], counts


def _next_moves(plan: Plan) -> np.ndarray:
    """For each move boundary b (0..n) and axis: (start tick, direction) of the first move at or after
    b that steps the axis, as arrays [n+1, axes] (tick _BIG and direction 0 when there is none)."""
    n, n_axes = len(plan.moves), len(plan.machine.axes)
    rate = 1e6 / plan.machine.tick_us
    ticks = np.full((n + 1, n_axes), _BIG, np.int64)
    dirs = np.zeros((n + 1, n_axes), np.int8)
    for m in range(n - 1, -1, -1):
        ticks[m], dirs[m] = ticks[m + 1], dirs[m + 1]
        move = plan.moves[m]
        if move.profile is None:
            continue
        t = tick_of(move.t0_s, rate)
        for a, (s, e) in enumerate(zip(move.start, move.end)):
            if e != s:
                ticks[m, a], dirs[m, a] = t, 1 if e > s else -1
    return ticks, dirs


def stream_frames(plan: Plan, window_steps: int = 1 << 20,
                  on_waypoint: Callable[[Waypoint], None] | None = None,
                  progress: Callable[[float], None] | None = None) -> Iterator[PortFrames]:
    """The plan's port frames in consecutive chunks (equal, joined, to ``execute_fast``'s).

    Moves are taken in windows of about ``window_steps`` steps. ``on_waypoint`` gets each move's
    waypoint as soon as its last step is known; ``progress`` the fraction of moves done. The
    generator's return value (``StopIteration.value``) is a :class:`StreamStats`.
    """
    machine = plan.machine
    pins = PinMap(machine)
    n_axes, n_moves = len(machine.axes), len(plan.moves)
    rate = 1e6 / machine.tick_us
    next_tick, next_dir = _next_moves(plan)
    period = np.array([a.pulse_high_ticks + a.pulse_low_ticks for a in machine.axes], np.int64)
    high = np.array([a.pulse_high_ticks for a in machine.axes], np.int64)
    step_mask = np.array(pins.step_masks, np.int64)
    dir_mask = np.array(pins.dir_masks, np.int64)
    shape_state = np.array([[-1, _NEVER, _NEVER, 0] for _ in machine.axes], np.int64)
    pending = _Axes(n_axes)
    bits_last = np.array([0, -1], np.int64)
    stats = StreamStats(np.zeros(n_axes, np.int64))
    end = tick_of(plan.end_s, rate)
    first = True
    chunk_end = 0
    sizes = [sum(abs(e - s) for s, e in zip(m.start, m.end)) if m.profile is not None else 0 for m in plan.moves]
    if not compiled(sum(sizes)):           # a small run: one chunk by NumPy, no compiler to load
        return (yield from _whole_run(plan, on_waypoint, progress))
    lo = 0
    while lo < n_moves or first:
        hi, total = lo, 0
        while hi < n_moves and (hi == lo or total + sizes[hi] <= window_steps):
            total += sizes[hi]
            hi += 1
        wanted, dirs, counts = _window_requests(plan, lo, hi, rate)
        window_rises = []
        for a, axis in enumerate(machine.axes):
            rises = np.empty(len(wanted[a]), np.int64)
            turn_ticks = np.empty(len(wanted[a]), np.int64)
            turn_dirs = np.empty(len(wanted[a]), np.int8)
            k = _shape_from(shape_state[a], wanted[a], dirs[a], period[a], axis.dir_setup_ticks,
                            axis.dir_hold_ticks, rises, turn_ticks, turn_dirs)
            _append(pending, a, rises, turn_ticks[:k], turn_dirs[:k], wanted[a])
            window_rises.append(rises)
            if len(rises):
                end = max(end, int(rises[-1]) + int(period[a]) - 1)
            stats.steps[a] += len(rises)
        _waypoints(plan, lo, hi, rate, counts, window_rises, on_waypoint)
        stats.lag = max(stats.lag, _settle_lag(pending, final=hi >= n_moves))
        limit = _BIG
        if hi < n_moves:      # no later event, and no later waypoint, comes before the limit
            limit = min(_limit(shape_state, next_tick[hi], next_dir[hi], period, machine),
                        tick_of(plan.moves[hi].t0_s, rate))
        chunk = _merge(pending, limit, high, step_mask, dir_mask, pins.invert, bits_last, first)
        first = False
        chunk_end = max(chunk_end, limit) if hi < n_moves else max(end, 0) + 1
        chunk = PortFrames(chunk.ticks, chunk.values, chunk_end)
        yield chunk
        if progress is not None:
            progress(hi / n_moves if n_moves else 1.0)
        lo = hi
        if lo >= n_moves:
            break
    stats.end_tick = max(end, 0) + 1
    return stats


def _whole_run(plan: Plan, on_waypoint, progress):
    """The whole run as one chunk (``execute_numpy``, the same frames), for small programs."""
    from .vectorised import execute_numpy
    log = execute_numpy(plan)
    for waypoint in log.waypoints:
        if on_waypoint is not None:
            on_waypoint(waypoint)
    yield log.frames
    if progress is not None:
        progress(1.0)
    steps = np.array([log.steps_emitted.get(a.name, 0) for a in plan.machine.axes], np.int64)
    return StreamStats(steps, int(log.max_following_error_steps), int(log.frames.end_tick))


def _append(pending: _Axes, a: int, rises, turn_ticks, turn_dirs, wanted) -> None:
    pending.rises[a] = np.concatenate((pending.rises[a], rises))
    pending.turns[a] = np.concatenate((pending.turns[a], turn_ticks))
    pending.turn_dirs[a] = np.concatenate((pending.turn_dirs[a], turn_dirs))
    pending.wanted[a] = np.concatenate((pending.wanted[a], wanted))
    pending.open_rises[a] = np.concatenate((pending.open_rises[a], rises))


def _waypoints(plan: Plan, lo: int, hi: int, rate: float, counts, window_rises, on_waypoint) -> None:
    """Each move's waypoint: reached at its last rising edge (``execute.run_log``'s rule)."""
    if on_waypoint is None:
        return
    n_axes = counts.shape[1] if len(counts) else 0
    for m in range(lo, hi):
        row = counts[m - lo]
        last = [int(window_rises[a][row[a] - 1]) for a in range(n_axes)
                if row[a] > 0 and (m == lo or row[a] > counts[m - lo - 1][a])]
        move = plan.moves[m]
        reached = max(last) if last else tick_of(move.t0_s + move.duration_s, rate)
        on_waypoint(Waypoint(move.target, loaded_tick=tick_of(move.t0_s, rate), reached_tick=reached))


def _settle_lag(pending: _Axes, final: bool) -> int:
    """The following error over the rises whose count of due steps can no longer change."""
    lag = 0
    for a in range(len(pending.rises)):
        wanted, rises = pending.wanted[a], pending.open_rises[a]
        if not len(rises):
            continue
        ready = len(rises) if final or not len(wanted) else int(np.searchsorted(rises, wanted[-1], side="left"))
        if ready:
            lag = max(lag, int(_lag_of(wanted, rises[:ready], pending.due_before[a], pending.risen_before[a])))
            keep_from = rises[ready] if ready < len(rises) else rises[ready - 1] + 1
            cut = int(np.searchsorted(wanted, keep_from, side="left"))
            pending.wanted[a] = wanted[cut:]
            pending.due_before[a] += cut
            pending.open_rises[a] = rises[ready:]
            pending.risen_before[a] += ready
    return lag


def _limit(shape_state, next_tick, next_dir, period, machine) -> int:
    """The earliest tick any event of a later window can have (see the module doc)."""
    limit = _BIG
    for a, axis in enumerate(machine.axes):
        if next_dir[a] == 0:
            continue
        direction, last_rise, _, done = (int(v) for v in shape_state[a])
        first = last_rise + 1 if done > 0 else 1
        if next_dir[a] != direction:
            bound = max(last_rise + axis.dir_hold_ticks, first)
        else:
            bound = max(int(next_tick[a]), first, last_rise + int(period[a]))
        limit = min(limit, bound)
    return int(limit)


def _merge(pending: _Axes, limit: int, high, step_mask, dir_mask, invert: int, bits_last, first: bool) -> PortFrames:
    """Port frames of the pending events before ``limit``; what is merged leaves ``pending``."""
    n_axes = len(pending.rises)
    rise_start = np.zeros(n_axes + 1, np.int64)
    turn_start = np.zeros(n_axes + 1, np.int64)
    for a in range(n_axes):
        rise_start[a + 1] = rise_start[a] + len(pending.rises[a])
        turn_start[a + 1] = turn_start[a] + len(pending.turns[a])
    rises = np.concatenate(pending.rises) if n_axes else np.zeros(0, np.int64)
    turns = np.concatenate(pending.turns) if n_axes else np.zeros(0, np.int64)
    turn_dirs = np.concatenate(pending.turn_dirs) if n_axes else np.zeros(0, np.int8)
    i_fall = rise_start[:-1].copy()
    i_rise = i_fall + pending.i_rise
    i_turn = turn_start[:-1].copy()
    capacity = 2 * len(rises) + len(turns) + 1
    out_ticks = np.empty(capacity, np.int64)
    out_values = np.empty(capacity, np.uint8)
    start = 0
    if first:
        out_ticks[0], out_values[0] = 0, invert
        bits_last[0], bits_last[1] = 0, invert
        start = 1
    count = _merge_until(np.int64(limit), rises, rise_start, i_rise, i_fall, turns, turn_dirs, turn_start,
                         i_turn, high, step_mask, dir_mask, np.int64(invert), bits_last,
                         out_ticks[start:], out_values[start:])
    for a in range(n_axes):
        fallen = int(i_fall[a] - rise_start[a])
        pending.rises[a] = pending.rises[a][fallen:]
        pending.i_rise[a] = int(i_rise[a] - i_fall[a])
        pending.turns[a] = pending.turns[a][int(i_turn[a] - turn_start[a]):]
        pending.turn_dirs[a] = pending.turn_dirs[a][int(i_turn[a] - turn_start[a]):]
    n = start + count
    return PortFrames(out_ticks[:n].copy(), out_values[:n].copy(), min(int(limit), int(_BIG)))


def execute_streamed(plan: Plan, window_steps: int = 1 << 20) -> RunLog:
    """The whole run through :func:`stream_frames`, joined into one ``RunLog`` (for tests and
    small programs; a long run should consume the chunks as they come)."""
    waypoints: list[Waypoint] = []
    chunks = []
    gen = stream_frames(plan, window_steps, on_waypoint=waypoints.append)
    while True:
        try:
            chunks.append(next(gen))
        except StopIteration as stop:
            stats = stop.value
            break
    frames = PortFrames(np.concatenate([c.ticks for c in chunks]), np.concatenate([c.values for c in chunks]),
                        stats.end_tick)
    log = RunLog(plan.machine, frames, waypoints=waypoints, start_steps=plan.start_steps)
    log.steps_emitted = {a.name: int(n) for a, n in zip(plan.machine.axes, stats.steps)}
    log.max_following_error_steps = int(stats.lag)
    return log
