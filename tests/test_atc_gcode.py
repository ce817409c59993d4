"""T, M6, G43 and G49 in part programs for the mill with the tool changer."""

from dataclasses import replace

import pytest

from retrofit.atc.cell import SimCell
from retrofit.atc.changer import ToolChanger
from retrofit.atc.gcode import ToolSession
from retrofit.atc.sequences import change_sequence
from retrofit.atc.settings import atc_of
from retrofit.atc.state import SpindleStore
from retrofit.atc.tooltable import Reference, ToolEntry, ToolTable
from retrofit.commands import Spin
from retrofit.config import load_machine
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program

MILL = load_machine("tul-mill")
ATC = atc_of(MILL)
ON_M6 = replace(MILL, parts={**MILL.parts, "atc": replace(ATC, change_on="M6")})
TABLE = ToolTable("tul-mill", Reference(1, 20.0, 32.0), {3: ToolEntry(24.5, 6.0), 8: ToolEntry(10.25, 0.8)})


def compiled(text, machine=MILL, tool=0, table=TABLE):
    session = ToolSession(machine, tool, table)
    with session.active():
        program = compile_program(text, machine, file="prog.ngc")
    return [str(c) for c in program.commands], session


def test_tn_m6_is_the_documents_sequence():
    commands, session = compiled("T3 M6", ON_M6)
    assert commands == [str(c) for c in change_sequence(ATC, 0, 3).commands()]
    assert session.tool == 3 and [(m.current, m.new) for m in session.changes] == [(0, 3)]


def test_t_alone_only_selects_when_changes_happen_on_m6():
    commands, session = compiled("T3\nG0 X1 Y1 Z1\nM6", ON_M6)
    assert commands[0] == "FMOV X1 Y1 Z1 E0"                  # nothing moved for T3 alone
    assert commands[1:] == [str(c) for c in change_sequence(ATC, 0, 3).commands()]


def test_t_alone_changes_the_tool_on_tul_mill_as_in_the_document():
    commands, _ = compiled("T3")
    assert commands == [str(c) for c in change_sequence(ATC, 0, 3).commands()]
    again, _ = compiled("T3 M6")                              # M6 in the same block: one change
    assert again == commands


def test_changes_follow_the_tool_through_the_program():
    commands, session = compiled("T3\nT5\nT5\nT0", tool=0)
    expected = [c for cur, new in [(0, 3), (3, 5), (5, 0)] for c in change_sequence(ATC, cur, new).commands()]
    assert commands == [str(c) for c in expected]
    assert [(m.current, m.new) for m in session.changes] == [(0, 3), (3, 5), (5, 0)]


def test_after_a_change_the_program_goes_on_from_where_the_change_left_the_axes():
    commands, _ = compiled("G0 X5 Y5 Z5\nT3\nG91\nG0 X1")
    assert commands[-1] == "FMOV X24 Y28 Z45 E0"               # X1 + 1, Y_POINT_A, Z_POINT_2, door closed


def test_the_spindle_stops_before_a_change_and_the_feed_is_sent_again():
    commands, _ = compiled("S1000 M3\nG1 X5 F300\nT3\nG1 X10")
    change = commands.index("FMOV X23 Y28 Z40.5")
    assert commands[change - 1] == str(Spin(0.0, 0))
    assert commands[-2:] == ["PFDR F300", "PMOV X10 Y28 Z45 E0"]


def test_a_change_under_g92_moves_to_the_machine_positions(tmp_path):
    changer, cell = ToolChanger(MILL, SpindleStore("tul-mill", tmp_path / "s.json")), SimCell(MILL)
    session = ToolSession(MILL, changer.spindle_tool, TABLE)
    with session.active():
        program = compile_program("G0 X10 Y10 Z10\nG92 X0 Y0\nT3\nG0 X2 Y2\nT0", MILL)
    changer.run_program(program.commands, session.changes, cell)
    assert cell.violations == []
    assert cell.magazine.state.spindle is None and cell.magazine.state.pockets[3] == 3
    assert any(m.reached_mm["X"] == 23.0 and m.reached_mm["Y"] == 44.0 for m in cell.moves())
    assert changer.spindle_tool == 0


@pytest.mark.parametrize("text, message", [
    ("T13", "T13: no such tool on tul-mill; the carousel has pockets 1..12"),
    ("T2.5", "T2.5: a tool number must be a whole number 0..12"),
    ("T-1", "T-1: a tool number cannot be negative"),
    ("M6", "M6 without a tool selected"),
    ("G43 H5", "G43 H5: tool 5 has no measured length in the tool table of tul-mill"),
    ("G0 X1 H3", "H3 without G43"),
    ("G0 E3", "unknown word 'E3'"),
], ids=["out-of-range", "fraction", "negative", "m6-alone", "unmeasured", "h-alone", "carousel-word"])
def test_refused_with_file_line_before_any_command(text, message):
    with pytest.raises(GcodeError) as err:
        compiled("G0 X1 Y1 Z1\n" + text)
    assert str(err.value).startswith(f"prog.ngc:2: {message}")


def test_a_tool_change_outside_a_session_says_how_to_run_it():
    with pytest.raises(GcodeError, match="needs the tool in the spindle; compile the program in a ToolSession"):
        compile_program("T3", MILL)


def test_other_machines_have_no_tool_words():
    lathe = load_machine("chivu-lathe")
    with pytest.raises(GcodeError, match="T1: machine chivu-lathe has no tool changer"):
        compile_program("T1", lathe)
    with pytest.raises(GcodeError, match="M6 is not supported; supported: M2 M3 M4 M5 M7 M8 M9 M30"):
        compile_program("M6", lathe)


def test_g43_shifts_z_by_the_length_offset_and_g49_cancels_it():
    # Z counts downward: T3 is 4.5 mm longer than the reference, so the gauge line goes 4.5 mm higher
    commands, _ = compiled("G0 X5 Y5 Z10\nG43 H3\nG0 Z10\nG43 H8\nG0 Z20\nG49\nG0 Z20")
    assert commands == ["FMOV X5 Y5 Z10 E0", "PSTN Z14.5", "FMOV X5 Y5 Z10 E0",
                        "PSTN Z-4.25", "FMOV X5 Y5 Z20 E0", "PSTN Z29.75", "FMOV X5 Y5 Z20 E0"]


def test_g43_without_h_uses_the_tool_in_the_spindle():
    commands, _ = compiled("G43\nG0 X5 Y5 Z10", tool=3)
    assert commands == ["PSTN Z4.5", "FMOV X5 Y5 Z10 E0"]
