"""A stepper motor as the machine file describes it (``[sim.motor.<axis>]``): its data and reader.

The description belongs with the machine file; what the motor does with step pulses (a rotor
that can slip and lose steps) is the simulator's :mod:`retrofit.sim.pullout`.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

from ..errors import ConfigError


@dataclass(frozen=True)
class MotorModel:
    """One axis's stepper motor as the simulator models it (``[sim.motor.<axis>]``)."""

    inertia_kg_m2: float                          # rotor + screw + carriage, reflected to the shaft
    pullout_curve: tuple[tuple[float, float], ...]  # (rpm, N·m): the pull-out torque curve
    load_torque_nm: float = 0.0                   # friction and cutting load at the shaft
    full_steps_per_rev: int = 200                 # 1.8 degree motor
    microsteps: int = 1                           # driver steps per full step
    damping_ratio: float = 0.3

    @property
    def steps_per_rev(self) -> int:
        """Driver steps (what the step pulses count) per motor revolution."""
        return self.full_steps_per_rev * self.microsteps

    def torque_nm(self, rate_steps_s: float) -> float:
        """Pull-out torque at a step rate: the curve, linear between its points, 0 beyond the last."""
        rpm = abs(rate_steps_s) * 60.0 / self.steps_per_rev
        speeds = [p[0] for p in self.pullout_curve]
        if rpm > speeds[-1]:
            return 0.0
        i = bisect.bisect_right(speeds, rpm) - 1
        if i >= len(speeds) - 1:
            return self.pullout_curve[-1][1]
        (r0, t0), (r1, t1) = self.pullout_curve[i], self.pullout_curve[i + 1]
        return t0 + (t1 - t0) * (rpm - r0) / (r1 - r0)

    def max_accel_steps_s2(self, rate_steps_s: float = 0.0) -> float:
        """The most the motor can accelerate at this step rate: (T - T_L) / J, in steps/s²."""
        spare = self.torque_nm(rate_steps_s) - self.load_torque_nm
        return max(spare, 0.0) * self.steps_per_rev / (2.0 * math.pi * self.inertia_kg_m2)

    def max_rate_steps_s(self) -> float:
        """The fastest step rate the motor can hold against its load (where T = T_L)."""
        to_steps = self.steps_per_rev / 60.0
        points = self.pullout_curve
        for (r0, t0), (r1, t1) in zip(points, points[1:]):
            if t1 <= self.load_torque_nm < t0:
                return (r0 + (r1 - r0) * (t0 - self.load_torque_nm) / (t0 - t1)) * to_steps
        if points[0][1] <= self.load_torque_nm:
            return 0.0
        return points[-1][0] * to_steps

    def pull_in_rate_steps_s(self) -> float:
        """The fastest rate the motor starts at from rest without a ramp (see the module doc)."""
        return math.sqrt(4.0 * self.microsteps * self.max_accel_steps_s2(0.0))

    def natural_frequency_rad_s(self) -> float:
        """The rotor's natural frequency on the field at standstill (small load angles)."""
        k = self.steps_per_rev / (2.0 * math.pi * self.inertia_kg_m2)
        return math.sqrt(k * self.pullout_curve[0][1] * math.pi / (2.0 * self.microsteps))


def read_motor_tables(sec, axes) -> dict[str, MotorModel]:
    """Read ``[sim.motor.<axis>]`` tables strictly: axis name -> MotorModel."""
    names = {a.name.lower(): a.name for a in axes}
    motors = {}
    for key, table in sec.subsections():
        if key not in names:
            raise ConfigError(f"{sec.file} [{sec.name}.{key}]: no axis {key!r}; "
                              f"axes are {', '.join(sorted(names))}")
        motors[names[key]] = _read_motor(table)
    sec.finish()
    return motors


def _read_motor(sec) -> MotorModel:
    d = MotorModel(1.0, ((0.0, 1.0),))
    model = MotorModel(
        inertia_kg_m2=sec.get_float("inertia_kg_m2", above=0.0, maxval=10.0),
        pullout_curve=_curve(sec),
        load_torque_nm=sec.get_float("load_torque_nm", d.load_torque_nm, minval=0.0, maxval=1000.0),
        full_steps_per_rev=sec.get_int("full_steps_per_rev", d.full_steps_per_rev, minval=4, maxval=100_000),
        microsteps=sec.get_int("microsteps", d.microsteps, minval=1, maxval=1024),
        damping_ratio=sec.get_float("damping_ratio", d.damping_ratio, above=0.0, maxval=10.0),
    )
    sec.finish()
    return model


def _curve(sec) -> tuple[tuple[float, float], ...]:
    """``pullout_curve = [[rpm, N·m], ...]``: from 0 rpm, speeds increasing, torques >= 0."""
    raw = sec.get_list("pullout_curve")
    rule = "must be [[rpm, N·m], ...] starting at 0 rpm, rpm increasing, torque >= 0"
    points = []
    for item in raw:
        ok = (isinstance(item, list) and len(item) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in item))
        if not ok:
            raise sec.error("pullout_curve", rule)
        points.append((float(item[0]), float(item[1])))
    if (not points or points[0][0] != 0.0 or points[0][1] <= 0.0 or any(t < 0 for _, t in points)
            or any(b[0] <= a[0] for a, b in zip(points, points[1:]))):
        raise sec.error("pullout_curve", rule)
    return tuple(points)
