"""Rotary axes A, B and C in a machine file: degrees, steps per degree, limits or wrap.

An ``[axis.a]`` table (or b, c) reads ``steps_per_degree`` and either ``min_deg``/``max_deg``
(soft limits, like a linear axis) or ``wrap = true`` (a table that turns without end: no limits,
and an absolute move takes the shorter way round, as LinuxCNC's wrapped rotary axes do); speed
and acceleration are ``max_velocity_deg_s`` and ``max_accel_deg_s2``, the clearance
``backlash_deg``. Inside, the axis is an :class:`~retrofit.machine.config.Axis` whose "mm" are degrees:
a program's A word is degrees under G20 and G21 alike, and never a diameter.
"""

from __future__ import annotations

from .config import STEPS_MAX, Axis

#: the mm-named keys a rotary axis does not take, and what it takes instead
_LINEAR_KEYS = {"steps_per_mm": "steps_per_degree", "min_mm": "min_deg", "max_mm": "max_deg",
                "max_velocity_mm_s": "max_velocity_deg_s", "max_accel_mm_s2": "max_accel_deg_s2",
                "backlash_mm": "backlash_deg"}


def read_rotary(key: str, sec, step_pin, dir_pin, step_bit: int, dir_bit: int) -> Axis:
    """One ``[axis.a|b|c]`` table (the pins already read)."""
    for linear, rotary in _LINEAR_KEYS.items():
        if sec.has(linear):
            raise sec.error(linear, f"{key.upper()} is a rotary axis (degrees): write {rotary}")
    steps = sec.get_float("steps_per_degree", above=0.0, maxval=1e6)
    reach = STEPS_MAX / steps
    wrap = sec.get_bool("wrap", False)
    if wrap:
        for limit in ("min_deg", "max_deg"):
            if sec.has(limit):
                raise sec.error(limit, "a wrapped axis (wrap = true) has no limits; give the "
                                       "limits or wrap, not both")
        low, high = -reach, reach
    else:
        low = sec.get_float("min_deg", minval=-reach, maxval=reach,)
        high = sec.get_float("max_deg", minval=-reach, maxval=reach)
        if not high > low:
            raise sec.error("max_deg", f"must be > min_deg ({low:g})")
    axis = Axis(
        name=key.upper(), label=sec.get_str("label", key.upper()), steps_per_mm=steps,
        min_mm=low, max_mm=high,
        pulse_high_ticks=sec.get_int("pulse_high_ticks", 1, minval=1, maxval=10_000),
        pulse_low_ticks=sec.get_int("pulse_low_ticks", 1, minval=1, maxval=10_000),
        dir_setup_ticks=sec.get_int("dir_setup_ticks", 1, minval=0, maxval=10_000),
        dir_hold_ticks=sec.get_int("dir_hold_ticks", 1, minval=0, maxval=10_000),
        backlash_mm=sec.get_float("backlash_deg", 0.0, minval=0.0, maxval=10.0),
        max_velocity_mm_s=sec.get_float("max_velocity_deg_s", 90.0, above=0.0, maxval=100_000.0),
        max_accel_mm_s2=sec.get_float("max_accel_deg_s2", 900.0, above=0.0, maxval=1e7),
        step_bit=step_bit, dir_bit=dir_bit, step_pin=step_pin, dir_pin=dir_pin,
        invert_step=sec.get_bool("invert_step", False), invert_dir=sec.get_bool("invert_dir", False),
        rotary=True, wrap=wrap,
    )
    sec.finish()
    return axis


def shorter_way(here_deg: float, target_deg: float) -> float:
    """Where a wrapped axis at ``here_deg`` ends when sent to ``target_deg``: the same angle
    modulo 360, reached by the shorter turn (half a turn goes forward).

    >>> shorter_way(350.0, 10.0), shorter_way(10.0, 350.0), shorter_way(720.0, 90.0)
    (370.0, -10.0, 810.0)
    """
    turn = (target_deg - here_deg) % 360.0
    if turn > 180.0:
        turn -= 360.0
    return here_deg + turn
