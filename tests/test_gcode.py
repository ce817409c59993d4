"""The G-code front end: programs become the exact commands, and every broken rule names file:line."""

import math
import re
from importlib import resources
from pathlib import Path

import pytest

from retrofit.commands import Cool, Dely, FMov, PFdr, PMov, Spin, ZMov
from retrofit.errors import GcodeError
from retrofit.gcode import Program, compile_program, load_program
from retrofit.machine.config import load_machine

ENGRAVER_TOML = """\
[machine]
name = "engraver"
tick_us = 1.0
port = "none"

[axis.x]
steps_per_mm = 80.0
min_mm = 0.0
max_mm = 200.0

[axis.y]
steps_per_mm = 80.0
min_mm = 0.0
max_mm = 200.0

[axis.z]
steps_per_mm = 400.0
min_mm = -20.0
max_mm = 20.0
"""


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def engraver(tmp_path_factory):
    shipped = resources.files("retrofit") / "machines" / "engraver.toml"
    if shipped.is_file():
        return load_machine("engraver")
    path = tmp_path_factory.mktemp("machines") / "engraver.toml"
    path.write_text(ENGRAVER_TOML)
    return load_machine(path)


def xz(x, z):
    return (("X", float(x)), ("Z", float(z)))


def xyz(x, y, z):
    return (("X", float(x)), ("Y", float(y)), ("Z", float(z)))


def at_line(n, text):
    """``text`` placed on line ``n`` of a program (comment lines before it)."""
    return "(setup)\n" * (n - 1) + text


def motions(program):
    return [c for c in program.commands if isinstance(c, (FMov, PMov))]


# -- translation ---------------------------------------------------------------------------------

def test_g0_g1_sequence_gives_exact_commands(lathe):
    prog = compile_program("G0 X10 Z2\nG1 Z-5 F100\nG1 X12.5\nG0 X20 Z5\nG1 Z0", lathe)
    assert prog.commands == [FMov(xz(10, 2)), PFdr(100.0), PMov(xz(10, -5)), PMov(xz(12.5, -5)),
                             FMov(xz(20, 5)), PMov(xz(20, 0))]
    assert prog.lines == [1, 2, 2, 3, 4, 5]
    assert prog.file == "<string>"
    assert isinstance(prog, Program)


def test_g1_before_any_f_uses_the_machine_default_feed(lathe):
    prog = compile_program("G1 X1", lathe)
    assert prog.commands == [PFdr(lathe.motion.default_feed_mm_min), PMov(xz(1, 0))]


def test_feed_is_sent_before_the_next_feed_move_only_when_it_changed(lathe):
    prog = compile_program("G1 X1 F100\nF100\nG1 X2\nF50\nG0 X3\nG1 X4\nG1 X5 F50", lathe)
    assert prog.commands == [PFdr(100.0), PMov(xz(1, 0)), PMov(xz(2, 0)), FMov(xz(3, 0)),
                             PFdr(50.0), PMov(xz(4, 0)), PMov(xz(5, 0))]
    assert prog.lines[4] == 6


def test_g91_incremental_becomes_absolute(lathe):
    prog = compile_program("G0 X10 Z0\nG91\nG1 X-2.5 Z-3 F100\nZ-3\nG90 G1 X1", lathe)
    assert motions(prog) == [FMov(xz(10, 0)), PMov(xz(7.5, -3)), PMov(xz(7.5, -6)), PMov(xz(1, -6))]


def test_g91_sums_do_not_pile_up_float_noise(lathe):
    prog = compile_program("G91\n" + "G1 X0.1 F100\n" * 30, lathe)
    assert motions(prog)[-1] == PMov(xz(3, 0))
    assert str(motions(prog)[2]) == "PMOV X0.3 Z0"


def test_g20_inches_become_mm_for_axes_feed_and_arc_words(engraver):
    prog = compile_program("G20 G0 X1 Y2 Z0.5\nG1 X2 F10\nG2 X3 Y3 I0 J1\nG21 G1 X10", engraver)
    cmds = prog.commands
    assert cmds[0] == FMov(xyz(25.4, 50.8, 12.7))
    assert cmds[1] == PFdr(254.0)
    assert cmds[2] == PMov(xyz(50.8, 50.8, 12.7))
    arc_end = motions(prog)[-2]
    assert arc_end == PMov(xyz(76.2, 76.2, 12.7))
    # the arc's centre is 1 inch above its start: every chord point 25.4 mm from it
    arc = [c.position() for c in motions(prog)[2:-1]]
    assert all(math.hypot(p["X"] - 50.8, p["Y"] - 76.2) == pytest.approx(25.4, abs=1e-6) for p in arc)
    assert motions(prog)[-1] == PMov(xyz(10, 76.2, 12.7))


def test_axis_words_alone_continue_the_last_motion_mode(lathe):
    prog = compile_program("G1 X1 F100\nX2\nZ-3\nG0 X5\nZ2", lathe)
    assert motions(prog) == [PMov(xz(1, 0)), PMov(xz(2, 0)), PMov(xz(2, -3)),
                             FMov(xz(5, -3)), FMov(xz(5, 2))]


def test_comments_block_delete_line_numbers_and_case(lathe):
    text = """%
(whole-line comment)
N10 g0 x10 (inline comment) z2 ; trailing comment
/G0 X5 (block delete is off, as in LinuxCNC: the line runs)
n20 G1 Z - 5 f 100
   ; only a comment
N30G1X12
%
"""
    prog = compile_program(text, lathe)
    assert prog.commands == [FMov(xz(10, 2)), FMov(xz(5, 2)), PFdr(100.0), PMov(xz(5, -5)),
                             PMov(xz(12, -5))]
    assert prog.lines == [3, 4, 5, 5, 7]


def test_start_position_is_where_the_program_begins(lathe):
    prog = compile_program("G91 G1 X-1 Z-2 F100", lathe, start_mm={"x": 5, "Z": 10})
    assert motions(prog) == [PMov(xz(4, 8))]


def test_dwell_home_and_set_position(lathe):
    prog = compile_program("G0 X5 Z5\nG4 P1.5\nG28\nG91 G0 X1\nG90 G92 X0 Z-10\nG0 Z-12", lathe)
    # G92 is an offset kept by the interpreter: Z-12 with Z reading -10 at machine 0 is machine -2
    assert prog.commands == [FMov(xz(5, 5)), Dely(1.5), ZMov(), FMov(xz(1, 0)), FMov(xz(1, -2))]


def test_g28_with_axis_words_goes_through_the_intermediate_point(lathe):
    prog = compile_program("G0 X5 Z5\nG28 Z10\nG91 G0 Z-1", lathe)
    # only the named axis goes home (LinuxCNC, grbl): X stays at 5
    assert prog.commands == [FMov(xz(5, 5)), FMov(xz(5, 10)), ZMov(("Z",)), FMov(xz(5, -1))]


def test_spindle_and_coolant(lathe):
    prog = compile_program("M3 S800\nS1000\nM4\nM5\nM7\nM8\nM9", lathe)
    assert prog.commands == [Spin(800.0, 1), Spin(1000.0, 1), Spin(1000.0, -1), Spin(0.0, 0),
                             Cool(7), Cool(8), Cool(0)]


def test_m30_ends_the_program_stopping_spindle_and_coolant(lathe):
    prog = compile_program("M3 S500 M8\nG0 X1\nM30\nG0 X999 Q5 G65\n", lathe)
    assert prog.commands == [Spin(500.0, 1), Cool(8), FMov(xz(1, 0)), Spin(0.0, 0), Cool(0)]
    assert prog.lines == [1, 1, 2, 3, 3]


def test_m2_ends_after_the_motion_of_its_own_block(lathe):
    prog = compile_program("G0 X1 M2\nG0 X2", lathe)
    assert prog.commands == [FMov(xz(1, 0))]


# -- arcs through G-code -------------------------------------------------------------------------

@pytest.mark.parametrize("text, end", [
    ("G17 G0 X10 Y20 Z1\nG2 X30 Y20 I10 J0 F200", xyz(30, 20, 1)),
    ("G17 G0 X10 Y20 Z1\nG3 X20 Y30 R10 F200", xyz(20, 30, 1)),
    ("G17 G0 X10 Y20 Z1\nG2 X20 Y10 R-10 F200", xyz(20, 10, 1)),
    ("G18 G0 X10 Y20 Z1\nG2 X14 Z5 I4 K0 F200", xyz(14, 20, 5)),
    ("G19 G0 X10 Y20 Z1\nG3 Y26 Z7 J0 K6 F200", xyz(10, 26, 7)),
    ("G17 G0 X10 Y20 Z1\nG91 G2 X12 Y2 I6 J1 Z-0.5 F200", xyz(22, 22, 0.5)),
], ids=["G2-IJ", "G3-R", "G2-R-long", "G18-IK", "G19-JK", "G91-helix"])
def test_arc_ends_exactly_on_its_end_point(engraver, text, end):
    prog = compile_program(text, engraver)
    assert motions(prog)[-1] == PMov(end)
    assert len(motions(prog)) > 3


def _arc_points(prog):
    return [c.position() for c in prog.commands if isinstance(c, PMov)]


@pytest.mark.parametrize("radius", [0.5, 15.0], ids=["r0.5", "r15"])
def test_arc_chords_stay_within_the_machine_tolerance(engraver, radius):
    prog = compile_program(f"G0 X100 Y100\nG3 X{100 + 2 * radius} Y100 I{radius} J0", engraver)
    pts = [(100.0, 100.0)] + [(p["X"], p["Y"]) for p in _arc_points(prog)]
    centre = (100.0 + radius, 100.0)
    for p, q in zip(pts[:-1], pts[1:]):
        assert math.dist(p, centre) == pytest.approx(radius, abs=1e-8)
        mid = ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2)
        assert radius - math.dist(mid, centre) <= engraver.motion.arc_tolerance_mm + 1e-9
    assert all(p[1] <= 100.0 + 1e-12 for p in pts)          # G3 from the left: under the centre


def test_negative_r_takes_the_long_way(engraver):
    short = _arc_points(compile_program("G0 X50 Y50\nG2 X60 Y60 R10", engraver))
    long = _arc_points(compile_program("G0 X50 Y50\nG2 X60 Y60 R-10", engraver))
    assert len(long) == pytest.approx(3 * len(short), abs=2)
    assert max(p["Y"] for p in short) == pytest.approx(60.0)
    assert min(p["X"] for p in long) < 50.0 - 9.0      # round the far side of centre X60 Y50


def test_full_circle_returns_to_its_start_exactly_in_steps(engraver):
    prog = compile_program("G0 X96.013 Y60.007 Z-0.3\nG2 X96.013 Y60.007 I-40 J0 F400", engraver)
    last = motions(prog)[-1]
    assert last == PMov(xyz(96.013, 60.007, -0.3))
    start_steps = [engraver.axis(n).to_steps(v) for n, v in FMov(xyz(96.013, 60.007, -0.3)).axes]
    assert [engraver.axis(n).to_steps(v) for n, v in last.axes] == start_steps
    ys = [c.position()["Y"] for c in motions(prog)]
    assert max(ys) == pytest.approx(100.007, abs=0.01) and min(ys) == pytest.approx(20.007, abs=0.01)


def test_g18_is_the_default_plane_on_a_lathe(lathe, engraver):
    # G2 from X10 Z0 around the centre X10 Z-3: clockwise in the (Z, X) plane seen from +Y
    # turns from +Z towards -X, so it passes through X7; G3 passes through X13
    pts = _arc_points(compile_program("G0 X10 Z0\nG2 X10 Z-6 K-3 F100", lathe))
    assert pts[-1] == {"X": 10.0, "Z": -6.0}
    assert min(p["X"] for p in pts) == pytest.approx(7.0, abs=1e-3)
    pts = _arc_points(compile_program("G0 X10 Z0\nG3 X10 Z-6 K-3 F100", lathe))
    assert max(p["X"] for p in pts) == pytest.approx(13.0, abs=1e-3)
    # the engraver has a Y axis: G17 is its default, so the same words are an XY arc there
    with pytest.raises(GcodeError, match="K-3 is not a centre offset in plane G17"):
        compile_program("G0 X10 Z0\nG2 X10 Z-6 K-3", engraver)


def test_arc_chord_outside_the_soft_limits_is_refused(engraver):
    with pytest.raises(GcodeError) as err:
        compile_program("G0 X5 Y100\nG2 X5 Y120 I0 J10 F100", engraver)
    assert err.value.line == 2
    assert "mm on the G2 arc is outside the soft limits 0..200 mm" in str(err.value)
    assert str(err.value).startswith("<string>:2: X -")


# -- every rule names file:line ------------------------------------------------------------------

@pytest.mark.parametrize("machine_name, line, text, message", [
    ("engraver", 12, "G0 X20 Y50\nG2 X40.4 Y50 I10 J0",
     "G2: radius to end of arc differs from radius to start by 0.4 mm (start radius 10.0000, "
     "end radius 10.4000; allowed 0.0282 mm, or 0.1% of the radius)"),
    ("lathe", 7, "G0 X1 Q5", "Q5: Q word with no G code that uses it (G5, G73, G83, G64, G76, M61, M66)"),
    ("lathe", 3, "G65 P1", "unknown G code used: G65"),
    ("lathe", 9, "G1 F100\nG1 X1 I2", "I2: I word with no G code that uses it (G2/G3 arcs, G5, G5.1, G33.1, G76, G87)"),
    ("lathe", 4, "G0 X1 Y2", "axis Y is not on machine chivu-lathe (axes: X, Z)"),
    ("lathe", 15, "G0 X45", "X 45.000 mm is outside the soft limits -40..40 mm"),
    ("lathe", 5, "F0\nG1 X1", "G1 with feed 0 (set F > 0)"),
    ("lathe", 8, "G2 X5 Z-5", "G2: R, I, J and K words all missing for arc (plane G18 takes K/I or R)"),
], ids=["radius-mismatch", "unknown-word", "unsupported-g", "no-axis-word", "axis-not-on-machine",
        "soft-limit", "feed-0", "arc-without-centre"])
def test_errors_name_file_line_and_rule(lathe, engraver, machine_name, line, text, message):
    machine = lathe if machine_name == "lathe" else engraver
    n_before = text.count("\n")
    with pytest.raises(GcodeError) as err:
        compile_program(at_line(line - n_before, text), machine, file="prog.ngc")
    assert str(err.value) == f"prog.ngc:{line}: {message}"
    assert (err.value.file, err.value.line, err.value.rule) == ("prog.ngc", line, message)


@pytest.mark.parametrize("text, message", [
    ("G0 X1 (open comment", "comment '(' is not closed on this line"),
    ("G0 X#<nope>", "named parameter #<nope> is not defined"),
    ("G0 X", "word 'X' has no value"),
    ("G0 X[1+", "a value is missing at the end of the line"),
    ("G0 X[1 ? 2]", "unknown operator '?2]'"),
    ("o100 sub", "o100 sub is never closed (no o100 endsub)"),
    ("o<loop> endwhile", "o<loop> endwhile without a matching o<loop> while"),
    ("G0 X[1/0]", "attempt to divide by zero"),
    ("G0 X1 E5", "E5: E word with no G code that uses it (G76, M66)"),
    ("M104 S200", "M104 (hot-end temperature) is a 3D-printer code"),
    ("G41 D1", "G41 D1: requested tool 1 not found in the tool table"),
    ("G0 X1 X2", "X given twice in one block (X1, X2)"),
    ("G0 G1 X1", "two G codes used from the same modal group (motion): G0 and G1"),
    ("M3 M5", "two M codes used from the same modal group (spindle): M3 and M5"),
    ("G1 X1 F-5", "F-5: a feed is from 0 to"),
    ("G1 X1 I2", "I2: I word with no G code that uses it"),
    ("G0 X1 P2", "P2: P word with no G code that uses it"),
    ("G4", "G4 needs P<seconds>"),
    ("G4 P1e15", "E15: E word with no G code that uses it"),
    ("G4 P1000000", "G4 P1e+06: a dwell is from 0 to 86400 s"),
    ("G92", "G92 with no axis words"),
    ("G1 G92 X1", "cannot use two G codes that both use axis values: G1 and G92"),
    ("G80 X1", "cannot use axis values with G80"),
    ("G1 X1 N5", "line number N must be the first word of the block"),
    ("G2 X10 Z0 R4", "G2 radius 4.000 mm is too small for the 10.000 mm from start to end"),
    ("G2 X1 Z1 R1" + "0" * 200, "R1e+200: the value is not a finite number within +-1e+09"),
    ("G2 X0 Z0 R4", "G2 with R cannot make a full circle"),
    ("G2 X0 Z0 I0 K0", "G2 radius 0"),
    ("G2 X1 Z1 I1 J1", "J1 is not a centre offset in plane G18 (use K and I)"),
    ("G2 X1 Z1 I1 R1", "G2 with both R and I1"),
    ("G17 G2 X1 Z1 I1", "G2 in plane G17 needs axes X and Y; machine chivu-lathe has X, Z"),
], ids=lambda v: v if len(v) < 20 else None)
def test_more_rules(lathe, text, message):
    with pytest.raises(GcodeError, match="^prog.ngc:1: " + _re(message)):
        compile_program(text + "\nG0 X1\n", lathe, file="prog.ngc")


def _re(text):
    return re.escape(text)


def test_soft_limit_on_the_last_line_returns_nothing(lathe):
    body = "".join(f"G1 X{i % 30} Z-{i} F100\n" for i in range(1, 60))
    text = "G0 X30 Z10\n" + body + "G0 Z-201\n"
    result = None
    with pytest.raises(GcodeError) as err:
        result = compile_program(text, lathe, file="prog.ngc")
    assert result is None
    assert str(err.value) == "prog.ngc:61: Z -201.000 mm is outside the soft limits -200..20 mm"


def test_load_program_names_the_file(lathe, tmp_path):
    path = tmp_path / "prog.ngc"
    path.write_text("G0 X10 Z2\nG1 Z-5 F100\nG0 X50\n")
    with pytest.raises(GcodeError, match=r"^prog.ngc:3: X 50.000 mm is outside"):
        load_program(path, lathe)
    path.write_text("G0 X10 Z2\n")
    assert load_program(path, "chivu-lathe").commands == [FMov(xz(10, 2))]
    assert load_program(str(path), lathe).file == "prog.ngc"


def test_unknown_start_axis_is_an_error(lathe):
    with pytest.raises(GcodeError, match="start_mm names axis 'Y'"):
        compile_program("G0 X1", lathe, start_mm={"Y": 1.0})


# -- the shipped example programs ----------------------------------------------------------------

def _example(name) -> Path:
    return Path(str(resources.files("retrofit.examples") / name))


def test_lathe_profile_example_compiles_for_chivu_lathe(lathe):
    prog = load_program(_example("lathe-profile.ngc"), lathe)
    moves = motions(prog)
    assert moves[0] == FMov(xz(30, 10)) and moves[-1] == FMov(xz(30, 10))   # the safe point
    text = _example("lathe-profile.ngc").read_text()
    assert "G2 " in text and "G3 " in text
    points = [c.position() for c in moves]
    assert min(p["X"] for p in points) < 0.0 < 15.0 < max(p["X"] for p in points)   # faced past centre
    assert Spin(800.0, 1) in prog.commands and prog.commands[-1] == Spin(0.0, 0)
    # the R3 fillet (G2) and the R2 edge (G3) bend the right way: inside the corner they round
    lines = text.splitlines()
    fillet_line = next(i for i, t in enumerate(lines, 1) if t.startswith("G2 "))
    edge_line = next(i for i, t in enumerate(lines, 1) if t.startswith("G3 "))
    fillet = [c.position() for c, n in zip(prog.commands, prog.lines) if n == fillet_line]
    edge = [c.position() for c, n in zip(prog.commands, prog.lines) if n == edge_line]
    assert all(15 <= p["X"] <= 18 and -30 <= p["Z"] <= -27 for p in fillet) and len(fillet) > 3
    assert all(math.hypot(p["X"] - 18, p["Z"] + 27) == pytest.approx(3, abs=1e-6) for p in fillet)
    assert all(19 <= p["X"] <= 21 and -32 <= p["Z"] <= -30 for p in edge) and len(edge) > 3


def test_engraving_example_compiles_for_the_engraver(engraver):
    prog = load_program(_example("engraving.ngc"), engraver)
    moves = motions(prog)
    assert moves[-1] == FMov(xyz(0, 0, 10))
    cuts = [c.position() for c in moves if isinstance(c, PMov) and c.position()["Z"] < 0]
    assert len(cuts) > 100                               # letters, a smile and a ring, as chords
    assert min(p["Z"] for p in cuts) == pytest.approx(-0.3)
    assert all(0 <= p["X"] <= 200 and 0 <= p["Y"] <= 200 for p in cuts)
