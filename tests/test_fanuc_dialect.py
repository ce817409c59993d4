"""The Fanuc/Haas lathe dialect's rules: chosen, never guessed; what it reads and what it refuses.

Refusals name the file, the line, what was wrong and what would be read; machine-dependent
readings follow the machine file's ``[fanuc]`` section.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import pytest

from retrofit.cli import main
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

DATA = Path(__file__).parent / "data" / "fanuc"


@pytest.fixture(scope="module")
def lathe():
    return load_machine(DATA / "fanuc-school-lathe.toml")


def with_settings(machine, **changes):
    parts = dict(machine.parts, fanuc=dataclasses.replace(machine.parts["fanuc"], **changes))
    return dataclasses.replace(machine, parts=parts)


def fmovs(program) -> list[str]:
    return [str(c) for c in program.commands if str(c).startswith(("FMOV", "PMOV"))]


def refused(text: str, machine, **kw) -> str:
    with pytest.raises(GcodeError) as info:
        compile_program(text, machine, "part.nc", **kw)
    return str(info.value)


def test_a_fanuc_program_is_refused_without_the_dialect_never_guessed():
    """mitic-lathe's machine file names no dialect: its M31 and G50 are refused, as before."""
    mitic = load_machine("mitic-lathe")
    assert mitic.dialect == "rs274"
    text = "O0001\nG50 S2000\nM31\nG00 X40. Z2.\nM30\n"
    assert "G50" in refused(text, mitic)
    program = compile_program(text, mitic, "part.nc", dialect="fanuc")
    assert fmovs(program)[-1] == "FMOV X20 Z2"          # diameter 40: 20 mm from the axis


def test_unknown_g_code_names_file_line_and_what_is_read(lathe):
    message = refused("G98\nG00 X40. Z2.\nG140 X20.\nM30\n", lathe)
    assert message.startswith("part.nc:3: G140: not read under the Fanuc dialect (read: G0 G1")
    assert "G70-G76" in message


def test_unknown_m_code_is_refused_and_harmless_ones_run_with_a_note(lathe):
    assert refused("M51\n", lathe).startswith("part.nc:1: M51: not read under the Fanuc dialect")
    program = compile_program("M41\nM31\nM08\nM09\nM33\nM30\n", lathe, "part.nc")
    notes = [(line, text) for _, line, kind, text in program.messages if kind == "NOTE"]
    assert [line for line, _ in notes] == [1, 2, 5]
    assert "gear range 1" in notes[0][1] and "chip conveyor" in notes[1][1]
    assert [str(c) for c in program.commands] == ["COOL M8", "COOL M0"]


def test_g80_leaves_the_motion_mode_as_on_a_fanuc_lathe(lathe):
    """G80 cancels the drilling cycles (group 10); G01 (group 01) stays in force."""
    program = compile_program("G98\nG00 X20. Z2.\nG01 Z-5. F100.\nG80\nZ-10.\nM30\n", lathe, "p.nc")
    assert fmovs(program) == ["FMOV X10 Z2", "PMOV X10 Z-5", "PMOV X10 Z-10"]


def test_u_and_w_are_incremental_diameter_and_z(lathe):
    program = compile_program("G98\nG00 X40. Z2.\nU-10. W-5.\nG01 U4. F100.\nM30\n", lathe, "p.nc")
    assert fmovs(program) == ["FMOV X20 Z2", "FMOV X15 Z-3", "PMOV X17 Z-3"]
    assert "X and U in one block" in refused("G98\nG00 X40. U2.\n", lathe)


def test_g50_x_z_sets_the_coordinates_and_g50_s_caps_constant_surface_speed(lathe):
    text = "G98\nG00 X40. Z10.\nG50 X100. Z50.\nG00 X90. Z50.\nG50 S500\nG96 S200 M03\nM30\n"
    program = compile_program(text, lathe, "p.nc")
    assert fmovs(program)[-1] == "FMOV X15 Z10"          # 10 mm less on the diameter: 5 mm radius
    spins = [str(c) for c in program.commands if str(c).startswith("SPIN")]
    assert spins == ["SPIN S500 D1", "SPIN S0 D0"]       # 200 m/min at X90 is 707 rpm: capped at 500


def test_g92_s_is_read_as_the_spindle_cap_with_a_note(lathe):
    program = compile_program("G92 S800\nG96 S300 M03\nG98 G00 X10. Z2.\nM30\n", lathe, "p.nc")
    assert any("G92 S800" in m[3] for m in program.messages)
    assert [str(c) for c in program.commands if str(c).startswith("SPIN")][-2] == "SPIN S800 D1"


def test_feed_per_revolution_is_the_default_and_g98_feeds_per_minute(lathe):
    program = compile_program("M03 S500\nG00 X20. Z2.\nG01 Z-10. F0.2\nG98 G01 Z-20. F80.\nM30\n",
                              lathe, "p.nc")
    assert [str(c) for c in program.commands if str(c).startswith("PFDR")] == ["PFDR F100", "PFDR F80"]


def test_feed_per_revolution_on_a_machine_without_encoder_says_how_to_choose(lathe):
    chivu = load_machine("chivu-lathe")
    message = refused("G00 X20. Z2.\nG01 Z-10. F0.2\n", chivu, dialect="fanuc")
    assert message.startswith("part.nc:2: G99 (feed per revolution, the Fanuc default)")
    assert 'feed_at_start = "per_min"' in message
    ok = compile_program("G98\nG00 X20. Z2.\nG01 Z-10. F100.\nM30\n", chivu, "p.nc", dialect="fanuc")
    assert fmovs(ok)[-1] == "PMOV X10 Z-10"


def test_tool_words_by_the_machine_setting(lathe):
    table = ToolTable.load(DATA / "tools.tbl")
    program = compile_program("T0304\nT0300\nM30\n", lathe, "p.nc", tool_table=table)
    assert [str(c) for c in program.commands] == ["TOOL T3"]
    assert "T5: which tool and which offset?" in refused("T5\n", lathe)
    two = with_settings(lathe, tool_digits=2)
    assert [str(c) for c in compile_program("T34\nM30\n", two, "p.nc").commands] == ["TOOL T3"]


def test_whole_numbers_follow_the_machine_setting(lathe):
    text = "G98\nG00 X20 Z2\nM30\n"
    assert fmovs(compile_program(text, lathe, "p.nc"))[-1] == "FMOV X10 Z2"
    fanuc_dpi0 = with_settings(lathe, whole_numbers="increments")
    assert fmovs(compile_program(text, fanuc_dpi0, "p.nc"))[-1] == "FMOV X0.01 Z0.002"


def test_radius_programming_when_the_machine_says_so(lathe):
    radius = with_settings(lathe, x_diameter=False)
    assert fmovs(compile_program("G98\nG00 X20. Z2.\nM30\n", radius, "p.nc"))[-1] == "FMOV X20 Z2"


def test_g53_is_measured_from_the_reference_position_as_on_fanuc_and_haas(lathe):
    """``G53 X0 Z0`` sends a Fanuc or Haas lathe home; here home is [homing]'s X130 Z200."""
    program = compile_program("G98\nG00 X20. Z2.\nG53 X0 Z0\nG53 X-100. Z-50.\nM30\n", lathe,
                              "p.nc", start_mm={"X": 130.0, "Z": 200.0})
    assert fmovs(program) == ["FMOV X10 Z2", "FMOV X130 Z200", "FMOV X80 Z150"]


def test_dwell_p_is_milliseconds_without_a_point_and_x_seconds(lathe):
    program = compile_program("G04 P1500\nG04 X2.\nG04 P0.5\nM30\n", lathe, "p.nc")
    assert [str(c) for c in program.commands] == ["DELY P1.5", "DELY P2", "DELY P0.5"]


def test_program_numbers_percent_and_subprogram_calls(lathe):
    text = ("%\n:0100 (MAIN)\nG98 G00 X20. Z0.\nM98 P1000 L2\nM98 P21000\nM97 P50\nM30\n"
            "N50 G00 W1.\nM99\n%\nO1000\nG00 W-1.\nM99\n%\n")
    program = compile_program(text, lathe, "p.nc")
    assert fmovs(program) == ["FMOV X10 Z0", "FMOV X10 Z-1", "FMOV X10 Z-2", "FMOV X10 Z-3",
                              "FMOV X10 Z-4", "FMOV X10 Z-3"]
    assert "no program O2000" in refused("M98 P2000\n", lathe)


def test_m99_in_the_main_program_ends_it_with_a_note(lathe):
    program = compile_program("G98 G00 X20. Z0.\nM99\nG00 X40.\n", lathe, "p.nc")
    assert fmovs(program) == ["FMOV X10 Z0"]
    assert any("M99" in m[3] for m in program.messages)


POCKET = ("G98 M03 S500\nG00 X42. Z2.\nG71 U1. R0.5\nG71 P10 Q40 U0.2 W0.1 F100.\n"
          "N10 G00 X20. Z2.\nG01 Z-10.\nX30. Z-20.\nX24. Z-30.\nN40 X42. Z-40.\nM30\n")


def test_type_ii_roughs_the_pocket_level_by_level_and_never_enters_the_part(lathe):
    """The profile X20 -> Z-10 -> X30 Z-20 -> X24 Z-30 -> X42 Z-40 has a pocket between Z-20
    and Z-40; shifted by the allowances (0.1 mm a side, 0.1 mm in Z) its corners are X20.2 Z2.1,
    X20.2 Z-9.9, X30.2 Z-19.9, X24.2 Z-29.9, X42.2 Z-39.9. Worked by hand: at X30 (1 mm a side
    from X42) the pocket is cut from Z-20.2333 (the far flank at X30) to Z-33.1222; at X26 from
    Z-26.9 to Z-30.9; at X24 there is none (its floor is at X24.2)."""
    program = compile_program(POCKET, lathe, "p.nc")
    cuts, here = [], None
    for command in program.commands:
        name, *words = str(command).split()
        if name in ("FMOV", "PMOV"):
            v = {w[0]: float(w[1:]) for w in words}
            point = (round(2 * v["X"], 4), round(v["Z"], 4))
            if name == "PMOV" and here is not None and here[0] == point[0]:
                cuts.append((point[0], here[1], point[1]))
            here = point
    assert (30.0, -20.2333, -33.1222) in cuts and (26.0, -26.9, -30.9) in cuts
    assert not [c for c in cuts if c[0] == 24.0 and c[1] < -20]
    corners = [(2.1, 20.2), (-9.9, 20.2), (-19.9, 30.2), (-29.9, 24.2), (-39.9, 42.2)]
    for command in program.commands:                    # every point stays on or above the
        name, *words = str(command).split()             # profile shifted by the allowances
        if name not in ("FMOV", "PMOV"):
            continue
        v = {w[0]: float(w[1:]) for w in words}
        for (z0, x0), (z1, x1) in itertools.pairwise(corners):
            if z1 <= v["Z"] <= z0:
                floor = x0 + (x1 - x0) * (v["Z"] - z0) / (z1 - z0)
                assert 2 * v["X"] >= floor - 1e-6, (command, floor)
    assert fmovs(program)[-1] == "FMOV X21 Z2"


def test_type_ii_can_be_switched_off_and_must_run_one_way_along_z(lathe):
    off = with_settings(lathe, g71_type2=False)
    assert "g71_type2 = false" in refused(POCKET, off)
    back = POCKET.replace("X24. Z-30.", "X24. Z-15.")
    assert "must run one way along the cut axis" in refused(back, lathe)


def test_g76_thread_chamfer_pulls_each_pass_out_at_45_degrees(lathe):
    """P011060: one finishing pass, chamfer 10 tenths of the lead (1.5 mm for F1.5), 60 degrees.
    Worked by hand: the full-depth pass runs at X18.16 to Z-18.5, then out to X21.16 at Z-20
    (1.5 mm a side over 1.5 mm), a synchronised move 1.5 sqrt(2) mm long per turn."""
    text = "M03 S400\nG00 X24. Z5.\nG76 P011060 Q50 R0.\nG76 X18.16 Z-20. P920 Q300 F1.5\nM30\n"
    program = compile_program(text, lathe, "part.nc")
    words = [str(c) for c in program.commands]
    last = len(words) - 1 - words[::-1].index("ISTP")
    assert words[last:last + 3] == ["ISTP", "PFDR F1.5", "PMOV X9.08 Z-18.5"]
    assert float(words[last + 3][6:]) == pytest.approx(1.5 * 2 ** 0.5, abs=1e-9)
    assert words[last + 4] == "PMOV X10.58 Z-20"
    assert words[last + 5:last + 7] == ["CSTP", "FMOV X12 Z-20"]
    too_long = text.replace("P011060", "P019960")
    assert "shorter than the thread" in refused(too_long, lathe) or \
        "pass the start point" in refused(too_long, lathe)


def test_a_word_the_block_does_not_use_is_refused_not_dropped(lathe):
    """Haas and some Fanuc controls round a G1 corner with R or chamfer it with C or I/K; they
    are refused here, not ignored."""
    message = refused("G98\nG00 X20. Z2.\nG01 Z-10. R1. F100.\n", lathe)
    assert message.startswith("part.nc:3: R1: not read in this block under the Fanuc dialect")
    assert "C2" in refused("G98\nG01 X20. Z-2. C2. F100.\n", lathe)


def test_a_thread_under_constant_surface_speed_is_refused_with_the_fanuc_remedy(lathe):
    text = "G50 S1000\nG96 S100 M03\nG00 X24. Z5.\nG92 X19. Z-20. F1.5\n"
    assert refused(text, lathe).startswith("part.nc:4: a thread (G32, G92, G76) under G96")


def test_macro_variables_are_refused_with_the_line(lathe):
    assert refused("G98\n#1=20.\nG00 X#1\n", lathe).startswith("part.nc:2: custom macro variables")


def test_cli_reads_a_fanuc_program_with_dialect_option(tmp_path, capsys):
    program = tmp_path / "part.nc"
    program.write_text("%\nO0001\nG98\nG00 X20. Z2.\nG01 Z-5. F200.\nM31\nG00 X30.\nM30\n%\n")
    report = tmp_path / "r.json"
    assert main(["run", str(program), "--machine", "chivu-lathe", "--dialect", "fanuc",
                 "--report", str(report)]) == 0
    shown = capsys.readouterr().out
    assert "(target 15.000)" in shown and "line 6: note: M31 (chip conveyor forward)" in shown
    assert main(["run", str(program), "--machine", "chivu-lathe", "--report", str(report)]) == 2
