"""Lathe roughing and finishing passes from a plain profile: the paths of G70, G71 and G72.

The geometry knows nothing of blocks, words or modal state, so any front end can call it: the
RS274 cycles (``G71 Q..``, :mod:`retrofit.gcode.lathecycles`) and a Fanuc-style two-block G71
alike. Points are ``(z, x)`` pairs in the program's units, X as written (a diameter under G7);
the passes come back as :class:`Move` in the same frame, for the caller to run as G0/G1/G2/G3.

The rules are those of LinuxCNC 2.9's rs274 (its G7x code, read for its behaviour):

- The profile is mirrored so that Z falls and X rises from its first point to its last (and, for
  G72 or a G70 on a profile that is not monotonic in Z, first a quarter turn); the passes are
  made in that frame and turned back.
- Roughing (G71/G72) offsets the profile by ``allowance`` (D, towards the stock), shifts it by
  ``shift`` (U, W), then cuts layers ``depth`` (I) apart from the start point's X: each layer is
  fed along Z to the profile, retracted by ``retract`` (R) at 45 degrees, and the tool rapids
  back. Pockets (a profile that climbs and falls again) are cut after the layer that opens them
  (``pockets="all"``, G71/G72), skipped (``"none"``, G71.1/G72.1, whose last pass follows the
  contour's climbing parts), or cut alone (``"only"``, G71.2/G72.2).
- Finishing (G70) follows the profile offset by ``first`` .. ``last`` in ``passes`` passes.
"""

from __future__ import annotations

import copy
from contextlib import contextmanager
from dataclasses import dataclass

from .g7xgeom import EPS, NEAR, Arc, Line, Recorder, join

POCKETS = {"all": 0, "none": 1, "only": 2}
#: the offset grows by at most half the shortest segment a round: a bound on the rounds
MAX_OFFSET_ROUNDS = 20000


@dataclass(frozen=True)
class Segment:
    """One move of a profile: ``kind`` "line", "cw" (G2) or "ccw" (G3); points ``(z, x)``."""

    kind: str
    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float] | None = None


@dataclass(frozen=True)
class Move:
    """One move of a pass: ``kind`` "rapid", "feed", "cw" or "ccw" to ``end``, ``(z, x)``."""

    kind: str
    end: tuple[float, float]
    centre: tuple[float, float] | None = None


def rough(profile: list[Segment], start: tuple[float, float], *, depth: float,
          retract: float = 0.5, allowance: float = 0.0, shift: tuple[float, float] = (0.0, 0.0),
          facing: bool = False, pockets: str = "all") -> list[Move]:
    """The roughing passes of G71 (``facing=False``) or G72 (``facing=True``).

    ``profile`` is the contour in order; its first segment's start is replaced by ``start``
    (the cycle's start point: the first segment is the approach to the contour). ``depth`` is
    the depth of each layer (I, > 0), ``retract`` the 45-degree retract after each layer (R),
    ``allowance`` the stock left on the contour (D), ``shift`` the contour's shift ``(w, u)``
    (W on Z, U on X), which moves the whole path, the start included, as rs274 moves it.
    Raises :class:`ValueError` with rs274's reason ("Not monotonic", ...).

    >>> p = [Segment("line", (0, 0), (0, 10)), Segment("line", (0, 10), (-5, 10)),
    ...      Segment("line", (-5, 10), (-5, 12))]
    >>> [(m.kind, m.end) for m in rough(p, (2, 12), depth=1.5, retract=0.5)][3:7]
    [('feed', (-5.0, 12.0)), ('rapid', (-4.5, 12.5)), ('rapid', (1.5, 12.5)), ('rapid', (2.0, 12.0))]
    """
    if not depth > 0:
        raise ValueError(f"the depth of cut (I) must be > 0, not {depth:g}")
    if retract < 0:
        raise ValueError(f"the retract (R) must be >= 0, not {retract:g}")
    if pockets not in POCKETS:
        raise ValueError(f"pockets must be one of {', '.join(POCKETS)}, not {pockets!r}")
    path = Path(_segments(profile, start))
    out = Recorder()
    with _degenerate():
        path.rough(out, POCKETS[pockets], complex(*shift), allowance, depth, retract, facing)
    return [Move(kind, _pair(end), None if c is None else _pair(c)) for kind, end, c in out.moves]


def finish(profile: list[Segment], start: tuple[float, float], *, first: float = 0.0,
           last: float = 0.0, passes: int = 1) -> list[Move]:
    """The finishing passes of G70: ``passes`` passes from ``first`` (D) to ``last`` (E) off
    the contour, each a rapid to its start and one along it. Same frame as :func:`rough`."""
    if passes != int(passes) or passes < 1:
        raise ValueError(f"the number of passes (P) must be a whole number >= 1, not {passes:g}")
    path = Path(_segments(profile, start))
    out = Recorder()
    with _degenerate():
        path.finish(out, first, last, int(passes))
    return [Move(kind, _pair(end), None if c is None else _pair(c)) for kind, end, c in out.moves]


@contextmanager
def _degenerate():
    """A profile whose geometry divides by zero (a segment shrunk to nothing, parallel lines
    to meet) is refused with that reason, not a crash."""
    try:
        yield
    except (ZeroDivisionError, IndexError, OverflowError) as exc:
        raise ValueError(f"the profile's geometry degenerates ({exc}): a segment of no length, "
                         f"an arc of no radius, or an allowance larger than the profile") from None


def _segments(profile: list[Segment], start) -> list:
    if len(profile) < 2:
        raise ValueError("the profile needs a move after its first point (its first move is "
                         "the approach from the start point)")
    segs = []
    for n, seg in enumerate(profile):
        a = complex(*(start if n == 0 else seg.start))
        b = complex(*seg.end)
        if seg.kind == "line":
            segs.append(Line(a, b))
        elif seg.kind in ("cw", "ccw"):
            assert seg.centre is not None        # an arc is read with its centre
            segs.append(Arc(a, b, complex(*seg.centre), seg.kind == "ccw"))
        else:
            raise ValueError(f"segment {n}: kind {seg.kind!r}; known: line, cw, ccw")
    return segs


def _pair(p: complex) -> tuple[float, float]:
    return (p.real + 0.0, p.imag + 0.0)


class Path:
    """A profile (its first segment the approach from the start point) and its frame."""

    def __init__(self, segs: list[Line]):
        self.segs = segs
        self.frame = 0          # 4: turned a quarter, 2: X mirrored, 1: Z mirrored

    def _map(self, f, mirror: bool, bit: int) -> None:
        for seg in self.segs:
            seg.transform(f, mirror)
        self.frame ^= bit

    def turn(self) -> None:
        self._map(lambda p: -1j * p, False, 4)

    def fall(self) -> None:
        """Mirror the profile so that Z falls and X rises from its first point to its last."""
        d = self.segs[0].b - self.segs[-1].b
        if d.imag > 0:
            self._map(lambda p: p.conjugate(), True, 2)
        if d.real < 0:
            self._map(lambda p: -p.conjugate(), True, 1)

    def finish(self, out: Recorder, first: float, last: float, passes: int) -> None:
        out.rapid(self.segs[0].a)
        self.fall()
        if not all(seg.monotonic() for seg in self.segs[1:]):
            self.turn()
            self.fall()
        self._approach()
        out.frame = self.frame
        for n in range(passes, 0, -1):
            path = copy.deepcopy(self)
            path.offset((n - 1) * (first - last) / passes + last)
            out.rapid(path.segs[0].a)
            out.rapid(path.segs[0].b)
            for seg in path.segs[1:]:
                seg.draw(out)

    def _approach(self, check: bool = True) -> None:
        """An approach that ends behind its start starts above its end; then every segment
        must move Z one way (falling); X may fall and climb (a pocket)."""
        first = self.segs[0]
        if (first.b - first.a).real > 0:
            first.a = complex(first.b.real, first.a.imag)
        if check and not all(seg.monotonic() for seg in self.segs):
            raise ValueError("Not monotonic")

    def rough(self, out: Recorder, pockets: int, shift: complex, allowance: float,
              depth: float, retract: float, facing: bool) -> None:
        out.rapid(self.segs[0].a)
        if facing:
            self.turn()
        self.fall()
        self._approach()
        self.offset(allowance)
        self.fall()
        for seg in self.segs:
            seg.transform(lambda p: p + shift)
        out.frame = self.frame
        first = self.segs[0]
        out.rapid(first.a)
        last = self.segs[-1].b
        if last.imag < first.a.imag:            # leave the contour at the start point's X
            self.segs.append(Line(last, complex(last.real, first.a.imag)))
        Layers(self.segs, depth, retract * (1 + 1j), out).cut(pockets, first.a, 0)

    def offset(self, distance: float) -> None:
        """Offset the contour (all but the approach) by ``distance`` towards the stock."""
        self.fall()
        segs = self.segs
        if ((segs[0].b - segs[0].a) / (segs[-1].a - segs[0].a)).imag < 0:
            distance = -distance
        approach, rest = segs[0], segs[1:]
        done, rounds = 0.0, 0
        while done != distance:
            rounds += 1
            if rounds > MAX_OFFSET_ROUNDS:
                raise ValueError(f"an offset of {abs(distance):g} takes more than "
                                 f"{MAX_OFFSET_ROUNDS} rounds on this profile's short segments")
            step = min([1e9, abs(distance - done)] + [s.radius() / 2 for s in rest])
            step = -step if distance < 0 else step
            rest = self._offset_once(rest, step, distance > 0)
            done += step
        for p, n in zip(rest, rest[1:]):
            p.b = n.a = (p.b + n.a) / 2
        approach.b = rest[0].a
        self.segs = [approach] + rest

    @staticmethod
    def _offset_once(segs: list[Line], step: float, outward: bool) -> list[Line]:
        kept = []
        for seg in segs:
            seg.offset(step)
            if seg.radius() >= NEAR:
                kept.append(seg)
        segs, k = kept, 0
        while k < len(segs) - 1:                 # round the corners that opened
            p, n = segs[k], segs[k + 1]
            if (p.b - n.a).real > 1e-2:
                s, e = copy.copy(p), copy.copy(n)
                s.offset(-step)
                e.offset(-step)
                segs.insert(k + 1, Arc(p.b, n.a, (s.b + e.a) / 2, outward))
                k += 1
            k += 1
        k = 0
        while k < len(segs) - 1:                 # drop what folded over, meet the rest
            if not segs[k].monotonic():
                if k == 0:
                    raise ValueError("the offset profile folds over at its start")
                drop = k if segs[k].radius() < segs[k - 1].radius() else k - 1
                del segs[drop]
                k = 0
            if k + 1 >= len(segs):
                break
            if segs[k].radius() < NEAR:
                del segs[k]
                k = 0
            else:
                join(segs[k], segs[k + 1])
            k += 1
        return segs


class Layers:
    """The roughing layers: cut along Z at X levels ``depth`` apart, pockets in turn."""

    def __init__(self, segs: list[Line], depth: float, escape: complex, out: Recorder):
        self.segs, self.depth, self.escape, self.out = segs, depth, escape, out
        self.budget = 200000
        self.top = segs[0].a.imag
        self.pockets_only = False

    def cut(self, pockets: int, at: complex, k: int) -> None:
        """Cut from segment ``k`` on; every pocket's layers count down from ``self.top``."""
        segs, out = self.segs, self.out
        x = self.top
        if pockets == 2:                         # skip the first roughing: the pockets alone
            while k < len(segs):
                stop, at = segs[k].dive(at, -1e9, out, k == 0)
                if stop:
                    break
                k += 1
            self.pockets_only = True             # along the contour to the first pocket
            self._climb(0, at, k)
            return
        while k < len(segs):
            self.budget -= 1
            if self.budget < 0:
                raise ValueError("the roughing passes do not end (check the profile and I)")
            while x > at.imag:
                x -= self.depth
            stop, at = segs[k].dive(at, x, out, k == 0)
            if stop:
                self._climb(pockets, at, k)
                return
            if at.imag > x or abs(at.imag - x) > EPS:
                k += 1
                continue
            k, x = self._layer(at, k, x)

    def _climb(self, pockets: int, at: complex, k: int) -> None:
        for j in range(k, len(self.segs)):
            if pockets == 1:
                at = self.segs[j].climb_only(at, self.out)
                continue
            stop, at = self.segs[j].climb(at, self.out)
            if stop:
                if self.pockets_only:            # each pocket's layers from the tool's height
                    self.top = at.imag
                self.cut(0, at, j)
                return

    def _layer(self, at: complex, k: int, x: float):
        """One layer from ``at`` along Z to the first segment it meets, then out and back."""
        out, esc = self.out, self.escape
        for j in range(k, len(self.segs)):
            zs = self.segs[j].crossings(at.imag)
            if not zs:
                continue
            z = zs[-1] if j == k else zs[0]
            dist = abs(z - at.real)
            if dist < EPS:
                if j == k:
                    continue
                return k + 1, x
            end = complex(z, at.imag)
            out.feed(end)
            scale = min(1.0, dist / 2 / esc.real) if esc.real else 1.0
            out.rapid(end + scale * esc)
            out.rapid(at - (scale * esc).conjugate())
            (out.rapid if k == 0 else out.feed)(at)
            return k, x - self.depth
        return k, x
