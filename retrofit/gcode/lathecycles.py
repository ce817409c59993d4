"""G70, the lathe finishing cycle, as LinuxCNC 2.9's rs274 runs it (passes on the profile itself).

``G70 Q<sub> [X Z] [P<passes>]``: the profile is the moves of ``o<sub> sub`` (X and Z words,
G0/G1 lines and G2/G3 arcs by I K or R), read from its text, not called. The tool rapids to the
start (X Z, or where it is), rapids to the profile's first point, then follows the rest of the
profile at the feed (a G0 inside the profile is cut at F, as rs274 does); P repeats it. Every
segment must be monotonic (Z and X each change one way only, after the profile is turned so that
both fall, or turned a quarter for a facing profile), else "Not monotonic". Offset passes (D, E
not 0) and the roughing cycles G71/G72 are refused: their parallel-offset paths are not made here.
"""

from __future__ import annotations

from .blocks import make_block
from .errors import RuleError

ALLOWED = set("GQXZDEPF")


def run_g70(runner, src, line, words: list[tuple[str, float]]) -> bool:
    """One G70 block (``words`` evaluated); the moves go through the translator as G0/G1/G2/G3."""
    s = runner.tr.state
    v = dict(words)
    extra = sorted({k for k, _ in words} - ALLOWED)
    if extra or sum(1 for k, _ in words if k == "G") != 1:
        raise RuleError(f"G70: write it alone with Q, X, Z, D, E, P, F (found {', '.join(extra) or 'other G codes'})")
    if "Q" not in v:
        raise RuleError("G70 requires a Q word (the O-number of the profile subroutine)")
    if v.get("D", 0.0) != 0.0 or v.get("E", 0.0) != 0.0:
        raise RuleError("G70: finishing passes offset from the profile (D, E not 0) are not "
                        "supported; give D0 E0 (or leave them out) to cut on the profile")
    if s.incremental:
        raise RuleError("G70 will only work in absolute distance mode (G90)")
    passes = v.get("P", 1.0)
    if passes != int(passes) or not 1 <= passes <= 100:
        raise RuleError(f"P{passes:g}: G70 runs its profile 1 to 100 times")
    name = f"{round(v['Q'])}"
    if name not in src.subs:
        raise RuleError(f"G70 Q{v['Q']:g}: Q routine not found (no o{name} sub in {src.file})")
    unit = 25.4 if s.inch else 1.0
    here = (s.program_position("Z") / unit, s.program_position("X") / unit * (2 if s.diameter else 1))
    start = (v.get("Z", here[0]), v.get("X", here[1]))
    path = _profile(runner, src, name, start)
    if not path:
        return False
    _check(path)
    feed = [("F", v["F"])] if "F" in v else []
    for _ in range(int(passes)):
        _move(runner, line, src, [("G", 0.0), ("X", start[1]), ("Z", start[0])] + feed)
        first = path[0]
        _move(runner, line, src, [("G", 0.0), ("X", first[2][1]), ("Z", first[2][0])])
        for kind, a, b, centre in path[1:]:
            words = [("G", 1.0 if kind == "line" else float(kind)), ("X", b[1]), ("Z", b[0])]
            if kind != "line":
                ref = (0.0, 0.0) if not s.arc_incremental else a
                words += [("I", centre[1] - ref[1]), ("K", centre[0] - ref[0])]
            _move(runner, line, src, words)
    return False


def _move(runner, line, src, words) -> None:
    runner.tr.run(make_block(line.number, words, runner.machine), src.file)


def _profile(runner, src, name: str, start: tuple) -> list:
    """The sub's moves: ("line", start, end, None) and (2 or 3, start, end, centre), (z, x)."""
    first, last = src.subs[name]
    here, motion, path = start, None, []
    for line in src.lines[first + 1:last]:
        if line.oword is not None or line.assigns:
            raise RuleError(f"G70 Q{name}: the profile o{name} may hold only moves (line "
                            f"{line.number})")
        w = {k: runner._value(t) for k, t in line.words}
        if "G" in w:
            motion = w["G"]
        end = (w.get("Z", here[0]), w.get("X", here[1]))
        if end == here or motion is None:
            continue
        if motion in (0.0, 1.0):
            path.append(("line", here, end, None))
        elif motion in (2.0, 3.0):
            path.append((int(motion), here, end, _centre(runner, here, end, motion, w, name)))
        else:
            raise RuleError(f"G70 Q{name}: G{motion:g} in the profile (line {line.number}); "
                            f"the profile is G0, G1, G2, G3 moves")
        here = end
    return path


def _centre(runner, a, b, motion, w, name):
    if "R" in w:
        za, xa, zb, xb, r = a[0], a[1], b[0], b[1], w["R"]
        dz, dx = zb - za, xb - xa
        n2 = dz * dz + dx * dx
        k = ((r * r - n2 / 4) / n2) ** 0.5
        sign = 1 if motion == 3.0 else -1
        return ((za + zb) / 2 - sign * k * dx, (xa + xb) / 2 + sign * k * dz)
    if "I" not in w and "K" not in w:
        raise RuleError(f"G70 Q{name}: either I or K must be present for an arc")
    i, k = w.get("I", 0.0), w.get("K", 0.0)
    if runner.tr.state.arc_incremental:
        return (a[0] + k, a[1] + i)
    return (k, i)


def _check(path) -> None:
    """rs274's rule: turn the profile a quarter if a segment is not monotonic, flip it so Z and X
    fall from its start to its end, then every segment must be monotonic."""
    z = [(p[1], p[2], p[3], p[0]) for p in path]
    if not all(_monotonic(seg) for seg in z):
        z = [_turn(seg) for seg in z]
    dx = z[0][1][1] - z[-1][1][1]
    dz = z[0][1][0] - z[-1][1][0]
    if dx > 0:
        z = [_flip(seg, 1) for seg in z]
    if dz < 0:
        z = [_flip(seg, 0) for seg in z]
    if not all(_monotonic(seg) for seg in z[1:]):     # the approach to the profile may climb
        raise RuleError("G7X error: Not monotonic (each segment of the profile must move Z one "
                        "way and X one way)")


def _turn(seg):
    a, b, c, kind = seg
    t = lambda p: None if p is None else (p[1], -p[0])  # noqa: E731   -i * (z + i x)
    return t(a), t(b), t(c), kind


def _flip(seg, axis: int):
    a, b, c, kind = seg
    f = lambda p: None if p is None else tuple(-u if n == axis else u for n, u in enumerate(p))  # noqa: E731
    return f(a), f(b), f(c), (kind if kind == "line" else 5 - kind)


def _monotonic(seg) -> bool:
    a, b, c, kind = seg
    if kind == "line":
        return b[0] - a[0] <= 1e-3
    entry, leave, dz = a[1] - c[1], b[1] - c[1], b[0] - a[0]
    if kind == 3:
        return entry >= -1e-3 and leave >= -1e-3 and dz <= -1e-3
    return entry <= 1e-3 and leave <= 1e-3 and dz <= -1e-3
