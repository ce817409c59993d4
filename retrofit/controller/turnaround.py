"""The spindle turned round at the end of an ISTP move, so that it stands still where the move ends.

Rigid tapping (G33.1) runs a tap in under ISTP, reverses the spindle and runs the tap out along the
same helix: the carriage follows the encoder both ways. A spindle cannot reverse at once; its
drive slows at a rate (``reverse_rpm_s`` in ``[spindle]``). So the controller brings it to rest
at the move's end itself, in a closed loop on the encoder: once the counts left ``r`` are fewer
than it needs to stop, every tick it sets the drive's speed to the one from which it can still
stop in ``r`` counts, ``w = sqrt(2 a r)``, planned with :data:`PLAN_SHARE` of the drive's rate
(the cutting load makes the speed wander, and the loop takes it up). A quarter step before the
end it commands the reversal. The carriage stays locked to the count throughout, so the pitch
holds while the spindle slows, stops and turns back.

A spindle that turns back before the carriage reached the end anyway stops the run with an
error: the move could not be finished.
"""

from __future__ import annotations

import math

from ..errors import MotionError
from ..motion.indexer import PLAN_SHARE

#: the approach never asks for less than this share of the cruising speed (it would never arrive)
FLOOR_SHARE = 0.005


class Turnaround:
    """Bring the spindle to rest at the move's end, then reverse it (``rpm``, ``direction``).

    ``cruise`` is the drive's (rpm, direction) during the move; ``command(tick, rpm, direction)``
    sets the drive from the next tick on; counts are in the move's frame (they rise while the move
    advances).
    """

    def __init__(self, rpm: float, direction: int, cruise: tuple[float, int], reverse_rpm_s: float,
                 counts_per_rev: int, command):
        self.rpm, self.direction = rpm, direction
        self.cruise_rpm, self.cruise_dir = cruise
        self.reverse_rpm_s = reverse_rpm_s
        self.plan = PLAN_SHARE * reverse_rpm_s / 60.0 * counts_per_rev        # counts/s^2
        self.per_rpm = counts_per_rev / 60.0                                   # counts/s per rpm
        self.command = command
        self.asked = self.cruise_rpm               # the speed last set
        self.issued_at: int | None = None
        self.furthest: int | None = None

    def watch(self, tick: int, count: int, start_count: float, end_count: float, step_counts: float) -> None:
        """One tick of the move at encoder ``count``: slow the spindle, or reverse it, when due.
        (Until a step past ``start_count`` the spindle may still be running on from the move
        before, the wrong way.)"""
        if count >= start_count + step_counts:
            self.furthest = count if self.furthest is None else max(self.furthest, count)
        if self.issued_at is not None:
            return
        left = end_count - count
        if left <= step_counts / 4.0:
            self.issue(tick)
            return
        rpm = max(math.sqrt(2.0 * self.plan * left) / self.per_rpm, FLOOR_SHARE * self.cruise_rpm)
        if rpm < self.asked:
            self.command(tick, rpm, self.cruise_dir)
            self.asked = rpm

    def issue(self, tick: int) -> None:
        self.command(tick, self.rpm, self.direction)
        self.issued_at = tick

    def check(self, count: int, step_counts: float, what: str) -> None:
        """MotionError when the spindle turned back before the carriage reached the move's end."""
        if self.furthest is not None and count < self.furthest - step_counts:
            raise MotionError(f"{what}: the spindle turned back {self.furthest - count} counts before the "
                              f"carriage reached the move's end (the rigid tap cannot finish it); "
                              f"motion halted")
