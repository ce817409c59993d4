"""What the controller did during a run: the port frames, the targets and when each was reached."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .frames import PortFrames
from .machine.config import Machine


@dataclass
class Waypoint:
    """A commanded position (steps per axis) and the ticks it was loaded and reached.

    ``reached_tick`` is the frame carrying the last rising step edge towards it (or the tick the
    loop found it reached, when no step was needed), so the machine has taken every step by then.
    """

    steps: tuple[int, ...]
    loaded_tick: int
    reached_tick: int | None = None


class WaypointTable(Sequence):
    """Waypoints held as columns (a streamed run's): ``steps`` [n, axes], ``loaded`` and
    ``reached`` [n] ticks (-1: not reached). Reads as a list of :class:`Waypoint`."""

    def __init__(self, n_axes: int, keep_all: bool = True):
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._n_axes = n_axes
        self.keep_all = keep_all                    # False: only the last waypoint (the report's)
        self._joined = None
        self.worst_mm: np.ndarray | None = None     # per axis, when settled as the run went

    def add(self, steps: np.ndarray, loaded: np.ndarray, reached: np.ndarray) -> None:
        """Waypoints of the next moves, in order."""
        if not self.keep_all and len(loaded):
            self._parts = [(steps[-1:], loaded[-1:], reached[-1:])]
        elif self.keep_all:
            self._parts.append((steps, loaded, reached))
        self._joined = None

    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(steps, loaded, reached) of every waypoint."""
        if self._joined is None:
            if not self._parts:
                self._parts = [(np.zeros((0, self._n_axes), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))]
            self._parts = [tuple(np.concatenate(c) for c in zip(*self._parts))]
            self._joined = self._parts[0]
        return self._joined

    def __len__(self) -> int:
        return sum(len(p[1]) for p in self._parts)

    def __getitem__(self, k):
        steps, loaded, reached = self.columns()
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(loaded)))]
        r = int(reached[k])
        return Waypoint(tuple(steps[k].tolist()), int(loaded[k]), r if r >= 0 else None)


@dataclass
class RunLog:
    """The controller's side of a run; outputs and the report read it."""

    machine: Machine
    frames: PortFrames
    waypoints: list[Waypoint] = field(default_factory=list)
    steps_emitted: dict[str, int] = field(default_factory=dict)
    max_following_error_steps: int = 0
    start_steps: tuple[int, ...] = ()

    @property
    def ticks(self) -> int:
        return self.frames.end_tick

    @property
    def final_target(self) -> tuple[int, ...]:
        return self.waypoints[-1].steps if self.waypoints else self.start_steps
