"""M61, M70-M73 and polar coordinates: what the differential test (tests/test_gcode_rs274.py)
cannot show, because rs274 run alone does not keep it (the tool M61 sets) or prints no trace of
it, checked against hand computations."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from retrofit.commands import FMov, Tool
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

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


def test_polar_hole_circle_by_hand():
    # six holes on a 30 mm bolt circle round G54 X100 Y50, one every 60 degrees from 0 degrees
    prog = run("G10 L2 P1 X100 Y50\nG0 @15 ^0 Z5\nG98 G91 G81 ^60 R-3 Z-2 L6 F100\nG90 G80\nM2")
    holes = [(x, y) for x, y, z in ends(prog) if z == 2.0]
    expected = [(100 + 15 * math.cos(math.radians(a)), 50 + 15 * math.sin(math.radians(a)))
                for a in (60, 120, 180, 240, 300, 360)]
    assert len(holes) == 6
    for (x, y), (ex, ey) in zip(holes, expected):
        assert abs(x - ex) < 1e-9 and abs(y - ey) < 1e-9


def test_polar_inch_radius_and_angle_alone():
    # G20 @1 ^90: (0, 25.4) mm; ^180 keeps the radius; G91 @-0.5 halves it along the same ray
    prog = run("G20 G0 @1 ^90\n^180\nG91 @-0.5\nM2")
    assert [(round(x, 9), round(y, 9)) for x, y, _ in ends(prog)] == [(0.0, 25.4), (-25.4, 0.0),
                                                                      (-12.7, 0.0)]


def test_polar_refusal_names_the_line():
    with pytest.raises(GcodeError, match=r"^<string>:3: polar coordinates \(@ \^\) with cutter"):
        run("G0 X-10 Y-10\nG41.1 D2 G1 X0 Y0 F100\nG1 @5 ^10\nM2")


@pytest.mark.parametrize("name", ["m70m72-demo", "m73-demo", "toplevel"])
def test_m70_m73_demos_report_the_state_rs274_reports(name):
    # LinuxCNC's demos print the modal state (#<_imperial> #<_absolute> #<_feed> #<_rpm>) with
    # DEBUG before, inside and after the saving subroutine; rs274 printed them as MESSAGE calls
    golden = (HERE / "golden" / "linuxcnc" / f"{name}.canon").read_text()
    expected = [text.strip() for text in re.findall(r'MESSAGE\("(.*)"\)', golden)]
    prog = compile_program((HERE / "linuxcnc" / f"{name}.ngc").read_text(), MACHINE,
                           tool_table=TOOLS)
    got = [text for _, _, _, text in prog.messages]
    assert len(got) == len(expected)
    for ours, theirs in zip(got, expected):
        assert _numbers(ours) == pytest.approx(_numbers(theirs)) and \
            re.sub(_NUMBER, "", ours) == re.sub(_NUMBER, "", theirs)


_NUMBER = r"-?\d+(?:\.\d+)?"


def _numbers(text: str) -> list[float]:
    return [float(v) for v in re.findall(_NUMBER, text)]
