"""Canned cycles G73, G74, G81-G89 in the XY plane (G17), as LinuxCNC runs them.

Words: X Y the hole, Z the bottom, R the retract plane, L repeats, P the dwell (G82, G86, G88,
G89, and G74/G84 at the bottom), Q the peck (G73, G83). Each hole: if Z is below R, rapid up to R first (once); rapid over the hole at
the clearance height; rapid down to R; the cycle's cut; back to the clearance height -- the start
height under G98, R under G99. The spindle cycles: G74 (left hand, M4) and G84 (right hand, M3)
tap with a floating holder -- feed in at F (program F = pitch x rpm), reverse the spindle, dwell,
feed out, turn forward again; G86 bores, stops the spindle at the bottom and rapids out; G88
bores, stops the spindle and pauses (M0) for the operator, then rapids out with the spindle
stopped (LinuxCNC leaves the retract to the operator's hands; a stepper machine's position
cannot be moved by hand) and restarts it. G87 back-bores: at R it moves off the hole by I J, stops the
spindle and pauses (PAUS M19) while the operator turns the stopped spindle so that the bar's edge
clears the hole (LinuxCNC orients the spindle, M19; these machines cannot), rapids down through the
hole to Z, back over the hole centre, restarts the spindle, feeds up to K and back down to Z, stops
and pauses again for the orientation, moves off by I J and rapids out, back over the hole centre,
and restarts the spindle. Under G91, X and Y are steps from hole to hole (repeated L
times), R is measured from the current Z, Z from R and G87's K from Z.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..canon import Pause, Spindle
from . import polar
from .errors import RuleError
from .state import clean_mm
from .threading import leave

if TYPE_CHECKING:
    from .translate import Translator

CYCLES = (73, 74, 81, 82, 83, 84, 85, 86, 87, 88, 89)
#: cycles that dwell P at the bottom and need P the first time
DWELLING = (82, 86, 88, 89)
#: cycles that need the spindle turning, and the direction they need (0: either)
SPINDLE = {74: -1, 84: 1, 86: 0, 87: 0, 88: 0}
#: G83's rapid stop above the last peck, and G73's chip-breaking retract (mm)
PECK_CLEARANCE_MM = 0.254
#: most holes one cycle block may drill (L)
MAX_REPEATS = 10000


def run(tr: Translator, block, mode) -> None:
    """One canned-cycle block."""
    s = tr.state
    if s.plane != 17 or not {"X", "Y", "Z"} <= set(tr.machine.axis_names):
        raise RuleError(f"G{mode:g}: canned cycles run in the XY plane (G17) of a machine with X, "
                        f"Y and Z")
    v = block.values
    if "R" not in v and s.cycle_r is None:
        raise RuleError(f"G{mode:g}: R clearance plane unspecified in cycle")
    if mode in (73, 83) and "Q" not in v and s.cycle_q is None:
        raise RuleError(f"G{mode:g}: Q word missing (the peck depth)")
    if mode in DWELLING and "P" not in v and s.cycle_p is None:
        raise RuleError(f"G{mode:g}: dwell time P word missing (seconds at the bottom)")
    if mode in SPINDLE:
        _check_spindle(s, mode)
    if mode == 87:
        s.cycle_ijk.update({a: v[a] for a in "IJK" if a in v})
        missing = [a for a in "IJK" if a not in s.cycle_ijk]
        if missing:
            raise RuleError(f"G87: {missing[0]} word missing (back boring needs I J, the offset "
                            f"that clears the hole, and K, the top of the back bore)")
    repeats = v.get("L", 1.0)
    if repeats != int(repeats) or not 0 <= repeats <= MAX_REPEATS:
        raise RuleError(f"{block.texts['L']}: L repeats a cycle 0 to {MAX_REPEATS} times")
    leave(tr)
    s.cycle_r = v.get("R", s.cycle_r)
    s.cycle_q = v.get("Q", s.cycle_q)
    s.cycle_p = v.get("P", s.cycle_p)
    s.cycle_z = block.axes.get("Z", s.cycle_z)
    if s.cycle_z is None:
        raise RuleError(f"G{mode:g}: Z value unspecified in XY plane canned cycle")
    offset_z = s.offset("Z")
    if s.cycle_start is None:                  # the initial level of this run of cycles
        s.cycle_start = s.position["Z"]
    old = s.cycle_start
    if s.incremental:
        r = old + s.to_mm(s.cycle_r)
        bottom = r + s.to_mm(s.cycle_z)
    else:
        r = s.to_mm(s.cycle_r) + offset_z
        bottom = s.to_mm(s.cycle_z) + offset_z
    if r < bottom:
        raise RuleError(f"G{mode:g}: R less than Z in cycle (R is the retract plane above the "
                        f"bottom Z)")
    if old < r:
        tr.rapid({**s.position, "Z": clean_mm(r)})
        old = r
    clear = r if s.retract_r else old
    if s.incremental:
        step = {a: s.word_mm(a, block.axes.get(a, 0.0)) for a in "XY"}
    hole = {a: block.axes[a] for a in "XY" if a in block.axes}
    height = max(s.position["Z"], r)         # the first hole is reached at the current height
    for _ in range(int(repeats)):
        if s.incremental:
            xy = {a: clean_mm(s.position[a] + step[a]) for a in "XY"}
            if block.polar is not None:          # G91 @ ^: out and round again at every hole
                xy = polar.turn_machine(s, xy, block.polar)
        else:
            xy = s.target(hole)
        tr.rapid({**s.position, "X": xy["X"], "Y": xy["Y"], "Z": clean_mm(height)})
        if height != r:
            tr.rapid({**s.position, "Z": clean_mm(r)})
        _cut(tr, mode, r, bottom, clear)
        height = clear


def _check_spindle(s, mode) -> None:
    need = SPINDLE[mode]
    if not s.spindle or s.rpm <= 0.0:
        raise RuleError(f"G{mode}: the spindle is not turning (M3 or M4 with S > 0 first)")
    if need and s.spindle != need:
        raise RuleError(f"G{mode}: the spindle turns {'counter' if need > 0 else ''}clockwise; "
                        f"G{mode} taps {'right' if need > 0 else 'left'}-handed and needs "
                        f"M{3 if need > 0 else 4}")


def _spindle_cycle(tr: Translator, mode, bottom: float, clear: float) -> bool:
    """G74, G84, G86, G88 at one hole (the tool at R); False for the other cycles."""
    s = tr.state
    if mode == 87:
        _back_bore(tr, bottom, clear)
        return True
    if mode not in SPINDLE:
        return False
    at = lambda z: {**s.position, "Z": clean_mm(z)}  # noqa: E731
    forward = Spindle(s.rpm, s.spindle)
    tr.feed_line(at(bottom), mode)
    if mode in (74, 84):
        tr.emit(Spindle(s.rpm, -s.spindle))
        tr.dwell(s.cycle_p or 0.0)
        tr.feed_line(at(clear), mode)
    else:
        tr.dwell(s.cycle_p if s.cycle_p is not None else 0.0)     # given: checked by run()
        tr.emit(Spindle(0.0, 0))
        if mode == 88:
            tr.emit(Pause(0))
        tr.rapid(at(clear))
    tr.emit(forward)
    return True


def _back_bore(tr: Translator, bottom: float, clear: float) -> None:
    """G87 at one hole, the tool at R over its centre."""
    s = tr.state
    centre = dict(s.position)
    off = {**centre, "X": clean_mm(centre["X"] + s.to_mm(s.cycle_ijk["I"])),
           "Y": clean_mm(centre["Y"] + s.to_mm(s.cycle_ijk["J"]))}
    k = s.to_mm(s.cycle_ijk["K"]) + (bottom if s.incremental else s.offset("Z"))
    forward = Spindle(s.rpm, s.spindle)
    at = lambda xy, z: {**xy, "Z": clean_mm(z)}  # noqa: E731
    tr.rapid(off)
    tr.emit(Spindle(0.0, 0))
    tr.emit(Pause(19))
    tr.rapid(at(off, bottom))
    tr.rapid(at(centre, bottom))
    tr.emit(forward)
    tr.feed_line(at(centre, k), 87)
    tr.feed_line(at(centre, bottom), 87)
    tr.emit(Spindle(0.0, 0))
    tr.emit(Pause(19))
    tr.rapid(at(off, bottom))
    tr.rapid(at(off, clear))
    tr.rapid(at(centre, clear))
    tr.emit(forward)


def _cut(tr: Translator, mode, r: float, bottom: float, clear: float) -> None:
    s = tr.state
    if _spindle_cycle(tr, mode, bottom, clear):
        return
    at = lambda z: {**s.position, "Z": clean_mm(z)}  # noqa: E731
    if mode in (73, 83):
        if s.cycle_q is None:                     # checked by run() as the cycle began
            raise RuleError(f"G{mode:g}: Q word missing (the peck depth)")
        peck = s.to_mm(s.cycle_q)
        if not peck > 0.0:
            raise RuleError(f"Q{s.cycle_q:g}: the peck depth Q must be > 0")
        if (r - bottom) / peck > 100000:
            raise RuleError(f"Q{s.cycle_q:g}: more than 100000 pecks; raise Q")
        depth = r - peck
        while depth > bottom:
            tr.feed_line(at(depth), mode)
            if mode == 83:
                tr.rapid(at(r))
                tr.rapid(at(depth + PECK_CLEARANCE_MM))
            else:
                tr.rapid(at(depth + PECK_CLEARANCE_MM))
            depth -= peck
    tr.feed_line(at(bottom), mode)
    if mode in (82, 89):
        tr.dwell(s.cycle_p or 0.0)
    if mode == 85:
        tr.feed_line(at(r), mode)
        if clear != r:
            tr.rapid(at(clear))
    elif mode == 89:
        tr.feed_line(at(clear), mode)
    else:
        tr.rapid(at(clear))
