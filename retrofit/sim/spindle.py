"""The simulated spindle: a drive that ramps to its speed, a load that makes the speed wander, and
an encoder giving the indexer's two inputs, ICLK (counts) and SIND (one index pulse a turn).

Time is the machine's tick. The angle is kept as an integer number of 1/65536 encoder counts, so
the spindle's position is exact and the same on every run; the only randomness is the load,
drawn from a seeded generator: every ``noise_interval_ms`` a new load factor in
``±load_noise`` is drawn and the speed moves linearly towards it (a cutting load changes
smoothly, the spindle's inertia sees to that).

The encoder counts pulses whatever the direction (002's ICLK drives a counter input), and the
index pulse comes each time the count passes a multiple of the counts per revolution.
"""

from __future__ import annotations

import random
from array import array
from dataclasses import dataclass

import numpy as np

FRACTION_BITS = 16
ONE_COUNT = 1 << FRACTION_BITS


@dataclass(frozen=True)
class SpindleInputs:
    """What the controller reads at the end of a tick."""

    count: int            # ICLK pulses since power-up
    index_count: int      # count at the last SIND pulse (-1 before the first)
    index_tick: int       # tick of that pulse (-1 before the first)
    at_speed: bool        # the drive has finished its ramp (a drive's at-speed output)


class SimSpindle:
    """Spindle drive, load and encoder of a machine's ``[spindle]`` section."""

    def __init__(self, settings, tick_us: float):
        self.counts_per_rev = settings.encoder_counts_per_rev
        self.physics = settings.sim
        self.tick_s = tick_us * 1e-6
        self.rng = random.Random(self.physics.seed)
        self.interval = max(1, round(self.physics.noise_interval_ms * 1e-3 / self.tick_s))
        self.tick = -1                      # last tick simulated
        self.angle = 0                      # 1/65536 counts travelled (never decreases)
        self.rpm = 0.0                      # signed drive speed, before the load
        self.target_rpm = 0.0
        self.history = array("q")           # angle at the end of every tick
        self.index_count = -1
        self.index_tick = -1
        self._knots = (0.0, self._draw())   # load factor at the last and the next knot

    def _draw(self) -> float:
        noise = self.physics.load_noise
        return self.rng.uniform(-noise, noise) if noise else 0.0

    def command(self, tick: int, rpm: float, direction: int) -> None:
        """Set the drive (SPIN): ``rpm`` and +1 (M3), -1 (M4) or 0 (M5), from tick ``tick`` on."""
        self.advance_to(tick - 1)
        self.target_rpm = rpm * direction

    @property
    def at_speed(self) -> bool:
        return self.rpm == self.target_rpm

    def _load(self, tick: int) -> float:
        phase = tick % self.interval
        if phase == 0 and tick > 0:
            self._knots = (self._knots[1], self._draw())
        start, end = self._knots
        return start + (end - start) * phase / self.interval

    def _step(self, tick: int) -> None:
        ramp = self.physics.accel_rpm_s * self.tick_s
        delta = self.target_rpm - self.rpm
        self.rpm = self.target_rpm if abs(delta) <= ramp else self.rpm + (ramp if delta > 0 else -ramp)
        load = self._load(tick)
        per_tick = abs(self.rpm) / 60.0 * self.counts_per_rev * self.tick_s * (1.0 + load)
        before = self.angle >> FRACTION_BITS
        self.angle += int(round(per_tick * ONE_COUNT))
        after = self.angle >> FRACTION_BITS
        c = self.counts_per_rev
        if after // c > before // c:
            self.index_count = (after // c) * c
            self.index_tick = tick
        self.history.append(self.angle)
        self.tick = tick

    def advance_to(self, tick: int) -> None:
        """Simulate every tick up to and including ``tick``."""
        for t in range(self.tick + 1, tick + 1):
            self._step(t)

    def read(self, tick: int) -> SpindleInputs:
        """The encoder and drive outputs at the end of frame ``tick``."""
        self.advance_to(tick)
        return SpindleInputs(self.angle >> FRACTION_BITS, self.index_count, self.index_tick, self.at_speed)

    def revolutions_at(self, ticks) -> np.ndarray:
        """The spindle's angle in revolutions (float, since power-up) at the end of each tick."""
        self.advance_to(int(np.max(ticks)) if len(ticks) else -1)
        hist = np.frombuffer(self.history, dtype=np.int64)
        return hist[np.asarray(ticks, dtype=np.int64)] / float(ONE_COUNT * self.counts_per_rev)

    def rpm_between(self, tick0: int, tick1: int) -> float:
        """Mean speed (rpm) the encoder saw from the end of ``tick0`` to the end of ``tick1``."""
        revs = self.revolutions_at([tick0, tick1])
        return float((revs[1] - revs[0]) / ((tick1 - tick0) * self.tick_s) * 60.0)
