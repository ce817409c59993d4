"""G70, G71 and G72, the lathe cycles, as LinuxCNC 2.9's rs274 runs them.

``G70 Q<sub> [X Z] [D E P]`` finishes, ``G71 Q<sub> [X Z] [D I R]`` roughs along Z and
``G72`` along X (``.1``: no pockets, ``.2``: the pockets alone). The profile is the moves of
``o<sub> sub`` (X and Z words, G0/G1 lines and G2/G3 arcs by I K or R), read from its text, not
called (a line of it that cannot be read is refused as the run refuses it, never left out); its
first segment is the approach from the start point (X Z, or where the tool is). The
passes are made by :mod:`retrofit.gcode.lathepasses` and go through the translator as G0, G1,
G2 and G3 moves, in the program's units with X as written. F, S and T on the cycle's line act
before its moves. rs274's word defaults: D0 E0 P1 for G70; D0 I1 R0.5 for G71/G72.
"""

from __future__ import annotations

from .blocks import make_block
from .errors import RuleError
from .expressions import evaluate
from .lathepasses import Move, Segment, finish, rough

#: the G codes run here, by the number rs274 gives them
CODES = (70.0, 71.0, 71.1, 71.2, 72.0, 72.1, 72.2)
CYCLE_WORDS = set("GQXZDEIPR")
OTHER_WORDS = set("FST")
_POCKETS = {0: "all", 1: "none", 2: "only"}


def is_cycle(words) -> bool:
    """True when the line's words name one of the lathe cycles."""
    return any(k == "G" and type(v) is float and round(v, 1) in CODES for k, v in words)


def run_cycle(runner, src, line, words: list[tuple[str, float]]) -> bool:
    """One G70/G71/G72 block (``words`` evaluated); the moves go through the translator."""
    s = runner.tr.state
    code = next(round(v, 1) for k, v in words if k == "G" and round(v, 1) in CODES)
    name = f"G{code:g}"
    v = dict(words)
    extra = sorted({k for k, _ in words} - CYCLE_WORDS - OTHER_WORDS)
    if extra or sum(1 for k, _ in words if k == "G") != 1:
        raise RuleError(f"{name}: write it alone with Q, X, Z, D, E, I, R, P and F, S, T "
                        f"(found {', '.join(extra) or 'other G codes'})")
    if "Q" not in v:
        raise RuleError(f"{name} requires a Q word (the O-number of the profile subroutine)")
    if s.incremental:
        raise RuleError(f"{name} will only work in absolute distance mode (G90)")
    if code != 70.0 and runner.tr.comp.on:
        raise RuleError(f"{name} cannot be used with cutter compensation turned on (G40 first)")
    sub = f"{round(v['Q'])}"
    if sub not in src.subs:
        raise RuleError(f"{name} Q{v['Q']:g}: Q routine not found (no o{sub} sub in {src.file})")
    others = [(k, x) for k, x in words if k in OTHER_WORDS]
    if others:
        runner.tr.run(make_block(line.number, others, runner.machine), src.file)
    across = 2.0 if s.diameter else 1.0          # rs274 computes in radii under G7
    here = _here(s)
    start = (v.get("Z", here[0]), v["X"] / across if "X" in v else here[1])
    profile = _profile(runner, src, sub, start, name, across)
    if not profile:
        return False
    try:
        moves = _passes(code, profile, start, v)
    except ValueError as exc:
        raise RuleError(f"{name}: G7X error: {exc}") from None
    for move in moves:
        _move(runner, line, src, move, across)
    return False


def _passes(code: float, profile, start, v) -> list[Move]:
    if code == 70.0:
        passes = v.get("P", 1.0)
        if passes != int(passes) or not 1 <= passes <= 100:
            raise ValueError(f"P{passes:g}: G70 runs its profile 1 to 100 times")
        return finish(profile, start, first=v.get("D", 0.0), last=v.get("E", 0.0),
                      passes=int(passes))
    sub = round((code - int(code)) * 10)
    return rough(profile, start, depth=v.get("I", 1.0), retract=v.get("R", 0.5),
                 allowance=v.get("D", 0.0), facing=int(code) == 72, pockets=_POCKETS[sub])


def _move(runner, line, src, move: Move, across: float) -> None:
    kind = {"rapid": 0.0, "feed": 1.0, "cw": 2.0, "ccw": 3.0}[move.kind]
    z, x = move.end
    words = [("G", kind), ("X", x * across), ("Z", z)]
    if move.centre is not None:
        s = runner.tr.state
        ref = (0.0, 0.0) if not s.arc_incremental else _here(s)
        words += [("I", move.centre[1] - ref[1]), ("K", move.centre[0] - ref[0])]
    runner.tr.run(make_block(line.number, words, runner.machine), src.file)


def _here(s) -> tuple[float, float]:
    """Where the tool is, ``(z, x)`` in program units, X a radius."""
    unit = 25.4 if s.inch else 1.0
    return (s.program_position("Z") / unit, s.program_position("X") / unit)


def _profile(runner, src, sub: str, start: tuple, name: str, across: float) -> list[Segment]:
    """The sub's moves as segments, ``(z, x)``; the first starts at ``start``. As rs274 reads
    the profile, its loops and branches run, and ``#<_x>`` and ``#<_z>`` read the profile's
    point so far."""
    first, last = src.subs[sub]
    here, motion, path, pc = start, None, [], first + 1
    repeats: dict = {}
    while pc < last:
        line = src.lines[pc]
        if line.error:                  # as the run would when it reached the line: told, not skipped
            exc = RuleError(f"{name} Q{sub}: in the profile o{sub}: {line.error}")
            exc.file, exc.line = src.file, line.number
            raise exc
        if line.dollar is not None:
            raise RuleError(f"{name} Q{sub}: the grbl line {line.dollar!r} in the profile o{sub} (line "
                            f"{line.number}); the profile is G0, G1, G2, G3 moves")
        if line.assigns:
            raise RuleError(f"{name} Q{sub}: the profile o{sub} may hold only moves (line "
                            f"{line.number} sets a parameter)")
        if line.oword is not None:
            if line.oword[1] in ("CALL", "RETURN", "SUB", "ENDSUB"):
                raise RuleError(f"{name} Q{sub}: o{line.oword[0]} {line.oword[1].lower()} in "
                                f"the profile (line {line.number}); loops and branches only")
            _, pc = runner._oword(src, pc, line, [], repeats)
            continue
        pc += 1
        at = {"_x": here[1] * across, "_z": here[0]}
        read = lambda ref, at=at: at[ref] if ref in at else runner._read(ref)  # noqa: E731
        w = {k: t if type(t) is float else evaluate(t, read, runner.params.exists)
             for k, t in line.words}
        if "G" in w:
            motion = w["G"]
            if motion not in (0.0, 1.0, 2.0, 3.0):      # named on its own line, moving or not
                raise RuleError(f"{name} Q{sub}: G{motion:g} in the profile (line {line.number}); "
                                f"the profile is G0, G1, G2, G3 moves")
        end = (w.get("Z", here[0]), w["X"] / across if "X" in w else here[1])
        if end == here or motion is None:
            continue
        if motion in (0.0, 1.0):
            path.append(Segment("line", here, end))
        else:
            kind = "ccw" if motion == 3.0 else "cw"
            path.append(Segment(kind, here, end, _centre(runner, here, end, motion, w, name)))
        here = end
    return path


def _centre(runner, a, b, motion, w, name):
    if "R" in w:
        za, xa, zb, xb, r = a[0], a[1], b[0], b[1], w["R"]
        dz, dx = zb - za, xb - xa
        n2 = dz * dz + dx * dx
        if r * r < n2 / 4 - 1e-9:
            raise RuleError(f"{name}: an arc of R{r:g} cannot reach from Z{za:g} X{xa:g} to "
                            f"Z{zb:g} X{xb:g} (the radius is under half the chord)")
        k = (max(r * r - n2 / 4, 0.0) / n2) ** 0.5
        sign = 1 if motion == 3.0 else -1
        return ((za + zb) / 2 - sign * k * dx, (xa + xb) / 2 + sign * k * dz)
    if "I" not in w and "K" not in w:
        raise RuleError(f"{name}: G7X error: either I or K must be present for an arc")
    i, k = w.get("I", 0.0), w.get("K", 0.0)
    if runner.tr.state.arc_incremental:
        return (a[0] + k, a[1] + i)
    return (k, i)
