"""The geometry under G70/G71/G72: profile segments as complex numbers ``z + 1j * x``.

Each segment can be offset, cut by a line of constant X, and followed by the tool in the ways
the roughing layers need (dive into the stock, climb out of a pocket). :class:`Path` holds the
whole profile, puts it in the frame where X and Z fall, offsets it and makes the passes; the
public entry points, with the rules in words, are in :mod:`retrofit.gcode.lathepasses`.
"""

from __future__ import annotations

import math

EPS = 1e-6
NEAR = 1e-3


def _cross(u: complex, v: complex) -> float:
    return (u.conjugate() * v).imag


class Recorder:
    """Collects the moves of a pass: ("rapid"|"feed", end, None) or ("cw"|"ccw", end, centre)."""

    def __init__(self, frame: int = 0):
        self.moves: list[tuple] = []
        self.frame = frame

    def _back(self, p: complex) -> complex:
        """From the working frame back to the program's: undo the mirrors, then the turn."""
        f = self.frame
        if f & 4:
            p = p * 1j
            return {0: p, 1: p.conjugate(), 2: -p.conjugate(), 3: -p}[f & 3]
        return {0: p, 1: -p.conjugate(), 2: p.conjugate(), 3: -p}[f & 3]

    def rapid(self, end: complex) -> None:
        self.moves.append(("rapid", self._back(end), None))

    def feed(self, end: complex) -> None:
        self.moves.append(("feed", self._back(end), None))

    def arc(self, ccw: bool, centre: complex, end: complex) -> None:
        if self.frame & 3 in (1, 2):
            ccw = not ccw
        self.moves.append(("ccw" if ccw else "cw", self._back(end), self._back(centre)))


class Line:
    """A straight segment from ``a`` to ``b``."""

    def __init__(self, a: complex, b: complex):
        self.a, self.b = a, b

    def radius(self) -> float:
        return abs(self.a - self.b)

    def monotonic(self) -> bool:
        return (self.b - self.a).real <= NEAR

    def transform(self, f, mirror: bool = False) -> None:
        self.a, self.b = f(self.a), f(self.b)

    def offset(self, d: float) -> None:
        n = 1j * d * (self.a - self.b) / abs(self.a - self.b)
        self.a, self.b = self.a + n, self.b + n

    def crossings(self, x: float) -> list[float]:
        """The Z values where this segment meets X = ``x``."""
        lo, hi = sorted((self.a.imag, self.b.imag))
        if lo > x + EPS or hi < x - EPS:
            return []
        if abs(self.a.imag - self.b.imag) < EPS:
            return [self.a.real, self.b.real]
        t = (x - self.a.imag) / (self.b.imag - self.a.imag)
        return [t * (self.b.real - self.a.real) + self.a.real]

    def draw(self, out) -> None:
        out.feed(self.b)

    def climb(self, at: complex, out):
        """Follow a climbing segment: (True, at) if it does not climb."""
        if self.b.imag < self.a.imag - EPS:
            return True, at
        if abs(at - self.a) > EPS:
            raise ValueError("How did we get here?")
        out.feed(self.b)
        return False, self.b

    def climb_only(self, at: complex, out) -> complex:
        if self.b.imag < self.a.imag - EPS:
            return at
        zs = self.crossings(at.imag)
        if not zs:
            return at
        at = complex(zs[0], at.imag)
        out.feed(at)
        out.feed(self.b)
        return self.b

    def dive(self, at: complex, x: float, out, fast: bool):
        """Go down this segment as far as X = ``x``: (True, at) if it does not go down."""
        if self.a.imag <= self.b.imag + EPS:   # level (to EPS) or climbing: not a dive
            return True, at
        move = out.rapid if fast else out.feed
        if x < self.b.imag - EPS:             # (a layer within EPS of the end stops on it)
            move(self.b)
            return False, self.b
        zs = self.crossings(x)
        if not zs:
            raise ValueError("x too large in straight dive")
        end = complex(zs[0], x)
        move(end)
        return False, end


class Arc(Line):
    """An arc from ``a`` to ``b`` about ``c``, counter-clockwise (G3) when ``ccw``."""

    def __init__(self, a: complex, b: complex, c: complex, ccw: bool):
        super().__init__(a, b)
        self.c, self.ccw = c, ccw

    def radius(self) -> float:
        return min(abs(self.a - self.b), abs(self.a - self.c))

    def monotonic(self) -> bool:
        entry, leave = (self.a - self.c).imag, (self.b - self.c).imag
        dz = (self.b - self.a).real
        if self.ccw:
            return entry >= -NEAR and leave >= -NEAR and dz <= -NEAR
        return entry <= NEAR and leave <= NEAR and dz <= -NEAR

    def transform(self, f, mirror: bool = False) -> None:
        self.a, self.b, self.c = f(self.a), f(self.b), f(self.c)
        self.ccw ^= mirror

    def offset(self, d: float) -> None:
        r = abs(self.a - self.c)
        k = (r + (d if self.ccw else -d)) / r
        self.a, self.b = k * (self.a - self.c) + self.c, k * (self.b - self.c) + self.c

    def _on(self, p: complex) -> bool:
        s, e = _cross(self.a - self.c, p - self.c), _cross(self.b - self.c, p - self.c)
        if self.ccw:
            return s >= -EPS and e <= EPS
        return s <= EPS and e >= -EPS

    def crossings(self, x: float) -> list[float]:
        r, c = abs(self.a - self.c), self.c
        s = -(x - r - c.imag) * (x + r - c.imag)
        if s < -EPS:
            return []
        s = math.sqrt(max(s, 0.0))
        return [p.real for p in (complex(c.real + s, x), complex(c.real - s, x)) if self._on(p)]

    def draw(self, out) -> None:
        out.arc(self.ccw, self.c, self.b)

    def _top(self) -> complex:
        """Where a G3 arc stops climbing: its end, or its highest point if it goes past it."""
        if self.b.real < self.c.real:
            return complex(self.c.real, self.c.imag + abs(self.a - self.c))
        return self.b

    def climb(self, at: complex, out):
        if not self.ccw:
            if at.real > self.c.real:
                return True, at
            if abs(at - self.b) > NEAR:
                out.arc(False, self.c, self.b)
            return False, self.b
        if at.real < self.c.real:
            return True, at
        end = self._top()
        if abs(at - end) > NEAR:
            out.arc(True, self.c, end)
        return True, end

    def climb_only(self, at: complex, out) -> complex:
        zs = self.crossings(at.imag)
        if not zs:
            return at
        if not self.ccw:
            if zs[-1] > self.c.real:
                return at
            at = complex(zs[-1], at.imag)
            out.feed(at)
            if abs(at - self.b) > NEAR:
                out.arc(False, self.c, self.b)
            return self.b
        if zs[0] < self.c.real:
            return at
        at = complex(zs[0], at.imag)
        out.feed(at)
        end = self._top()
        if abs(at - end) > NEAR:
            out.arc(True, self.c, end)
        return end

    def dive(self, at: complex, x: float, out, fast: bool):
        if abs(at - self.b) < NEAR:
            return False, at
        zs = self.crossings(x)
        if self.ccw:
            if at.real > self.c.real:
                return True, at
            z = zs[-1] if zs and zs[-1] <= self.c.real else None
        else:
            if at.real <= self.c.real:
                return True, at
            z = zs[0] if zs and zs[0] >= self.c.real else None
        end = self.b if z is None else complex(z, x)
        if z is None or abs(at - end) > NEAR:
            out.arc(self.ccw, self.c, end)
        return False, end


def join(p: Line, n: Line) -> None:
    """Move the end of ``p`` and the start of ``n`` (both offset) to where they meet."""
    if type(n) is Line and type(p) is Line:
        rot = (n.a - n.b).conjugate() / abs(n.a - n.b)
        ps, pe = (p.a - n.b) * rot, (p.b - n.b) * rot
        if (ps - pe).imag == 0:
            raise ValueError("Cannot intersect parallel lines")
        f = ps.imag / (ps - pe).imag
        n.a = p.b = (ps + f * (pe - ps)) / rot + n.b
        return
    if type(n) is Arc and type(p) is Arc:
        ra, rb, d = abs(n.a - n.c), abs(p.a - p.c), abs(n.c - p.c)
        cos_b = (d * d + ra * ra - rb * rb) / 2.0 / ra / d
        turn = complex(cos_b, math.sqrt(1 - min(cos_b * cos_b, 1.0)))
        n.a = p.b = turn * (p.c - n.c) / d * ra + n.c
        return
    if abs(n.a - p.b) < EPS:
        return
    line, arc = (n, p) if type(n) is Line else (p, n)
    assert isinstance(arc, Arc)                    # one line and one arc are left
    base = line.b if line is n else p.b
    along = (line.a - line.b) if line is n else (p.a - p.b)
    rot = along.conjugate() / abs(along)
    pe, pc = (arc.b - base) * rot, (arc.c - base) * rot
    b = abs(pc - pe) ** 2 - pc.imag * pc.imag
    b = math.sqrt(b) if b >= 0 else 0.0
    s1, s2 = (pc.real + b) / rot + base, (pc.real - b) / rot + base
    n.a = p.b = s1 if abs(n.a - s1) < abs(n.a - s2) else s2

