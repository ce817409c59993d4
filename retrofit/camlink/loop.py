"""The 1 ms position loop of the Grenoble mill, one axis: encoder in, corrected feedrate out.

Each loop period (one tick) the real-time task of the paper

1. reads the encoder position,
2. compares it with the position set-point of this period's trajectory row,
3. corrects the row's feedrate by the following error (P, or PI when ``ki`` > 0),
4. writes the corrected feedrate, a whole number -255..255, to the axis's drive.

All in integers at the edges: pulses in, feed units out; no wall clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .motor import ServoMotor
from .servo import FEED_FULL_SCALE, ServoSettings


def round_half_away(x: float) -> int:
    """Nearest whole number, halves away from zero (as a drive's DAC rounding would be, symmetric)."""
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


@dataclass
class LoopSample:
    """What one loop period saw and did on one axis."""

    setpoint: int        # pulses
    encoder: int         # pulses, read at the start of the period
    feed_in: int         # the row's feedrate
    feed_out: int        # the corrected feedrate written to the drive

    @property
    def following_error(self) -> int:
        return self.setpoint - self.encoder


class PositionLoop:
    """P or PI position loop with the row's feedrate as feed-forward, for one servo axis."""

    def __init__(self, servo: ServoSettings, period_s: float):
        self.kp = servo.kp
        self.ki_per_period = servo.ki * period_s   # integral gain per pulse per period
        self.feedforward = servo.feedforward
        self.integral = 0.0                        # sum of following errors, pulses x periods
        self.last: LoopSample | None = None

    def reset(self) -> None:
        """Forget the integral (a new operation, a stop)."""
        self.integral = 0.0

    def correct(self, setpoint: int, encoder: int, feed: int) -> int:
        """The feedrate to write this period for set-point and encoder in pulses."""
        error = setpoint - encoder
        base = feed if self.feedforward else 0
        integral = self.integral + error
        wanted = base + self.kp * error + self.ki_per_period * integral
        whole = round_half_away(wanted)
        out = max(-FEED_FULL_SCALE, min(FEED_FULL_SCALE, whole))
        if out == whole:          # no wind-up: integrate only while not saturated
            self.integral = integral
        self.last = LoopSample(setpoint, encoder, feed, out)
        return out


class ServoAxis:
    """One axis under closed-loop control: a :class:`PositionLoop` driving a :class:`ServoMotor`."""

    def __init__(self, motor: ServoMotor, loop: PositionLoop, period_s: float):
        self.motor, self.loop, self.period_s = motor, loop, period_s
        self.setpoint = motor.encoder()

    def step(self, setpoint: int, feed: int) -> LoopSample:
        """One loop period: read, compare, correct, drive the motor for the period."""
        self.setpoint = setpoint
        out = self.loop.correct(setpoint, self.motor.encoder(), feed)
        self.motor.run(out, self.period_s)
        return self.loop.last

    def hold(self) -> LoopSample:
        """One loop period holding the last set-point (no feed-forward)."""
        return self.step(self.setpoint, 0)

    def brake(self) -> None:
        """One loop period with the drive at 0 (the motor brakes on its own back-emf)."""
        self.motor.run(0, self.period_s)

    def in_position(self, tolerance: int) -> bool:
        """At rest and within ``tolerance`` pulses of the set-point."""
        return self.motor.at_rest and abs(self.setpoint - self.motor.encoder()) <= tolerance

    def stop_here(self) -> None:
        """Take the present encoder position as the set-point and forget the integral."""
        self.setpoint = self.motor.encoder()
        self.loop.reset()


def run_setpoints(axis: ServoAxis, rows) -> list[LoopSample]:
    """Run one loop period per (set-point, feed) pair; return what every period saw."""
    return [axis.step(int(p), int(f)) for p, f in rows]
