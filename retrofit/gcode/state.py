"""The modal state of a G-code program: what one block leaves behind for the next.

Position, motion mode, plane, units, distance mode, feed, spindle and coolant.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from ..config import Machine

MM_PER_INCH = 25.4
#: positions and feeds are rounded to this many decimals of a mm (1 pm): float noise of G91 sums
#: and inch conversion disappears, far below any machine's step
DECIMALS = 9


def clean_mm(value: float) -> float:
    """``value`` rounded to :data:`DECIMALS`, with -0.0 made 0.0."""
    return round(value, DECIMALS) + 0.0


def default_plane(machine: Machine) -> int:
    """G18 (ZX) on a machine without a Y axis (a lathe), G17 (XY) otherwise."""
    return 17 if "Y" in machine.axis_names else 18


@dataclass
class ModalState:
    """Everything a block may leave behind for the next one."""

    position: dict[str, float]          # mm, every machine axis, in the machine's axis order
    plane: int                          # 17, 18 or 19
    feed_mm_min: float                  # programmed feed (F), or the machine's default
    motion: int | None = None           # 0, 1, 2, 3; None until the first motion code
    inch: bool = False                  # G20 (True) or G21
    incremental: bool = False           # G91 (True) or G90
    feed_sent: float | None = None      # the feed of the last PFDR emitted
    rpm: float = 0.0                    # S
    spindle: int = 0                    # +1 (M3), -1 (M4), 0 (M5)
    coolant: int = 0                    # 7, 8 or 0

    @classmethod
    def start(cls, machine: Machine, start_mm: Mapping[str, float] | None = None) -> "ModalState":
        """The state at the top of a program: G21 G90, the default plane, at ``start_mm``
        (axes not named there at 0 mm)."""
        position = {name: 0.0 for name in machine.axis_names}
        for name, value in (start_mm or {}).items():
            key = name.upper()
            if key not in position:
                raise ValueError(f"start_mm names axis {name!r}, which is not on machine "
                                 f"{machine.name} (axes: {', '.join(machine.axis_names)})")
            position[key] = clean_mm(float(value))
        return cls(position=position, plane=default_plane(machine),
                   feed_mm_min=machine.motion.default_feed_mm_min)

    def to_mm(self, value: float) -> float:
        """A length in program units (inch under G20) in mm."""
        return value * MM_PER_INCH if self.inch else value

    def target(self, axes: Mapping[str, float]) -> dict[str, float]:
        """The absolute end point (mm, every axis) of axis words in program units, under G90/G91."""
        end = dict(self.position)
        for name, value in axes.items():
            mm = self.to_mm(value)
            end[name] = clean_mm(end[name] + mm if self.incremental else mm)
        return end
