"""M61, M70-M73 and polar coordinates: what the differential test (tests/test_gcode_rs274.py)
cannot show, because rs274 run alone does not keep it (the tool M61 sets) or prints no trace of
it, checked against hand computations."""

from __future__ import annotations

from pathlib import Path

import pytest

from retrofit.commands import FMov, Tool
from retrofit.config import load_machine
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.tooltable import ToolTable

HERE = Path(__file__).resolve().parent / "gcode"
MACHINE = load_machine(HERE / "rs274-mill.toml")
TOOLS = ToolTable.load(HERE / "tool.tbl")


def run(text: str):
    return compile_program(text, MACHINE, tool_table=TOOLS)


def ends(program) -> list[tuple]:
    return [tuple(v for _, v in c.axes) for c in program.commands if isinstance(c, FMov)]


def test_m61_sets_the_tool_number_without_a_change():
    # tool 3 of tool.tbl: X1.5 Z4; #5400 reads 3 on the next line and G43 alone applies tool 3
    prog = run("M61 Q3\nG0 X#5400 Y[#<_current_tool>*2]\nG43\nG0 X3 Z1\nM2")
    assert not any(isinstance(c, Tool) for c in prog.commands)
    assert ends(prog) == [(3.0, 6.0, 0.0), (4.5, 6.0, 5.0)]


def test_m61_then_m6_changes_to_the_selected_tool():
    prog = run("T2\nM61 Q1\nM6\nG0 X#5400\nM2")
    assert [c for c in prog.commands if isinstance(c, Tool)] == [Tool(2)]
    assert ends(prog) == [(2.0, 0.0, 0.0)]


@pytest.mark.parametrize("text, message", [
    ("G0 X1\nM61 Q8\nM2", "2: M61 Q8: requested tool 8 not found in the tool table"),
    ("M61 Q-0.6\nM2", "1: M61 Q-0.6: M61 needs Q<tool number>"),
    ("M61\nM2", "1: M61 without Q: M61 needs Q<tool number>"),
])
def test_m61_refusals_name_the_line_and_rule(text, message):
    with pytest.raises(GcodeError, match=message.replace("<", ".").replace(">", ".")):
        run(text)
