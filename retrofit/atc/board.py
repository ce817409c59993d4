"""The ``[ramps]`` section: board pins beyond each axis's step and direction (enables, spindle PWM).

On a RAMPS 1.4 shield each stepper driver has an enable pin next to its step and direction pins,
and the spindle's speed is a PWM output (D10 on the mill of 000). The step and direction pins
stay in ``[axis.*]``; this section holds the rest, checked against them.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..machine.config import Axis
from ..machine.tomlreader import Section


@dataclass(frozen=True)
class RampsPins:
    """Driver enable pin per axis, and the spindle's PWM pin (Arduino Mega pin numbers)."""

    enable_pins: dict[str, int]
    spindle_pwm_pin: int | None


def read_ramps_section(sec: Section, axes: tuple[Axis, ...]) -> RampsPins:
    """Read ``[ramps]``: ``enable_pins = { x = 38, ... }`` and ``spindle_pwm_pin``; no pin twice."""
    used = {pin: f"{a.name}.{what}" for a in axes
            for what, pin in (("step_pin", a.step_pin), ("dir_pin", a.dir_pin)) if pin is not None}
    enables: dict[str, int] = {}
    table = sec.section("enable_pins", required=False)
    if table is not None:
        for axis in axes:
            if table.has(axis.name.lower()):
                enables[axis.name] = _pin(table, axis.name.lower(), used, f"{axis.name}.enable")
        table.finish()
    pwm = _pin(sec, "spindle_pwm_pin", used, "spindle PWM") if sec.has("spindle_pwm_pin") else None
    sec.finish()
    return RampsPins(enables, pwm)


def _pin(sec: Section, key: str, used: dict[int, str], what: str) -> int:
    pin = sec.get_int(key, minval=0, maxval=69)          # the Mega 2560's D0..D69 (A0..A15 = 54..69)
    if pin in used:
        raise sec.error(key, f"already used by {used[pin]}; each pin drives one signal")
    used[pin] = what
    return pin
