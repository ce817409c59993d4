"""The simulated spindle: a drive that ramps to its speed, a load that makes the speed wander, and
an encoder giving the indexer's two inputs, ICLK (counts) and SIND (one index pulse a turn).

Time is the machine's tick. The angle is kept as an integer number of 1/65536 encoder counts, so
the spindle's position is exact and the same on every run; the only randomness is the load,
drawn from a seeded generator: every ``noise_interval_ms`` a new load factor in
``±load_noise`` is drawn and the speed moves linearly towards it (a cutting load changes
smoothly, the spindle's inertia sees to that).

The encoder counts pulses whatever the direction (002's ICLK drives a counter input), and the
index pulse comes each time the count passes a multiple of the counts per revolution. A spindle
that reverses on command (``reverse_rpm_s`` in ``[spindle]``) has a quadrature encoder instead:
its count is the signed angle, going down while the spindle turns backwards (M4), and the index
comes when the count crosses a multiple of the counts per revolution either way.
"""

from __future__ import annotations

import random
from array import array
from collections import deque
from dataclasses import dataclass

import numpy as np

from ..motion._jit import compiled, kernel

FRACTION_BITS = 16
ONE_COUNT = 1 << FRACTION_BITS
#: ticks from which :meth:`SimSpindle.advance_to` runs the compiled loop
COMPILED_SPAN = 2048

# integer state slots of the compiled spindle (see spindle_state)
S_ANGLE, S_TICK, S_INDEX_COUNT, S_INDEX_TICK, S_DRAWN = 0, 1, 2, 3, 4
# float state slots
F_RPM, F_TARGET, F_KNOT0, F_KNOT1 = 0, 1, 2, 3
# float parameter slots
P_RAMP, P_TICK_S, P_COUNTS, P_INTERVAL, P_SIGNED = 0, 1, 2, 3, 4


@kernel
def spindle_step(si, sf, par, draws, tick):
    """One tick of :meth:`SimSpindle._step` on the state arrays (the same arithmetic, in order);
    a new load knot is taken from ``draws`` (values drawn beforehand from the seeded generator)."""
    ramp = par[P_RAMP]
    delta = sf[F_TARGET] - sf[F_RPM]
    if abs(delta) <= ramp:
        sf[F_RPM] = sf[F_TARGET]
    else:
        sf[F_RPM] = sf[F_RPM] + (ramp if delta > 0 else -ramp)
    interval = np.int64(par[P_INTERVAL])
    phase = tick % interval
    if phase == 0 and tick > 0:
        sf[F_KNOT0] = sf[F_KNOT1]
        sf[F_KNOT1] = draws[si[S_DRAWN]]
        si[S_DRAWN] += 1
    load = sf[F_KNOT0] + (sf[F_KNOT1] - sf[F_KNOT0]) * phase / interval
    c = np.int64(par[P_COUNTS])
    speed = sf[F_RPM] if par[P_SIGNED] != 0.0 else abs(sf[F_RPM])
    per_tick = speed / 60.0 * c * par[P_TICK_S] * (1.0 + load)
    before = si[S_ANGLE] >> FRACTION_BITS
    si[S_ANGLE] += np.int64(np.rint(per_tick * ONE_COUNT))
    after = si[S_ANGLE] >> FRACTION_BITS
    if after // c > before // c:
        si[S_INDEX_COUNT] = (after // c) * c
        si[S_INDEX_TICK] = tick
    elif after // c < before // c:
        si[S_INDEX_COUNT] = (before // c) * c
        si[S_INDEX_TICK] = tick
    si[S_TICK] = tick


@kernel
def spindle_run(si, sf, par, draws, tick, history):
    """Every tick after the state's up to and including ``tick``; the angles go to ``history``."""
    k = 0
    for t in range(si[S_TICK] + 1, tick + 1):
        spindle_step(si, sf, par, draws, t)
        history[k] = si[S_ANGLE]
        k += 1


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
        self.signed = settings.reverse_rpm_s is not None    # a quadrature encoder: the signed angle
        self.physics = settings.sim
        self.tick_s = tick_us * 1e-6
        self.rng = random.Random(self.physics.seed)
        self.interval = max(1, round(self.physics.noise_interval_ms * 1e-3 / self.tick_s))
        self.tick = -1                      # last tick simulated
        self.angle = 0                      # 1/65536 counts (never decreases unless signed)
        self.rpm = 0.0                      # signed drive speed, before the load
        self.target_rpm = 0.0
        self.history = array("q")           # angle at the end of every tick
        self.index_count = -1
        self.index_tick = -1
        self._drawn: deque[float] = deque()  # load factors drawn ahead, not used yet
        self._knots = (0.0, self._draw())   # load factor at the last and the next knot

    def _fresh(self) -> float:
        noise = self.physics.load_noise
        return self.rng.uniform(-noise, noise) if noise else 0.0

    def _draw(self) -> float:
        return self._drawn.popleft() if self._drawn else self._fresh()

    # -- the compiled loop's view of the same state -------------------------------------------------
    def draws_until(self, tick: int) -> np.ndarray:
        """The load factors the ticks up to ``tick`` may take, drawn now in the generator's order
        (the ones not used stay for later ticks: the sequence is the same however it is run)."""
        knots = max(tick // self.interval - max(self.tick, 0) // self.interval, 0)
        while len(self._drawn) < knots:
            self._drawn.append(self._fresh())
        return np.array(list(self._drawn)[:knots] or [0.0], dtype=np.float64)

    def state(self):
        """(int state, float state, parameters) arrays for :func:`spindle_step`."""
        si = np.array([self.angle, self.tick, self.index_count, self.index_tick, 0], dtype=np.int64)
        sf = np.array([self.rpm, self.target_rpm, *self._knots], dtype=np.float64)
        par = np.array([self.physics.accel_rpm_s * self.tick_s, self.tick_s, self.counts_per_rev,
                        self.interval, float(self.signed)], dtype=np.float64)
        return si, sf, par

    def set_state(self, si, sf, history) -> None:
        """Take the state back from the compiled loop, with the angles of the ticks it ran."""
        for _ in range(int(si[S_DRAWN])):
            self._drawn.popleft()
        self.angle, self.tick = int(si[S_ANGLE]), int(si[S_TICK])
        self.index_count, self.index_tick = int(si[S_INDEX_COUNT]), int(si[S_INDEX_TICK])
        self.rpm, self.target_rpm = float(sf[F_RPM]), float(sf[F_TARGET])
        self._knots = (float(sf[F_KNOT0]), float(sf[F_KNOT1]))
        self.history.frombytes(np.ascontiguousarray(history, dtype=np.int64).tobytes())

    def command(self, tick: int, rpm: float, direction: int) -> None:
        """Set the drive (SPIN): ``rpm`` and +1 (M3), -1 (M4) or 0 (M5), from tick ``tick`` on."""
        self.advance_to(tick - 1)
        self.target_rpm = 0.0 if self.physics.stalled else rpm * direction

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
        speed = self.rpm if self.signed else abs(self.rpm)
        per_tick = speed / 60.0 * self.counts_per_rev * self.tick_s * (1.0 + load)
        before = self.angle >> FRACTION_BITS
        self.angle += int(round(per_tick * ONE_COUNT))
        after = self.angle >> FRACTION_BITS
        c = self.counts_per_rev
        if after // c != before // c:
            self.index_count = max(after // c, before // c) * c
            self.index_tick = tick
        self.history.append(self.angle)
        self.tick = tick

    def advance_to(self, tick: int) -> None:
        """Simulate every tick up to and including ``tick`` (a long stretch by the compiled loop,
        the same numbers)."""
        if tick - self.tick >= COMPILED_SPAN and compiled(tick - self.tick):
            draws = self.draws_until(tick)
            si, sf, par = self.state()
            history = np.empty(tick - self.tick, dtype=np.int64)
            spindle_run(si, sf, par, draws, tick, history)
            self.set_state(si, sf, history)
            return
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
