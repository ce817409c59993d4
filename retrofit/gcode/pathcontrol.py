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

from ..commands import Dely, FMov, PMov
from .errors import RuleError


def set_mode(tr, block) -> None:
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


def stop_between_blocks(tr, command) -> None:
    """Under G61/G61.1, a ``DELY P0`` before the first move of a block that follows another
    block's move."""
    if not isinstance(command, (FMov, PMov)) or tr.indexing:
        return
    here = (tr._file, tr._line)
    if tr.last_block not in (None, here):
        tr.commands.append(Dely(0.0))
        tr.lines.append(tr._line)
        tr.files.append(tr._file)
    tr.last_block = here
