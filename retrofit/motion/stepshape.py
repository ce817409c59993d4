"""The step generator's timing rule solved per step: the one kernel behind the fast and streamed paths.

The tick loop of 003 (``motion.pulses``, the reference path) tries each axis's next request
every tick; here the same rules are solved request by request, so a whole window of steps is
shaped in one pass:

* a step rises at the latest of its wanted tick, the first tick its request is looked at (the
  tick after the last rise), one period after the last rise, and the direction set-up after the
  last turn;
* the direction turns as soon as the hold after the last rise allows, but not before the move
  that needs it is in the look-ahead window: a controller sees only ``lookahead`` moves behind
  the running one (plus one), so a reversal far ahead turns the pin when the move ``lookahead
  + 1`` before it starts (:func:`window_seen`), never earlier. No rule reads further ahead.
"""

from __future__ import annotations

import numpy as np

from ._jit import kernel

#: a tick long before any run: no rise, no turn yet
NEVER = -(1 << 40)


def window_seen(loaded: np.ndarray, depth: int) -> np.ndarray:
    """The tick each move enters the look-ahead window: the start of the move ``depth + 1``
    before it (0 for the first ``depth + 1`` moves, in the window from the start)."""
    ahead = depth + 1
    seen = np.zeros(len(loaded), np.int64)
    seen[ahead:] = loaded[:max(len(loaded) - ahead, 0)]
    return seen


def plan_seen(plan) -> np.ndarray:
    """:func:`window_seen` of every move of a plan (the tick each is loaded: ``execute.tick_of``)."""
    rate = 1e6 / plan.machine.tick_us
    loaded = np.floor(plan.arrays().t0s * rate + 0.5).astype(np.int64)
    return window_seen(loaded, plan.machine.motion.lookahead)


def fresh_state(n_axes: int) -> np.ndarray:
    """The generators' state before the first step: direction negative, nothing risen."""
    return np.array([[-1, NEVER, NEVER, 0] for _ in range(n_axes)], np.int64)


@kernel
def shape_steps(state, wanted, dirs, counts, seen, period, setup, hold, rises, turn_ticks, turn_dirs):
    """Rise ticks of one axis's requests and its direction turns, continued from ``state``.

    ``state`` = [direction, last rise, last turn, requests shaped so far] is updated;
    ``counts[m]`` is the number of these requests up to the end of move m (of the moves they
    come from) and ``seen[m]`` the tick move m enters the look-ahead window. Returns the
    number of turns written to ``turn_ticks`` / ``turn_dirs``.
    """
    direction, last_rise, last_turn, done = state[0], state[1], state[2], state[3]
    turns = 0
    m = 0
    for j in range(wanted.shape[0]):
        first = last_rise + 1 if done + j > 0 else 1     # the first tick this request is looked at
        if dirs[j] != direction:
            while counts[m] <= j:
                m += 1
            turn = last_rise + hold
            if turn < first:
                turn = first
            if turn < seen[m]:
                turn = seen[m]
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
def lag_of(wanted, rises, due_before, risen_before):
    """Most steps due (wanted by a rise's tick) but not yet risen, over ``rises`` (a merge walk);
    ``due_before`` / ``risen_before`` count the requests and rises before these."""
    lag = 0
    due = 0
    for j in range(rises.shape[0]):
        while due < wanted.shape[0] and wanted[due] <= rises[j]:
            due += 1
        behind = due_before + due - (risen_before + j + 1)
        if behind > lag:
            lag = behind
    return lag
