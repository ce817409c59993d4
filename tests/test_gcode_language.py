"""RS274NGC as LinuxCNC reads it: the two G28 bugs, O-words, tools, dialects and hardening."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from retrofit.commands import FMov, Paus, PMov, Tool, ZMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program, load_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

HERE = Path(__file__).resolve().parent / "gcode"
MILL = load_machine(HERE / "rs274-mill.toml")
ENGRAVER = load_machine("engraver")


def ends(program):
    """Where each move ends: (X, Y, Z) machine mm (ZMOV homes its axes to 0 on these machines)."""
    here, out = (0.0, 0.0, 0.0), []
    for cmd in program.commands:
        if isinstance(cmd, (FMov, PMov)):
            here = tuple(dict(cmd.axes)[n] for n in "XYZ")
        elif isinstance(cmd, ZMov):
            here = tuple(0.0 if not cmd.names or n in cmd.names else v for n, v in zip("XYZ", here))
        else:
            continue
        out.append(here)
    return out


def golden_ends(name: str) -> list[tuple]:
    """The end points rs274 printed for corpus program ``name`` (G21 programs, no offsets)."""
    from tests.test_gcode_rs274 import canon_events  # noqa: PLC0415
    text = (HERE / "golden" / "programs" / f"{name}.canon").read_text()
    return [e[1] for e in canon_events(text)]


# -- the two semantic bugs, against LinuxCNC's own output ---------------------------------------

def test_g28_with_an_axis_word_homes_only_that_axis():
    prog = load_program(HERE / "programs" / "g28-named-axis-bug1.ngc", MILL)
    # G0 X10 Y20 Z5 / G28 Z2 / G0 X1: X and Y stay where they were while Z goes home
    assert ends(prog) == [(10, 20, 5), (10, 20, 2), (10, 20, 0), (1, 20, 0)]
    assert ends(prog) == [pytest.approx(p, abs=1e-4) for p in golden_ends("g28-named-axis-bug1")]


def test_the_cam_retract_g91_g28_z0_moves_z_only():
    prog = load_program(HERE / "programs" / "g28-cam-retract.ngc", MILL)
    assert [p[:2] for p in ends(prog)[:3]] == [(10, 20)] * 3        # no diagonal rapid home
    assert ends(prog) == [pytest.approx(p, abs=1e-4) for p in golden_ends("g28-cam-retract")]


def test_after_g28_the_program_goes_on_from_machine_zero_with_the_g92_offset():
    prog = load_program(HERE / "programs" / "g28-after-g92-bug2.ngc", MILL)
    # G0 X20 / G92 X10 / G28 / G91 G1 X5 ends at X5 (LinuxCNC), not X15
    assert ends(prog)[-1] == (5, 0, 0)
    assert ends(prog)[-1] == pytest.approx(golden_ends("g28-after-g92-bug2")[-1], abs=1e-4)


# -- language -------------------------------------------------------------------------------------

def test_subroutine_files_are_found_next_to_the_program_and_errors_name_them(tmp_path):
    (tmp_path / "peck.ngc").write_text("o<peck> sub\nG0 X#1\nG1 Z#2 F100\nG0 X[1/0]\no<peck> endsub\n")
    (tmp_path / "main.ngc").write_text("G0 Z1\no<peck> call [5] [-1]\nM2\n")
    with pytest.raises(GcodeError) as err:
        load_program(tmp_path / "main.ngc", MILL)
    assert (err.value.file, err.value.line) == ("peck.ngc", 4)
    (tmp_path / "peck.ngc").write_text("o<peck> sub\nG0 X#1\nG1 Z#2 F100\no<peck> endsub\n")
    prog = load_program(tmp_path / "main.ngc", MILL)
    assert ends(prog) == [(0, 0, 1), (5, 0, 1), (5, 0, -1)]
    assert prog.files[-1] == "peck.ngc" and prog.lines[-1] == 3


def test_o_word_errors_talk_about_o_words():
    with pytest.raises(GcodeError, match=r"^p.ngc:2: o<x> endsub without a matching o<x> sub"):
        compile_program("G0 X1\no<x> endsub\n", MILL, "p.ngc")
    with pytest.raises(GcodeError, match=r"^p.ngc:1: o100 call: unknown subroutine o100"):
        compile_program("o100 call\n", MILL, "p.ngc")


def test_an_endless_loop_is_refused_with_its_line_not_run_for_ever(monkeypatch):
    from retrofit.gcode import program  # noqa: PLC0415
    monkeypatch.setattr(program, "MAX_STEPS", 3000)
    with pytest.raises(GcodeError, match=r"^p.ngc:[13]: the program runs more than 3003 lines, 3000 more than it has"):
        compile_program("o1 while [1]\n#1=[#1+1]\no1 endwhile\n", MILL, "p.ngc")


def test_a_program_longer_than_the_loop_limit_runs_whole(monkeypatch):
    """The limit counts lines run beyond the program's own: a long CAM program is not a loop."""
    from retrofit.gcode import program  # noqa: PLC0415
    monkeypatch.setattr(program, "MAX_STEPS", 3000)
    text = "G21 G90 F600\n" + "".join(f"G1 X{1 + i % 50}\n" for i in range(5000)) + "M2\n"
    compiled = compile_program(text, MILL, "long.ngc")
    assert len(compiled.commands) >= 4900
    assert max(compiled.lines) >= 5001           # the last G1 (line 5001) was compiled


def test_messages_are_kept_with_their_line_and_parameters():
    prog = compile_program("#1=3\n(DEBUG, one is #1)\n(MSG, load the part)\n", MILL, "m.ngc")
    assert prog.messages == [("m.ngc", 2, "DEBUG", "one is 3"), ("m.ngc", 3, "MSG", "load the part")]


# -- tools, pauses --------------------------------------------------------------------------------

def test_m6_changes_tools_and_g43_applies_the_table_length():
    table = ToolTable.parse("T1 P1 Z10\nT2 P2 Z-2.5\n")
    prog = compile_program("T1 M6\nG43 H1\nG0 X0 Y0 Z5\nM0\nT2 M6 G43\nG0 Z5\nG49\nG0 Z5\n", MILL,
                           tool_table=table)
    tools = [c for c in prog.commands if isinstance(c, (Tool, Paus))]
    assert tools == [Tool(1), Paus(0), Tool(2)]
    assert [p[2] for p in ends(prog)] == [15, 2.5, 5]


def test_g43_with_a_tool_not_in_the_table_is_refused():
    with pytest.raises(GcodeError, match="G43 H4: tool 4 is not in the tool table"):
        compile_program("G43 H4\n", MILL, tool_table=ToolTable.parse("T1 Z1\n"))


def test_t_alone_changes_the_tool_where_the_changer_changes_on_t():
    prog = compile_program("T3\nG0 X1\n", load_machine("tul-mill"))
    assert prog.commands[0] == Tool(3)
    prog = compile_program("T3\nG0 X1\n", MILL)
    assert not any(isinstance(c, Tool) for c in prog.commands)


# -- dialects ---------------------------------------------------------------------------------------

def test_grbl_lines_run_what_has_a_meaning_and_skip_settings():
    text = "%\n$H\n$110=500\nG21 G90\n$J=G91 X5 F300\nG0 Y2\n%\n"
    prog = compile_program(text, ENGRAVER, "grbl.nc")
    assert [str(c) for c in prog.commands if isinstance(c, (FMov, PMov, ZMov))] == [
        "ZMOV", "PMOV X5 Y0 Z0", "FMOV X5 Y2 Z0"]
    assert [m[1] for m in prog.messages] == [3]


def test_3d_printer_codes_are_refused_clearly():
    with pytest.raises(GcodeError, match=r"^p.gcode:2: M104 \(hot-end temperature\) is a 3D-printer "
                                         r"code; a CNC machine cannot do it"):
        compile_program("G21\nM104 S200\n", ENGRAVER, "p.gcode")


# -- hardening --------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("G0 X50 Y50\nG2 X50 Y50 I900000000 F100", r"X 1800000050.000 mm on the G2 arc is outside"),
    ("G0 X50 Y50\nG2 X50 Y50 I40 P1000 F100", "arc would be"),
    ("G0 X50 Y50\nG2 X50 Y50 I10000000000 F100", "I1e\\+10: the value is not a finite number"),
    ("G92 X1" + "0" * 400, "not a finite number within"),
    ("G4 P100000", "G4 P100000: a dwell is from 0 to 86400 s"),
    ("G0 X[EXP[1000]]", "EXP\\[1000\\] overflows"),
], ids=["huge-arc", "too-many-chords", "overflowing-offset", "overflowing-g92", "long-dwell",
        "overflowing-expression"])
def test_numbers_that_overflow_are_refused_with_their_line_before_any_chord(text, message):
    started = time.process_time()
    with pytest.raises(GcodeError, match=message) as err:
        compile_program(text, ENGRAVER, "h.ngc")
    assert err.value.line == text.count("\n") + 1
    assert time.process_time() - started < 1.0


@pytest.mark.parametrize("separator", ["\v", "\f", "\u2028", "\x85", "\u2029", "\x1c"])
def test_only_newline_and_carriage_return_end_a_line(separator):
    prog = compile_program(f"G0 X1 ;comment{separator}G0 X50\nG0 Y2\r\nG0 Y3\rG0 Y4", ENGRAVER, "s.ngc")
    assert [p[:2] for p in ends(prog)] == [(1, 0), (1, 2), (1, 3), (1, 4)]
    assert prog.lines == [1, 2, 3, 4]
