"""G2/G3 words: the plane's axes, the arc centre from I/J/K or R, and the rules an arc must meet.

Planes follow RS274NGC: G17 is XY, G18 is ZX (Z first, X second, so G2 is clockwise seen from
+Y), G19 is YZ. Counter-clockwise (G3) turns from the plane's first axis towards its second.
I, J and K are the centre's offsets from the start point along X, Y and Z, always incremental.
R is the radius: positive for the short way (at most half a turn), negative for the long way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..machine.config import Machine
from .errors import RuleError

#: plane G code -> (first axis, second axis, normal axis)
PLANES: dict[int, tuple[str, str, str]] = {17: ("X", "Y", "Z"), 18: ("Z", "X", "Y"), 19: ("Y", "Z", "X")}
#: the centre-offset word of each axis
OFFSET_LETTER = {"X": "I", "Y": "J", "Z": "K"}
#: LinuxCNC's rule for the end point of an I/J/K arc (measured against its ``rs274``): the radius
#: to the end may differ from the radius to the start by up to ``ABS`` (0.0282 mm under G21,
#: 0.0025 inch under G20), or by more when it is within ``REL`` (0.1 %) of the radius -- never by
#: more than 100 times ``ABS``
RADIUS_ABS_MM, RADIUS_ABS_INCH, RADIUS_REL = 0.0282, 0.0025 * 25.4, 0.001
#: an R arc may be this much (mm) too short to reach its end point and is then a half circle
R_REACH_MM = 0.00127


def plane_axes(machine: Machine, plane: int, mode: int) -> tuple[str, str]:
    """The (first, second) axis names of ``plane``; both must be on the machine."""
    first, second, _ = PLANES[plane]
    missing = [n for n in (first, second) if n not in machine.axis_names]
    if missing:
        raise RuleError(f"G{mode} in plane G{plane} needs axes {first} and {second}; machine "
                        f"{machine.name} has {', '.join(machine.axis_names)} (select G18 for ZX)")
    return first, second


def arc_center(mode: int, plane: int, start: tuple[float, float], end: tuple[float, float],
               words_mm: Mapping[str, float], texts: Mapping[str, str],
               inch: bool = False) -> tuple[float, float]:
    """Plane coordinates (first, second) of the centre of a G2/G3 from ``start`` to ``end``.

    ``words_mm`` holds the block's I/J/K/R values converted to mm, ``texts`` the words as
    written (for messages); ``inch``: G20 is in force (the tolerance of the end radius).
    """
    allowed_mm = RADIUS_ABS_INCH if inch else RADIUS_ABS_MM
    first, second, _ = PLANES[plane]
    in_plane = (OFFSET_LETTER[first], OFFSET_LETTER[second])
    offsets = [c for c in "IJK" if c in words_mm]
    for letter in offsets:
        if letter not in in_plane:
            raise RuleError(f"{texts[letter]} is not a centre offset in plane G{plane} "
                            f"(use {in_plane[0]} and {in_plane[1]})")
    if "R" in words_mm and offsets:
        raise RuleError(f"G{mode} with both R and {texts[offsets[0]]}: give the centre one way")
    if "R" in words_mm:
        return _center_from_radius(mode, start, end, words_mm["R"])
    if not offsets:
        raise RuleError(f"G{mode}: R, I, J and K words all missing for arc (plane G{plane} takes "
                        f"{in_plane[0]}/{in_plane[1]} or R)")
    center = (start[0] + words_mm.get(in_plane[0], 0.0), start[1] + words_mm.get(in_plane[1], 0.0))
    _check_radii(mode, start, end, center, allowed_mm)
    return center


def _check_radii(mode: int, start, end, center, allowed_mm: float) -> None:
    r0 = math.dist(start, center)
    r1 = math.dist(end, center)
    if r0 == 0.0 or r1 == 0.0:
        raise RuleError(f"G{mode} radius 0: the centre offsets put the centre on the "
                        f"{'start' if r0 == 0.0 else 'end'} point")
    err = abs(r1 - r0)
    if err > 100.0 * allowed_mm or (err / max(r0, r1) > RADIUS_REL and err > allowed_mm):
        raise RuleError(f"G{mode}: radius to end of arc differs from radius to start by "
                        f"{err:.4g} mm (start radius {r0:.4f}, end radius {r1:.4f}; allowed "
                        f"{allowed_mm:g} mm, or {RADIUS_REL:.1%} of the radius)")


def _center_from_radius(mode: int, start, end, radius: float):
    dx, dy = end[0] - start[0], end[1] - start[1]
    d = math.hypot(dx, dy)
    if d == 0.0:
        raise RuleError(f"G{mode} with R cannot make a full circle (end point = start point); "
                        "use I/J/K")
    if radius == 0.0:
        raise RuleError(f"G{mode} with R0: the radius must not be 0")
    r = abs(radius)
    h2 = r * r - (d / 2.0) ** 2
    if h2 < 0.0:
        if d / 2.0 - r > R_REACH_MM:
            raise RuleError(f"G{mode} radius {r:.3f} mm is too small for the {d:.3f} mm from "
                            f"start to end (needs |R| >= {d / 2.0:.3f} mm)")
        h2 = 0.0
    h = math.sqrt(h2)
    # short way: the centre lies left of start->end for G3 (counter-clockwise), right for G2
    side = 1.0 if mode == 3 else -1.0
    if radius < 0.0:
        side = -side
    nx, ny = -dy / d, dx / d
    return (start[0] + dx / 2.0 + side * h * nx, start[1] + dy / 2.0 + side * h * ny)

