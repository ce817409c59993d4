"""T, M6 and M61 in a block: the tool selected, changed (a TOOL command) or set without a change."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..canon import ChangeTool
from .blocks import Block
from .errors import RuleError
from .threading import leave

if TYPE_CHECKING:
    from .translate import Translator

#: the largest tool number a program may name
MAX_TOOL = 99999


def tool_words(tr: Translator, block: Block) -> None:
    """T selects a tool (and changes to it on machines that change on T); M6 changes to the
    selected one; M61 Q sets the tool in the spindle without a change."""
    s = tr.state
    if "T" in block.values:
        number = block.values["T"]
        if number < 0 or number != int(number) or number > MAX_TOOL:
            raise RuleError(f"{block.texts['T']}: a tool number is a whole number from 0 to "
                            f"{MAX_TOOL}")
        s.selected = int(number)
        if tr.change_on_t and "tool change" not in block.m:
            change_tool(tr, s.selected)
    if block.m.get("tool change") == 61:
        set_tool_number(tr, block)
    elif "tool change" in block.m:
        if s.selected is None:
            s.selected = s.tool      # M6 without T: LinuxCNC changes to the tool in the spindle
        change_tool(tr, s.selected)


def set_tool_number(tr: Translator, block: Block) -> None:
    """M61 Q: the tool in the spindle is now tool Q; nothing moves, no TOOL is sent."""
    number = math.floor(block.values.get("Q", -1.0) + 0.5)       # rs274 rounds to nearest
    if number < 0 or number > MAX_TOOL:
        raise RuleError(f"M61 {block.texts.get('Q', 'without Q')}: M61 needs Q<tool number>, "
                        f"a whole number from 0 to {MAX_TOOL}")
    if number and tr.tool_table is not None and tr.tool_table.get(number) is None:
        raise RuleError(f"M61 Q{number}: requested tool {number} not found in the tool table")
    tr.state.tool = number
    tr.state.params.write(5400, float(number))


def change_tool(tr: Translator, tool: int) -> None:
    """M6 (or T on change-on-T machines): a tool change to ``tool``, the selected one."""
    leave(tr)
    tr.state.tool = tool
    tr.state.params.write(5400, float(tr.state.tool))
    tr.emit(ChangeTool(tr.state.tool))
