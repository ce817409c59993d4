"""Execute a plan with whole-array NumPy: the fast path where no compiler is installed.

Same answer as the reference and the compiled path, bit for bit, by array arithmetic:

* step positions per move from the interpolator's vectorised form (``bresenham_cycles``,
  ``dda_positions``) and times from the trapezoid formula applied to whole arrays (the same
  IEEE operations in the same order as ``profile.time_at``; exponential ramps call the scalar
  kernel per step, since NumPy's own ``exp`` / ``log`` may differ from the C library's by an ulp);
* rises from a max-plus recurrence solved with a running maximum: a step rises at
  ``r_j = max(wanted_j, r_(j-1) + gap_j)``, where the gap is the pulse period, or the direction
  hold plus set-up when the direction turns (and a turning step waits the set-up after its move
  enters the look-ahead window), so ``r_j = G_j + cummax(wanted_i - G_i)``;
* port frames by sorting every bit change and sampling each axis's state at those ticks.
"""

from __future__ import annotations

import numpy as np

from ..frames import PinMap, PortFrames
from . import profile as prof
from .bresenham import bresenham_cycles, prepare_line
from .dda import dda_positions
from .execute import StepRequests, run_log, tick_of
from .planner import Plan
from .stepshape import plan_seen


def _times(s: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``profile.time_at`` over an array of distances."""
    if p[prof.P_KIND] != prof.TRAPEZOID:
        return np.array([prof.time_at(float(x), p) for x in s])
    a, vc, v0 = p[prof.P_A], p[prof.P_VC], p[prof.P_V0]
    t1, tc, d1 = p[prof.P_T1], p[prof.P_TC], p[prof.P_D1]
    cruise_end = p[prof.P_LEN] - p[prof.P_D2]
    out = np.empty_like(s)
    up = s <= d1
    out[up] = (np.sqrt(v0 * v0 + 2.0 * a * s[up]) - v0) / a
    cruise = ~up & (s <= cruise_end)
    out[cruise] = t1 + (s[cruise] - d1) / vc
    down = ~up & ~cruise
    under = np.maximum(vc * vc - 2.0 * a * (s[down] - cruise_end), 0.0)
    out[down] = (t1 + tc) + (vc - np.sqrt(under)) / a
    return out


def request_steps_numpy(plan: Plan) -> StepRequests:
    """Step requests of the whole plan, move by move with array arithmetic."""
    machine = plan.machine
    n_axes = len(machine.axes)
    rate = 1e6 / machine.tick_us
    dda = machine.motion.interpolator == "dda"
    ticks: list[list] = [[] for _ in range(n_axes)]
    dirs: list[list] = [[] for _ in range(n_axes)]
    counts = np.zeros((len(plan.moves), n_axes), dtype=np.int64)
    running = np.zeros(n_axes, dtype=np.int64)
    for m, move in enumerate(plan.moves):
        if move.profile is not None:
            line = prepare_line(move.start, move.end)
            places = dda_positions(line) if dda else [c.astype(np.float64) for c in bresenham_cycles(line)]
            length = move.profile[prof.P_LEN]
            for a, position in enumerate(places):
                if len(position):
                    s = position * length / line.n
                    t = move.t0_s + _times(s, move.profile)
                    ticks[a].append(np.floor(t * rate + 0.5).astype(np.int64))
                    dirs[a].append(np.full(len(position), line.direction[a], dtype=np.int8))
                    running[a] += len(position)
        counts[m] = running
    move_end = np.array([tick_of(m.t0_s + m.duration_s, rate) for m in plan.moves], dtype=np.int64)
    join = lambda parts, dtype: np.concatenate(parts) if parts else np.zeros(0, dtype)   # noqa: E731
    return StepRequests([join(t, np.int64) for t in ticks], [join(d, np.int8) for d in dirs],
                        counts, move_end, tick_of(plan.end_s, rate))


def rises_numpy(wanted: np.ndarray, dirs: np.ndarray, seen: np.ndarray,
                axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rise ticks, turn ticks, turn directions) of one axis, by the running-maximum solution;
    ``seen``: the tick each request's move enters the look-ahead window (no turn before it)."""
    n = len(wanted)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int8)
    period = axis.pulse_high_ticks + axis.pulse_low_ticks
    turn_gap = max(1, axis.dir_hold_ticks) + axis.dir_setup_ticks
    previous = np.concatenate(([-1], dirs[:-1]))          # the generator starts turned negative
    turns = dirs != previous
    gaps = np.where(turns, max(period, turn_gap), period).astype(np.int64)
    gaps[0] = 0
    first = 1 + (axis.dir_setup_ticks if turns[0] else 0)
    floor = np.where(turns, np.maximum(wanted, seen + axis.dir_setup_ticks), wanted)
    floor[0] = max(int(floor[0]), first, 1)
    cumulative = np.cumsum(gaps)
    rises = cumulative + np.maximum.accumulate(floor - cumulative)
    turn_at = np.flatnonzero(turns)
    turn_ticks = np.where(turn_at == 0, 1, rises[np.maximum(turn_at - 1, 0)] + max(1, axis.dir_hold_ticks))
    return rises, np.maximum(turn_ticks, seen[turn_at]).astype(np.int64), dirs[turn_at]


def frames_numpy(machine, rises: list[np.ndarray], turns: list[tuple[np.ndarray, np.ndarray]], end_tick: int):
    """Port frames from every axis's rises and turns: sort the changes, sample every axis."""
    pins = PinMap(machine)
    per_axis = []
    for axis, r, (t_ticks, t_dirs) in zip(machine.axes, rises, turns):
        step_ticks = np.empty(2 * len(r), dtype=np.int64)        # rise, fall, rise, ...: already in order
        step_ticks[0::2], step_ticks[1::2] = r, r + axis.pulse_high_ticks
        step_vals = np.tile(np.array([1, 0], dtype=np.int64), len(r))
        per_axis.append((step_ticks, step_vals, t_ticks, (t_dirs > 0).astype(np.int64)))
    changes = np.sort(np.concatenate([np.concatenate((s, t)) for s, _, t, _ in per_axis] + [[0]]))
    changes = changes[np.concatenate(([True], changes[1:] != changes[:-1]))]
    value = np.full(len(changes), pins.invert, dtype=np.int64)
    for a, (s_ticks, s_vals, t_ticks, t_vals) in enumerate(per_axis):
        step = _sample(s_ticks, s_vals, changes)
        direction = _sample(t_ticks, t_vals, changes)
        value ^= step * pins.step_masks[a] | direction * pins.dir_masks[a]
    keep = np.concatenate(([True], value[1:] != value[:-1]))
    return PortFrames(changes[keep], value[keep].astype(np.uint8), end_tick)


def _sample(ticks: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Value of a step function (0 before its first change) at each tick of ``at``."""
    index = np.searchsorted(ticks, at, side="right") - 1
    return np.where(index >= 0, values[np.maximum(index, 0)] if len(values) else 0, 0)


def execute_numpy(plan: Plan):
    """NumPy fast path: plan → step requests → pulses → port frames and the run log."""
    machine = plan.machine
    requests = request_steps_numpy(plan)
    rises, turns = [], []
    end = requests.end_tick
    seen = plan_seen(plan)
    for a, (axis, wanted, dirs) in enumerate(zip(machine.axes, requests.ticks, requests.dirs)):
        per_move = np.diff(requests.counts[:, a], prepend=0)
        r, t_ticks, t_dirs = rises_numpy(wanted, dirs, np.repeat(seen, per_move), axis)
        rises.append(r)
        turns.append((t_ticks, t_dirs))
        if len(r):
            end = max(end, int(r[-1]) + axis.pulse_high_ticks + axis.pulse_low_ticks - 1)
    frames = frames_numpy(machine, rises, turns, max(end, 0) + 1)
    return run_log(plan, requests, frames, rises)
