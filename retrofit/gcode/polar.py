"""Polar coordinates: ``@`` radius and ``^`` angle (degrees) in place of X and Y, as LinuxCNC
reads them.

Both are measured from the origin of the program coordinates (the coordinate system, G92 and
tool offsets in force), in the XY plane (G17) only. Under G90, ``@r ^a`` is the point at radius r
and angle a; ``@`` alone keeps the current angle, ``^`` alone the current radius. Under G91,
``@`` adds to the current radius and ``^`` turns the current point about the origin; both need
a current point off the origin. A G91 canned cycle with L repeats turns (or steps out) again at
every hole: ``G91 G81 ^60 L6`` drills six holes around the origin.

A block with ``@`` or ``^`` is given X and Y words when it is run (:func:`mark`); the motion
replaces them with the polar point (:func:`resolve`) when it knows the modes of its block.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .errors import RuleError
from .state import clean_mm

if TYPE_CHECKING:
    from .translate import Translator

POLAR = ("@", "^")


def mark(tr: Translator, block) -> None:
    """Check a block with polar words against the state before it; give it X Y placeholders."""
    s = tr.state
    if not {"X", "Y"} <= set(tr.machine.axis_names):
        raise RuleError(f"polar coordinates (@ ^) need X and Y axes; machine {tr.machine.name} "
                        f"has {', '.join(tr.machine.axis_names)}")
    if s.plane != 17:
        raise RuleError(f"polar coordinates (@ ^) work in the G17 (XY) plane only, not "
                        f"G{s.plane}")
    for axis in "XY":
        if axis in block.axes:
            raise RuleError(f"cannot give both polar coordinates (@ ^) and an {axis} word")
    if block.g.get("non-modal") == 53:
        raise RuleError("G53: polar coordinates (@ ^) are measured in program coordinates; give "
                        "G53 machine X and Y")
    if block.g.get("non-modal") in (10, 28, 30, 92):
        raise RuleError(f"G{block.g['non-modal']:g}: polar coordinates (@ ^) can only be used "
                        f"for motion")
    if tr.comp.on or block.g.get("cutter radius", 40) != 40:
        raise RuleError("polar coordinates (@ ^) with cutter radius compensation are not "
                        "supported; give X and Y")
    block.polar = (block.values.pop("@", None), block.values.pop("^", None))
    block.axes["X"] = block.axes["Y"] = 0.0


def here(s) -> tuple[float, float]:
    """The current X Y in program coordinates and units."""
    unit = 25.4 if s.inch else 1.0
    return s.program_position("X") / unit, s.program_position("Y") / unit


def turn(x: float, y: float, radius_step, angle_step) -> tuple[float, float]:
    """(x, y) moved out by ``radius_step`` and turned by ``angle_step`` degrees about the origin
    (either None: no change); refused at the origin, where neither has a direction."""
    if x == 0.0 and y == 0.0:
        raise RuleError("G91 motion with polar coordinates is indeterminate at the origin "
                        "(X0 Y0 of the program coordinates)")
    radius, angle = math.hypot(x, y), math.atan2(y, x)
    if radius_step is not None:
        radius += radius_step
    if angle_step is not None:
        angle += math.radians(angle_step)
    return radius * math.cos(angle), radius * math.sin(angle)


def point(s, radius, angle) -> tuple[float, float]:
    """The absolute (G90) point of ``@radius ^angle`` (either None: the current one)."""
    x, y = here(s)
    if angle is None:
        if x == 0.0 and y == 0.0:
            raise RuleError("@ without ^ at the origin: give the angle ^ (the current point has "
                            "none)")
        angle = math.degrees(math.atan2(y, x))
    if radius is None:
        radius = math.hypot(x, y)
    return radius * math.cos(math.radians(angle)), radius * math.sin(math.radians(angle))


def resolve(tr: Translator, block) -> None:
    """Replace the X Y placeholders of a polar block with its point: absolute words under G90,
    steps from the current point under G91."""
    s = tr.state
    radius, angle = block.polar
    if not s.incremental:
        block.axes["X"], block.axes["Y"] = point(s, radius, angle)
        return
    x, y = here(s)
    nx, ny = turn(x, y, radius, angle)
    block.axes["X"], block.axes["Y"] = nx - x, ny - y


def turn_machine(s, xy: dict, steps: tuple) -> dict:
    """Machine X Y (mm) turned as :func:`turn` turns program coordinates (a G91 cycle's hole)."""
    unit = 25.4 if s.inch else 1.0
    ox, oy = s.offset("X"), s.offset("Y")
    radius_step, angle_step = steps
    nx, ny = turn((xy["X"] - ox) / unit, (xy["Y"] - oy) / unit, radius_step or None,
                  angle_step or None)
    return {"X": clean_mm(nx * unit + ox), "Y": clean_mm(ny * unit + oy)}
