"""Cutter radius compensation geometry (G41/G42) in the active plane.

The programmed path is a chain of segments in plane coordinates (u, v): straight lines and
circular arcs. ``Compensator`` takes them one at a time and holds one back, as a corner can
only be joined once the next segment is known. It yields the tool-centre path:

- a line is shifted by the tool radius to the left (G41) or right (G42) of the travel direction;
- an arc keeps its centre and grows or shrinks its radius by the tool radius;
- a convex (outside) corner is rounded with an arc of the tool radius around the programmed corner;
- a concave (inside) corner ends both offset lines at their intersection; when that point lies
  behind the start of either segment the tool would gouge the part and the corner is refused;
- an arc on the inside whose radius is not larger than the tool radius is refused;
- the entry move (the first move after G41/G42) must be longer than the tool radius.

Segments are tuples: ``("line", start, end)`` or ``("arc", start, end, centre, ccw)`` with
points as (u, v) float pairs in mm.
"""
from __future__ import annotations

import math

from .errors import RuleError

EPS = 1e-9


class CutterError(RuleError):
    """The compensated path cannot be cut with this tool (the part would be gouged)."""


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1])


def _unit(d):
    n = math.hypot(*d)
    if n < EPS:
        raise CutterError("zero-length move with cutter compensation on; every move must have "
                          "a direction")
    return (d[0] / n, d[1] / n)


def _left(d):
    return (-d[1], d[0])


def directions(seg) -> tuple[tuple[float, float], tuple[float, float]]:
    """Unit travel directions of a segment at its start and at its end."""
    if seg[0] == "line":
        d = _unit(_sub(seg[2], seg[1]))
        return d, d
    _, start, end, centre, ccw = seg
    rs, re = _unit(_sub(start, centre)), _unit(_sub(end, centre))
    turn = _left if ccw else (lambda r: (r[1], -r[0]))
    return turn(rs), turn(re)


class Compensator:
    """Offsets a chain of segments by ``radius`` on ``side`` ("left" for G41, "right" for G42)."""

    def __init__(self, radius: float, side: str):
        if radius < 0:
            raise CutterError(f"tool radius {radius} is negative; the diameter must be >= 0")
        self.r = radius
        self.sign = 1.0 if side == "left" else -1.0
        self.pending = None          # the programmed segment held back
        self.start = None            # where the tool centre starts the held segment
        self.first = True

    def _normal(self, d):
        n = _left(d)
        return (self.sign * n[0], self.sign * n[1])

    def _shift(self, p, d):
        n = self._normal(d)
        return (p[0] + self.r * n[0], p[1] + self.r * n[1])

    def _offset_arc(self, seg):
        """Centre and tool-centre radius of an arc; refuses an inside arc tighter than the tool."""
        _, start, _, centre, ccw = seg
        radius = math.hypot(*_sub(start, centre))
        inside = (self.sign > 0) == ccw      # G41 on a CCW arc keeps the tool towards the centre
        new = radius - self.r if inside else radius + self.r
        if new <= EPS:
            raise CutterError(f"arc radius {radius:.4f} mm is not larger than the tool radius "
                              f"{self.r:.4f} mm on the inside of the arc; use a smaller tool")
        return centre, new

    def feed(self, seg) -> list:
        """Takes the next programmed segment; returns the compensated segments now known."""
        if self.first:
            self.first = False
            if seg[0] != "line":
                raise CutterError("the entry move after G41/G42 must be a straight line")
            length = math.hypot(*_sub(seg[2], seg[1]))
            if length <= self.r + EPS:
                raise CutterError(f"entry move of {length:.4f} mm is not longer than the tool "
                                  f"radius {self.r:.4f} mm")
            self.start = seg[1]
            self.pending = seg
            return []
        out = self._join(self.pending, seg)
        self.pending = seg
        return out

    def _end_of(self, seg):
        d = directions(seg)[1]
        if seg[0] == "line":
            return self._shift(seg[2], d)
        centre, radius = self._offset_arc(seg)
        return (centre[0] + radius * (seg[2][0] - centre[0]) / math.hypot(*_sub(seg[2], centre)),
                centre[1] + radius * (seg[2][1] - centre[1]) / math.hypot(*_sub(seg[2], centre)))

    def _emit(self, seg, start, end):
        if seg[0] == "line":
            return ("line", start, end)
        return ("arc", start, end, seg[3], seg[4])

    def _join(self, a, b) -> list:
        """Compensated form of ``a`` ending where it meets ``b``."""
        da, db = directions(a)[1], directions(b)[0]
        cross = da[0] * db[1] - da[1] * db[0]
        corner = a[2]
        end_a = self._end_of(a)
        start_b = self._shift(corner, db) if b[0] == "line" else self._start_arc(b)
        if abs(cross) < EPS and da[0] * db[0] + da[1] * db[1] > 0:
            out = [self._emit(a, self.start, end_a)]
            self.start = end_a
            return out
        convex = cross * self.sign < 0
        if convex:
            out = [self._emit(a, self.start, end_a),
                   ("arc", end_a, start_b, corner, self.sign < 0)]
            self.start = start_b
            return out
        if a[0] != "line" or b[0] != "line":
            raise CutterError("inside corner next to an arc with cutter compensation on; "
                              "round the corner with an arc at least the tool radius")
        p = self._intersect(end_a, da, start_b, db)
        # like LinuxCNC, a move is found too short when the corner at its end is joined
        if (p[0] - self.start[0]) * da[0] + (p[1] - self.start[1]) * da[1] < -EPS:
            raise CutterError("inside corner tighter than the tool: the cutter would gouge "
                              "the part; use a smaller tool or a longer move")
        out = [("line", self.start, p)]
        self.start = p
        return out

    def _start_arc(self, seg):
        centre, radius = self._offset_arc(seg)
        d = _unit(_sub(seg[1], centre))
        return (centre[0] + radius * d[0], centre[1] + radius * d[1])

    @staticmethod
    def _intersect(p, d, q, e):
        cross = d[0] * e[1] - d[1] * e[0]
        t = ((q[0] - p[0]) * e[1] - (q[1] - p[1]) * e[0]) / cross
        return (p[0] + t * d[0], p[1] + t * d[1])

    def finish(self) -> list:
        """Ends compensation (G40): the held segment ends offset at its programmed end."""
        if self.pending is None:
            return []
        end = self._end_of(self.pending)
        out = [self._emit(self.pending, self.start, end)]
        self.pending, self.start = None, end
        return out
