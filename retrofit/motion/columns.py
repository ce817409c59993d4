"""What the stream reads of the moves it can see: a whole plan, or a window that rolls along the
program as the planner hands on more moves.

The stream (:mod:`retrofit.motion.stream`) reads per move its step count, the tick it is loaded,
the tick it enters the look-ahead window (``stepshape.window_seen``: the load of the move
``lookahead + 1`` before it) and ends, and per axis the next move that steps it. Over a whole
plan these are columns made once. Fed block by block (:meth:`Columns.rolling`), the columns hold
the moves from the window being made to the last move planned; the moves done are dropped when
more come. An axis whose next move is not planned yet cannot step or turn before that move
enters the look-ahead window, so :attr:`Columns.horizon_seen` bounds every frame the stream may
emit until it is known.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ._jit import kernel
from .planarrays import PlanArrays
from .profile import P_T1, P_T2, P_TC


class Columns:
    """The moves the stream can see, as columns (see the module doc)."""

    def __init__(self, machine, rate: float, arrays: PlanArrays, end_s: float | None,
                 blocks: Iterator[tuple[PlanArrays, float | None]] | None = None):
        self.machine, self.rate, self.depth = machine, rate, machine.motion.lookahead
        self.blocks = blocks
        self.end_s = end_s                        # known once the last move is planned
        self.history = np.zeros(self.depth + 1, np.int64)    # loads of the moves before the first
        self._set(arrays)

    @classmethod
    def of_plan(cls, plan, rate: float) -> Columns:
        return cls(plan.machine, rate, plan.arrays(), plan.end_s)

    @classmethod
    def rolling(cls, machine, rate: float, blocks) -> Columns:
        """Columns fed by ``blocks``, an iterator of (PlanArrays, end time or None until the last)."""
        cols = cls(machine, rate, _empty(len(machine.axes)), None, iter(blocks))
        return cols

    @property
    def final(self) -> bool:
        """Whether the last move of the program is among the columns."""
        return self.end_s is not None

    def __len__(self) -> int:
        return len(self.loaded)

    def _set(self, a: PlanArrays) -> None:
        self.arrays = a
        self.sizes = np.abs(a.ends - a.starts).sum(axis=1) * a.has_profile
        self.cumulative = np.cumsum(self.sizes)
        self.loaded = np.floor(a.t0s * self.rate + 0.5).astype(np.int64)           # execute.tick_of
        p = a.profiles
        durations = np.where(a.has_profile, p[:, P_T1] + p[:, P_TC] + p[:, P_T2], a.dwells)
        self.ends = np.floor((a.t0s + durations) * self.rate + 0.5).astype(np.int64)
        n, n_axes = a.starts.shape
        combined = np.concatenate((self.history, self.loaded))
        self.seen = combined[:n]                                       # stepshape.window_seen
        self.horizon_seen = int(combined[n])
        self.next_move = np.empty((n + 1, n_axes), np.int64)
        self.next_dir = np.empty((n + 1, n_axes), np.int8)
        _next_moves(a.starts, a.ends, a.has_profile, self.next_move, self.next_dir)

    def steps_from(self, lo: int) -> int:
        """Steps of the moves from ``lo`` to the last one seen."""
        base = int(self.cumulative[lo - 1]) if lo else 0
        return (int(self.cumulative[-1]) if len(self) else 0) - base

    def more(self, lo: int, window_steps: int) -> int:
        """Take blocks until a window from ``lo`` and the move after it are seen (or the last
        move is); the moves before ``lo`` are dropped. Returns the new index of move ``lo``."""
        if self.final or (len(self) > lo + 1 and self.steps_from(lo) > window_steps):
            return lo
        parts, size = [], self.steps_from(lo)
        count = len(self) - lo
        while not self.final and (count <= 1 or size <= window_steps):
            assert self.blocks is not None        # not final: the columns roll (made by rolling())
            block, end_s = next(self.blocks)
            parts.append(block)
            count += len(block)
            size += int((np.abs(block.ends - block.starts).sum(axis=1) * block.has_profile).sum())
            self.end_s = end_s
        kept = _rows(self.arrays, lo)
        self.history = np.concatenate((self.history, self.loaded[:lo]))[-(self.depth + 1):]
        self._set(_joined([kept] + parts))
        return 0

    def window_end(self, lo: int, window_steps: int) -> int:
        """End of the window of moves from ``lo``: as many as fit ``window_steps``, at least one."""
        base = int(self.cumulative[lo - 1]) if lo else 0
        return max(int(np.searchsorted(self.cumulative, base + window_steps, side="right")), lo + 1)


@kernel
def _next_moves(starts, ends, has_profile, moves, dirs):
    """For each move boundary b (0..n) and axis: (index, direction) of the first move at or
    after b that steps the axis (index n and direction 0 when there is none)."""
    n, n_axes = starts.shape
    for a in range(n_axes):
        moves[n, a], dirs[n, a] = n, 0
    for m in range(n - 1, -1, -1):
        for a in range(n_axes):
            moves[m, a], dirs[m, a] = moves[m + 1, a], dirs[m + 1, a]
            if has_profile[m] and ends[m, a] != starts[m, a]:
                moves[m, a] = m
                dirs[m, a] = 1 if ends[m, a] > starts[m, a] else -1


_FIELDS = ("starts", "ends", "targets", "t0s", "profiles", "has_profile", "dwells", "index")


def _rows(a: PlanArrays, lo: int) -> PlanArrays:
    return PlanArrays(*(getattr(a, f)[lo:] for f in _FIELDS))


def _joined(parts: list[PlanArrays]) -> PlanArrays:
    return PlanArrays(*(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS))


def _empty(n_axes: int) -> PlanArrays:
    from .profile import P_WIDTH
    starts, ends, targets = (np.zeros((0, n_axes), np.int64) for _ in range(3))
    return PlanArrays(starts, ends, targets, np.zeros(0), np.zeros((0, P_WIDTH)),
                      np.zeros(0, np.bool_), np.zeros(0), np.zeros(0, np.int64))
