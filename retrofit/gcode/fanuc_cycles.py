"""Fanuc lathe roughing cycles G71, G72 and G73 as paths: a finished profile in, the passes out.

Points are ``(x, z)`` in program units with X a *radius*; a profile is a list of segments
``(kind, start, end, centre)``, kind ``1`` (line), ``2`` or ``3`` (arc; centre ``(x, z)``). A path
is a list of moves ``(kind, end, centre)``, kind 0 (rapid), 1, 2 or 3.

* :func:`rough` -- G71 (cuts along Z, steps in X) and G72 (cuts along X, steps in Z): the
  profile is shifted by the finishing allowances (Fanuc shifts it, it does not offset it
  normally); type I (a monotonic profile): from the start point A each level is cut to the shifted
  profile, left by ``e`` at 45 degrees and returned to A's line; type II (pockets):
  :mod:`retrofit.gcode.fanuc_pockets`; then the tool goes to the shifted profile's first point,
  follows it, and returns to A. No move may enter the shifted profile (checked).
* :func:`pattern_repeat` -- G73: the profile is cut ``n`` times, shifted from ``relief +
  allowance`` down to ``allowance``, returning to A after each pass (out to A's X, then along Z).

Both work in a *normalised* frame where the depth axis falls toward the part and the cut runs
toward minus, so outside and inside (boring), toward and away from the chuck, are one case.
"""

from __future__ import annotations

import itertools
import math

from . import fanuc_pockets
from .errors import RuleError

EPS = 1e-9


def _frame(swap: bool, sd: float, sc: float):
    """To and from the normalised frame: (depth, cut) with depth falling toward the part."""
    def to(p):
        d, c = (p[1], p[0]) if swap else p
        return (sd * d, sc * c)

    def back(p):
        d, c = sd * p[0], sc * p[1]
        return (c, d) if swap else (d, c)
    flips = (swap + (sd < 0) + (sc < 0)) % 2 == 1
    return to, back, flips


def _map_profile(profile, to, flips):
    out = []
    for kind, a, b, centre in profile:
        k = kind if kind == 1 or not flips else 5 - kind
        out.append((k, to(a), to(b), None if centre is None else to(centre)))
    return out


def _map_path(path, back, flips):
    return [(k if k in (0, 1) or not flips else 5 - k, back(p), None if c is None else back(c))
            for k, p, c in path]


def _shift(profile, dd: float, dc: float):
    move = lambda p: None if p is None else (p[0] + dd, p[1] + dc)
    return [(k, move(a), move(b), move(c)) for k, a, b, c in profile]


def _check_monotonic(profile, what: str) -> None:
    """Depth never falls and the cut coordinate never rises along the profile (type I)."""
    for kind, a, b, c in profile:
        for p, q in zip(_samples(kind, a, b, c), _samples(kind, a, b, c)[1:]):
            if q[0] < p[0] - 1e-6 or q[1] > p[1] + 1e-6:
                raise RuleError(f"{what}: the profile is not monotonic (it turns back at "
                                f"X{2 * p[0]:g} Z{p[1]:g} in the cycle's frame); a type I cycle "
                                f"needs a profile that only climbs away from the axis and runs one "
                                f"way; for pockets start the profile with both X and Z (type II)")


def _samples(kind, a, b, c, n: int = 32):
    if kind == 1:
        return [a, b]
    r = math.dist(a, c)
    t0 = math.atan2(a[1] - c[1], a[0] - c[0])
    t1 = math.atan2(b[1] - c[1], b[0] - c[0])
    sweep = _sweep(kind, t0, t1)
    return [(c[0] + r * math.cos(t0 + sweep * i / n), c[1] + r * math.sin(t0 + sweep * i / n))
            for i in range(n + 1)]


def _sweep(kind, t0, t1) -> float:
    """Angle from t0 to t1 (in the (depth, cut) plane, angles from +depth toward +cut). In
    (x, z) axes G2 is clockwise seen with Z to the right and X up: angle decreasing in (x, z)."""
    d = t1 - t0
    if kind == 3:                   # G3 counter-clockwise in (z right, x up) = angle falls in (x,z)
        while d > EPS:
            d -= 2 * math.pi
        return d if abs(d) > EPS else -2 * math.pi
    while d < -EPS:
        d += 2 * math.pi
    return d if abs(d) > EPS else 2 * math.pi


def _crossing(profile, level: float):
    """The cut coordinate where the profile first reaches depth ``level`` (None: never)."""
    for kind, a, b, c in profile:
        lo, hi = min(a[0], b[0]), max(a[0], b[0])
        if kind == 1:
            if lo - EPS <= level <= hi + EPS and b[0] != a[0]:
                t = (level - a[0]) / (b[0] - a[0])
                return a[1] + t * (b[1] - a[1])
            continue
        pts = _samples(kind, a, b, c, 256)
        for p, q in itertools.pairwise(pts):
            if min(p[0], q[0]) - EPS <= level <= max(p[0], q[0]) + EPS and q[0] != p[0]:
                r = math.dist(a, c)
                h = math.sqrt(max(r * r - (level - c[0]) ** 2, 0.0))
                guess = p[1] + (level - p[0]) / (q[0] - p[0]) * (q[1] - p[1])
                return min((c[1] + h, c[1] - h), key=lambda z: abs(z - guess))
    return None


def rough(profile, start, depth: float, retract: float, allow_x: float, allow_z: float,
          along_z: bool, approach: int, retract_kind: int, what: str, type2: bool = False):
    """The path of G71 (``along_z``) or G72 from ``start`` for ``profile``; ``depth`` per level
    and ``retract`` (radius/Z units), ``allow_x`` (radius) and ``allow_z`` the allowances (signed
    as written), ``approach`` 0 or 1 the mode of the profile's first block; ``type2``: pockets
    allowed (:mod:`retrofit.gcode.fanuc_pockets`)."""
    if not depth > 0.0:
        raise RuleError(f"{what}: the depth of cut (first block U or W) must be > 0")
    if retract < 0.0:
        raise RuleError(f"{what}: the retract R must be >= 0")
    first, last = profile[0][1], profile[-1][2]
    swap = not along_z
    dpos = 1 if swap else 0
    cpos = 1 - dpos
    if abs(start[dpos] - first[dpos]) < EPS:
        raise RuleError(f"{what}: the start point and the profile's first point are at the same "
                        f"{'Z' if swap else 'X'}: nothing to rough")
    sd = 1.0 if start[dpos] > first[dpos] else -1.0          # outside (turning) or inside (boring)
    sc = 1.0 if last[cpos] <= first[cpos] else -1.0
    to, back, flips = _frame(swap, sd, sc)
    shifted = _shift(_map_profile(profile, to, flips), *to_allow(allow_x, allow_z, swap, sd, sc))
    a = to(start)
    bottom = shifted[0][1][0]
    if type2:
        lowest = min(p[0] for k, p0, p1, c in shifted for p in _samples(k, p0, p1, c))
        path = fanuc_pockets.rough_type2(shifted, a, lowest, depth, retract, approach,
                                         retract_kind, what)
    else:
        _check_monotonic(shifted, what)
        path = _levels(shifted, a, bottom, depth, retract, approach, retract_kind, what)
    path.append((approach, shifted[0][1], None))          # A' of the shifted profile
    path += [(kind, b, c) for kind, _, b, c in shifted]
    end = shifted[-1][2]
    path += [(0, (max(a[0], end[0]), end[1]), None), (0, a, None)]
    path = _drop_null(path, a)
    fanuc_pockets.check_clear(path, shifted, a, what)
    return _map_path(path, back, flips)


def _levels(shifted, a, bottom, depth, retract, approach, retract_kind, what):
    """Type I: each level from A's line to the profile, out at 45 degrees, back to A's line."""
    path, level = [], a[0] - depth
    while level > bottom + 1e-7:
        cut = _crossing(shifted, level)
        if cut is None:
            cut = shifted[-1][2][1]
        if cut < a[1] - 1e-7:
            path += [(approach, (level, a[1]), None), (1, (level, cut), None),
                     (retract_kind, (level + retract, cut + retract), None),
                     (0, (level + retract, a[1]), None)]
        level -= depth
        if len(path) > 40000:
            raise RuleError(f"{what}: more than 10000 levels; the depth of cut is too small")
    return path


def to_allow(allow_x: float, allow_z: float, swap: bool, sd: float, sc: float):
    """The allowances as a (depth, cut) shift in the normalised frame."""
    d, c = (allow_z, allow_x) if swap else (allow_x, allow_z)
    return sd * d, sc * c


def _drop_null(path, start):
    out, here = [], start
    for kind, p, c in path:
        if math.dist(p, here) > 1e-9 or kind in (2, 3):
            out.append((kind, p, c))
            here = p
    return out


def pattern_repeat(profile, start, relief_x: float, relief_z: float, passes: int,
                   allow_x: float, allow_z: float, approach: int, what: str):
    """G73: ``passes`` cuts of the profile, shifted from relief + allowance down to allowance."""
    if passes < 1 or passes != int(passes) or passes > 1000:
        raise RuleError(f"{what}: R, the number of passes, is a whole number from 1 to 1000")
    path: list[tuple[int, tuple[float, float], tuple[float, float] | None]] = []
    out = 1.0 if start[0] >= profile[0][1][0] else -1.0       # outside (turning) or boring
    for j in range(int(passes)):
        share = (passes - 1 - j) / (passes - 1) if passes > 1 else 0.0
        dx, dz = allow_x + relief_x * share, allow_z + relief_z * share
        moved = [(k, (a[0] + dx, a[1] + dz), (b[0] + dx, b[1] + dz),
                  None if c is None else (c[0] + dx, c[1] + dz)) for k, a, b, c in profile]
        path.append((approach, moved[0][1], None))
        path += [(k, b, c) for k, _, b, c in moved]
        end = moved[-1][2]
        path += [(0, (out * max(out * start[0], out * end[0]), end[1]), None), (0, start, None)]
    return _drop_null(path, start)
