"""The tick step generator of the lathe paper: pulse-width and period counters, plus direction timing.

One ``StepGenerator`` per axis. Each tick the controller first calls :meth:`StepGenerator.frame`
(the paper's ``PasAvans``) to get this tick's step and direction bits, writes the port byte, and
then may call :meth:`set_direction` and :meth:`start_step` (the paper's ``SetPasAvans``) to shape
the next ticks. A step asked for while a pulse is in progress is refused (the caller asks again
next tick): pulses never overlap and a request is never lost, only deferred.

Timing, with tick ``n`` the frame just written and ``n + 1`` the next:

* a step may start only when ``period == 0``; then ``high := pulse_high`` and
  ``period := high + pulse_low`` (the paper's ``dunu`` and ``perioada``), so the shortest step
  period is ``pulse_high + pulse_low`` ticks (two with 1/1);
* the direction bit never changes within ``dir_hold`` ticks after a rising edge, nor within
  ``dir_setup`` ticks before one.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..machine.config import Axis

_LONG_AGO = -(1 << 40)


@dataclass(frozen=True)
class StepTiming:
    """Pulse and direction timing of one axis, in ticks."""

    pulse_high: int = 1     # 'dunu'
    pulse_low: int = 1      # period = high + low ('perioada')
    dir_setup: int = 0
    dir_hold: int = 0

    @classmethod
    def of(cls, axis: Axis) -> StepTiming:
        return cls(axis.pulse_high_ticks, axis.pulse_low_ticks, axis.dir_setup_ticks, axis.dir_hold_ticks)

    @property
    def period(self) -> int:
        return self.pulse_high + self.pulse_low


class StepGenerator:
    """Step and direction bits of one axis, tick by tick."""

    def __init__(self, timing: StepTiming, direction: int = -1):
        self.timing = timing
        self.high = 0                 # 'dunu': ticks of logic 1 still to come
        self.period = 0               # 'perioada': ticks until the next step may start
        self.direction = direction    # +1 right / positive, -1 left / negative (paper: b1 false)
        self.tick = -1                # the frame last produced
        self.last_rise = _LONG_AGO    # frame of the last rising step edge
        self.last_dir_change = _LONG_AGO

    def frame(self) -> tuple[int, int]:
        """Advance one tick and return (step bit, direction) for it ('PasAvans')."""
        self.tick += 1
        if self.high > 0:
            step = 1
            self.high -= 1
            self.period -= 1
        else:
            step = 0
            if self.period > 0:
                self.period -= 1
        return step, self.direction

    @property
    def busy(self) -> bool:
        """True while a pulse or its low time is still in progress."""
        return self.period > 0

    def can_change_direction(self) -> bool:
        return (self.tick + 1) - self.last_rise >= self.timing.dir_hold

    def set_direction(self, direction: int) -> bool:
        """Ask for a direction from the next tick on; False while the hold time forbids it."""
        if direction == self.direction:
            return True
        if not self.can_change_direction():
            return False
        self.direction = direction
        self.last_dir_change = self.tick + 1
        return True

    def can_start(self) -> bool:
        return self.period == 0 and (self.tick + 1) - self.last_dir_change >= self.timing.dir_setup

    def start_step(self) -> bool:
        """Start a pulse rising on the next tick ('SetPasAvans'); False (deferred) if not allowed."""
        if not self.can_start():
            return False
        self.high = self.timing.pulse_high
        self.period = self.high + self.timing.pulse_low
        self.last_rise = self.tick + 1
        return True
