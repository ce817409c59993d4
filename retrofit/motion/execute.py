"""Execute a plan, reference path: one interpolation cycle at a time, then one tick at a time.

Readable on purpose, next to the papers:

1. for each prepared move, the interpolator (Bresenham of 002, or 004's digital integration)
   runs its execute phase cycle by cycle; each step gets the tick nearest its ideal time on the
   move's velocity profile (a *step request*);
2. the tick loop of 003 shapes the requests into pulses: each tick every axis's step generator
   gives its bits, the port byte is computed once and recorded once, then each axis's next
   request is tried (a step asked for during a pulse waits; the direction follows its set-up
   and hold times, and turns no earlier than the move needing it enters the look-ahead window).

The fast path (``motion.fast``) must produce the very same port frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..runlog import RunLog, Waypoint
from . import profile as prof
from .bresenham import BresenhamExecutor, prepare_line
from .dda import DdaExecutor, pulse_position
from .planner import Plan
from .pulses import PulseShaper
from .stepshape import plan_seen


@dataclass
class StepRequests:
    """Per axis, the tick each step is wanted on and its direction; per move, steps so far."""

    ticks: list[np.ndarray]
    dirs: list[np.ndarray]
    counts: np.ndarray          # counts[m, i]: steps of axis i requested up to the end of move m
    move_end_ticks: np.ndarray  # tick nearest the planned end of each move
    end_tick: int               # tick nearest the planned end of the program


def tick_of(seconds: float, ticks_per_s: float) -> int:
    """Nearest tick to a time (halves round up), the same rule on both paths."""
    return int(math.floor(seconds * ticks_per_s + 0.5))


def request_steps(plan: Plan) -> StepRequests:
    """Step requests of every move, cycle by cycle (execute phase of the interpolator)."""
    machine = plan.machine
    rate = 1e6 / machine.tick_us
    n_axes = len(machine.axes)
    ticks: list[list[int]] = [[] for _ in range(n_axes)]
    dirs: list[list[int]] = [[] for _ in range(n_axes)]
    counts = np.zeros((len(plan.moves), n_axes), dtype=np.int64)
    move_end = np.zeros(len(plan.moves), dtype=np.int64)
    use_dda = machine.motion.interpolator == "dda"
    for m, move in enumerate(plan.moves):
        if move.profile is not None:
            line = prepare_line(move.start, move.end)
            steps = _dda_steps(line) if use_dda else _bresenham_steps(line)
            length = move.profile[prof.P_LEN]
            for axis, position, direction in steps:
                s = position * length / line.n
                t = move.t0_s + prof.time_at(s, move.profile)
                ticks[axis].append(tick_of(t, rate))
                dirs[axis].append(direction)
        counts[m] = [len(t) for t in ticks]
        move_end[m] = tick_of(move.t0_s + move.duration_s, rate)
    return StepRequests([np.array(t, dtype=np.int64) for t in ticks],
                        [np.array(d, dtype=np.int8) for d in dirs], counts, move_end,
                        tick_of(plan.end_s, rate))


def _bresenham_steps(line):
    """(axis, position along the move in base steps, direction) of every step, in time order."""
    executor = BresenhamExecutor(line)
    cycle = 0
    while not executor.done:
        cycle += 1
        for axis, step in enumerate(executor.step()):
            if step:
                yield axis, float(cycle), step
    return


def _dda_steps(line):
    """The same for 004's digital integration: the k-th pulse of an axis with d pulses sits at k·n/d."""
    executor = DdaExecutor(line)
    sent = [0] * line.axes
    while not executor.done:
        for axis, delay in enumerate(executor.step()):
            if delay is not None:
                sent[axis] += 1
                yield axis, pulse_position(sent[axis], line.n, abs(line.delta[axis])), line.direction[axis]


def shape_reference(plan: Plan, requests: StepRequests) -> tuple:
    """The tick loop of 003 over the requests: (port frames, rise ticks per axis).

    A move's requests join the queues when the move enters the look-ahead window (the start of
    the move ``lookahead + 1`` before it), as in the controller: a direction turns no earlier.
    """
    shaper = PulseShaper(plan.machine)
    seen = plan_seen(plan).tolist()
    queued, n_moves = 0, len(plan.moves)
    no_hint = lambda axis: 0                                      # noqa: E731 - the window is queued
    tick = 0
    while True:
        shaper.frame(tick)                                        # 'PasAvans', 'CalculByte', 'WritePort'
        while queued < n_moves and seen[queued] <= tick + 1:      # the window moves on
            _queue_move(shaper, requests, queued)
            queued += 1
        if tick >= requests.end_tick and queued == n_moves and not shaper.pending and not shaper.busy:
            break
        shaper.shape(tick, no_hint)                               # try each axis's next request
        tick += 1
    return shaper.recorder.frames(tick + 1), [np.array(r, dtype=np.int64) for r in shaper.rises]


def _queue_move(shaper: PulseShaper, requests: StepRequests, m: int) -> None:
    """Queue the step requests of move ``m``."""
    for axis, (ticks, dirs) in enumerate(zip(requests.ticks, requests.dirs)):
        lo, hi = (int(requests.counts[m - 1, axis]) if m else 0), int(requests.counts[m, axis])
        for due, direction in zip(ticks[lo:hi].tolist(), dirs[lo:hi].tolist()):
            shaper.request(axis, due, direction)


def run_log(plan: Plan, requests: StepRequests, frames, rises: list[np.ndarray],
            lag: int | None = None) -> RunLog:
    """The controller's log of an executed plan: waypoints reached, steps, following error.

    The following error is the most steps ever due but not yet risen (``lag`` when the caller
    already knows it).
    """
    machine = plan.machine
    log = RunLog(machine, frames, start_steps=plan.start_steps)
    rate = 1e6 / machine.tick_us
    for m, move in enumerate(plan.moves):
        last = [int(rises[i][c - 1]) for i, c in enumerate(requests.counts[m]) if c > 0
                and (m == 0 or c > requests.counts[m - 1][i])]
        reached = max(last) if last else int(requests.move_end_ticks[m])
        log.waypoints.append(Waypoint(move.target, loaded_tick=tick_of(move.t0_s, rate), reached_tick=reached))
    log.steps_emitted = {a.name: int(len(r)) for a, r in zip(machine.axes, rises)}
    if lag is None:
        lag = max((_lag(wanted, risen) for wanted, risen in zip(requests.ticks, rises)), default=0)
    log.max_following_error_steps = int(lag)
    return log


def _lag(wanted: np.ndarray, risen: np.ndarray) -> int:
    """The most steps of one axis ever due (wanted by a tick) but not yet risen by it."""
    if not len(risen):
        return 0
    due_by = np.searchsorted(wanted, risen, side="right")
    return max(0, int(np.max(due_by - np.arange(1, len(risen) + 1))))


def execute_reference(plan: Plan) -> RunLog:
    """Reference path: plan → step requests → tick loop → port frames and the run log."""
    requests = request_steps(plan)
    frames, rises = shape_reference(plan, requests)
    return run_log(plan, requests, frames, rises)
