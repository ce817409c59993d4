"""G-code rules that need more than one word: soft limits, feed, and which words a block may use.

Each check raises :class:`RuleError` with the rule in words; the compiler adds file and line
and raises it as a :class:`~retrofit.errors.GcodeError` (``prog.ngc:12: ...``).
"""

from __future__ import annotations

from collections.abc import Mapping

from ..config import Machine

#: slack on the soft limits for the float noise of unit conversion and chord points (mm)
LIMIT_SLACK_MM = 1e-9


class RuleError(Exception):
    """A rule of the G-code front end is broken; the compiler adds file and line."""


def check_soft_limits(machine: Machine, point_mm: Mapping[str, float], where: str = "") -> None:
    """Every axis of ``point_mm`` within its soft limits ``min_mm..max_mm``.

    ``where`` is added to the message (e.g. ``" on the G2 arc"``).
    """
    for axis in machine.axes:
        value = point_mm.get(axis.name)
        if value is None:
            continue
        if value < axis.min_mm - LIMIT_SLACK_MM or value > axis.max_mm + LIMIT_SLACK_MM:
            raise RuleError(f"{axis.name} {value:.3f} mm{where} is outside the soft limits "
                            f"{axis.min_mm:g}..{axis.max_mm:g} mm")


def check_feed(mode: int, feed_mm_min: float) -> None:
    """A feed move (G1, G2, G3) needs a feed above 0."""
    if not feed_mm_min > 0.0:
        raise RuleError(f"G{mode} with feed 0 (set F > 0)")


def check_word_use(block, mode: int | None) -> None:
    """Words that need a particular code in the block: I/J/K/R need G2/G3, P needs G4,
    and the axis words of G28/G92 cannot also feed a motion code of the same block.

    ``block`` is a :class:`~retrofit.gcode.parser.ParsedBlock`, ``mode`` the motion mode in force.
    """
    nonmodal = block.g.get("non-modal")
    if nonmodal in (28, 92) and block.motion is not None and block.axes:
        raise RuleError(f"G{block.motion} and G{nonmodal} in one block both use the axis words; "
                        "put them on separate lines")
    moves = bool(block.axes) or block.motion is not None
    thread = mode == 33 and nonmodal not in (28, 92) and moves       # G33 takes K, its pitch
    arc_words = [block.texts[c] for c in "IJKR" if c in block.values and not (thread and c == "K")]
    arc_applies = mode in (2, 3) and nonmodal not in (28, 92) and moves
    if arc_words and not arc_applies and nonmodal != 76:
        raise RuleError(f"{arc_words[0]} is an arc word but no G2/G3 arc is made in this block")
    if "P" in block.values and nonmodal not in (4, 76):
        raise RuleError(f"{block.texts['P']} without G4 (P is the dwell time of G4, in seconds)")
    if nonmodal == 4 and "P" not in block.values:
        raise RuleError("G4 needs P<seconds>, e.g. G4 P0.5")
    if nonmodal == 92 and not block.axes:
        raise RuleError("G92 without an axis word (G92 X0 sets the current X to 0)")
    if "H" in block.values and block.g.get("tool length") != 43 and nonmodal != 76:
        raise RuleError(f"{block.texts['H']} without G43 (H names the tool whose length offset "
                        "G43 applies)")
