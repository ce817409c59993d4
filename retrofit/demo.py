"""The lathe paper's demo ('CalcNextInput'): 100 points equally spaced on a circle of radius 15 mm."""

from __future__ import annotations

import math
from collections.abc import Iterator

from .machine.config import Machine


def circle_targets(machine: Machine, radius_mm: float = 15.0, points: int = 100) -> Iterator[tuple[int, ...]]:
    """Targets in steps: transversal = r*sin, longitudinal = r*cos, truncated to steps as 003 does.

    Points 0..points are visited in turn, so the tool goes once round and ends where it began.
    On a lathe the transversal axis is X and the longitudinal Z; on other machines the first two.
    """
    names = machine.axis_names
    if "X" in names and "Z" in names:
        across, along = names.index("X"), names.index("Z")
    else:
        across, along = 0, min(1, len(names) - 1)
    k_across = machine.axes[across].steps_per_mm       # KT
    k_along = machine.axes[along].steps_per_mm         # KL
    for n in range(points + 1):
        angle = n * 2 * math.pi / points
        target = [0] * len(names)
        target[across] = math.trunc(radius_mm * math.sin(angle) * k_across)
        target[along] = math.trunc(radius_mm * math.cos(angle) * k_along)
        yield tuple(target)
