"""G5, G5.1, G5.2/G5.3: splines in the XY plane (G17), cut into chords within the machine's
arc tolerance, as LinuxCNC reads them.

* ``G5 X- Y- I- J- P- Q-``: a cubic Bezier from the current point to X Y; I J is the first
  control point relative to the start, P Q the second relative to the end. Without I J, the
  curve leaves in the direction the previous G5 arrived (I J = minus the last P Q, 0 0 at first).
* ``G5.1 X- Y- I- J-``: a quadratic Bezier, I J its control point relative to the start.
* ``G5.2 X- Y- P- <L->`` then lines ``X- Y- P-`` and ``G5.3``: a NURBS through control points
  X Y of weight P (the first point is where the tool stands, weight 1, or P of a first block
  without X Y); L its order (3, a quadratic, unless L is more than 3); knots uniform and clamped
  as LinuxCNC makes them. The curve is cut at G5.3.

G5 and G5.1 leave the motion mode as it was (a bare ``X3`` after them moves as before them);
G5.3 leaves none (as G80). I J P Q are distances in program units, never G90/G91 dependent.
Every chord point lies on the curve; the curve strays at most the machine's arc tolerance from
its chords.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..canon import StraightFeed
from .errors import RuleError
from .state import clean_mm
from .threading import leave
from .validate import MAX_CHORDS, check_soft_limits

if TYPE_CHECKING:
    from .translate import Translator

#: motion codes of this module; G5 and G5.1 keep the motion mode in force
MODES = (5, 5.1, 5.2)
KEEP_MODE = (5, 5.1)
#: the highest NURBS order (L) accepted
MAX_ORDER = 16
#: the most control points one G5.2 ... G5.3 may collect
MAX_POINTS = 10000
#: a chord is accepted when the curve strays from it by at most this share of the tolerance
_MARGIN = 0.9
#: pieces each Bezier or knot span is cut into before the tolerance test
_FIRST_PIECES = 4


def run(tr: Translator, block, mode) -> None:
    """One block in motion mode G5, G5.1 or G5.2."""
    s = tr.state
    if s.plane != 17 or not {"X", "Y"} <= set(tr.machine.axis_names):
        raise RuleError(f"G{mode:g}: splines are in the XY plane (G17) of a machine with X and Y")
    moving = [n for n in block.axes if n not in "XY"]
    if moving:
        raise RuleError(f"G{mode:g}: {block.texts[moving[0]]}: splines move X and Y only")
    if mode == 5.2:
        _nurbs_point(tr, block)
        return
    if s.nurbs is not None:
        raise RuleError(f"G{mode:g} inside a G5.2 NURBS: end the NURBS with G5.3 first")
    if not block.axes:
        raise RuleError(f"G{mode:g}: all axes missing with a motion code (give X and/or Y)")
    v, mm = block.values, s.to_mm
    start = (s.position["X"], s.position["Y"])
    end_all = s.target(block.axes)
    end = (end_all["X"], end_all["Y"])
    if mode == 5.1:
        if "I" not in v or "J" not in v:
            raise RuleError("G5.1 needs both I and J (its control point from the start)")
        control = [start, (start[0] + mm(v["I"]), start[1] + mm(v["J"])), end]
    else:
        if ("I" in v) != ("J" in v):
            raise RuleError("G5 needs both I and J, or neither (then it leaves in the direction "
                            "the previous G5 arrived)")
        if "P" not in v or "Q" not in v:
            raise RuleError("G5 needs both P and Q (its second control point from the end)")
        i, j = (mm(v["I"]), mm(v["J"])) if "I" in v else s.spline_ij
        p, q = mm(v["P"]), mm(v["Q"])
        control = [start, (start[0] + i, start[1] + j), (end[0] + p, end[1] + q), end]
        s.spline_ij = (-p, -q)
    points = [tuple(c) for c in control]
    _cut(tr, mode, lambda u: _bezier(points, u), [0.0, 1.0], end_all)


def _nurbs_point(tr: Translator, block) -> None:
    s, v = tr.state, block.values
    if s.inverse_time:
        raise RuleError("G5.2 under G93 inverse time is not supported (use G94)")
    has_xy = "X" in block.axes or "Y" in block.axes
    if has_xy and not ("X" in block.axes and "Y" in block.axes):
        raise RuleError("G5.2: give both X and Y of every control point")
    if s.nurbs is None:
        first = v["P"] if not has_xy and v.get("P", 0.0) > 0.0 else 1.0
        s.nurbs = {"points": [(s.position["X"], s.position["Y"], first)], "order": 3}
    elif not has_xy and "P" in v:
        raise RuleError(f"{block.texts['P']}: P without X and Y is for the first control point "
                        f"only")
    if "L" in v:
        order = v["L"]
        if order != int(order) or order > MAX_ORDER:
            raise RuleError(f"{block.texts['L']}: the order L of a NURBS is a whole number up to "
                            f"{MAX_ORDER} (3, a quadratic, when L is 3 or less)")
        if order > 3:
            s.nurbs["order"] = int(order)
    if has_xy:
        if not v.get("P", 0.0) > 0.0:
            raise RuleError(f"G5.2: every control point needs a weight P > 0 "
                            f"({block.texts.get('P', 'no P given')})")
        if len(s.nurbs["points"]) >= MAX_POINTS:
            raise RuleError(f"G5.2: more than {MAX_POINTS} control points; end with G5.3 sooner")
        end = s.target({a: block.axes[a] for a in "XY"})
        s.nurbs["points"].append((end["X"], end["Y"], v["P"]))


def finish(tr: Translator, block) -> None:
    """G5.3: cut the NURBS collected since G5.2."""
    s = tr.state
    if s.motion != 5.2 or s.nurbs is None:
        raise RuleError("G5.3 without G5.2 first (G5.3 ends a NURBS that G5.2 began)")
    points, order = s.nurbs["points"], s.nurbs["order"]
    if len(points) < order:
        raise RuleError(f"G5.3: the NURBS has {len(points)} control points; its order L = {order} "
                        f"needs at least as many")
    s.nurbs = None
    s.motion = None
    knots = knot_vector(len(points), order)
    end = {**s.position, "X": clean_mm(points[-1][0]), "Y": clean_mm(points[-1][1])}
    spans = sorted(set(knots))
    _cut(tr, 5.2, lambda u: nurbs_point(points, order, knots, u), spans, end)


def knot_vector(count: int, order: int) -> list[float]:
    """LinuxCNC's clamped uniform knots for ``count`` control points of ``order``: ``order``
    zeros, then 1, 2, ..., then ``order`` times the last."""
    inner = count - order
    return [0.0] * order + [float(i) for i in range(1, inner + 1)] + [float(inner + 1)] * order


def nurbs_point(points, order: int, knots, u: float) -> tuple[float, float]:
    """The NURBS through weighted ``points`` ((x, y, w), ...) at ``u`` (de Boor's algorithm in
    homogeneous coordinates)."""
    degree = order - 1
    span = min(max(k for k in range(degree, len(points)) if knots[k] <= u), len(points) - 1)
    d = [[x * w, y * w, w] for x, y, w in points[span - degree:span + 1]]
    for r in range(1, degree + 1):
        for j in range(degree, r - 1, -1):
            i = j + span - degree
            den = knots[i + degree + 1 - r] - knots[i]
            a = (u - knots[i]) / den if den else 0.0
            d[j] = [(1.0 - a) * p + a * q for p, q in zip(d[j - 1], d[j])]
    x, y, w = d[degree]
    return x / w, y / w


def _bezier(points, u: float) -> tuple[float, float]:
    """de Casteljau: the Bezier of ``points`` at ``u`` in 0..1."""
    pts = list(points)
    while len(pts) > 1:
        pts = [((1 - u) * a[0] + u * b[0], (1 - u) * a[1] + u * b[1]) for a, b in zip(pts, pts[1:])]
    return pts[0]


def chord_parameters(curve, breaks, tolerance: float) -> list[float]:
    """Parameters of the chord ends of ``curve`` over ``breaks`` (its knots): every piece is
    split until the curve at 1/4, 1/2 and 3/4 of it lies within ``tolerance`` of its chord."""
    params = [breaks[0]]
    for lo, hi in zip(breaks, breaks[1:]):
        stack = [lo + (hi - lo) * k / _FIRST_PIECES for k in range(_FIRST_PIECES, 0, -1)]
        a = lo
        while stack:
            b = stack[-1]
            if b - a > 1e-9 * (hi - lo + 1.0) and _strays(curve, a, b) > tolerance * _MARGIN:
                stack.append((a + b) / 2.0)
                continue
            params.append(b)
            a = stack.pop()
            if len(params) > MAX_CHORDS:
                raise RuleError(f"the spline would be more than {MAX_CHORDS} chords at the "
                                f"machine's tolerance; split it")
    return params


def _strays(curve, a: float, b: float) -> float:
    p, q = curve(a), curve(b)
    return max(_off_chord(curve(a + (b - a) * f), p, q) for f in (0.25, 0.5, 0.75))


def _off_chord(m, p, q) -> float:
    dx, dy = q[0] - p[0], q[1] - p[1]
    length2 = dx * dx + dy * dy
    t = 0.0 if not length2 else max(0.0, min(1.0, ((m[0] - p[0]) * dx + (m[1] - p[1]) * dy) / length2))
    return math.hypot(m[0] - p[0] - t * dx, m[1] - p[1] - t * dy)


def _cut(tr: Translator, mode, curve, breaks, end: dict) -> None:
    s = tr.state
    leave(tr)
    params = chord_parameters(curve, breaks, tr.machine.motion.arc_tolerance_mm)
    path = [curve(u) for u in params[1:-1]] + [(end["X"], end["Y"])]
    length, here = 0.0, (s.position["X"], s.position["Y"])
    for p in path:
        length += math.dist(here, p)
        here = p
    chords = [{**s.position, "X": clean_mm(x), "Y": clean_mm(y)} for x, y in path]
    for c in chords:
        check_soft_limits(tr.machine, c, f" on the G{mode:g} spline")
    tr.send_feed(length, mode)
    for c in chords:
        tr.emit(StraightFeed(tr.position_of(c)))
    s.position = chords[-1]
