"""G71/G72 type II: roughing a profile with pockets, and the check that no roughing move enters
the part.

Works in the normalised frame of :mod:`retrofit.gcode.fanuc_cycles` (depth falling toward the
part, the cut running toward minus), on the profile already shifted by the allowances. A type II
profile must run one way along the cut axis (Z for G71); its depth may rise and fall.

Each level is cut where the stock lies above the profile: the first span from the start point's
line, as type I; a pocket's span is entered by a rapid out to the start point's depth, along to
the pocket's near wall, a rapid down the cleared column to the level above, and a feed down to
the level; each span ends at the far wall, left by R at 45 degrees (less where the span is
shorter) and, for a pocket, by a rapid out. After the levels one pass follows the shifted
profile, then the tool returns to the start point as in type I.
"""

from __future__ import annotations

import itertools
import math

from .errors import RuleError

EPS = 1e-9


def depth_at(profile, c: float) -> float | None:
    """The lowest depth of the profile at cut coordinate ``c`` (None: outside its span)."""
    found = None
    for kind, a, b, centre in profile:
        lo, hi = min(a[1], b[1]), max(a[1], b[1])
        if not lo - EPS <= c <= hi + EPS:
            continue
        if kind == 1:
            d = min(a[0], b[0]) if hi - lo < EPS else a[0] + (c - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
            found = d if found is None else min(found, d)
            continue
        for d in _arc_depths(a, b, centre, kind, c):
            found = d if found is None else min(found, d)
    return found


def _arc_depths(a, b, centre, kind, c):
    r = math.dist(a, centre)
    h2 = r * r - (c - centre[1]) ** 2
    if h2 < -1e-9:
        return []
    h = math.sqrt(max(h2, 0.0))
    return [d for d in (centre[0] + h, centre[0] - h) if _on_arc(a, b, centre, kind, (d, c))]


def _on_arc(a, b, centre, kind, p) -> bool:
    t0 = math.atan2(a[1] - centre[1], a[0] - centre[0])
    t1 = math.atan2(b[1] - centre[1], b[0] - centre[0])
    tp = math.atan2(p[1] - centre[1], p[0] - centre[0])
    sign = -1.0 if kind == 3 else 1.0        # the orientation of fanuc_cycles._sweep
    span = (sign * (t1 - t0)) % (2 * math.pi) or 2 * math.pi
    at = (sign * (tp - t0)) % (2 * math.pi)
    return at <= span + 1e-9 or at >= 2 * math.pi - 1e-9


def _spans(profile, level: float, c_start: float):
    """(high c, low c) spans from ``c_start`` to the profile's end where the stock at ``level``
    lies above the profile."""
    c_end = profile[-1][2][1]
    cuts = {c_start, c_end} | {p[1] for seg in profile for p in (seg[1], seg[2])}
    for kind, a, b, centre in profile:
        if kind == 1 and abs(b[0] - a[0]) > EPS:
            t = (level - a[0]) / (b[0] - a[0])
            if -EPS <= t <= 1 + EPS:
                cuts.add(a[1] + t * (b[1] - a[1]))
        elif kind == 1:
            cuts.add(a[1])
        elif kind in (2, 3):
            h2 = math.dist(a, centre) ** 2 - (level - centre[0]) ** 2
            for c in (centre[1] + math.sqrt(max(h2, 0)), centre[1] - math.sqrt(max(h2, 0))):
                if h2 >= 0 and _on_arc(a, b, centre, kind, (level, c)):
                    cuts.add(c)
    edges = sorted((c for c in cuts if c_end - EPS <= c <= c_start + EPS), reverse=True)
    spans: list[tuple[float, float]] = []
    for hi, lo in itertools.pairwise(edges):
        if hi - lo < 1e-7:
            continue
        d = depth_at(profile, (hi + lo) / 2)
        if d is None or d < level - 1e-9:
            if spans and abs(spans[-1][1] - hi) < 1e-7:
                spans[-1] = (spans[-1][0], lo)
            else:
                spans.append((hi, lo))
    return spans


def rough_type2(shifted, a, bottom: float, depth: float, retract: float, approach: int,
                retract_kind: int, what: str):
    """The levels (normalised frame) of a type II roughing from ``a`` down to ``bottom``."""
    for _, p, q, _ in shifted:
        if q[1] > p[1] + 1e-6:
            raise RuleError(f"{what}: a type II profile must run one way along the cut axis (it "
                            f"turns back near {q[1]:g})")
    path, level, above = [], a[0] - depth, a[0]
    here = a

    def go(kind, d, c):
        nonlocal here
        path.append((kind, (d, c), None))
        here = (d, c)

    def over(c):                      # out to the start depth, along it, to column c
        if abs(here[1] - c) > 1e-7:
            go(0, a[0], here[1])
            go(0, a[0], c)
    while level > bottom + 1e-7:
        for hi, lo in _spans(shifted, level, a[1]):
            back = min(retract, (hi - lo) / 2, depth)
            first = abs(hi - a[1]) < 1e-7
            over(hi)
            if first:
                go(approach, level, hi)
            else:
                go(0, above, hi)
                go(1, level, hi)
            go(1, level, lo)
            go(retract_kind, level + back, lo + back)
            go(0, level + back if first else a[0], lo + back if not first else a[1])
        above, level = level, level - depth
        if len(path) > 100_000:
            raise RuleError(f"{what}: too many roughing moves; the depth of cut is too small")
    over(a[1])
    return path


def check_clear(path, shifted, start, what: str) -> None:
    """No straight move of a roughing path goes below the shifted profile (into the part)."""
    here = start
    c_hi, c_lo = shifted[0][1][1], shifted[-1][2][1]       # the part's ends: touching them is not
    for kind, p, _ in path:                                  # entering
        if kind in (0, 1):
            for i in range(1, 33):
                q = (here[0] + (p[0] - here[0]) * i / 32, here[1] + (p[1] - here[1]) * i / 32)
                if not c_lo + 1e-7 < q[1] < c_hi - 1e-7:
                    continue
                d = depth_at(shifted, q[1])
                if d is not None and q[0] < d - 1e-6:
                    raise RuleError(f"{what}: a roughing move would cut into the part (depth "
                                    f"{q[0]:.4f} below the profile's {d:.4f}); the profile and "
                                    f"start point do not fit this cycle")
        here = p
