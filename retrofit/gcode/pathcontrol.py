"""G61, G61.1 and G64 P Q: how the tool passes from one block into the next.

retrofit's planner never rounds a corner: the carriage passes through every programmed point
(within one motor step), and the look-ahead only chooses the speed at which it turns there (the
machine's ``junction_deviation_mm`` rule). So:

* ``G64`` (the default) and ``G64 P<mm>``: blocks flow into each other at the look-ahead's junction
  speeds; the path stays within any P of the programmed corners (it touches them), P >= 0;
* ``G61`` (exact path) and ``G61.1`` (exact stop): the tool stops at the end of every block --
  a ``DELY P0`` between blocks, which every planner honours as a stop. Chords of one arc or spline,
  one canned cycle and a synchronised thread chain are not split.
* ``G64 Q<mm>``: LinuxCNC's motion controller may merge nearly collinear moves into one as long
  as the path stays within Q of them (its naive-CAM detector); retrofit runs every move as
  programmed, a path within any Q >= 0 (as LinuxCNC's interpreter prints it: Q changes no move).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import RuleError

if TYPE_CHECKING:
    from .blocks import Block
    from .translate import Translator


def set_mode(tr: Translator, block: Block) -> None:
    """The path control code of ``block`` (G61, G61.1, G64) with its P and Q."""
    code, v = block.g["path control"], block.values
    if code != 64:
        tr.state.exact_stop = True
        return
    if "P" in v and not v["P"] >= 0.0:
        raise RuleError(f"{block.texts['P']}: G64's path tolerance P must be >= 0")
    if "Q" in v and not v["Q"] >= 0.0:
        raise RuleError(f"{block.texts['Q']}: G64's naive-CAM tolerance Q must be >= 0")
    tr.state.exact_stop = False


def stop_between_blocks(tr: Translator, move: bool) -> bool:
    """Under G61/G61.1: True when a stop (a dwell of 0 s, ``DELY P0``) goes before this call,
    the first move (``move``) of a block that follows another block's move."""
    if not move or tr.indexing:
        return False
    line, file = tr.where
    here = (file, line)
    stop = tr.last_block not in (None, here)
    tr.last_block = here
    return stop
