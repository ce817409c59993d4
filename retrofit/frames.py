"""Port frames: the port byte over time, in run-length form, and the pin map that makes it.

The lathe paper computes the byte once per tick from all bits ('CalculByte') and writes it once.
Everything after the controller (simulator, parallel port, VCD) reads the same ``PortFrames``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .machine.config import Machine


class PinMap:
    """Turns logical axis bits (step, direction +1/-1) into the port byte, with inversions."""

    def __init__(self, machine: Machine):
        self.axes = machine.axes
        self.step_masks = [1 << a.step_bit for a in machine.axes]
        self.dir_masks = [1 << a.dir_bit for a in machine.axes]
        invert = 0
        for a in machine.axes:
            invert |= (a.invert_step << a.step_bit) | (a.invert_dir << a.dir_bit)
        self.invert = invert      # XOR mask applied to the logical byte

    def byte(self, steps: list[int], dirs: list[int]) -> int:
        """The port byte for one tick ('CalculByte'): step bits 0/1, dirs +1 (positive) or -1."""
        value = 0
        for step, direction, sm, dm in zip(steps, dirs, self.step_masks, self.dir_masks):
            if step:
                value |= sm
            if direction > 0:
                value |= dm
        return value ^ self.invert

    def decode(self, value: int) -> tuple[list[int], list[int]]:
        """Logical (step bits, directions) from a port byte, as a driver sees them."""
        logical = value ^ self.invert
        steps = [1 if logical & sm else 0 for sm in self.step_masks]
        dirs = [1 if logical & dm else -1 for dm in self.dir_masks]
        return steps, dirs


@dataclass
class PortFrames:
    """The port byte over time: ``values[i]`` holds from ``ticks[i]`` until ``ticks[i+1]``.

    ``ticks`` are int64 and strictly increasing; ``values`` are uint8; a frame is recorded only
    when the byte changes. ``end_tick`` is one past the last tick of the run.
    """

    ticks: np.ndarray
    values: np.ndarray
    end_tick: int

    def __post_init__(self):
        self.ticks = np.asarray(self.ticks, dtype=np.int64)
        self.values = np.asarray(self.values, dtype=np.uint8)

    def __len__(self) -> int:
        return len(self.ticks)

    def __eq__(self, other) -> bool:
        return (isinstance(other, PortFrames) and self.end_tick == other.end_tick
                and np.array_equal(self.ticks, other.ticks)
                and np.array_equal(self.values, other.values))

    def per_tick(self) -> np.ndarray:
        """The byte at every tick 0..end_tick-1 (for small runs and tests)."""
        out = np.empty(self.end_tick, dtype=np.uint8)
        bounds = list(self.ticks) + [self.end_tick]
        for i, value in enumerate(self.values):
            out[bounds[i]:bounds[i + 1]] = value
        return out

    def value_at(self, tick: int) -> int:
        i = int(np.searchsorted(self.ticks, tick, side="right")) - 1
        return int(self.values[max(i, 0)])

    @classmethod
    def from_per_tick(cls, values) -> PortFrames:
        """Run-length form of a byte-per-tick array."""
        values = np.asarray(values, dtype=np.uint8)
        if len(values) == 0:
            return cls(np.zeros(0, np.int64), np.zeros(0, np.uint8), 0)
        change = np.flatnonzero(np.diff(values)) + 1
        ticks = np.concatenate(([0], change)).astype(np.int64)
        return cls(ticks, values[ticks], len(values))


class FrameRecorder:
    """Collects the byte of each tick, keeping only changes (what the reference path emits)."""

    def __init__(self):
        self.ticks: list[int] = []
        self.values: list[int] = []
        self._last = -1

    def put(self, tick: int, value: int) -> None:
        if value != self._last:
            self.ticks.append(tick)
            self.values.append(value)
            self._last = value

    def frames(self, end_tick: int) -> PortFrames:
        return PortFrames(np.array(self.ticks, np.int64), np.array(self.values, np.uint8), end_tick)
