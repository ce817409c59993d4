"""The Fanuc lathe cycles' blocks read and run: G70-G76 (two-block forms) and modal G90/G92/G94.

The passes come from :mod:`retrofit.gcode.fanuc_cycles` (G71/G72/G73, from the profile between
the blocks N``P`` and N``Q``) and :mod:`retrofit.gcode.fanuc_fixed`; here the words are read,
checked and turned into those functions' arguments, and G70 runs the profile's own blocks. Every
cycle starts where the tool is (the start point A) and ends there.
"""

from __future__ import annotations

import math

from . import fanuc_cycles, fanuc_fixed
from .errors import RuleError

#: what the first block of each two-block cycle holds
FIRST = {71: "U (depth of cut) R (retract)", 72: "W (depth of cut) R (retract)",
         73: "U (X relief) W (Z relief) R (passes)", 74: "R (return after a peck)",
         75: "R (return after a peck)", 76: "P (mmrraa: finishing passes, chamfer, angle) Q (minimum "
                                             "depth) R (finishing allowance)"}


def run_cycle(run, block, code: int) -> None:
    """A G70-G76 block: a first block is kept, a second block (or G70) cut."""
    if code == 70:
        _g70(run, block)
        return
    second = (block.has("P") and block.has("Q")) if code in (71, 72, 73) else run.has_axes(block)
    if not second:
        run.first[code] = block
        return
    first = run.first.get(code)
    if code in (71, 72, 73) and first is None and not block.has("D"):
        raise RuleError(f"G{code} P Q: the cycle's first block (G{code} {FIRST[code]}) must come "
                        f"before it")
    {71: _rough, 72: _rough, 73: _pattern, 74: _peck, 75: _peck, 76: _g76}[code](run, block, first, code)


def _value(run, block, letter: str, default=None):
    v = run.number(block, letter)
    return default if v is None else v


def _profile(run, block, what: str):
    """(approach kind, type II?, segments, start index, end index) of N P .. N Q from here."""
    if not (block.has("P") and block.has("Q")):
        raise RuleError(f"{what} needs P and Q, the N numbers of the profile's first and last block")
    p = run.index_of(int(block.get("P")), f"{what} P", run.pc)
    q = run.index_of(int(block.get("Q")), f"{what} Q", p - 1)
    if q < p:
        raise RuleError(f"{what}: N{int(block.get('Q'))} comes before N{int(block.get('P'))}")
    here = start = run.here()
    motion, segments, approach = run.motion if run.motion in (0, 1, 2, 3) else 1, [], None
    blocks = run.prog.blocks[p:q + 1]
    for b in blocks:
        if b.error:
            raise RuleError(f"{what}: line {b.line}: {b.error}")
        for g in b.codes("G"):
            if g in (0, 1, 2, 3):
                motion = int(g)
            elif g not in (40, 41, 42, 18):
                raise RuleError(f"{what}: G{g:g} in the profile (line {b.line}); a profile is G0, "
                                f"G1, G2, G3 moves")
        if any(m in (98, 97, 99) for m in b.codes("M")):
            raise RuleError(f"{what}: a subprogram call in the profile (line {b.line})")
        end = run.target(b, here)
        if approach is None:
            approach = motion
            type2 = (b.has("X") or b.has("U")) and (b.has("Z") or b.has("W"))
            if motion not in (0, 1):
                raise RuleError(f"{what}: the profile's first block N{int(block.get('P'))} must be "
                                f"G0 or G1 (line {b.line})")
            first = end
        elif end != here:
            centre = arc_centre(run, b, here, end, motion) if motion in (2, 3) else None
            segments.append((1 if motion in (0, 1) else motion, here, end, centre))
        here = end
    if not segments:
        raise RuleError(f"{what}: the profile between N{int(block.get('P'))} and "
                        f"N{int(block.get('Q'))} has no moves after its first block")
    return approach, type2, segments, start, first, (p, q)


def _rough(run, block, first, code: int) -> None:
    what = f"G{code}"
    approach, type2, segments, start, entry, (_, q) = _profile(run, block, what)
    if type2 and not run.settings.g71_type2:
        raise RuleError(f"{what}: the profile's first block moves X and Z (type II), which this "
                        f"control does not have (g71_type2 = false in [fanuc])")
    if block.has("D"):                   # the one-block form (Haas, Fanuc 0-T): D the depth
        depth, retract = _pq(run, block, "D"), run.settings.g71_retract_mm / run.unit()
        type2 = type2 or block.get("R") == 1.0                       # Haas R1: type II
    else:
        depth = _value(run, first, "U" if code == 71 else "W")
        retract = _value(run, first, "R", 0.0)
    if depth is None:
        raise RuleError(f"{what}: the first block needs {FIRST[code]}")
    profile = [(1, entry, segments[0][1], None)] if entry != segments[0][1] else []
    profile += segments
    kind = 0 if run.settings.retract_45 == "rapid" else 1
    path = fanuc_cycles.rough(profile, start, depth, retract, _value(run, block, "U", 0.0) / run.xf,
                              _value(run, block, "W", 0.0), code == 71, approach, kind, what,
                              type2)
    run.path(path, start)
    run.pc = max(run.pc, q)              # the profile's blocks are not run: on after N Q


def _pattern(run, block, first, code: int) -> None:
    approach, _, segments, start, entry, (_, q) = _profile(run, block, "G73")
    if block.has("D"):                   # Haas: G73 P Q U W I(X relief) K(Z relief) D(passes) F
        relief, passes = (_value(run, block, "I", 0.0), _value(run, block, "K", 0.0)), block.get("D")
    elif first is None or first.get("R") is None:
        raise RuleError(f"G73: the first block needs {FIRST[73]}")
    else:
        relief = (_value(run, first, "U", 0.0), _value(run, first, "W", 0.0))
        passes = first.get("R")
    profile = [(1, entry, segments[0][1], None)] if entry != segments[0][1] else []
    path = fanuc_cycles.pattern_repeat(
        profile + segments, start, *relief, passes, _value(run, block, "U", 0.0) / run.xf,
        _value(run, block, "W", 0.0), approach, "G73")
    run.path(path, start)
    run.pc = max(run.pc, q)


def _g70(run, block) -> None:
    """G70 P Q: the profile's own blocks run (their F, S and T act), then a rapid back to A."""
    *_, (p, q) = _profile(run, block, "G70")
    start, back, motion = run.here(), run.pc, run.motion
    for i in range(p, q + 1):
        run.pc = i
        run.line = run.prog.blocks[i].line
        run.block(run.prog.blocks[i])
    run.pc, run.line = back, block.line
    run.motion = motion
    run.path([(0, start, None)], run.here())


def _peck(run, block, first, code: int) -> None:
    back = _value(run, first, "R", 0.0) if first is not None else 0.0
    start = run.here()
    x, z = run.target(block)
    shift, peck = _pq(run, block, "P"), _pq(run, block, "Q")
    if code == 75:
        shift, peck = peck, shift                    # G75: P pecks along X, Q shifts along Z
    relief = _value(run, block, "R", 0.0)
    run.path(fanuc_fixed.pecking(start, x, z, shift, peck, back, relief, code == 74), start)


def _pq(run, block, letter: str) -> float:
    """P, Q (G74-G76) or D (G71/G72 one-block form): least input increments without a decimal
    point (``cycle_pq``)."""
    w = block.word(letter)
    if w is None:
        return 0.0
    if run.settings.cycle_pq == "increments" and not w.point:
        return w.value * (0.0001 if run.tr.state.inch else 0.001)
    return w.value


def _g76(run, block, first, code: int) -> None:
    if block.has("K") or block.has("D"):
        _g76_one_block(run, block)
        return
    if first is None:
        raise RuleError(f"G76 X Z P Q F: the first block (G76 {FIRST[76]}) must come before it")
    mra = int(first.get("P", 10060.0))
    finishing, chamfer, angle = mra // 10000, (mra // 100) % 100, mra % 100
    if angle not in (0, 29, 30, 55, 60, 80):
        raise RuleError(f"G76 P{mra:06d}: the angle aa is one of 00 29 30 55 60 80")
    minimum, allowance = _pq(run, first, "Q"), _value(run, first, "R", 0.0)
    height, first_depth = _pq(run, block, "P"), _pq(run, block, "Q")
    lead = block.get("F")
    if lead is None or not lead > 0.0:
        raise RuleError("G76: the second block needs F, the lead (> 0)")
    start = run.here()
    x_root, z_end = run.target(block)
    taper = _value(run, block, "R", 0.0)
    depths = fanuc_fixed.thread_depths(first_depth, height, minimum, allowance, finishing)
    run.path(fanuc_fixed.thread_cycle(start, x_root, z_end, taper, height, depths, angle, lead,
                                      chamfer * lead / 10.0), start)


def _g76_one_block(run, block) -> None:
    """Haas: ``G76 X Z K(height) D(first depth) F [A(angle)] [I(taper)] [P1]``: depths D sqrt(n),
    then one pass at the full height K, the infeed along the flank at A/2."""
    if not (block.has("K") and block.has("D")):
        raise RuleError("G76 in one block needs K (the thread height) and D (the first depth)")
    if block.get("P", 1.0) != 1.0:
        raise RuleError(f"G76 P{block.get('P'):g}: only P1 (one edge, constant amount) is made")
    lead = block.get("F")
    if lead is None or not lead > 0.0:
        raise RuleError("G76: F, the lead, must be given and > 0")
    angle = block.get("A", 0.0)
    if not 0.0 <= angle <= 120.0:
        raise RuleError(f"G76 A{angle:g}: the tool's angle is 0 to 120 degrees")
    start = run.here()
    x_root, z_end = run.target(block)
    height = _pq(run, block, "K")
    depths = fanuc_fixed.thread_depths(_pq(run, block, "D"), height, 0.0, 0.0, 1)
    run.path(fanuc_fixed.thread_cycle(start, x_root, z_end, _value(run, block, "I", 0.0), height,
                                      depths, angle, lead), start)


def run_modal(run, block, code: int) -> None:
    """A block under G90, G92 or G94: one pass of the cycle to its X and Z (the last ones kept)."""
    start = run.here()
    x, z = run.target(block, (run.modal.get("x", start[0]), run.modal.get("z", start[1])))
    if block.has("U"):
        x = start[0] + run.number(block, "U") / run.xf
    if block.has("W"):
        z = start[1] + run.number(block, "W")
    taper = _value(run, block, "R", 0.0 if code not in run.modal.get("codes", ()) else run.modal["r"])
    run.modal.update(x=x, z=z, r=taper, codes=(code,))
    if code == 92:
        lead = block.get("F", run.modal.get("lead"))
        if lead is None:
            raise RuleError("G92 needs F, the lead of the thread")
        run.modal["lead"] = lead
        run.path(fanuc_fixed.thread_single(start, x, z, taper, lead), start)
        return
    path = fanuc_fixed.turning(start, x, z, taper, code == 94)
    run.path(path, start)


def arc_centre(run, block, start, end, kind: int):
    """The centre (x radius, z) of a G2/G3 from ``start`` to ``end``: R, or I (radius) and K."""
    if block.has("R"):
        r = run.number(block, "R")
        dx, dz = end[0] - start[0], end[1] - start[1]
        chord = math.hypot(dx, dz)
        if chord == 0.0 or abs(r) < chord / 2 - 1e-6:
            raise RuleError(f"G{kind} R{r:g}: the radius is shorter than half the chord "
                            f"({chord / 2:.4f})")
        h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
        side = -1.0 if (kind == 2) == (r > 0) else 1.0
        mx, mz = (start[0] + end[0]) / 2, (start[1] + end[1]) / 2
        return (mx + side * h * dz / chord, mz - side * h * dx / chord)
    if not (block.has("I") or block.has("K")):
        raise RuleError(f"G{kind} needs R, or I and K (the centre from the start; I a radius)")
    return start[0] + _value(run, block, "I", 0.0), start[1] + _value(run, block, "K", 0.0)
