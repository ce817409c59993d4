"""Motor and carriage of one axis after each step: every step, or decimated to what a plot can show.

With ``limit`` set the trace keeps at most about ``limit`` points spread evenly over the steps:
when it fills up it drops every other point and from then on keeps every second step (then every
fourth, ...), so its memory stays bounded however long the run. Points inside a tick window
asked for (``windows``) or near a violation are kept in full on top of that.
"""

from __future__ import annotations

import numpy as np


class AxisTrace:
    """Motor and carriage of one axis after each step kept, in tick order.

    ``ticks``, ``motor_steps`` and ``carriage_mm`` are lists; :meth:`arrays` gives NumPy arrays.
    """

    def __init__(self, limit: int | None = None, windows: tuple[tuple[int, int], ...] = ()):
        self.limit = limit
        self.windows = tuple(windows)
        self.stride = 1             # every stride-th step is kept (decimated traces)
        self.seen = 0               # steps seen so far
        self._kept = 0              # points in the evenly spaced chunks
        self._chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._pending: list[tuple[int, int, float]] = []
        self._detail: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._cache = None
        self._lists = None

    @property
    def decimated(self) -> bool:
        """True once some steps were left out."""
        return self.stride > 1

    def append(self, tick: int, motor: int, carriage: float) -> None:
        """One step (the per-step reference path)."""
        self._pending.append((tick, motor, carriage))
        if len(self._pending) >= 4096:
            self._flush()
        self._cache = None

    def extend(self, ticks: np.ndarray, motor: np.ndarray, carriage: np.ndarray,
               keep: np.ndarray | None = None) -> None:
        """A chunk of steps in tick order; ``keep`` marks steps to keep in full whatever the stride."""
        self._flush()
        self._add(np.asarray(ticks, np.int64), np.asarray(motor, np.int64), np.asarray(carriage, float), keep)

    def kept_from(self) -> int | None:
        """Which of the next steps a decimated trace without windows keeps: this one (0 the next
        step), then every ``stride``-th (:meth:`extend_kept` takes them); None when it takes every
        step (no limit, or windows kept in full)."""
        if self.limit is None or self.windows:
            return None
        self._flush()
        return (-self.seen) % self.stride

    def extend_kept(self, ticks: np.ndarray, motor: np.ndarray, carriage: np.ndarray, steps: int) -> None:
        """The points :meth:`kept_from` asked for, out of the next ``steps`` steps (the same trace
        as :meth:`extend` of every step)."""
        self._cache = None
        self._chunks.append((ticks.copy(), motor.copy(), carriage.copy()))
        self._kept += len(ticks)
        self.seen += steps
        while self._kept > self.limit:
            self._halve()

    def _flush(self) -> None:
        if self._pending:
            t, m, c = zip(*self._pending)
            self._pending = []
            self._add(np.array(t, np.int64), np.array(m, np.int64), np.array(c, float), None)

    def _add(self, ticks, motor, carriage, keep) -> None:
        self._cache = None
        n = len(ticks)
        if self.limit is None:
            self._chunks.append((ticks.copy(), motor.copy(), carriage.copy()))
            self.seen += n
            return
        first = (-self.seen) % self.stride                  # the first step of the chunk on the stride
        if keep is None and not self.windows:
            every = slice(first, None, self.stride)
        else:
            every = np.zeros(n, bool)
            every[first::self.stride] = True
            extra = np.zeros(n, bool) if keep is None else np.asarray(keep, bool).copy()
            for t0, t1 in self.windows:
                extra |= (ticks >= t0) & (ticks < t1)
            every &= ~extra
            if extra.any():
                self._detail.append((ticks[extra], motor[extra], carriage[extra]))
        self._chunks.append((ticks[every].copy(), motor[every].copy(), carriage[every].copy()))
        self._kept += len(self._chunks[-1][0])
        self.seen += n
        while self._kept > self.limit:
            self._halve()

    def _halve(self) -> None:
        """Keep every other point of the evenly spaced ones; the stride doubles."""
        t, m, c = (np.concatenate(part) for part in zip(*self._chunks))
        self._chunks = [(t[::2].copy(), m[::2].copy(), c[::2].copy())]
        self._kept = len(self._chunks[0][0])
        self.stride *= 2

    def _arrays(self):
        if self._cache is None:
            self._flush()
            parts = self._chunks + self._detail
            if not parts:
                self._cache = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, float))
            else:
                t, m, c = (np.concatenate(p) for p in zip(*parts))
                if self._detail:
                    order = np.argsort(t, kind="stable")
                    t, m, c = t[order], m[order], c[order]
                self._cache = (t, m, c)
        return self._cache

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ticks, motor steps, carriage mm) of the points kept, as NumPy arrays."""
        return self._arrays()

    def _list(self, k: int) -> list:
        if self._lists is None or self._lists[0] is not self._cache:
            self._lists = (self._cache, [None, None, None])
        lists = self._lists[1]
        if lists[k] is None:
            lists[k] = self._arrays()[k].tolist()
        return lists[k]

    @property
    def ticks(self) -> list[int]:
        """Tick of each point kept (a list, as the per-step path always gave)."""
        self._arrays()
        return self._list(0)

    @property
    def motor_steps(self) -> list[int]:
        self._arrays()
        return self._list(1)

    @property
    def carriage_mm(self) -> list[float]:
        self._arrays()
        return self._list(2)

    def __len__(self) -> int:
        return len(self._arrays()[0])

    def at(self, tick: int, default_motor: int = 0, default_carriage: float = 0.0) -> tuple[int, float]:
        """Motor steps and carriage mm at the end of frame ``tick`` (of the points kept)."""
        ticks, motor, carriage = self._arrays()
        i = int(np.searchsorted(ticks, tick, side="right")) - 1
        if i < 0:
            return default_motor, default_carriage
        return int(motor[i]), float(carriage[i])
