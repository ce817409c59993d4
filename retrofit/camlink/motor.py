"""One simulated servo axis: speed drive, DC motor with friction, lead screw, carriage, encoder.

The drive turns a feedrate (-255..255) into motor volts. The motor obeys

    J dw/dt = Kt (V - Kt w) / R - b w - Tc sign(w)

which is integrated exactly (it is linear between changes of the friction's sign) over a fixed
number of sub-steps per loop period; a Coulomb friction Tc holds the shaft still while the drive
torque is below it. The encoder counts whole pulses of the carriage position. No wall clock:
time advances only when :meth:`ServoMotor.run` is called.
"""

from __future__ import annotations

import math

from ..machine.config import Axis
from .servo import ServoSettings


def _sign(x: float) -> float:
    return (x > 0.0) - (x < 0.0)


class ServoMotor:
    """The physics of one axis, from drive set-point to encoder count."""

    def __init__(self, axis: Axis, servo: ServoSettings, start_pulses: int = 0):
        self.axis, self.servo = axis, servo
        self.volts_per_feed = servo.volts_per_feed(axis)
        self.damping = servo.damping_per_s
        self.pos_pulses = float(start_pulses)   # carriage position, not quantised
        self.omega = 0.0                        # motor speed, rad/s
        self.feed = 0                           # drive set-point now applied

    # -- what the controller sees --------------------------------------------------------------
    def encoder(self) -> int:
        """The encoder count: the carriage position in whole pulses."""
        return math.floor(self.pos_pulses + 0.5)

    @property
    def speed_pulses_s(self) -> float:
        return self.omega * self.servo.pulses_per_rad

    @property
    def at_rest(self) -> bool:
        """Still, or creeping slower than half a pulse per second."""
        return abs(self.speed_pulses_s) < 0.5

    # -- physics -------------------------------------------------------------------------------
    def run(self, feed: int, seconds: float) -> None:
        """Apply ``feed`` to the drive for ``seconds`` (held constant: the drive's DAC)."""
        self.feed = feed
        h = seconds / self.servo.substeps
        torque = self.servo.torque_constant_nm_a * feed * self.volts_per_feed / self.servo.resistance_ohm
        for _ in range(self.servo.substeps):
            self._substep(torque, h)

    def _substep(self, drive_torque: float, h: float) -> None:
        """Advance ``h`` seconds; split where friction changes sign (the shaft stops)."""
        j, tc, a = self.servo.inertia_kg_m2, self.servo.coulomb_nm, self.damping
        while h > 0.0:
            direction = _sign(self.omega) or _sign(drive_torque)
            if self.omega == 0.0 and abs(drive_torque) <= tc:
                return                                  # static friction holds the shaft
            w_inf = (drive_torque - tc * direction) / (j * a)
            w0 = self.omega
            decay = math.exp(-a * h)
            w1 = w_inf + (w0 - w_inf) * decay
            if w0 != 0.0 and _sign(w1) != _sign(w0):
                # stops inside this sub-step: advance to the stop, then start again from rest
                t_stop = math.log((w0 - w_inf) / (-w_inf)) / a
                self._advance(w0, w_inf, t_stop)
                self.omega = 0.0
                h -= t_stop
                continue
            self._advance(w0, w_inf, h)
            self.omega = w1
            return

    def _advance(self, w0: float, w_inf: float, t: float) -> None:
        """Move the carriage by the angle turned in ``t`` s from speed w0 towards w_inf."""
        a = self.damping
        angle = w_inf * t + (w0 - w_inf) * (1.0 - math.exp(-a * t)) / a
        self.pos_pulses += angle * self.servo.pulses_per_rad
