"""Backlash compensation as the lathe paper does it: on a reversal, shift the instantaneous position.

When the motor reverses it first turns through the clearance without moving the carriage. The
paper ('AvansLongitudinalDreapta' and friends) subtracts the clearance from the instantaneous
position when turning to the positive side and adds it when turning to the negative side, so the
position-error loop issues the extra steps by itself.
"""

from __future__ import annotations


class BacklashCompensator:
    """Clearance of one axis in steps ('JocL' / 'JocT'); ``enabled=False`` turns it off."""

    def __init__(self, clearance_steps: int, enabled: bool = True):
        if clearance_steps < 0:
            raise ValueError(f"clearance must be >= 0 steps, not {clearance_steps}")
        self.clearance = clearance_steps if enabled else 0

    def on_reversal(self, position: int, new_direction: int) -> int:
        """The instantaneous position after the direction turned to ``new_direction`` (+1/-1)."""
        return position - self.clearance * new_direction
