"""Execute a plan, fast path: the whole step schedule and port frames at once, compiled loops.

Same answer as ``motion.execute`` (the reference path), bit for bit, by other means:

* step requests: one compiled loop over the moves and their cycles (the same Bresenham error
  terms, the same 004 pulse positions, the same profile kernel and tick rounding);
* pulse shaping: instead of a loop over every tick, the step generator's rules solved per
  step (``motion.stepshape``, the one kernel the streamed path uses too);
* port frames: the axes' bit changes merged in tick order into the run-length byte stream.

Without Numba the same kernels run as plain Python (correct, slow).
"""

from __future__ import annotations

import numpy as np

from ..frames import PinMap, PortFrames
from ._jit import compiled, kernel
from .execute import StepRequests, run_log, tick_of
from .planner import Plan
from .profile import P_LEN, ticks_at, time_at
from .stepshape import fresh_state, lag_of, plan_seen, shape_steps


@kernel
def _base_steps(start, end):
    """Steps of the base axis of a move: the largest |end - start| over the axes."""
    n = 0
    for a in range(start.shape[0]):
        d = abs(end[a] - start[a])
        if d > n:
            n = d
    return n


@kernel
def _pieces_time(s, starts, offsets, rows):
    """Seconds to ``s`` mm into a move whose profile is in pieces (``rows`` starting at ``starts``
    mm and ``offsets`` s), as the controller's ``MoveProfile`` keeps a re-planned move."""
    i = 0
    while i + 1 < starts.shape[0] and starts[i + 1] <= s:
        i += 1
    return offsets[i] + time_at(s - starts[i], rows[i])


@kernel
def _tie(cycle, n, direction):
    """002's tie rule (``bresenham._tie_steps``): on a tie, does the axis step at this cycle?"""
    if 2 * cycle != n:
        return 2 * cycle > n
    return direction < 0


@kernel
def move_requests(dda, n, c0, c_stop, delta, state, length, t0, starts, offsets, rows, rate,
                  out_ticks, out_cycle, fill, cycle_due):
    """Step requests of cycles ``c0 + 1 .. c_stop`` of one move of ``n`` cycles (002's execute).

    Each axis's requests go to ``out_ticks[a, fill[a]]`` (``fill`` advances): the tick each step
    is wanted on, nearest the time the profile (one row, or the pieces of a re-planned move) is
    at the step's place. ``state`` is the interpolator's, updated: Bresenham's error terms
    (row 0), or for 004's digital integration the pulses sent (row 0) and SHORT's numerator
    (row 1). When given (non-empty), ``out_cycle`` gets the tick of the cycle that makes each
    request and ``cycle_due`` the tick of each cycle.
    """
    first = rows[0]
    single = starts.shape[0] == 1
    if dda:
        for a in range(delta.shape[0]):        # pulse j of d: at cycle j n // d, j n / d intervals in
            d = abs(delta[a])
            j = state[0, a] + 1
            while j <= d and n * j < (c_stop + 1) * d:
                s = float(j * n) / d * length / n
                t = time_at(s, first) if single else _pieces_time(s, starts, offsets, rows)
                out_ticks[a, fill[a]] = np.int64(np.floor((t0 + t) * rate + 0.5))
                if out_cycle.shape[1]:
                    s = float((n * j) // d) * length / n
                    t = time_at(s, first) if single else _pieces_time(s, starts, offsets, rows)
                    out_cycle[a, fill[a]] = np.int64(np.floor((t0 + t) * rate + 0.5))
                fill[a] += 1
                j += 1
            state[0, a] = j - 1
            state[1, a] = n * j
    for k in range(c0 + 1, c_stop + 1):
        if dda and not cycle_due.shape[0]:
            break
        s = float(k) * length / n
        t = time_at(s, first) if single else _pieces_time(s, starts, offsets, rows)
        due = np.int64(np.floor((t0 + t) * rate + 0.5))
        if cycle_due.shape[0]:
            cycle_due[k - c0 - 1] = due
        for a in range(delta.shape[0]):
            d = abs(delta[a])
            if dda or d == 0:
                continue
            state[0, a] += 2 * d
            if not (state[0, a] > n or (state[0, a] == n and _tie(k, n, delta[a]))):
                continue
            state[0, a] -= 2 * n
            out_ticks[a, fill[a]] = due
            if out_cycle.shape[1]:
                out_cycle[a, fill[a]] = due
            fill[a] += 1


@kernel
def _bresenham_requests(starts, ends, profiles, t0s, has_profile, rate, out_ticks, out_dirs, counts):
    """Per-axis requested ticks and directions of every move, cycle by cycle (002's execute)."""
    n_moves, n_axes = starts.shape
    fill = np.zeros(n_axes, dtype=np.int64)
    error = np.zeros(n_axes, dtype=np.int64)
    s = np.empty(1024)
    ticks = np.empty(1024, np.int64)
    for m in range(n_moves):
        if has_profile[m]:
            n = _base_steps(starts[m], ends[m])
            p = profiles[m]
            length = p[P_LEN]
            if n > s.shape[0]:
                s, ticks = np.empty(2 * n), np.empty(2 * n, np.int64)
            for k in range(n):                                  # cycle k + 1 of n
                s[k] = float(k + 1) * length / n
            ticks_at(s[:n], p, t0s[m], rate, ticks[:n])
            for a in range(n_axes):
                error[a] = 0
            for k in range(1, n + 1):
                for a in range(n_axes):
                    delta = ends[m, a] - starts[m, a]
                    if delta == 0:
                        continue
                    error[a] += 2 * abs(delta)
                    if error[a] > n or (error[a] == n and _tie(k, n, delta)):
                        error[a] -= 2 * n
                        out_ticks[a, fill[a]] = ticks[k - 1]
                        out_dirs[a, fill[a]] = 1 if delta > 0 else -1
                        fill[a] += 1
        for a in range(n_axes):
            counts[m, a] = fill[a]


@kernel
def _dda_requests(starts, ends, profiles, t0s, has_profile, rate, out_ticks, out_dirs, counts):
    """The same for 004's digital integration: pulse k of d sits at k·n/d base intervals."""
    n_moves, n_axes = starts.shape
    s = np.empty(1024)
    for a in range(n_axes):
        fill = 0
        for m in range(n_moves):
            if has_profile[m]:
                n = _base_steps(starts[m], ends[m])
                length = profiles[m, P_LEN]
                delta = ends[m, a] - starts[m, a]
                d = abs(delta)
                if d > s.shape[0]:
                    s = np.empty(2 * d)
                for k in range(d):                              # pulse k + 1 of d
                    position = float((k + 1) * n) / d
                    s[k] = position * length / n
                ticks_at(s[:d], profiles[m], t0s[m], rate, out_ticks[a, fill:fill + d])
                out_dirs[a, fill:fill + d] = 1 if delta > 0 else -1
                fill += d
            counts[m, a] = fill


@kernel
def _frames(rises, rise_start, turns, turn_dirs, turn_start, high, step_mask, dir_mask, invert,
            out_ticks, out_values):
    """Port byte stream of every axis's rises (high for ``high`` ticks) and direction turns.

    The axes' events are merged in tick order; all events of one tick are applied before the
    byte is compared with the last one recorded, so only real changes are kept.
    """
    n_axes = high.shape[0]
    i_rise = rise_start[:-1].copy()
    i_fall = rise_start[:-1].copy()
    i_turn = turn_start[:-1].copy()
    big = np.int64(1) << 62
    upcoming = np.full(n_axes, -1, dtype=np.int64)          # -1: work out this axis's next change
    bits = 0                                     # logical bits: steps low, directions negative
    out_ticks[0] = 0
    out_values[0] = bits ^ invert
    last = bits ^ invert
    count = 1
    while True:
        tick = big
        for a in range(n_axes):
            if upcoming[a] < 0:                              # the next fall, turn or rise of axis a
                nxt = big
                if i_fall[a] < rise_start[a + 1]:
                    nxt = rises[i_fall[a]] + high[a]
                if i_rise[a] < rise_start[a + 1] and rises[i_rise[a]] < nxt:
                    nxt = rises[i_rise[a]]
                if i_turn[a] < turn_start[a + 1] and turns[i_turn[a]] < nxt:
                    nxt = turns[i_turn[a]]
                upcoming[a] = nxt
            if upcoming[a] < tick:
                tick = upcoming[a]
        if tick == big:
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
    return count


def request_steps_fast(plan: Plan) -> StepRequests:
    """Step requests of the whole plan (equal to ``execute.request_steps``)."""
    machine = plan.machine
    n_axes, n_moves = len(machine.axes), len(plan.moves)
    starts = np.array([m.start for m in plan.moves], dtype=np.int64).reshape(n_moves, n_axes)
    ends = np.array([m.end for m in plan.moves], dtype=np.int64).reshape(n_moves, n_axes)
    has_profile = np.array([m.profile is not None for m in plan.moves], dtype=np.bool_)
    profiles = np.zeros((n_moves, 15))
    for i, move in enumerate(plan.moves):
        if move.profile is not None:
            profiles[i] = move.profile
    t0s = np.array([m.t0_s for m in plan.moves], dtype=np.float64)
    totals = np.abs(ends - starts)[has_profile].sum(axis=0) if n_moves else np.zeros(n_axes, np.int64)
    width = int(totals.max()) if n_moves else 0
    ticks = np.zeros((n_axes, width), dtype=np.int64)
    dirs = np.zeros((n_axes, width), dtype=np.int8)
    counts = np.zeros((n_moves, n_axes), dtype=np.int64)
    rate = 1e6 / machine.tick_us
    requests = _dda_requests if machine.motion.interpolator == "dda" else _bresenham_requests
    if n_moves:
        requests(starts, ends, profiles, t0s, has_profile, rate, ticks, dirs, counts)
    move_end = np.array([tick_of(m.t0_s + m.duration_s, rate) for m in plan.moves], dtype=np.int64)
    return StepRequests([ticks[a, :int(totals[a])] for a in range(n_axes)],
                        [dirs[a, :int(totals[a])] for a in range(n_axes)],
                        counts, move_end, tick_of(plan.end_s, rate))


def shape_fast(plan: Plan, requests: StepRequests):
    """(port frames, rise ticks per axis, following error) of the requests.

    Equal to ``execute.shape_reference`` and the lag ``execute.run_log`` would find.
    """
    machine = plan.machine
    pins = PinMap(machine)
    n_axes = len(machine.axes)
    sizes = np.array([len(t) for t in requests.ticks], dtype=np.int64)
    rise_start = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    rises = np.empty(int(rise_start[-1]), dtype=np.int64)
    turns = np.empty(int(rise_start[-1]), dtype=np.int64)
    turn_dirs = np.empty(int(rise_start[-1]), dtype=np.int8)
    turn_start = np.zeros(n_axes + 1, dtype=np.int64)
    end = requests.end_tick
    lag = 0
    state, seen = fresh_state(n_axes), plan_seen(plan)
    for a, axis in enumerate(machine.axes):
        lo, hi = rise_start[a], rise_start[a + 1]
        period = axis.pulse_high_ticks + axis.pulse_low_ticks
        count = shape_steps(state[a], requests.ticks[a], requests.dirs[a], requests.counts[:, a], seen, period,
                            axis.dir_setup_ticks, axis.dir_hold_ticks, rises[lo:hi],
                            turns[turn_start[a]:], turn_dirs[turn_start[a]:])
        turn_start[a + 1] = turn_start[a] + count
        lag = max(lag, int(lag_of(requests.ticks[a], rises[lo:hi], 0, 0)))
        if hi > lo:
            end = max(end, int(rises[hi - 1]) + period - 1)
    high = np.array([a.pulse_high_ticks for a in machine.axes], dtype=np.int64)
    capacity = 2 * len(rises) + int(turn_start[-1]) + 1
    out_ticks = np.empty(capacity, dtype=np.int64)
    out_values = np.empty(capacity, dtype=np.uint8)
    count = _frames(rises, rise_start, turns, turn_dirs, turn_start, high,
                    np.array(pins.step_masks, dtype=np.int64), np.array(pins.dir_masks, dtype=np.int64),
                    pins.invert, out_ticks, out_values)
    frames = PortFrames(out_ticks[:count], out_values[:count], max(end, 0) + 1)
    return frames, [rises[rise_start[a]:rise_start[a + 1]] for a in range(n_axes)], lag


def plan_steps(plan: Plan) -> int:
    """Steps of all axes over the whole plan (the work a run has to do)."""
    a = plan.arrays()
    return int((np.abs(a.ends - a.starts).sum(axis=1) * a.has_profile).sum())


def execute_fast(plan: Plan):
    """Fast path: plan → step requests → pulses → port frames and the run log.

    Compiled loops when Numba is installed and the plan is large enough to pay for loading
    them; otherwise whole-array NumPy (``motion.vectorised``), the same frames.
    """
    if not compiled(plan_steps(plan)):              # small (or no Numba): NumPy, no compiler to load
        from .vectorised import execute_numpy
        return execute_numpy(plan)
    requests = request_steps_fast(plan)
    frames, rises, lag = shape_fast(plan, requests)
    return run_log(plan, requests, frames, rises, lag)
