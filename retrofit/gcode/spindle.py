"""G95 feed per revolution and G96/G97 constant surface speed, on machines with a spindle encoder
(``[spindle]`` in the machine file: the lathes).

* ``G95``: F is a feed per revolution (mm/rev, inch/rev under G20). The spindle's encoder holds
  its speed to the commanded rpm within ``speed_tolerance``, so each feed move runs at
  ``F x rpm`` mm/min (a PFDR); the feed is re-sent whenever the rpm changes.
* ``G96 S<v> D<max rpm>``: S is a surface speed (m/min, ft/min under G20) and the spindle speed
  follows the tool's distance from the work's axis (program X0; X is a radius in the state):
  ``rpm = 1000 v / (pi d)`` with ``d = 2 |X|`` the diameter, capped at D (or the spindle's
  ``max_rpm``). A feed move that changes X is cut into pieces along which the speed changes by
  at most :data:`RPM_STEP`; each piece runs at the rpm of its middle. A rapid sets the speed of
  its end point before it starts.
* ``G97``: S is rpm again; the spindle keeps the speed it last had unless S is given.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..canon import Spindle, StraightFeed
from .errors import RuleError
from .state import clean_mm

if TYPE_CHECKING:
    from ..controller.settings import SpindleSettings
    from .translate import Translator

#: most a G96 piece changes the spindle speed (a ratio)
RPM_STEP = 1.05
#: most pieces one move under G96 becomes
MAX_PIECES = 1000
FT_PER_M = 1.0 / 0.3048


def needs_encoder(tr: Translator, code: str) -> SpindleSettings:
    spindle = tr.machine.parts.get("spindle")
    if spindle is None:
        raise RuleError(f"{code} needs a spindle encoder ([spindle] in the machine file); machine "
                        f"{tr.machine.name} has none (G94 feeds per minute, G97 S<rpm> sets the "
                        f"speed)")
    return spindle


def set_feed_mode(tr: Translator, code) -> None:
    """G93, G94, G95."""
    s = tr.state
    if code == 95:
        needs_encoder(tr, "G95")
    s.inverse_time, s.per_rev = code == 93, code == 95


def set_speed_mode(tr: Translator, block) -> None:
    """G96 (with S the surface speed, D the rpm ceiling) or G97; runs before the S word acts."""
    s = tr.state
    if block.g["spindle speed mode"] == 97:
        s.css = None
        return
    spindle = needs_encoder(tr, "G96")
    if "X" not in tr.machine.axis_names:
        raise RuleError("G96: the spindle speed follows X; the machine has no X axis")
    if "S" not in block.values:
        raise RuleError("G96 needs S, the surface speed (m/min; ft/min under G20), e.g. G96 S150 D2000")
    top = block.values.get("D", spindle.max_rpm)
    if not 0.0 < top <= spindle.max_rpm:
        raise RuleError(f"{block.texts.get('D', 'D')}: G96's D caps the spindle speed: above 0 and "
                        f"at most the spindle's max_rpm {spindle.max_rpm:g}")
    surface = block.values["S"] / (FT_PER_M if s.inch else 1.0)          # m/min
    if not surface > 0.0:
        raise RuleError(f"{block.texts['S']}: G96's surface speed must be > 0")
    s.css = (surface, top)


def surface_word(tr: Translator, block) -> None:
    """S under G96: a new surface speed; the spindle speed follows at once."""
    s = tr.state
    if "spindle speed mode" not in block.g:
        surface = block.values["S"] / (FT_PER_M if s.inch else 1.0)
        if not surface > 0.0:
            raise RuleError(f"{block.texts['S']}: G96's surface speed must be > 0")
        if s.css is None:                         # called under G96 only
            raise RuleError(f"{block.texts['S']}: no G96 surface speed in force")
        s.css = (surface, s.css[1])
    s.rpm = round(css_rpm(s.css, s.position["X"] - s.offset("X")), 3)


def css_rpm(css, radius_mm: float) -> float:
    """The spindle speed of surface speed ``css[0]`` m/min at ``radius_mm``, capped at ``css[1]``."""
    surface, top = css
    diameter = 2.0 * abs(radius_mm)
    if diameter == 0.0:
        return top
    return min(top, 1000.0 * surface / (math.pi * diameter))


def follow(tr: Translator, x_mm: float) -> None:
    """Under G96, a SPIN to the rpm where the tool is at machine X ``x_mm`` (its radius is
    measured from program X0, the work's axis), when it differs from the spindle's."""
    s = tr.state
    rpm = round(css_rpm(s.css, x_mm - s.offset("X")), 3)
    if s.spindle and rpm != s.rpm:
        tr.emit(Spindle(rpm, s.spindle))
    s.rpm = rpm


def css_breaks(x0: float, x1: float, css) -> list[float]:
    """Fractions (0..1] of a move from radius ``x0`` to ``x1`` (mm, signed) where its G96 pieces
    end: radii in geometric steps of at most RPM_STEP, one piece where the speed is capped."""
    surface, top = css
    capped = 1000.0 * surface / (math.pi * 2.0 * top)      # below this radius: ``top`` rpm
    parts = [(0.0, 1.0)]
    if x0 * x1 < 0.0:                                      # across the axis
        zero = x0 / (x0 - x1)
        parts = [(0.0, zero), (zero, 1.0)]
    ends = []
    for ta, tb in parts:
        ra, rb = abs(x0 + (x1 - x0) * ta), abs(x0 + (x1 - x0) * tb)
        ca, cb = max(ra, capped), max(rb, capped)
        n = math.ceil(abs(math.log(ca / cb)) / math.log(RPM_STEP) - 1e-9) if ca != cb else 0
        for k in range(1, n + 1):
            r = ca * (cb / ca) ** (k / n)
            ends.append(ta + (tb - ta) * (r - ra) / (rb - ra))
        ends.append(tb)
    ends = sorted({min(max(t, 0.0), 1.0) for t in ends} - {0.0})
    if len(ends) > MAX_PIECES:
        raise RuleError(f"G96: this move would be cut into {len(ends)} speed steps; at most "
                        f"{MAX_PIECES}")
    return ends


def css_line(tr: Translator, end: dict, mode) -> None:
    """A feed move under G96: pieces along which the rpm changes by at most RPM_STEP, each run
    at the rpm of its middle."""
    s = tr.state
    start = dict(s.position)
    off = s.offset("X")
    x0, x1 = start["X"] - off, end["X"] - off
    before = 0.0
    for t in css_breaks(x0, x1, s.css):
        point = end if t == 1.0 else {n: clean_mm(start[n] + (end[n] - start[n]) * t) for n in start}
        follow(tr, start["X"] + (end["X"] - start["X"]) * (before + t) / 2.0)
        tr.send_feed(math.dist(s.position.values(), point.values()), mode)
        tr.emit(StraightFeed(tr.position_of(point)))
        s.position, before = point, t


def per_rev_feed(tr: Translator, mode) -> float:
    """The feed (mm/min) of a move under G95: F mm/rev x the spindle's rpm."""
    s = tr.state
    if not (s.spindle and s.rpm > 0.0):
        raise RuleError(f"G{mode:g} under G95 with the spindle stopped: a feed per revolution "
                        f"needs the spindle turning (M3 or M4 with S > 0 first)")
    return clean_mm(s.feed_mm_min * s.rpm)
