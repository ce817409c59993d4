"""T, M6, G43 / G49 and M0 / M1 / M60 in part programs.

T n selects a tool; M6 (or T n alone, on a machine whose ``[atc]`` says ``change_on = "T"``)
emits ``TOOL Tn``: the run decides how the tool gets into the spindle (the changer's sequence,
or a pause for a manual change). M0, M1 and M60 emit ``PAUS``. G43 Hn applies the Z offset of
tool n from the tool table (``tool.tbl``), G43 alone that of the tool in the spindle, G49 cancels
it; an offset shifts Z's program coordinate (PSTN).
"""

from __future__ import annotations

from ..commands import Paus, Pstn, Tool
from .state import clean_mm
from .validate import RuleError


def change_tool(translator, block) -> None:
    """T (select; on a machine that changes on T, also change) and M6 (change) of one block."""
    if "T" in block.values:
        value = block.values["T"]
        if not (value.is_integer() and 0 <= value <= 99999):
            raise RuleError(f"{block.texts.get('T', 'T')}: a tool number is a whole number from 0 to 99999")
        translator.selected_tool = int(value)
    atc = translator.machine.parts.get("atc")
    on_t = getattr(atc, "change_on", "M6") == "T" and "T" in block.values
    if not ("tool change" in block.m or on_t):
        return
    if translator.selected_tool is None:
        raise RuleError("M6 without a tool selected: give T<n> before it or in its block "
                        "(T0 leaves the spindle empty)")
    if translator.selected_tool == translator.spindle_tool:
        return
    translator._emit(Tool(translator.selected_tool))
    translator.spindle_tool = translator.selected_tool
    translator.state.spindle = 0 if atc is not None else translator.state.spindle
    translator.state.feed_sent = None                 # a change sets its own feeds


def pause(translator, block) -> None:
    """M0, M1, M60: PAUS with the M code."""
    translator._emit(Paus(int(block.m["stop"])))


def tool_length(translator, block) -> None:
    """G43 [Hn] or G49: shift Z's program coordinate by the change of the length offset."""
    code = block.g["tool length"]
    if code == 43:
        number = int(block.values["H"]) if "H" in block.values else translator.spindle_tool
        offset = 0.0
        if number:
            tool = translator.tool_table.get(number) if translator.tool_table is not None else None
            if tool is None:
                raise RuleError(f"G43 H{number}: tool {number} is not in the tool table (tool.tbl); "
                                f"measure it: retrofit setter measure T{number}")
            offset = tool.z_offset_mm
    else:
        offset = 0.0
    delta = offset - translator.length_offset_mm
    translator.length_offset_mm = offset
    tools = translator.machine.parts.get("tools")
    hang = getattr(tools, "hang_sign", -1)
    if delta:
        z = clean_mm(translator.state.position["Z"] + hang * delta)
        translator._emit(Pstn((("Z", z),)))
        translator.state.position["Z"] = z
        translator.offset_mm["Z"] = clean_mm(translator.offset_mm.get("Z", 0.0) - hang * delta)
