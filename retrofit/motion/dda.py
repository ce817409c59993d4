"""Digital integration (DDA) line interpolation of the engraver (004): base axis, delayed short-axis pulses.

The **base axis** (the one with the most pulses, ``n``) sends one pulse per interval; a **short
axis** with ``d`` pulses sends its pulses evenly spaced *inside* the intervals rather than on the
base pulses, so 2:1 gives one short pulse every 2 base pulses and 3:2 one every 1.5.

004's counters, per short axis:

* ``COUNT = n / d``, the base pulses per short pulse;
* ``LONG``, the base pulses sent so far (+1 per base pulse);
* ``SHORT``, where the next short pulse is due; it starts at ``COUNT``.

After each base pulse, when the integer part of ``SHORT`` equals ``LONG``, the short axis pulses
after a delay of ``SHORT - LONG`` base intervals (004's ``(SHORT - LONG) / f``) and ``COUNT`` is
added to ``SHORT``.

So the ``k``-th pulse of an axis with ``d`` pulses sits at ``SHORT_k = k * n / d`` base
intervals from the start of the move. Positions are computed with that one formula, in float64:
``float(k * n) / d`` where ``k * n < 2**53`` is exact and the division is one IEEE-754
correctly rounded operation, so a compiled loop reproduces them bit for bit. ``SHORT`` is
kept as the exact fraction ``k * n / d`` (never accumulated in floating point), so the last
pulse of every axis is at exactly ``n``: the move ends on its end point.

:class:`DdaExecutor` is the reference path (one base pulse per call, mirroring 004's flow chart);
:func:`dda_positions` is the fast path and gives exactly the same positions.
"""

from __future__ import annotations

import numpy as np

from ..errors import MotionError
from .bresenham import LineMove


def pulse_position(k: int, n: int, d: int) -> float:
    """Where the ``k``-th of ``d`` pulses falls, in base intervals: ``float(k * n) / d``."""
    return float(k * n) / d


class DdaExecutor:
    """*Execute* phase of digital integration: one base pulse per call (the reference path).

    Parameters
    ----------
    move : LineMove
        The prepared move (:func:`retrofit.motion.bresenham.prepare_line`).

    Examples
    --------
    A 3:2 line: the short axis pulses half an interval after base pulse 1, and on base pulse 3.

    >>> from retrofit.motion.bresenham import prepare_line
    >>> ex = DdaExecutor(prepare_line((0, 0), (3, 2)))
    >>> [ex.step() for _ in range(3)]
    [(0.0, 0.5), (0.0, None), (0.0, 0.0)]
    >>> ex.position, ex.done
    ((3, 2), True)
    """

    def __init__(self, move: LineMove):
        self.move = move
        self.long = 0                                       # LONG: base pulses sent
        self.pulses = [abs(d) for d in move.delta]          # pulses per axis (d)
        self.sent = [0] * move.axes                         # pulses sent per axis (004's n)
        # SHORT as the exact fraction short_num / d; it starts at COUNT = n / d.
        self.short_num = [move.n] * move.axes
        self._position = list(move.start)

    @property
    def done(self) -> bool:
        """True once the base axis has sent all ``n`` pulses (at once for a null move)."""
        return self.long >= self.move.n

    @property
    def position(self) -> tuple[int, ...]:
        """The current lattice point, in steps per axis, after the pulses sent so far."""
        return tuple(self._position)

    def step(self) -> tuple[float | None, ...]:
        """Send the next base pulse; return, per axis, its pulse delay in this interval.

        Returns
        -------
        tuple of (float or None)
            Per axis, the delay after this base pulse, in base intervals (``0 <= delay < 1``),
            at which that axis pulses in this interval (``0.0`` for the base axis), or None if
            it does not pulse in it. The pulse's position along the move is ``long + delay``,
            exactly equal to the corresponding entry of :func:`dda_positions`.

        Raises
        ------
        MotionError
            If the move is already done.
        """
        move = self.move
        if self.done:
            raise MotionError(f"the move to {move.end} is done after {move.n} base pulses; "
                              f"prepare the next move")
        self.long += 1
        return tuple(self._short_pulse(axis) for axis in range(move.axes))

    def _short_pulse(self, axis: int) -> float | None:
        """One axis after base pulse LONG: pulse if int(SHORT) == LONG, then SHORT += COUNT."""
        d = self.pulses[axis]
        if self.sent[axis] == d or self.short_num[axis] // d != self.long:
            return None
        self.sent[axis] += 1
        position = pulse_position(self.sent[axis], self.move.n, d)
        self.short_num[axis] += self.move.n                # SHORT += COUNT
        self._position[axis] += self.move.direction[axis]
        return position - self.long                         # exact: LONG <= SHORT < LONG + 1


def dda_positions(move: LineMove) -> list[np.ndarray]:
    """Fast path of :class:`DdaExecutor`: per axis, where along the move its pulses fall.

    Parameters
    ----------
    move : LineMove

    Returns
    -------
    list of numpy.ndarray
        One float64 array per axis of ``|delta|`` increasing positions in base intervals, in
        ``(0, n]``: ``k * n / d`` for ``k = 1..d`` (``d = |delta|``). The base axis gets
        ``1, 2, ..., n``; every moving axis ends at exactly ``n``. Pulses go in
        ``move.direction[axis]``. With base pulses every ``P`` ticks, a pulse's ideal tick is
        ``position * P``.

    Examples
    --------
    >>> from retrofit.motion.bresenham import prepare_line
    >>> [p.tolist() for p in dda_positions(prepare_line((0, 0, 0), (6, -4, 0)))]
    [[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [1.5, 3.0, 4.5, 6.0], []]
    """
    out = []
    for delta in move.delta:
        d = abs(delta)
        k = np.arange(1, d + 1, dtype=np.int64)
        out.append((k * move.n).astype(np.float64) / d if d else np.empty(0, dtype=np.float64))
    return out
