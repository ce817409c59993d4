"""The [servo] section of a machine file: DC motor, encoder, position-loop gains, spindle drive.

One motor type drives every axis. The loop period is the machine's tick (``[machine] tick_us``,
1000 us on grenoble-mill): each tick the loop reads the encoder and writes a feedrate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ConfigError
from ..machine.config import Axis
from ..machine.tomlreader import Section

#: full scale of a feedrate on the link (and of the drive's speed set-point): -255..255
FEED_FULL_SCALE = 255


@dataclass(frozen=True)
class ServoSettings:
    """A DC servo axis and its position loop, as read from ``[servo]``."""

    kp: float                       # feed units per pulse of following error
    ki: float                       # feed units per pulse-second
    feedforward: bool               # add the row's feedrate to the loop's correction
    encoder_counts_per_rev: int
    lead_mm: float
    inertia_kg_m2: float
    torque_constant_nm_a: float     # also the back-emf constant (V s/rad)
    resistance_ohm: float
    viscous_nm_s_rad: float
    coulomb_nm: float
    substeps: int                   # motor integration steps per loop period
    in_position_pulses: int
    settle_timeout_ms: int
    spindle_max_rpm: float          # S255

    @property
    def pulses_per_rad(self) -> float:
        return self.encoder_counts_per_rev / (2.0 * math.pi)

    @property
    def damping_per_s(self) -> float:
        """1 / mechanical time constant: (Kt^2 / R + b) / J."""
        kt, r = self.torque_constant_nm_a, self.resistance_ohm
        return (kt * kt / r + self.viscous_nm_s_rad) / self.inertia_kg_m2

    @property
    def time_constant_s(self) -> float:
        """Mechanical time constant of motor and load, from drive voltage to speed."""
        return 1.0 / self.damping_per_s

    def gain_pulses_s(self, axis: Axis) -> float:
        """Steady speed in pulses/s per feed unit (friction aside): the plant's velocity gain."""
        return axis.max_velocity_mm_s * axis.steps_per_mm / FEED_FULL_SCALE

    def volts_per_feed(self, axis: Axis) -> float:
        """Drive output per feed unit, chosen so feed 255 runs the axis at its max velocity."""
        omega_max = axis.max_velocity_mm_s / self.lead_mm * 2.0 * math.pi
        kt, r = self.torque_constant_nm_a, self.resistance_ohm
        return omega_max * (kt * kt + self.viscous_nm_s_rad * r) / kt / FEED_FULL_SCALE


def read_servo_section(sec: Section, axes: tuple[Axis, ...]) -> ServoSettings:
    """Read ``[servo]`` strictly; the encoder and lead must give each axis's steps_per_mm."""
    counts = sec.get_int("encoder_counts_per_rev", minval=1, maxval=10_000_000)
    lead = sec.get_float("lead_mm", above=0.0, maxval=100.0)
    for axis in axes:
        if abs(counts / lead - axis.steps_per_mm) > 1e-6 * axis.steps_per_mm:
            raise sec.error("encoder_counts_per_rev",
                            f"{counts} counts/rev on a {lead:g} mm lead is {counts / lead:g} pulses/mm, "
                            f"but [axis.{axis.name.lower()}] steps_per_mm = {axis.steps_per_mm:g}; "
                            "they must agree")
    settings = ServoSettings(
        kp=sec.get_float("kp", minval=0.0, maxval=255.0),
        ki=sec.get_float("ki", 0.0, minval=0.0, maxval=1e6),
        feedforward=sec.get_bool("feedforward", True),
        encoder_counts_per_rev=counts,
        lead_mm=lead,
        inertia_kg_m2=sec.get_float("inertia_kg_m2", above=0.0, maxval=10.0),
        torque_constant_nm_a=sec.get_float("torque_constant_nm_a", above=0.0, maxval=100.0),
        resistance_ohm=sec.get_float("resistance_ohm", above=0.0, maxval=1000.0),
        viscous_nm_s_rad=sec.get_float("viscous_nm_s_rad", 0.0, minval=0.0, maxval=100.0),
        coulomb_nm=sec.get_float("coulomb_nm", 0.0, minval=0.0, maxval=100.0),
        substeps=sec.get_int("substeps", 4, minval=1, maxval=1000),
        in_position_pulses=sec.get_int("in_position_pulses", 2, minval=0, maxval=1_000_000),
        settle_timeout_ms=sec.get_int("settle_timeout_ms", 500, minval=1, maxval=60_000),
        spindle_max_rpm=sec.get_float("spindle_max_rpm", 3000.0, above=0.0, maxval=1e6),
    )
    _check_home(sec, axes)
    sec.finish()
    return settings


def _check_home(sec: Section, axes: tuple[Axis, ...]) -> None:
    """Home (H@, G28) is machine zero, 0 mm on every axis: it must lie inside the travel."""
    for axis in axes:
        if not axis.min_mm <= 0.0 <= axis.max_mm:
            raise ConfigError(f"{sec.file} [axis.{axis.name.lower()}]: travel {axis.min_mm:g}.."
                              f"{axis.max_mm:g} mm must include 0 mm, the home position of a servo axis")


def servo_of(machine) -> ServoSettings:
    """The machine's [servo] settings; ConfigError when its file has no [servo] section."""
    servo = machine.parts.get("servo")
    if servo is None:
        raise ConfigError(f"{machine.name}: no [servo] section; the CAM link needs servo axes "
                          "(see retrofit/machines/grenoble-mill.toml)")
    return servo
