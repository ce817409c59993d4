"""The physical dead band of a lead screw and nut, as the simulator models it.

The motor turns the screw; the nut (and the carriage on it) moves only once the screw has taken
up the play between them. ``gap`` is where the screw sits inside the play, in motor steps: 0 when
it pushes the negative face (last moved negative), ``width`` when it pushes the positive face.
The carriage therefore equals the motor when moving negative and lags it by the dead band when
moving positive. Units are motor steps (the width may be a fraction of a step).
"""

from __future__ import annotations


class DeadBand:
    """Motor -> carriage through a dead band of ``width`` steps (starts engaged on the negative face)."""

    def __init__(self, width: float, motor: int = 0):
        if width < 0:
            raise ValueError(f"dead band must be >= 0, not {width}")
        self.width = width
        self.gap = 0.0
        self.motor = motor

    @property
    def carriage(self) -> float:
        """Carriage position in motor steps."""
        return self.motor - self.gap

    def move_motor(self, direction: int) -> float:
        """Turn the motor one step (+1 / -1); return the new carriage position in steps."""
        self.motor += direction
        self.gap = min(max(self.gap + direction, 0.0), self.width)
        return self.motor - self.gap
