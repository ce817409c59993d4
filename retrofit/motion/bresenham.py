"""Bresenham line interpolation of the turning-machine controller (002): prepare once, execute per step cycle.

A straight move in the 24-bit step space is split the way 002 splits it:

* **prepare** (:func:`prepare_line`) runs once, when the motion command is interpreted. It checks
  the end points against the step space and computes every constant of the move: the per-axis
  deltas and directions, the **base axis** (the one with the most steps; it steps every cycle)
  and the error increments of the other axes. The result is a frozen :class:`LineMove`.
* **execute** (:class:`BresenhamExecutor`) runs once per step cycle: the base axis steps, and each
  other axis adds its error increment and steps when its error term says the ideal line is
  now nearer the next lattice point than the current one.

The rule is the midpoint rule: after cycle ``k`` (1..n) the lattice point is the one nearest the
ideal line at base position ``k``, within half a step on every axis. When the ideal line passes
exactly half-way between two lattice points (a tie), the point is taken

* towards the start of the move in the first half of the move (``2k < n``),
* towards the end of the move in the second half (``2k > n``),
* towards the more negative coordinate at the exact middle (``2k == n``).

So a move from A to B visits exactly the lattice points of the move from B to A, in reverse: a
cut retraced in the other direction runs over the same steps.

:func:`bresenham_cycles` is the fast path: NumPy computes, per axis, the cycles at which it
steps, with no Python loop per step, and gives exactly what the executor does.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import MotionError

#: Positions are signed 24-bit numbers of steps (002's "24-bit discrete motion space").
STEP_SPACE_LIMIT = 8_388_607

_DEFAULT_NAMES = ("X", "Y", "Z", "A")


@dataclass(frozen=True)
class LineMove:
    """What *prepare* makes of a straight motion command; every field is a constant of the move.

    Attributes
    ----------
    start, end : tuple of int
        Steps per axis at the start and at the end of the move.
    delta : tuple of int
        ``end - start`` per axis (signed).
    base : int
        Index of the base axis: the axis with the most steps (the first such axis on ties).
    n : int
        Number of step cycles = steps of the base axis = ``max |delta|`` (0 for a null move).
    direction : tuple of int
        Per axis +1, -1, or 0 for an axis that does not move.
    error_inc : tuple of int
        Per axis ``2 |delta|``: what the error term grows by each cycle (in 1/(2n) of a step).
    error_dec : int
        ``2 n``: what the error term drops by when the axis steps.
    """

    start: tuple[int, ...]
    end: tuple[int, ...]
    delta: tuple[int, ...]
    base: int
    n: int
    direction: tuple[int, ...]
    error_inc: tuple[int, ...]
    error_dec: int

    @property
    def axes(self) -> int:
        """Number of axes of the move."""
        return len(self.start)


def axis_names(count: int) -> tuple[str, ...]:
    """Default names of ``count`` axes for messages: X, Y, Z, A, then "axis 5", ..."""
    return tuple(_DEFAULT_NAMES[i] if i < len(_DEFAULT_NAMES) else f"axis {i + 1}"
                 for i in range(count))


def _checked(point: Sequence[int], which: str, names: Sequence[str]) -> tuple[int, ...]:
    """Whole steps inside the step space, or a MotionError naming the axis."""
    out = []
    for name, value in zip(names, point):
        try:
            steps = operator.index(value)
        except TypeError:
            raise MotionError(f"{name} {which} {value!r} is not a whole number of steps") from None
        if not -STEP_SPACE_LIMIT <= steps <= STEP_SPACE_LIMIT:
            raise MotionError(f"{name} {which} {steps} steps is outside the 24-bit step space "
                              f"±{STEP_SPACE_LIMIT}")
        out.append(steps)
    return tuple(out)


def prepare_line(start: Sequence[int], end: Sequence[int],
                 names: Sequence[str] | None = None) -> LineMove:
    """*Prepare* phase: check a straight move and compute its constants.

    Parameters
    ----------
    start, end : sequence of int
        Steps per axis; the same number of axes (one or more) in both.
    names : sequence of str, optional
        Axis names used in error messages (default X, Y, Z, A).

    Returns
    -------
    LineMove

    Raises
    ------
    MotionError
        If the point sizes differ, a coordinate is not a whole number of steps, or a coordinate
        lies outside the step space ``±STEP_SPACE_LIMIT``.

    Examples
    --------
    >>> m = prepare_line((0, 0), (5, -2))
    >>> m.base, m.n, m.direction, m.error_inc
    (0, 5, (1, -1), (10, 4))
    """
    if len(start) != len(end) or len(start) == 0:
        raise MotionError(f"start has {len(start)} axes and end has {len(end)}; "
                          f"a move needs the same axes (one or more) at both ends")
    names = tuple(names) if names is not None else axis_names(len(start))
    if len(names) != len(start):
        raise MotionError(f"{len(names)} axis names for a move of {len(start)} axes")
    start_steps = _checked(start, "start", names)
    end_steps = _checked(end, "end", names)
    delta = tuple(e - s for s, e in zip(start_steps, end_steps))
    lengths = [abs(d) for d in delta]
    n = max(lengths)
    return LineMove(
        start=start_steps, end=end_steps, delta=delta,
        base=lengths.index(n), n=n,
        direction=tuple((d > 0) - (d < 0) for d in delta),
        error_inc=tuple(2 * length for length in lengths),
        error_dec=2 * n,
    )


def _tie_steps(move: LineMove, axis: int, cycle: int) -> bool:
    """On a tie (line exactly half-way), does the axis step at this cycle? See the module rule."""
    if 2 * cycle != move.n:
        return 2 * cycle > move.n            # second half: towards the end
    return move.direction[axis] < 0           # the middle: towards the negative side


class BresenhamExecutor:
    """*Execute* phase: one step cycle at a time (the reference path).

    Each axis keeps an error term ``error = 2 k |delta| - 2 n s`` after ``k`` cycles and ``s``
    steps: how far the ideal line is ahead of the axis, in units of ``1 / (2 n)`` step. Each
    cycle it grows by ``error_inc``; when it passes ``n`` (half a step) the axis steps and it
    drops by ``error_dec``. The base axis has ``error_inc == error_dec`` and so steps every cycle.

    Parameters
    ----------
    move : LineMove
        The prepared move.

    Examples
    --------
    >>> ex = BresenhamExecutor(prepare_line((0, 0), (5, 2)))
    >>> [ex.step() for _ in range(5)]
    [(1, 0), (1, 1), (1, 0), (1, 1), (1, 0)]
    >>> ex.position, ex.done
    ((5, 2), True)
    """

    def __init__(self, move: LineMove):
        self.move = move
        self.cycle = 0                            # step cycles executed so far
        self.error = [0] * move.axes              # per-axis error terms
        self._position = list(move.start)

    @property
    def done(self) -> bool:
        """True once all ``n`` step cycles have run (at once for a null move)."""
        return self.cycle >= self.move.n

    @property
    def position(self) -> tuple[int, ...]:
        """The current lattice point, in steps per axis."""
        return tuple(self._position)

    def step(self) -> tuple[int, ...]:
        """Run one step cycle; return this cycle's step per axis (-1, 0 or +1).

        Raises
        ------
        MotionError
            If the move is already done.
        """
        move = self.move
        if self.done:
            raise MotionError(f"the move to {move.end} is done after {move.n} step cycles; "
                              f"prepare the next move")
        self.cycle += 1
        steps = []
        for axis in range(move.axes):
            self.error[axis] += move.error_inc[axis]
            half = move.n                          # half a step, in 1/(2n) units
            if self.error[axis] > half or (self.error[axis] == half
                                           and _tie_steps(move, axis, self.cycle)):
                self.error[axis] -= move.error_dec
                self._position[axis] += move.direction[axis]
                steps.append(move.direction[axis])
            else:
                steps.append(0)
        return tuple(steps)


def _axis_cycles(move: LineMove, axis: int) -> np.ndarray:
    """Cycles (1-based, int64) at which one axis steps, computed without a per-step loop.

    The ``j``-th step (j = 1..|delta|) comes at the first cycle ``k`` where the ideal line is at
    least half a step past ``j - 1``: ``2 k |delta| >= (2 j - 1) n``, taking the next cycle
    instead when equality holds and the tie rule keeps the axis back.
    """
    length = abs(move.delta[axis])
    if length == 0:
        return np.empty(0, dtype=np.int64)
    n = move.n
    inc = 2 * length
    target = (2 * np.arange(1, length + 1, dtype=np.int64) - 1) * n   # (2j - 1) n, < 2**50
    cycle = -(-target // inc)                                           # ceil(target / inc)
    tie = cycle * inc == target
    tie_steps = (2 * cycle > n) | ((2 * cycle == n) & (move.direction[axis] < 0))
    return cycle + (tie & ~tie_steps)


def bresenham_cycles(move: LineMove) -> list[np.ndarray]:
    """Fast path of :class:`BresenhamExecutor`: per axis, the cycles at which it steps.

    Parameters
    ----------
    move : LineMove

    Returns
    -------
    list of numpy.ndarray
        One int64 array per axis of the 1-based cycle indices (1..n), increasing, at which that
        axis steps in ``move.direction[axis]``; ``|delta|`` entries each. The base axis gets
        ``1, 2, ..., n``. Equal, cycle for cycle, to what the executor does.

    Examples
    --------
    >>> [c.tolist() for c in bresenham_cycles(prepare_line((0, 0), (5, 2)))]
    [[1, 2, 3, 4, 5], [2, 4]]
    """
    return [_axis_cycles(move, axis) for axis in range(move.axes)]
