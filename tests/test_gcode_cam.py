"""What real CAM and hobby programs need (grbl-flavoured output of Fusion 360, CAMotics, GRBL-Plotter,
UGS and cncjs examples; ``bench/cam_corpus.py`` measures them): each rule checked on a few lines
shaped as those programs write them, by hand and, where LinuxCNC runs the program, against a
live ``rs274``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from retrofit.commands import FMov, PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program

from tests.gcode.regenerate import run_rs274
from tests.test_gcode_rs274 import MACHINE, TOOLS, canon_events, compare, retrofit_points

needs_rs274 = pytest.mark.skipif(shutil.which("rs274") is None and not Path("/usr/bin/rs274").exists(),
                                 reason="LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace)")


def ends(text: str) -> list[tuple]:
    """The end point (X, Y, Z machine mm) of every move retrofit makes of ``text``."""
    program = compile_program(text, MACHINE, "p.ngc", tool_table=TOOLS)
    return [tuple(v for _, v in cmd.axes) for cmd in program.commands
            if isinstance(cmd, (FMov, PMov))]


def rs274(text: str, tmp_path) -> tuple[str, str]:
    """(rs274's first error line or 'ok', its canonical calls) for ``text``."""
    path = tmp_path / "p.ngc"
    path.write_text(text)
    head, _, body = run_rs274(path).partition("\n")
    return head.partition(": ")[2], body


# -- G80 with a motion code in the same block ---------------------------------------------------

#: the preamble of many posts (CAMotics' examples, Mach3-style posts): G0 and G80 on one line;
#: each program with the end points of its moves, worked by hand
PREAMBLE = {
    "N1 G00 G17 G21 G40 G49 G80 G90\nG0 X10 Y5\nG1 Z-1 F100\nM2\n":
        [(10.0, 5.0, 0.0), (10.0, 5.0, -1.0)],
    "G21 G80 G0 X3\nM2\n": [(3.0, 0.0, 0.0)],
    "G21 G1 G80 X2 Y1 F200\nX4\nM2\n": [(2.0, 1.0, 0.0), (4.0, 1.0, 0.0)],
}


@pytest.mark.parametrize("text", PREAMBLE, ids=["preamble", "g80-first", "g1-g80"])
def test_g80_beside_another_motion_code_gives_way_to_it(text):
    # LinuxCNC reads G80 and a motion code of the same block as the motion code (interp_read)
    assert ends(text) == PREAMBLE[text]
    kinds = [type(c) for c in compile_program(text, MACHINE, "p.ngc").commands
             if isinstance(c, (FMov, PMov))]
    assert kinds == ([FMov, PMov] if "Z-1" in text else [PMov, PMov] if "G1" in text else [FMov])


@needs_rs274
@pytest.mark.parametrize("text", PREAMBLE, ids=["preamble", "g80-first", "g1-g80"])
def test_g80_beside_another_motion_code_as_rs274(text, tmp_path):
    status, body = rs274(text, tmp_path)
    assert status == "ok"
    compare(canon_events(body), retrofit_points(compile_program(text, MACHINE, "p.ngc")))


def test_two_motion_codes_other_than_g80_are_still_refused():
    with pytest.raises(GcodeError, match=r"p.ngc:1: two G codes used from the same modal group "
                                         r"\(motion\): G0 and G1"):
        compile_program("G0 G1 X1 F100\n", MACHINE, "p.ngc")


# -- grbl's power-up motion mode ------------------------------------------------------------------

def test_axis_words_before_any_motion_code_are_a_rapid_as_grbl_starts_in_g0():
    # GRBL-Plotter's gcode_relative.nc and Fusion 360's grbl output ("T12 M6" then "Z10")
    text = "G21\nG91\nZ2\nG0 X-10 Y-10\nG1 Z-5 F100\nY20\nM30\n"
    assert ends(text) == [(0.0, 0.0, 2.0), (-10.0, -10.0, 2.0), (-10.0, -10.0, -3.0),
                          (-10.0, 10.0, -3.0)]
    program = compile_program("G21 G90\nT1 M6\nZ10\nX5\nM30\n", MACHINE, "p.ngc",
                              tool_table=TOOLS)
    assert [type(c) for c in program.commands if isinstance(c, (FMov, PMov))] == [FMov, FMov]


def test_after_an_explicit_g80_axis_words_are_refused_as_in_linuxcnc_and_grbl():
    with pytest.raises(GcodeError, match=r"p.ngc:2: cannot use axis values without a G code"):
        compile_program("G21 G80\nX1\nM2\n", MACHINE, "p.ngc")
    with pytest.raises(GcodeError, match=r"p.ngc:4: cannot use axis values without a G code"):
        compile_program("G21\nG0 X1\nG80\nX2\nM2\n", MACHINE, "p.ngc")


def test_axis_words_in_the_g80_block_are_refused_as_rs274_does():
    # rs274: "Cannot use axis values with g80"
    with pytest.raises(GcodeError, match=r"p.ngc:1: cannot use axis values with G80"):
        compile_program("G21 G80 X1\n", MACHINE, "p.ngc")


# -- comments with a '(' inside -------------------------------------------------------------------

@pytest.mark.parametrize("line, moves", [
    # GRBL-Plotter's scripts: an inner comment left open, a note in brackets inside a comment
    ("( G91 G0 Z30 \t\t\t( move brush upwards in relative coordinates)", []),
    ("(Move to the sensor at machine coordinates (HOMING NEEDED!))", []),
    ("G0 X1 (a (nested) note) Y2", [(1.0, 2.0, 0.0)]),
], ids=["inner-open", "inner-pair", "nested-then-words"])
def test_a_paren_inside_a_comment_is_part_of_it(line, moves):
    # grbl ends a comment at its first ')' and skips a ')' outside one; a nested pair is read
    # as one comment (rs274 refuses both: "Nested comment found")
    assert ends(f"G21\n{line}\nM2\n") == moves


def test_a_comment_never_closed_is_still_refused_with_its_line():
    with pytest.raises(GcodeError, match=r"p.ngc:2: comment '\(' is not closed on this line"):
        compile_program("G21\nG0 X1 (open (and open\nM2\n", MACHINE, "p.ngc")


# -- laser output: S on every G1 line ---------------------------------------------------------------

#: shaped as FluidNC's tree_laser_mode.nc and LaserGRBL raster output: M4 S0, then G1 with an S
#: power per line, G0 with S0 between the rows
LASER = ("G21 G90\nG0 X0 Y0\nM4 S0\nF1000\nG0 X71 Y0.333 S0\nG1 X70.667 S43\nX70.333 S65\n"
         "X70 S43\nG0 X60 Y0.667 S0\nG1 X60.333 S20\nX61 S0\nM5\nM2\n")


def test_laser_power_per_line_runs_with_the_power_before_each_move():
    program = compile_program(LASER, MACHINE, "p.ngc")
    listing = [str(c) for c in program.commands]
    assert listing.index("SPIN S43 D-1") < listing.index("PMOV X70.667 Y0.333 Z0")
    assert listing.index("SPIN S65 D-1") < listing.index("PMOV X70.333 Y0.333 Z0")
    assert ends(LASER)[-1] == (61.0, 0.667, 0.0)


@needs_rs274
def test_laser_power_per_line_moves_as_rs274(tmp_path):
    status, body = rs274(LASER, tmp_path)
    assert status == "ok"
    compare(canon_events(body), retrofit_points(compile_program(LASER, MACHINE, "p.ngc")))
