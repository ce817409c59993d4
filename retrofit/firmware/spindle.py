"""The spindle in the loop of the simavr harness: the drive of ``sim://`` driven by the firmware's
own spindle outputs (speed PWM on D10, direction on D11), its encoder fed back on D21 / D20.

The harness (``--spindle-model``, firmware/harness/hil.c) runs :class:`retrofit.sim.spindle.SimSpindle`'s
arithmetic tick for tick; the load factors come from here, drawn from the machine file's seed in
SimSpindle's order, so :func:`replay` gives back, in Python, the very spindle the firmware saw.
"""

from __future__ import annotations

from pathlib import Path

from ..machine.config import Machine
from ..sim.spindle import SimSpindle
from .sim import F_CPU


def spindle_model_args(machine: Machine, draws_path: Path, stalled: bool | int = False) -> list[str]:
    """The harness's spindle in the loop (``--spindle-model``): the drive of ``sim://``
    (:class:`retrofit.sim.spindle.SimSpindle`: ramp, load noise of ``[spindle.sim]``) driven by
    the firmware's PWM and direction pins; its load factors drawn here from the machine file's
    seed, in the order SimSpindle draws them, into ``draws_path``; ``stalled``: it never turns
    (True), or stops dead at that AVR cycle (a number) and stays jammed."""
    from array import array
    spindle = machine.parts.get("spindle")
    if spindle is None:
        return []
    model = SimSpindle(spindle, machine.tick_us)
    hours = 4 * 3600 / (model.interval * model.tick_s)
    draws = array("d", [model._knots[1]] + [model._fresh() for _ in range(int(min(hours, 1e6)))])
    draws_path.write_bytes(draws.tobytes())
    ramp = model.physics.accel_rpm_s * model.tick_s
    args = ["--spindle-model", f"{spindle.encoder_counts_per_rev},{spindle.max_rpm!r},"
            f"{round(machine.tick_us * F_CPU / 1e6)},{ramp!r},{model.tick_s!r},{model.interval},{draws_path}"]
    if stalled is not True and stalled:
        return args + ["--spindle-stall-at", str(int(stalled))]
    return args + (["--spindle-stall"] if stalled or spindle.sim.stalled else [])


def replay(log, machine: Machine) -> SimSpindle:
    """The spindle of ``sim://`` given the speeds the harness's drive was set to (``log.drive``):
    the same angles, tick for tick, as the harness's."""
    spindle = SimSpindle(machine.parts["spindle"], machine.tick_us)
    for _, tick, rpm in log.drive:
        spindle.command(tick, abs(rpm), 1 if rpm > 0 else (-1 if rpm < 0 else 0))
    return spindle
