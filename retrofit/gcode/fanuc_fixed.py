"""Fanuc lathe single cycles as paths: G90/G94 turning and facing, G92 and G76 threading, G74/G75
peck cycles.

Points are ``(x, z)`` in program units with X a radius; a path is a list of moves ``(kind, end,
extra)``: kind 0 (rapid) or 1 (feed), or 33 (a spindle-synchronised move, ``extra`` the lead
along Z per revolution). Every cycle starts and ends at its start point A.

* G90 ``X Z [R] F``: rapid to X (plus the taper R at A's Z), feed to Z, feed out to A's X, rapid
  back. G94 is the same with the axes' roles swapped (facing; R is a Z taper).
* G92 ``X Z [R] F``: as G90, the cut a thread of lead F, the way out and back rapids.
* G76 (two blocks): passes ``dd sqrt(n)`` deep (at least ``dmin`` more each time) until ``k - d``,
  then the finishing depth ``k`` m times. Each pass starts from A's X, moves in at rapid, cuts
  the thread, rapids out at the end and back along A's X. The infeed follows the flank at half
  the thread angle ``a``: a pass ``depth`` below the crest starts ``depth tan(a/2)`` on from A's Z
  and ends ``(k - depth) tan(a/2)`` short of the end -- the deepest pass ends at the end, as
  LinuxCNC's G76 Q places its passes (docs/fanuc.md: the way out differs). A chamfer
  ``rr`` (tenths of the lead) pulls each pass out at 45 degrees over its last ``rr L / 10``.
* G74 (face pecking, along Z) and G75 (grooving, along X): ``P`` shifts across, ``Q`` pecks,
  the first block's ``R`` the return after each peck; the second block's ``R`` a relief at the
  bottom.
"""

from __future__ import annotations

import math

from .errors import RuleError

#: most passes or pecks a cycle may make
MAX_MOVES = 100_000


def turning(start, x: float, z: float, taper: float, facing: bool):
    """G90 (``facing`` False) or G94 from A = ``start`` to the corner (x, z), radius units."""
    x0, z0 = start
    if facing:
        return [(0, (x0, z + taper), None), (1, (x, z), None), (1, (x, z0), None), (0, start, None)]
    return [(0, (x + taper, z0), None), (1, (x, z), None), (1, (x0, z), None), (0, start, None)]


def thread_single(start, x: float, z: float, taper: float, lead: float):
    """G92: one threading pass to (x, z) with lead ``lead`` along Z."""
    x0, z0 = start
    return [(0, (x + taper, z0), None), (33, (x, z), lead), (0, (x0, z), None), (0, start, None)]


def thread_depths(first: float, full: float, minimum: float, allowance: float,
                  finishing: int) -> list[float]:
    """G76's pass depths: ``first sqrt(n)``, each at least ``minimum`` deeper than the last, up
    to ``full - allowance``; then ``full`` ``finishing`` times.

    >>> [round(d, 3) for d in thread_depths(0.3, 0.9, 0.1, 0.0, 2)]
    [0.3, 0.424, 0.524, 0.624, 0.724, 0.824, 0.9, 0.9]
    """
    if not first > 0.0 or not full > 0.0:
        raise RuleError("G76: the thread height P and the first depth Q must be > 0")
    if finishing < 1 or finishing > 99:
        raise RuleError("G76: m (the first two digits of the first block's P) counts the finishing "
                        "passes, 01 to 99")
    depths, n, last, rough_to = [], 1, 0.0, full - allowance
    while True:
        depth = max(first * math.sqrt(n), last + minimum)
        if depth >= rough_to - 1e-9:
            break
        depths.append(depth)
        last, n = depth, n + 1
        if n > MAX_MOVES:
            raise RuleError("G76: too many passes; raise Q (first depth) or the minimum depth")
    if allowance > 0.0 and rough_to > 0.0:
        depths.append(rough_to)
    return depths + [full] * finishing


def thread_cycle(start, x_root: float, z_end: float, taper: float, height: float, depths,
                 angle_deg: float, lead: float, chamfer: float = 0.0):
    """G76's passes from A = ``start``; ``x_root`` the radius at full depth at the end, ``taper``
    the radius at the start minus at the end, ``height`` the thread height (radius); ``chamfer``
    the length along Z over which each pass pulls out at 45 degrees before the end."""
    x0, z0 = start
    outward = 1.0 if x0 > x_root else -1.0             # outside thread: the crest is above the root
    toward = 1.0 if z_end > z0 else -1.0
    slope = math.tan(math.radians(angle_deg / 2.0))
    if chamfer and not 0.0 < chamfer < abs(z_end - z0):
        raise RuleError(f"G76: the thread chamfer ({chamfer:g}) must be shorter than the thread")
    path: list[tuple[int, tuple[float, float], float | None]] = []
    for depth in depths:
        shift, z_in = (depth - height) * slope * toward, z0 + depth * slope * toward
        x_end = x_root + outward * (height - depth)
        path += [(0, (x0, z_in), None), (0, (x_end + taper, z_in), None)]
        if chamfer:
            share = chamfer / abs(z_end - z0)
            x_at = x_end + taper * share
            if outward * (x0 - x_at) < chamfer:
                raise RuleError(f"G76: the chamfer's pull-out ({chamfer:g}) would pass the start "
                                f"point's X; start further out")
            path += [(33, (x_at, z_end + shift - toward * chamfer), lead),
                     (33, (x_at + outward * chamfer, z_end + shift), lead)]
        else:
            path.append((33, (x_end, z_end + shift), lead))
        path.append((0, (x0, z_end + shift), None))
    path.append((0, start, None))
    return path


def pecking(start, x: float, z: float, shift: float, peck: float, back: float, relief: float,
            along_z: bool):
    """G74 (``along_z``) or G75: pecks of ``peck`` toward (x, z), ``back`` after each, rows
    ``shift`` apart across, ``relief`` at the bottom of each row."""
    a = start if along_z else (start[1], start[0])
    end = (x, z) if along_z else (z, x)
    d0, c0 = a                       # across (the shifted axis), along (the pecked axis)
    across, along = end
    code, peck_word, shift_word = ("G74", "Q", "P") if along_z else ("G75", "P", "Q")
    if along != c0 and not peck > 0.0:
        raise RuleError(f"{code}: {peck_word} (the peck depth) must be > 0")
    if across != d0 and not shift > 0.0:
        raise RuleError(f"{code}: {shift_word} (the shift between rows) must be > 0")
    rows = [d0] if across == d0 else _steps(d0, across, shift)
    into = 1.0 if along >= c0 else -1.0
    side = 1.0 if across >= d0 else -1.0
    path = []
    for row in rows:
        path.append((0, (row, c0), None))
        pecks = _steps(c0, along, peck)[1:] if along != c0 else []
        for k, level in enumerate(pecks):
            path.append((1, (row, level), None))
            if k < len(pecks) - 1:
                path.append((0, (row, level - into * back), None))
        if relief:
            path.append((0, (row - side * relief, along), None))
        path.append((0, (row - side * relief, c0), None))
        if len(path) > MAX_MOVES:
            raise RuleError("G74/G75: too many pecks; raise P or Q")
    path.append((0, a, None))
    if not along_z:
        path = [(k, (p[1], p[0]), e) for k, p, e in path]
    return [m for i, m in enumerate(path) if i == 0 or m[1] != path[i - 1][1]]


def _steps(first: float, last: float, step: float) -> list[float]:
    """``first``, then every ``step`` toward ``last``, ending on ``last``."""
    count = math.ceil(abs(last - first) / step - 1e-9)
    if count > MAX_MOVES:
        raise RuleError("G74/G75: too many pecks; raise P or Q")
    sign = 1.0 if last >= first else -1.0
    return [first + sign * step * i for i in range(count)] + [last]
