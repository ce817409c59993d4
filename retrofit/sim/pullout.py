"""Stepper pull-out in the simulator: a rotor that follows the step pulses only as far as its torque allows.

A stepper driver moves the magnetic field one step on every rising edge; the rotor follows the
field because the field pulls it with a torque ``T(speed) * sin(load angle)``, where the load
angle is how far the rotor lags the field (one full step is a quarter of the electrical period)
and ``T(speed)`` is the motor's pull-out torque curve, falling with speed. While the rotor lags
by less than two full steps the pull brings it back; beyond two full steps the field pulls it
the wrong way and the motor falls out of step (pull-out).

So a rotor of inertia ``J`` against a load torque ``T_L`` can accelerate at most at
``(T(speed) - T_L) / J`` and cannot run faster than the speed where ``T(speed) = T_L``: a step
rate that climbs faster, or goes higher, leaves the rotor behind until it slips. Short
irregularities (a tick of rounding, a Bresenham pattern on a minor axis) only wiggle the load
angle; only a sustained demand beyond the torque loses steps.

The model, per axis, between step edges (semi-implicit Euler in sub-steps of at most a
twentieth of the natural period's radian, landing exactly on every edge)::

    a = K (T(|v|) sin(pi/2 (n - x) / microsteps) - T_L sign(v)) - 2 zeta w_n (v - v_field)

with ``x`` the rotor and ``n`` the field in motor steps, ``K = steps_per_rev / (2 pi J)``,
``w_n`` the natural frequency of the rotor on the field at standstill, ``zeta`` the damping
ratio (electromagnetic damping acts on the rotor's speed relative to the field's,
``v_field = 1 / (time between the last two edges)``, slower when the next edge is late).
Static friction holds a rotor at rest while the pull is below ``T_L``.

When the rotor falls out of step it stalls: that edge and every following one are **lost**
(the motor does not move, the carriage neither) until an edge comes at least ``1 / pull-in
rate`` after the previous one; there the rotor locks onto the field again. The pull-in rate
is the fastest rate a motor at rest can start at without a ramp,
``sqrt(4 microsteps a0)`` steps/s with ``a0`` the acceleration at standstill (the rate whose
lag, starting from rest at full acceleration, just reaches two full steps).
The simulator reports each stall as a violation of kind ``lost_steps``.
"""

from __future__ import annotations

import math

from ..machine.motors import MotorModel, read_motor_tables  # noqa: F401  (re-exported: the simulator's motor model)
from .drivers import Violation


class PullOutMotor:
    """The rotor of one axis: :meth:`follow` each rising step edge to learn how far the motor turned."""

    def __init__(self, model: MotorModel, axis: str, tick_s: float):
        self.model, self.axis, self.tick_s = model, axis, tick_s
        self.k = model.steps_per_rev / (2.0 * math.pi * model.inertia_kg_m2)   # steps/s² per N·m
        w_n = model.natural_frequency_rad_s()
        self.damping = 2.0 * model.damping_ratio * w_n
        self.h_max = 0.05 / w_n
        self.settle_s = 20.0 / (model.damping_ratio * w_n)
        self.limit = 2.0 * model.microsteps            # load angle of two full steps, in steps
        self.pull_in_gap_s = 1.0 / max(model.pull_in_rate_steps_s(), 1e-9)
        self.x = 0.0                # rotor, steps from where it started
        self.v = 0.0                # rotor speed, steps/s
        self.n = 0                  # field = where the motor is locked, steps from the start
        self.t: float | None = None  # time the state is at, s
        self.t_edge = -math.inf     # last rising edge, s
        self.interval = math.inf    # time between the last two edges in one direction, s
        self.direction = 0
        self.stalled = False
        self.slip_lag = 0.0         # rotor lag (steps) when it last fell out of step
        self.lost = 0               # steps lost so far (not turned, or fallen back)
        self.violations: list[Violation] = []

    def follow(self, tick: int, direction: int) -> int:
        """A rising edge at ``tick`` asks for a step in ``direction`` (+1 / -1).

        Returns the steps the motor turned: ``direction`` when it follows, 0 when the step is
        lost, and, after a fall out of step found since the last edge, also the four full steps
        the rotor fell back to the field's previous stable position.
        """
        tick, direction = int(tick), int(direction)
        t = tick * self.tick_s
        moved = 0
        if not self.stalled and self.t is not None:
            self._advance(t)
            if self.stalled:
                moved = self._fall_back()
        if self.stalled:
            if t - self.t_edge < self.pull_in_gap_s:
                self.lost += 1
                self.t_edge = self.t = t
                return moved
            self.stalled, self.x, self.v, self.interval = False, float(self.n), 0.0, math.inf
        elif direction == self.direction:
            self.interval = t - self.t_edge
        else:
            self.interval = math.inf
        self.n += direction
        self.direction, self.t_edge, self.t = direction, t, t
        return moved + direction

    def _advance(self, t_end: float) -> None:
        """Integrate the rotor from ``self.t`` to ``t_end`` with the field standing at ``n``."""
        span = t_end - self.t
        if span <= 0.0:
            return
        settled = span > self.settle_s
        span = min(span, self.settle_s)
        count = max(1, math.ceil(span / self.h_max))
        h = span / count
        t = self.t
        for _ in range(count):
            t += h
            if not self._substep(h, t):
                self._slip(t)
                return
        if settled:
            self.x, self.v = float(self.n), 0.0
        self.t = t_end

    def _substep(self, h: float, t: float) -> bool:
        """One Euler sub-step ending at ``t``; False when the rotor is out of step."""
        m = self.model
        lag = self.n - self.x
        if abs(lag) > self.limit:
            return False
        gap = max(self.interval, t - self.t_edge)
        v_field = self.direction / gap
        pull = self.k * m.torque_nm(self.v) * math.sin(0.5 * math.pi * lag / m.microsteps)
        drive = pull - self.damping * (self.v - v_field)
        friction = self.k * m.load_torque_nm
        if self.v == 0.0:
            a = 0.0 if abs(drive) <= friction else drive - math.copysign(friction, drive)
        else:
            a = drive - math.copysign(friction, self.v)
        v = self.v + a * h
        if self.v != 0.0 and (v > 0.0) != (self.v > 0.0):
            v = 0.0                                     # friction stops it within the sub-step
        self.v = v
        self.x += v * h
        return True

    def _slip(self, t: float) -> None:
        """The rotor lags (or leads) the field by more than two full steps: it stalls."""
        m = self.model
        demanded = 1.0 / self.interval if self.interval > 0 else 0.0
        rotor = abs(self.v)
        rate = max(demanded, rotor)
        self.slip_lag = self.n - self.x
        self.stalled, self.v = True, 0.0
        self.violations.append(Violation(round(t / self.tick_s), self.axis, "lost_steps",
            f"motor fell out of step: pulses at {demanded:.0f} steps/s, rotor at {rotor:.0f} steps/s "
            f"lagging {self.slip_lag / m.microsteps:+.1f} full steps; at {rate:.0f} steps/s it can "
            f"accelerate at most {m.max_accel_steps_s2(rate):.0f} steps/s² (pull-out torque "
            f"{m.torque_nm(rate):.3g} N·m, load {m.load_torque_nm:.3g} N·m; top rate "
            f"{m.max_rate_steps_s():.0f} steps/s); steps are lost until the pulses slow to the "
            f"pull-in rate, {m.pull_in_rate_steps_s():.0f} steps/s"))

    def _fall_back(self) -> int:
        """Where a stalled rotor comes to rest: four full steps behind (or ahead of) the field."""
        back = -int(math.copysign(4 * self.model.microsteps, self.slip_lag))
        self.n += back
        self.lost += abs(back)
        return back


def turn_screw(screw, moved: int) -> float:
    """Turn a lead screw (``backlash.DeadBand``) by ``moved`` motor steps; the carriage, in steps."""
    step = 1 if moved > 0 else -1
    for _ in range(abs(moved)):
        screw.move_motor(step)
    return screw.carriage
