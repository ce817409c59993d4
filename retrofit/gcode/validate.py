"""G-code rules that need more than one word: soft limits, feed, and which words a block may use.

Each check raises :class:`RuleError` with the rule in words; the compiler adds file and line
and raises it as a :class:`~retrofit.errors.GcodeError` (``prog.ngc:12: ...``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..machine.config import Machine
from .errors import RuleError

#: slack on the soft limits, in steps of the axis: a point a tenth of a step beyond a limit (the
#: float noise of unit conversion, arcs and spirals ending on it) is on it; the step it rounds to is
LIMIT_SLACK_STEPS = 0.1


def check_soft_limits(machine: Machine, point_mm: Mapping[str, float], where: str = "") -> None:
    """Every axis of ``point_mm`` within its soft limits ``min_mm..max_mm`` (NaN is outside).

    ``where`` is added to the message (e.g. ``" on the G2 arc"``).
    """
    for name, low, high in _limits(machine):
        value = point_mm.get(name)
        if value is not None and not low <= value <= high:
            axis = machine.axis(name)
            if not math.isfinite(value):
                raise RuleError(f"{name} {value} mm{where} is not a finite number")
            raise RuleError(f"{name} {shown_mm(value, axis)} mm{where} is outside the soft limits "
                            f"{axis.min_mm:g}..{axis.max_mm:g} mm")


def shown_mm(value: float, axis) -> str:
    """A position beyond ``axis``'s soft limits as a message shows it: three decimals, more when
    three would put it on the limit, and never -0.000."""
    for digits in (3, 6, 9):
        text = f"{value:.{digits}f}"
        if not axis.min_mm <= float(text) <= axis.max_mm:
            break
    return text[1:] if float(text) == 0 and text.startswith("-") else text


def limit_slack_mm(axis) -> float:
    """How far beyond a soft limit a point is still on it (mm): :data:`LIMIT_SLACK_STEPS`."""
    return LIMIT_SLACK_STEPS / axis.steps_per_mm


_LIMITS: dict[int, tuple] = {}


def _limits(machine: Machine) -> tuple:
    limits = _LIMITS.get(id(machine))
    if limits is None or limits[0] is not machine:
        limits = _LIMITS[id(machine)] = (machine, tuple(
            (a.name, a.min_mm - limit_slack_mm(a), a.max_mm + limit_slack_mm(a)) for a in machine.axes))
    return limits[1]


#: the most chords one arc may become; more is refused before any chord is built
MAX_CHORDS = 200_000


def check_arc(machine: Machine, mode, lo: list, hi: list, chords: int, length: float) -> float:
    """An arc whose lowest and highest points (``lo``, ``hi``, over the machine's axes) are within
    the soft limits and whose chords are not too many; returns its length (mm)."""
    for axis, low, high in zip(machine.axes, lo, hi):
        for value in (low, high):
            if value < axis.min_mm - limit_slack_mm(axis) or value > axis.max_mm + limit_slack_mm(axis):
                raise RuleError(f"{axis.name} {shown_mm(value, axis)} mm on the G{mode:g} arc is outside the "
                                f"soft limits {axis.min_mm:g}..{axis.max_mm:g} mm")
    if chords > MAX_CHORDS:
        raise RuleError(f"G{mode:g}: the arc would be {chords} chords at the machine's arc "
                        f"tolerance; at most {MAX_CHORDS} (split it or fewer turns P)")
    return length


def check_feed(mode: int, feed_mm_min: float) -> None:
    """A feed move (G1, G2, G3) needs a feed above 0."""
    if not feed_mm_min > 0.0:
        raise RuleError(f"G{mode} with feed 0 (set F > 0)")


#: G codes of group 0 that take the block's axis words for themselves
AXIS_NONMODAL = (10, 28, 30, 92)
#: letters every block may carry
_ALWAYS = frozenset("FST")
#: canned cycles (motion group)
CYCLE_CODES = (73, 74, 81, 82, 83, 84, 85, 86, 87, 88, 89)


def check_word_use(block, mode) -> None:
    """Every word has a code in its block that uses it (LinuxCNC's "X word with no G code that
    uses it"), and two codes do not both claim the axis words.

    ``block`` is a :class:`~retrofit.gcode.blocks.Block`, ``mode`` the motion mode in force.
    """
    g = block.g
    if not block.values.keys() - _ALWAYS and not g:
        return                    # the common CAM block: axis words, F, S, T
    nonmodal = g.get("non-modal")
    if nonmodal in AXIS_NONMODAL and block.motion is not None and block.axes:
        raise RuleError(f"cannot use two G codes that both use axis values: G{block.motion:g} and "
                        f"G{nonmodal:g}; put them on separate lines")
    moving = bool(block.axes) and nonmodal not in AXIS_NONMODAL
    arc = mode in (2, 3) and (moving or (block.motion in (2, 3) and nonmodal not in AXIS_NONMODAL))
    cycle = mode in CYCLE_CODES and moving
    g76 = nonmodal == 76
    spline = mode in (5, 5.1) and block.motion == mode
    nurbs = mode == 5.2 and nonmodal not in AXIS_NONMODAL
    uses = {
        "I": arc or g76 or spline or (cycle and mode == 87) or (mode == 33.1 and moving),
        "J": arc or g76 or spline or (cycle and mode == 87),
        "K": arc or g76 or (mode in (33, 33.1) and moving) or (cycle and mode == 87),
        "R": arc or cycle or g76 or nonmodal == 10,
        "P": nonmodal in (4, 10) or arc or g76 or (cycle and mode in (74, 82, 84, 86, 88, 89))
        or g.get("path control") == 64 or (spline and mode == 5) or nurbs
        or block.m.get("override") in (50, 51, 52, 53) or "io" in block.m,
        "Q": block.m.get("io") == 66 or block.m.get("tool change") == 61 or g76 or (cycle and mode in (73, 83)) or g.get("path control") == 64
        or (spline and mode == 5),
        "L": block.m.get("io") == 66 or nonmodal == 10 or cycle or g76 or nurbs or g.get("cutter radius") in (41.1, 42.1),
        "H": g.get("tool length") == 43 or g76, "E": g76 or block.m.get("io") == 66,
        "D": g.get("cutter radius") in (41, 42, 41.1, 42.1) or g.get("spindle speed mode") == 96,
    }
    for letter, used in uses.items():
        if letter in block.values and not used:
            raise RuleError(f"{block.texts[letter]}: {letter} word with no G code that uses it "
                            f"({_USED_BY[letter]})")
    if "$" in block.values and "spindle" not in block.m and block.m.get("override") != 51 \
            and mode != 33 and nonmodal != 76 and "spindle speed mode" not in g:
        raise RuleError(f"{block.texts['$']}: $ (spindle selection) word with no M3, M4, M5, M51, "
                        f"G33, G76 or G97 to use it")
    if nonmodal == 4 and "P" not in block.values:
        raise RuleError("G4 needs P<seconds>, e.g. G4 P0.5")
    if nonmodal == 92 and not block.axes:
        raise RuleError("G92 with no axis words (G92 X0 sets the current X to 0)")


_USED_BY = {"I": "G2/G3 arcs, G5, G5.1, G33.1, G76, G87", "J": "G2/G3 arcs, G5, G5.1, G76, G87",
            "K": "G2/G3 arcs, G33, G33.1, G76, G87", "R": "G2/G3 arcs, canned cycles, G10, G76",
            "P": "G4, G10, G2/G3 turns, G5, G5.2, G74, G82, G84, G86, G88, G89, G64, G76, M50-M53, M62-M66",
            "Q": "G5, G73, G83, G64, G76, M61, M66",
            "L": "G10, canned cycles, G5.2, G76, G41.1/G42.1, M66",
            "H": "G43, G76", "E": "G76, M66", "D": "G41, G42, G41.1, G42.1, G96"}
