"""Cutter radius compensation (G41/G42) in the plane: the tool-centre path, as LinuxCNC makes it.

The geometry works in plane coordinates ``(u, v)``: X and Y under G17, Z and X under G18 (the
plane's first and second axis, so "left" is left of the travel seen from the plane's normal).

Each programmed move is offset by the tool radius as soon as it is read, to the left (G41) or the
right (G42) of its own direction at its end, and **held back**: only the next move tells how the
two meet.

- **Entry** (the first move after G41/G42): a straight move runs from where the tool is to the
  point one radius beside its programmed end, square to the move's direction; it must be longer
  than the radius. An entry arc keeps its end point one radius off the programmed arc and is bent
  to pass through the tool's start.
- **Convex (outside) corner**: the held move keeps its end, and an arc of the tool radius around
  the programmed corner joins it to the next move (a rapid gets a straight move instead).
- **Concave (inside) corner**: the held move's end is pulled back to where the tool touches both
  moves (for a line, the intersection of the offset lines; next to an arc, the point where the
  tool meets the offset arc). When pulling back would reverse the held move, or the tool cannot
  touch both, the cutter would gouge the part and the corner is refused.
- **Nearly straight on** (within :data:`SMALL` radians): no arc; the next move starts where the
  held one ends.
- A move with no motion in the plane (a plunge) waits behind the held move and is given the same
  end point in the plane.
- **G40** (and M0, M1, M2, M30, M60): the held moves go out as they are; after G40 the tool goes
  straight from there to the next programmed point (an arc is refused there).

The held moves and anything meant to run between them (feed, spindle, coolant, dwell) wait in a
queue of :class:`Held` items; :class:`Compensator` returns them, in order, once they are final.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import RuleError

#: angle (rad) under which a corner counts as straight on (LinuxCNC's concave-corner tolerance)
SMALL = 0.05
#: cosine under which the entry arc cannot be bent through the tool's start point
TOLERANCE_EQUAL = 1e-4
#: an arc's end may be pulled back past its programmed sweep by this much (rad; mm / inch units)
SWEEP_SLACK = {False: 0.0254, True: 0.001}
HALF_PI = math.pi / 2


class CutterError(RuleError):
    """The compensated path cannot be cut with this tool (the part would be gouged)."""


@dataclass
class Held:
    """One queued item: a move (``kind`` "feed", "rapid", "arc") or anything else ("other").

    ``end`` is the tool-centre end point in the plane; ``direction`` the programmed direction
    (lines, for the reversal check); arcs carry ``centre``, ``turn`` (counter-clockwise turns,
    negative clockwise) and ``sweep`` (the programmed sweep, rad, 0 for a corner arc). ``corner``
    marks a move added to round a corner; ``payload`` is the caller's (axes off the plane,
    source line, the command itself for "other").
    """

    kind: str
    end: tuple[float, float] = (0.0, 0.0)
    direction: tuple[float, float] = (0.0, 0.0)
    centre: tuple[float, float] = (0.0, 0.0)
    turn: int = 0
    sweep: float = 0.0
    corner: bool = False
    payload: object = field(default=None, repr=False)


def find_turn(start, centre, turn: int, end) -> float:
    """Signed sweep (rad, counter-clockwise positive) of ``turn`` turns from ``start`` to ``end``."""
    if turn == 0:
        return 0.0
    a = math.atan2(start[1] - centre[1], start[0] - centre[0])
    b = math.atan2(end[1] - centre[1], end[0] - centre[0])
    if turn > 0:
        if b <= a:
            b += 2 * math.pi
        return b - a + (turn - 1) * 2 * math.pi
    if a <= b:
        a += 2 * math.pi
    return b - a + (turn + 1) * 2 * math.pi


def _polar(p, radius, angle):
    return (p[0] + radius * math.cos(angle), p[1] + radius * math.sin(angle))


def _angle(p, q):
    """Direction (rad) from ``p`` to ``q``."""
    return math.atan2(q[1] - p[1], q[0] - p[0])


class Compensator:
    """The tool-centre path of G41 (``left``) or G42 of radius ``radius`` (mm, > 0) from
    ``start`` (u, v), where the tool stands; ``inch``: G20 is in force (one tolerance);
    ``lathe``: the machine positions a lathe insert's corner, not the nose centre."""

    def __init__(self, radius: float, left: bool, start: tuple[float, float], inch: bool = False,
                 lathe: bool = False):
        self.r = radius
        self.left = left
        self.inch = inch
        self.lathe = lathe
        self.first = True
        self.current: tuple[float, float] = (start[0], start[1])      # the tool centre
        self.programmed: tuple[float, float] = (start[0], start[1])   # the programmed point
        self.queue: list[Held] = []
        self.endpoint: tuple[float, float] | None = None   # where the queue's moves start

    @property
    def holding(self) -> bool:
        """True while a move waits in the queue (so everything else must wait behind it)."""
        return bool(self.queue)

    def hold(self, payload) -> None:
        """Queue something that is not a move behind the held moves."""
        self.queue.append(Held("other", payload=payload))

    def _inside(self, turn: int) -> bool:
        """The tool is on the inside of an arc turning ``turn`` (towards its centre)."""
        return (turn > 0) == self.left

    # -- straight moves ------------------------------------------------------------------------
    def straight(self, kind: str, p: tuple[float, float], payload=None) -> list[Held]:
        """A G0 (``kind`` "rapid") or G1 ("feed") to programmed ``p``; returns what is final."""
        if self.first:
            return self._straight_entry(kind, p, payload)
        op, c = self.programmed, self.current
        if p == op:                                   # no motion in the plane: wait behind
            self.queue.append(Held(kind, c, (0.0, 0.0), payload=payload))
            return []
        theta, alpha = _angle(op, c), _angle(op, p)
        if self.left:
            if theta < alpha:
                theta += 2 * math.pi
            beta, gamma = theta - alpha - HALF_PI, HALF_PI
        else:
            if alpha < theta:
                alpha += 2 * math.pi
            beta, gamma = alpha - theta - HALF_PI, -HALF_PI
        end = _polar(p, self.r, alpha + gamma)
        mid = _polar(op, self.r, alpha + gamma)
        front = self.queue[0] if self.queue else None
        concave = beta < -SMALL or beta > math.pi + SMALL or (
            beta > math.pi - SMALL and front is not None and front.kind == "arc"
            and not self._inside(front.turn))       # over the top of an "h": stay outside
        if concave:
            out = self._concave_to_line(front, beta, theta + gamma, p)
        elif beta > SMALL:                            # convex: round the corner
            out = self._flush_at(c)
            if kind == "feed":
                self.queue.append(Held("arc", mid, centre=op, turn=-1 if self.left else 1,
                                       corner=True, payload=payload))
            else:                                     # no rapid arc: straight across
                self.queue.append(Held("rapid", mid, corner=True, payload=payload))
            out += self._dequeue()
            self.endpoint = mid
        else:                                         # straight on
            out = self._dequeue()
            self.endpoint = c
        self.queue.append(Held(kind, end, (p[0] - op[0], p[1] - op[1]), payload=payload))
        self.current, self.programmed = end, p
        return out

    def _straight_entry(self, kind, p, payload) -> list[Held]:
        c = self.current
        distance = math.dist(p, c)
        if distance <= self.r:
            raise CutterError(f"entry move of {distance:.4f} mm after G41/G42 is not longer than "
                              f"the tool radius {self.r:.4f} mm; start the move farther away")
        alpha = _angle(c, p) + (HALF_PI if self.left else -HALF_PI)
        end = _polar(p, self.r, alpha)
        self.endpoint = c
        self.queue.append(Held(kind, end, (math.cos(alpha), math.sin(alpha)), payload=payload))
        self.first = False
        self.current, self.programmed = end, p
        return []

    def _concave_to_line(self, front, beta, back, p) -> list[Held]:
        """Pull the held move back so that the tool touches it and the new line."""
        c, op, r = self.current, self.programmed, self.r
        if front is None or front.kind != "arc":       # line -> line
            half = (beta + math.pi) / 2.0
            if half == 0.0:
                raise CutterError("zero-degree inside corner: the path turns straight back on "
                                  "itself, which no tool can follow with compensation on")
            return self._flush_at(_polar(c, r / math.tan(half), back))
        old = math.dist(front.centre, front.end)        # arc -> line; the held arc is offset
        base = _angle(op, p)
        theta = base + HALF_PI if front.turn > 0 else base - HALF_PI
        phi = _angle(op, front.centre)
        inside = self._inside(front.turn)
        uncomp = old + r if inside else old - r
        d = uncomp * math.cos(theta - phi)              # arc centre to the new line
        ratio = (d - r if inside else d + r) / old
        if abs(ratio) > 1.0:
            raise CutterError("arc then line make an inside corner the tool cannot reach "
                              f"without gouging (tool radius {r:.4f} mm); use a smaller tool")
        sign = -1.0 if (front.turn > 0) == inside else 1.0
        angle = sign * math.acos(ratio) + theta + math.pi
        return self._flush_at(_polar(front.centre, old, angle))

    # -- arcs ------------------------------------------------------------------------------------
    def arc(self, p, centre, turn: int, payload=None) -> list[Held]:
        """A G2 (``turn`` < 0) or G3 (> 0) of ``|turn|`` turns around the programmed ``centre``
        to programmed ``p``; returns what is final."""
        if self.first:
            return self._arc_entry(p, centre, turn, payload)
        op, c, r = self.programmed, self.current, self.r
        radius = math.dist(centre, p)
        theta = _angle(op, c) + (-HALF_PI if self.left else HALF_PI)   # the held move's direction
        delta = _angle(op, centre)
        alpha = delta - HALF_PI if turn > 0 else delta + HALF_PI      # the arc's first tangent
        beta = theta - alpha if self.left else alpha - theta
        beta = beta - 2 * math.pi if beta > 1.5 * math.pi else beta + 2 * math.pi \
            if beta < -HALF_PI else beta
        inside = self._inside(turn)
        if inside:
            if radius <= r:
                raise CutterError(f"arc radius {radius:.4f} mm is not larger than the tool radius "
                                  f"{r:.4f} mm on the inside of the arc; use a smaller tool")
            gamma = _angle(p, centre)
        else:
            gamma = _angle(centre, p)
            delta += math.pi
        end = _polar(p, r, gamma)
        main = Held("arc", end, centre=centre, turn=turn, sweep=find_turn(op, centre, turn, p),
                    payload=payload)
        if beta < -SMALL or beta > math.pi + SMALL or (abs(beta - math.pi) < SMALL and not inside):
            front = self.queue[0] if self.queue else None
            if front is None or front.kind != "arc":
                out = self._flush_at(self._line_meets_arc(beta, theta, centre, radius, turn))
            else:
                out = self._flush_at(self._arc_meets_arc(front, centre, radius, turn))
        elif beta > SMALL:                              # convex: round the corner first
            mid = _polar(op, r, delta)
            out = self._dequeue()
            self.queue.append(Held("arc", mid, centre=op, turn=-1 if self.left else 1,
                                   corner=True, payload=payload))
            out += self._dequeue()
            self.endpoint = mid
        else:
            out = self._dequeue()
            self.endpoint = c
        self.queue.append(main)
        self.current, self.programmed = end, p
        return out

    def _line_meets_arc(self, beta, theta, centre, radius, turn):
        r = self.r
        cy = radius * math.sin(beta - HALF_PI)
        if self._inside(turn):
            dist = radius - r
            ratio = (cy + r) / dist
            self._reachable(ratio, "line then arc")
            angle = theta + math.asin(ratio) if turn > 0 else theta - math.asin(ratio)
        else:
            dist = radius + r
            ratio = (cy - r) / dist
            self._reachable(ratio, "line then arc")
            angle = theta + math.pi - math.asin(ratio) if turn > 0 else \
                theta + math.pi + math.asin(ratio)
        return _polar(centre, dist, angle)

    def _arc_meets_arc(self, front, centre, radius, turn):
        old = math.dist(front.centre, front.end)
        new = radius - self.r if self._inside(turn) else radius + self.r
        between = math.dist(front.centre, centre)
        if old == 0 or between == 0:
            raise CutterError("two arcs in a row share their centre with compensation on; "
                              "join them into one arc")
        ratio = (old ** 2 + between ** 2 - new ** 2) / (2 * old * between)
        self._reachable(ratio, "arc then arc")
        pullback = math.acos(ratio)
        towards = _angle(front.centre, centre)
        sign = 1.0 if (turn > 0) == self._inside(front.turn) else -1.0
        return _polar(front.centre, old, towards + sign * pullback)

    def _reachable(self, ratio: float, what: str) -> None:
        if abs(ratio) > 1.0:
            raise CutterError(f"{what} make an inside corner the tool cannot reach without "
                              f"gouging (tool radius {self.r:.4f} mm); use a smaller tool")

    def _arc_entry(self, p, centre, turn, payload) -> list[Held]:
        c, r = self.current, self.r
        if math.dist(p, c) <= r:
            raise CutterError(f"entry arc after G41/G42 ends {math.dist(p, c):.4f} mm from the "
                              f"tool, not farther than the tool radius {r:.4f} mm")
        if self._inside(turn) and math.dist(centre, c) <= r:
            raise CutterError(f"arc radius {math.dist(centre, c):.4f} mm is not larger than the "
                              f"tool radius {r:.4f} mm on the inside of the arc; use a smaller tool")
        gamma = _angle(p, centre) if self._inside(turn) else _angle(centre, p)
        end = _polar(p, r, gamma)
        # the entry arc ends one radius off the programmed end; its centre moves along the
        # programmed radius so that it also passes through the tool's start
        towards = _angle(end, centre)
        corner = _angle(end, c) - towards
        if abs(math.cos(corner)) < TOLERANCE_EQUAL:
            raise CutterError(f"entry arc cannot pass through the tool's start with tool radius "
                              f"{r:.4f} mm; start the arc from another point")
        bent = _polar(end, math.dist(c, end) / 2.0 / math.cos(corner), towards)
        self.first = False
        if self.lathe:      # move the insert's corner to where the nose centre stands first
            self.queue.append(Held("feed", c, corner=True, payload=payload))
            self.endpoint = c
        self.queue.append(Held("arc", end, centre=bent, turn=turn,
                               sweep=find_turn(c, bent, turn, end), payload=payload))
        self.current, self.programmed = end, p
        return []

    # -- flushing --------------------------------------------------------------------------------
    def _dequeue(self) -> list[Held]:
        out, self.queue, self.endpoint = self.queue, [], None
        return out

    def _flush_at(self, point) -> list[Held]:
        """Every held move now ends at ``point``; refused when that reverses one of them."""
        if not self.queue:
            return []
        start = self.endpoint
        for item in self.queue:
            if item.kind == "arc":
                if abs(math.dist(item.centre, item.end) - math.dist(item.centre, point)) > \
                        (0.254 if self.inch else 0.01):
                    raise CutterError("compensation made an arc whose radii do not match; "
                                      "the path cannot be compensated here")
                if item.sweep and start is not None and abs(find_turn(
                        start, item.centre, item.turn, point)) > abs(item.sweep) + SWEEP_SLACK[self.inch]:
                    raise CutterError("arc in an inside corner cannot be reached by the tool "
                                      f"without gouging (tool radius {self.r:.4f} mm); use a "
                                      "smaller tool or a larger arc")
            elif item.kind != "other" and start is not None and \
                    item.direction[0] * (point[0] - start[0]) + item.direction[1] * (point[1] - start[1]) < 0:
                raise CutterError(f"{'straight feed' if item.kind == 'feed' else 'rapid'} into "
                                  "an inside corner tighter than the tool: it cannot be reached "
                                  f"without gouging (tool radius {self.r:.4f} mm); use a smaller "
                                  "tool or a longer move")
            if item.kind != "other":
                item.end = tuple(point)
        out = self._dequeue()
        self.endpoint = tuple(point)
        return out

    def flush(self) -> list[Held]:
        """M0, M1, M2, M30, M60: the held moves go out where they end now."""
        return self._flush_at(self.current) if self.queue else []

    def off(self) -> list[Held]:
        """G40: as :meth:`flush`; the next programmed point is reached by a plain move."""
        out = self.flush()
        self.current = self.programmed
        return out
