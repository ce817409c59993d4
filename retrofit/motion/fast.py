"""Execute a plan, fast path: the whole step schedule and port frames at once, compiled loops.

Same answer as ``motion.execute`` (the reference path), bit for bit, by other means:

* step requests: one compiled loop over the moves and their cycles (the same Bresenham error
  terms, the same 004 pulse positions, the same profile kernel and tick rounding);
* pulse shaping: instead of a loop over every tick, the step generator's rules solved per
  step: a step rises at the latest of its wanted tick, one period after the last rise, and the
  direction set-up after the last turn; the direction turns as soon as the hold allows;
* port frames: the axes' bit changes merged in tick order into the run-length byte stream.

Without Numba the same kernels run as plain Python (correct, slow).
"""

from __future__ import annotations

import numpy as np

from ..frames import PinMap, PortFrames
from ._jit import kernel
from .execute import StepRequests, run_log, tick_of
from .planner import Plan
from .profile import P_LEN, time_at

_NEVER = -(1 << 40)


@kernel
def _bresenham_requests(starts, ends, profiles, t0s, has_profile, rate, out_ticks, out_dirs, counts):
    """Per-axis requested ticks and directions of every move, cycle by cycle (002's execute)."""
    n_moves, n_axes = starts.shape
    fill = np.zeros(n_axes, dtype=np.int64)
    error = np.zeros(n_axes, dtype=np.int64)
    for m in range(n_moves):
        if has_profile[m]:
            n = 0
            for a in range(n_axes):
                d = abs(ends[m, a] - starts[m, a])
                if d > n:
                    n = d
            p = profiles[m]
            length = p[P_LEN]
            for a in range(n_axes):
                error[a] = 0
            for k in range(1, n + 1):
                s = float(k) * length / n
                tick = np.int64(np.floor((t0s[m] + time_at(s, p)) * rate + 0.5))
                for a in range(n_axes):
                    delta = ends[m, a] - starts[m, a]
                    if delta == 0:
                        continue
                    error[a] += 2 * abs(delta)
                    if error[a] > n or (error[a] == n and (2 * k > n if 2 * k != n else delta < 0)):
                        error[a] -= 2 * n
                        out_ticks[a, fill[a]] = tick
                        out_dirs[a, fill[a]] = 1 if delta > 0 else -1
                        fill[a] += 1
        for a in range(n_axes):
            counts[m, a] = fill[a]


@kernel
def _dda_requests(starts, ends, profiles, t0s, has_profile, rate, out_ticks, out_dirs, counts):
    """The same for 004's digital integration: pulse k of d sits at k·n/d base intervals."""
    n_moves, n_axes = starts.shape
    fill = np.zeros(n_axes, dtype=np.int64)
    for m in range(n_moves):
        if has_profile[m]:
            n = 0
            for a in range(n_axes):
                d = abs(ends[m, a] - starts[m, a])
                if d > n:
                    n = d
            p = profiles[m]
            length = p[P_LEN]
            for a in range(n_axes):
                delta = ends[m, a] - starts[m, a]
                d = abs(delta)
                for k in range(1, d + 1):
                    position = float(k * n) / d
                    s = position * length / n
                    out_ticks[a, fill[a]] = np.int64(np.floor((t0s[m] + time_at(s, p)) * rate + 0.5))
                    out_dirs[a, fill[a]] = 1 if delta > 0 else -1
                    fill[a] += 1
        for a in range(n_axes):
            counts[m, a] = fill[a]


@kernel
def _shape_axis(wanted, dirs, period, high, setup, hold, rises, change_ticks, change_dirs):
    """Rise tick of every step and the direction turns (the step generator's rules, solved).

    Returns the number of direction turns written to ``change_ticks`` / ``change_dirs``.
    """
    direction = -1
    last_rise = _NEVER
    last_turn = _NEVER
    turns = 0
    for j in range(wanted.shape[0]):
        first = last_rise + 1 if j > 0 else 1            # the first tick this request is looked at
        if dirs[j] != direction:
            turn = last_rise + hold
            if turn < first:
                turn = first
            direction = dirs[j]
            last_turn = turn
            change_ticks[turns] = turn
            change_dirs[turns] = direction
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
    return turns


@kernel
def _axis_timeline(rises, high, change_ticks, change_dirs, n_turns, out_ticks, out_states):
    """Run-length (tick, state) of one axis: state = step bit | (direction > 0) << 1."""
    count = 0
    step = 0
    dir_bit = 0
    i_rise = 0
    i_fall = 0
    i_turn = 0
    n = rises.shape[0]
    big = np.int64(1) << 62
    while i_rise < n or i_fall < n or i_turn < n_turns:
        t_rise = rises[i_rise] if i_rise < n else big
        t_fall = rises[i_fall] + high if i_fall < n else big
        t_turn = change_ticks[i_turn] if i_turn < n_turns else big
        tick = min(t_rise, t_fall, t_turn)
        if t_fall == tick:
            step = 0
            i_fall += 1
        if t_turn == tick:
            dir_bit = 1 if change_dirs[i_turn] > 0 else 0
            i_turn += 1
        if t_rise == tick:
            step = 1
            i_rise += 1
        state = step | (dir_bit << 1)
        if count > 0 and out_ticks[count - 1] == tick:
            out_states[count - 1] = state
        else:
            out_ticks[count] = tick
            out_states[count] = state
            count += 1
    return count


@kernel
def _merge_axes(ticks, states, lengths, table, invert, out_ticks, out_values):
    """Merge the axes' timelines into the port byte stream, recording only changes."""
    n_axes = lengths.shape[0]
    pos = np.zeros(n_axes, dtype=np.int64)
    current = np.zeros(n_axes, dtype=np.int64)       # every axis starts: step low, direction negative
    big = np.int64(1) << 62
    value = invert
    for a in range(n_axes):
        value ^= table[a, 0]
    out_ticks[0] = 0
    out_values[0] = value
    count = 1
    while True:
        tick = big
        for a in range(n_axes):
            if pos[a] < lengths[a] and ticks[a, pos[a]] < tick:
                tick = ticks[a, pos[a]]
        if tick == big:
            break
        for a in range(n_axes):
            if pos[a] < lengths[a] and ticks[a, pos[a]] == tick:
                current[a] = states[a, pos[a]]
                pos[a] += 1
        value = invert
        for a in range(n_axes):
            value ^= table[a, current[a]]
        if value != out_values[count - 1]:
            if out_ticks[count - 1] == tick:
                out_values[count - 1] = value
            else:
                out_ticks[count] = tick
                out_values[count] = value
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


def shape_fast(plan: Plan, requests: StepRequests) -> tuple[PortFrames, list[np.ndarray]]:
    """Pulses and port frames of the requests (equal to ``execute.shape_reference``)."""
    machine = plan.machine
    pins = PinMap(machine)
    n_axes = len(machine.axes)
    rises, timelines = [], []
    end = requests.end_tick
    for a, axis in enumerate(machine.axes):
        wanted, dirs = requests.ticks[a], requests.dirs[a]
        n = len(wanted)
        period = axis.pulse_high_ticks + axis.pulse_low_ticks
        axis_rises = np.zeros(n, dtype=np.int64)
        turn_ticks = np.zeros(n, dtype=np.int64)
        turn_dirs = np.zeros(n, dtype=np.int8)
        turns = _shape_axis(wanted, dirs, period, axis.pulse_high_ticks, axis.dir_setup_ticks,
                            axis.dir_hold_ticks, axis_rises, turn_ticks, turn_dirs)
        t_ticks = np.zeros(2 * n + turns + 1, dtype=np.int64)
        t_states = np.zeros(2 * n + turns + 1, dtype=np.int64)
        count = _axis_timeline(axis_rises, axis.pulse_high_ticks, turn_ticks, turn_dirs, turns, t_ticks, t_states)
        rises.append(axis_rises)
        timelines.append((t_ticks[:count], t_states[:count]))
        if n:
            end = max(end, int(axis_rises[-1]) + period - 1)
    width = max([len(t) for t, _ in timelines] + [1])
    ticks = np.zeros((n_axes, width), dtype=np.int64)
    states = np.zeros((n_axes, width), dtype=np.int64)
    lengths = np.zeros(n_axes, dtype=np.int64)
    for a, (t, s) in enumerate(timelines):
        ticks[a, :len(t)], states[a, :len(s)], lengths[a] = t, s, len(t)
    table = np.zeros((n_axes, 4), dtype=np.int64)
    for a in range(n_axes):
        step, dmask = pins.step_masks[a], pins.dir_masks[a]
        table[a] = (0, step, dmask, step | dmask)
    out_ticks = np.zeros(int(lengths.sum()) + 1, dtype=np.int64)
    out_values = np.zeros(int(lengths.sum()) + 1, dtype=np.int64)
    count = _merge_axes(ticks, states, lengths, table, pins.invert, out_ticks, out_values)
    frames = PortFrames(out_ticks[:count], out_values[:count].astype(np.uint8), max(end, 0) + 1)
    return frames, rises


def execute_fast(plan: Plan):
    """Fast path: plan → step requests → pulses → port frames and the run log."""
    requests = request_steps_fast(plan)
    frames, rises = shape_fast(plan, requests)
    return run_log(plan, requests, frames, rises)
