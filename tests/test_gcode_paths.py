"""G-code paths a mutation run (bench/mutation.py) found that no test ran: the modal groups of
every G and M code, an arc's end radius within LinuxCNC's tolerance, outside corners with the
tool on the left, a contour offset towards the stock of a bore, G70's pass count, a Fanuc G76
threading towards +Z, a Fanuc cycle arc whose R cannot reach, every operator and function of an
expression and each of their refusals, the plain-line scanner's numbers, the words each code
uses and the refusal of a word no code of its block uses, arcs by R, line ends at any piece
boundary."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program, lazylines, plainscan
from retrofit.gcode.blocks import make_block
from retrofit.gcode.errors import RuleError
from retrofit.gcode.lathepasses import Segment, rough
from retrofit.gcode.lazylines import LazyLines
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

HERE = Path(__file__).resolve().parent
MILL = load_machine(HERE / "gcode" / "rs274-mill.toml")
TOOLS = ToolTable.load(HERE / "gcode" / "tool.tbl")
FANUC = load_machine(HERE / "data" / "fanuc" / "fanuc-school-lathe.toml")
FANUC_TOOLS = ToolTable.load(HERE / "data" / "fanuc" / "tools.tbl")
LATHE = load_machine("chivu-lathe")

#: LinuxCNC's modal groups (its G-code overview, "Modal Groups"), as retrofit reads them: G76
#: and G5.3 take no motion mode of their own here
G_TABLE = {
    "non-modal": (4, 10, 28, 28.1, 30, 30.1, 53, 92, 92.1, 92.2, 92.3, 76, 5.3),
    "motion": (0, 1, 2, 3, 5, 5.1, 5.2, 33, 33.1, 38.2, 38.3, 38.4, 38.5, 73, 74, 81, 82, 83, 84, 85,
               86, 87, 88, 89),
    "plane": (17, 18, 19), "units": (20, 21), "distance": (90, 91), "arc distance": (90.1, 91.1),
    "feed mode": (93, 94, 95), "spindle speed mode": (96, 97),
    "cutter radius": (40, 41, 41.1, 42, 42.1), "tool length": (43, 43.1, 49), "return mode": (98, 99),
    "coordinate system": (54, 55, 56, 57, 58, 59, 59.1, 59.2, 59.3),
    "path control": (61, 61.1, 64), "lathe diameter": (7, 8),
}
M_TABLE = {
    "stopping": (0, 1, 2, 30, 60), "tool change": (6, 61), "spindle": (3, 4, 5, 70, 71, 72, 73),
    "coolant": (7, 8, 9), "override": (48, 49, 50, 51, 52, 53), "io": (62, 63, 64, 65, 66),
}


@pytest.mark.parametrize("letter, table", [("G", G_TABLE), ("M", M_TABLE)])
def test_every_code_is_known_and_two_of_one_modal_group_in_a_block_are_refused(letter, table):
    for group, codes in table.items():
        for code in codes:
            block = make_block(7, [(letter, float(code))], MILL)
            assert (block.g if letter == "G" else block.m) == {group: code}
        for first, second in zip(codes, codes[1:]):
            with pytest.raises(RuleError, match=rf"same modal group \({group}\): {letter}{first:g} "
                                                rf"and {letter}{second:g}"):
                make_block(7, [(letter, float(first)), (letter, float(second))], MILL)
    with pytest.raises(RuleError, match=f"unknown {letter} code used: {letter}27.1"):
        make_block(7, [(letter, 27.1)], MILL)


def test_g80_beside_another_motion_code_gives_way_to_it():
    assert make_block(1, [("G", 80.0), ("G", 1.0)], MILL).g == {"motion": 1}
    assert make_block(1, [("G", 81.0), ("G", 80.0)], MILL).g == {"motion": 81}


def test_an_arc_whose_end_radius_is_off_by_less_than_the_tolerance_is_cut():
    # radius 100 at the start, 100.05 at the end: 0.05 mm is above the 0.0282 mm allowed but
    # only 0.05 % of the radius, which LinuxCNC also accepts (it refuses past 0.1 % and 0.0282 mm)
    text = "G21 G17 G90\nG0 X0 Y0\nG2 X{} Y0 I100 J0 F100\nM2\n"
    ends = [c.axes for c in compile_program(text.format(200.05), MILL).commands if hasattr(c, "axes")]
    assert dict(ends[-1])["X"] == pytest.approx(200.05)
    # radius 10 at the start, 10.05 at the end: 0.5 % of the radius, refused with the line
    with pytest.raises(GcodeError, match=r":3: .*radius to end of arc differs from radius to start "
                                         r"by 0\.05 mm"):
        compile_program(text.replace("I100", "I10").format(20.05), MILL)


def corner_points(text: str) -> list[tuple[float, float]]:
    return [tuple(v for _, v in c.axes)[:2] for c in compile_program(text, MILL).commands
            if hasattr(c, "axes")]


def test_a_square_cut_clockwise_with_the_tool_on_the_left_is_rounded_outside_each_corner():
    # G41.1 D2 (radius 1) clockwise round the square (0,0)-(0,10)-(10,10)-(10,0): every corner is
    # outside; the tool runs 1 mm outside each side and round each corner on an arc about it
    pts = corner_points("G0 X-5 Y-5\nG41.1 D2\nG1 X0 Y0 F100\nY10\nX10\nY0\nX0\nG40 G1 X-5 Y-5\nM2\n")
    for side_end in [(-1.0, 10.0), (10.0, 11.0), (11.0, 0.0)]:
        assert any(p == pytest.approx(side_end) for p in pts), side_end
    corners = [(0.0, 10.0), (10.0, 10.0), (10.0, 0.0)]
    on_arcs = [p for p in pts if any(math.isclose(math.dist(p, c), 1.0, abs_tol=1e-9) for c in corners)]
    assert len(on_arcs) >= 9          # each corner's arc in several chords
    inside = [p for p in pts[1:-1] if -1e-9 < p[0] < 10 - 1e-9 and 1e-9 < p[1] < 10 - 1e-9]
    assert inside == []               # never inside the square


@pytest.mark.parametrize("start, x_wall, expect", [((2.0, 4.0), 10.0, (-9.5, 9.5)),
                                                   ((2.0, 12.0), 10.0, (-9.5, 10.5))],
                         ids=["bore", "shaft"])
def test_the_allowance_is_left_towards_the_stock_of_a_bore_and_of_a_shaft(start, x_wall, expect):
    # a bore of radius 10 (stock inside it) and a shaft of radius 10 (stock outside), 10 deep,
    # a wall at Z-10: D0.5 leaves the last pass 0.5 off both, towards the stock
    profile = [Segment("line", start, (0.0, x_wall)), Segment("line", (0.0, x_wall), (-10.0, x_wall)),
               Segment("line", (-10.0, x_wall), (-10.0, start[1]))]
    feeds = [m.end for m in rough(profile, start, depth=2.0, retract=0.5, allowance=0.5)
             if m.kind == "feed"]
    assert feeds[-2] == pytest.approx(expect)
    assert feeds[-1] == pytest.approx((-9.5, start[1]))


def test_g70_runs_its_profile_up_to_100_times_and_names_the_line_past_that():
    text = ("G18 G21 G90 G94 G8\nF200\nO100 SUB\nG0 X4 Z1\nG1 X6 Z0\nZ-5\nX10\nO100 ENDSUB\n"
            "G0 X12 Z3\nG70 Q100 X12 Z3 D0.5 P{}\nM2\n")
    # each pass ends at X10, 0.5 mm off the shoulder at Z-5 at first, on it at last
    ends = [dict(c.axes)["Z"] for c in compile_program(text.format(100), LATHE, file="g70.ngc").commands
            if str(c).startswith("PMOV") and dict(c.axes)["X"] == pytest.approx(10.0)]
    assert len(ends) == 100
    assert ends[0] == pytest.approx(-5.0 + 0.5 * 99 / 100) and ends[-1] == pytest.approx(-5.0)
    for bad in (101, 0, 2.5):
        with pytest.raises(GcodeError, match=f"g70.ngc:10: .*P{bad:g}: G70 runs its profile 1 to 100"):
            compile_program(text.format(bad), LATHE, file="g70.ngc")


def g76_fanuc(z0: str, z1: str) -> list[dict]:
    text = (f"G21 G99\nT0303\nG97 S400 M03\nG00 X24. Z{z0}\nG76 P020060 Q50 R0.\n"
            f"G76 X18.16 Z{z1} P920 Q300 F1.5\nM30\n")
    prog = compile_program(text, FANUC, "m20.nc", tool_table=FANUC_TOOLS)
    return [dict(c.axes) for c in prog.commands if hasattr(c, "axes")]


def test_a_fanuc_g76_threading_towards_plus_z_is_the_mirror_of_one_towards_minus_z():
    # M20x1.5 over 25 mm, once from Z5 to Z-20 and once from Z-25 to Z0: mirrored about Z-10
    # (machine Z-8.5 with tool 3's 1.5 mm offset), every pass, infeed along the flank included
    towards_minus, towards_plus = g76_fanuc("5.", "-20."), g76_fanuc("-25.", "0.")
    assert len(towards_minus) == len(towards_plus) > 20
    for a, b in zip(towards_minus, towards_plus):
        assert b["X"] == pytest.approx(a["X"], abs=1e-9)
        assert b["Z"] == pytest.approx(-17.0 - a["Z"], abs=1e-9)
    assert len({round(p["Z"], 6) for p in towards_plus if p["Z"] < -20}) > 5   # the flank infeed


def test_a_fanuc_cycle_arc_whose_radius_cannot_reach_its_end_is_refused_with_its_line():
    text = ("%\nO1\nG21 G98\nT0101\nG00 X42. Z2.\nG71 U2. R1.\nG71 P10 Q50 U0.4 W0.2 F200.\n"
            "N10 G00 X20.\nG01 Z-20.\nG02 X30. Z-25. R{}\nN50 G01 X40.\nM30\n%\n")
    # from X20 Z-20 to X30 Z-25 (radius 10 to 15 from the axis): a chord of 7.07 mm
    compile_program(text.format("5."), FANUC, "arc.nc", tool_table=FANUC_TOOLS)
    with pytest.raises(GcodeError, match=r"arc\.nc:7: G2 R3: the radius is shorter than half the "
                                         r"chord \(3\.5355\)"):
        compile_program(text.format("3."), FANUC, "arc.nc", tool_table=FANUC_TOOLS)


def x_of(expression: str) -> float:
    """Where ``G0 X<expression>`` puts X on the mill (mm, no offsets)."""
    prog = compile_program(f"G21 G90\n#1=7\n#<size>=2.5\nG0 X{expression}\nM2\n", MILL, file="e.ngc")
    return [dict(c.axes)["X"] for c in prog.commands if hasattr(c, "axes")][-1]


@pytest.mark.parametrize("expression, x", [
    ("[1+2*3]", 7.0), ("[[1+2]*3]", 9.0), ("[2**3**2]", 64.0), ("[10-4-3]", 3.0), ("[12/4/3]", 1.0),
    ("[7 MOD 3]", 1.0), ("[-7 MOD 3]", 2.0), ("[7 MOD -3]", -2.0), ("[-7.5 MOD 2]", 0.5),
    ("[1 EQ 1]", 1.0), ("[1 NE 1]", 0.0), ("[2 GT 1]", 1.0), ("[1 GE 2]", 0.0), ("[1 LT 2]", 1.0),
    ("[2 LE 2]", 1.0), ("[1 AND 0]", 0.0), ("[1 OR 0]", 1.0), ("[1 XOR 1]", 0.0), ("[1 XOR 0]", 1.0),
    ("[1+1 EQ 2]", 1.0), ("[1 EQ 1 AND 2 GT 1]", 1.0), ("-[2+3]", -5.0), ("-#1", -7.0), ("#<size>", 2.5),
    ("#[#1-6]", 7.0), ("[ABS[-3]]", 3.0), ("ACOS[0]", 90.0), ("ASIN[1]", 90.0), ("COS[60]", 0.5),
    ("SIN[30]", 0.5), ("TAN[45]", 1.0), ("[EXP[0]]", 1.0), ("FIX[-2.5]", -3.0), ("FUP[-2.5]", -2.0),
    ("FIX[2.5]", 2.0), ("FUP[2.1]", 3.0), ("LN[1]", 0.0), ("ROUND[2.5]", 3.0), ("ROUND[-2.5]", -3.0),
    ("ROUND[2.4]", 2.0), ("SQRT[16]", 4.0), ("ATAN[1]/[-1]", 135.0), ("EXISTS[#<size>]", 1.0),
    ("EXISTS[#<nothing>]", 0.0), ("[#1/2]", 3.5), ("[2.5**2]", 6.25), ("[-2**2]", 4.0),
])
def test_an_expression_puts_the_carriage_where_the_hand_computation_does(expression, x):
    assert x_of(expression) == pytest.approx(x, abs=1e-12)


@pytest.mark.parametrize("expression, message", [
    ("[1/0]", "attempt to divide by zero in an expression"),
    ("[1 MOD 0]", "MOD by zero in an expression"),
    ("[-8**0.5]", "attempt to raise negative -8 to non-integer power 0.5"),
    ("[10**400]", r"the expression overflows \(10 \*\* 400\)"),
    ("ACOS[2]", r"argument to ACOS out of range: 2 \(needs -1..1\)"),
    ("ASIN[-1.5]", r"argument to ASIN out of range: -1.5"),
    ("LN[0]", "zero or negative argument to LN: 0"),
    ("SQRT[-4]", "negative argument to SQRT: -4"),
    ("EXP[1000]", r"EXP\[1000\] overflows"),
    ("FOOBAR[2]", r"unknown function or word 'FOOBA' where a value was expected \(functions: ABS"),
    ("SIN30", r"SIN needs its argument in brackets, e.g. SIN\[30\]"),
    ("EXISTS[#1]", r"EXISTS takes a named parameter: EXISTS\[#<name>\]"),
    ("ATAN[1]", r"ATAN takes two arguments: ATAN\[y\]/\[x\]"),
    ("[1+2", r"expression '\[' is not closed with '\]'"),
    ("[1 ? 2]", r"unknown operator '\?2\]' in expression"),
    ("#<size", "named parameter '#<' is not closed with '>'"),
    ("[1+]", "bad number starting"),
])
def test_a_bad_expression_is_refused_naming_its_line_and_what_was_wrong(expression, message):
    with pytest.raises(GcodeError, match=f"e.ngc:4: .*{message}"):
        x_of(expression)


def scanned(lines: list[str]):
    """The (G, X, Y, Z, F) rows the plain-line scanner reads, and how many lines it took."""
    text = "".join(line + "\n" for line in lines)
    starts, at = [], 0
    for line in lines:
        starts.append(at)
        at += len(line) + 1
    starts = np.array(starts, np.int64)
    stops = starts + np.array([len(line) for line in lines], np.int64)
    table = np.full((len(lines), 5), -1.0)
    taken = plainscan.scan_plain(np.frombuffer(text.encode("ascii"), np.uint8), starts, stops, table)
    return table[:taken], taken


def test_the_plain_line_scanner_reads_numbers_exactly_and_leaves_the_rest_to_the_full_reader():
    rows, taken = scanned(["G1 X1.5 Y-2 F300", "X.25 Y+3", "G00 Z-00012.340", "X123456789012345 Y1",
                           "X1.0000000000000001 Y2", "X3 Y4"])
    assert taken == 4                 # the fifth line has 17 digits: the full reader takes it on
    assert rows[0].tolist()[:2] == [1.0, 1.5] and rows[0][2] == -2.0 and rows[0][4] == 300.0
    assert rows[1][1] == 0.25 and rows[1][2] == 3.0 and np.isnan(rows[1][0])
    assert rows[2][0] == 0.0 and rows[2][3] == -12.34
    assert rows[3][1] == 123456789012345.0
    for line in ("X. Y1", "X- Y1", "G2 X1", "X1 M3"):
        assert scanned(["X1 Y1", line, "X2 Y2"])[1] == 1, line
    assert scanned(["XY1", "X2 Y2"])[1] == 0        # an X with no number: the full reader refuses it


WORDS_HEAD = "G21 G17 G90 G94\nG0 X0 Y0 Z10\nF100\nM3 S1000\n"


def test_each_word_is_taken_where_a_code_uses_it():
    # the words LinuxCNC reads with each code (overrides M48-M53, G64's P Q, G10's L P R, arcs'
    # P turns, the cycles' P Q L and I J K, G43's H, splines, the spindle selection $, M61's Q)
    blocks = ["M48", "M49", "M50 P0", "M50 P1", "M51 P1", "M52 P1", "M53 P1", "G64 P0.01", "G64 P0.01 Q0.01",
              "G4 P0.5", "G10 L2 P1 X0", "G10 L1 P1 R2", "G2 X10 Y0 I5 J0 P2", "G2 X10 Y0 Z-1 I5 J0 P1",
              "G2 X10 Y0 R5", "G82 X1 Y1 Z-1 R1 P0.5", "G73 X1 Y1 Z-1 R1 Q0.5", "G83 X1 Y1 Z-1 R1 Q0.5",
              "G81 X1 Y1 Z-1 R1 L2", "G87 X1 Y1 Z-1 R1 I1 J1 K-2", "G86 X1 Y1 Z-1 R1 P1",
              "G89 X1 Y1 Z-1 R1 P1", "G84 X1 Y1 Z-1 R1 P1", "M4\nG74 X1 Y1 Z-1 R1 P1", "G43 H1",
              "G5 X10 Y0 I1 J1 P1 Q-1", "G5.1 X10 Y0 I5 J1", "M3 $0 S500", "M5 $0", "G97 $0 S200",
              "M51 P1 $0", "M61 Q1"]
    for block in blocks:
        compile_program(WORDS_HEAD + block + "\nM2\n", MILL, "u.ngc", tool_table=TOOLS)


@pytest.mark.parametrize("block, message", [
    ("G1 X1 I1", "I1: I word with no G code that uses it (G2/G3 arcs, G5, G5.1, G33.1, G76, G87)"),
    ("G1 X1 J1", "J1: J word with no G code that uses it (G2/G3 arcs, G5, G5.1, G76, G87)"),
    ("G1 X1 K1", "K1: K word with no G code that uses it (G2/G3 arcs, G33, G33.1, G76, G87)"),
    ("G1 X1 R1", "R1: R word with no G code that uses it (G2/G3 arcs, canned cycles, G10, G76)"),
    ("G1 X1 P1", "P1: P word with no G code that uses it (G4, G10, G2/G3 turns, G5, G5.2, G74, G82, G84, "
                 "G86, G88, G89, G64, G76, M50-M53, M62-M66)"),
    ("G1 X1 Q1", "Q1: Q word with no G code that uses it (G5, G73, G83, G64, G76, M61, M66)"),
    ("G1 X1 L1", "L1: L word with no G code that uses it (G10, canned cycles, G5.2, G76, G41.1/G42.1, M66)"),
    ("G1 X1 H1", "H1: H word with no G code that uses it (G43, G76)"),
    ("G1 X1 E1", "E1: E word with no G code that uses it (G76, M66)"),
    ("G1 X1 D1", "D1: D word with no G code that uses it (G41, G42, G41.1, G42.1, G96)"),
    ("G1 X1 $0", "$0: $ (spindle selection) word with no M3, M4, M5, M51, G33, G76 or G97 to use it"),
    ("G81 X1 Y1 Z-1 R1 P1", "P1: P word"), ("G81 X1 Y1 Z-1 R1 Q1", "Q1: Q word"),
    ("G82 X1 Y1 Z-1 R1 Q1", "Q1: Q word"), ("G4 P1 Q1", "Q1: Q word"), ("M48 P1", "P1: P word"),
    ("M5 P1", "P1: P word"), ("M3 S100 P1", "P1: P word"), ("G10 L2 P1 X0 Q1", "Q1: Q word"),
    ("G43 H1 D1", "D1: D word"), ("G0 X1 I1 J1 K1", "I1: I word"), ("G33 X1 K1 I1", "I1: I word"),
    ("G4", "G4 needs P<seconds>, e.g. G4 P0.5"), ("G92", "G92 with no axis words"),
])
def test_a_word_no_code_of_its_block_uses_is_refused_naming_the_line(block, message):
    with pytest.raises(GcodeError) as info:
        compile_program(WORDS_HEAD + block + "\nM2\n", MILL, "u.ngc", tool_table=TOOLS)
    assert str(info.value).startswith(f"u.ngc:5: {message}")


def arc_points(block: str) -> list[tuple[float, float]]:
    prog = compile_program("G21 G17 G90\nG0 X0 Y0\nF100\n" + block + "\nM2\n", MILL, "a.ngc")
    return [tuple(v for _, v in c.axes)[:2] for c in prog.commands if hasattr(c, "axes")][1:]


def test_an_arc_by_r_takes_the_short_way_or_with_r_negative_the_long_way_round_its_centre():
    # G2 from (0, 0) to (10, 0) with R-6: the centre left of the chord, at (5, sqrt(11)); the arc
    # runs clockwise the long way over it, through (5, sqrt(11) + 6), 247 degrees
    pts = arc_points("G2 X10 Y0 R-6")
    assert all(math.dist(p, (5.0, math.sqrt(11))) == pytest.approx(6.0) for p in pts)
    assert max(p[1] for p in pts) == pytest.approx(math.sqrt(11) + 6.0, abs=0.05)   # chord ends
    assert min(p[1] for p in pts) == pytest.approx(0.0, abs=1e-9)
    # G3 with R 0.0001 short of half the chord is within reach: a half circle about (5, 0)
    pts = arc_points("G3 X10 Y0 R4.9999")
    assert all(math.dist(p, (5.0, 0.0)) == pytest.approx(5.0) for p in pts)
    assert pts[-1] == pytest.approx((10.0, 0.0)) and min(p[1] for p in pts) == pytest.approx(-5.0, abs=0.05)


@pytest.mark.parametrize("block, message", [
    ("G2 X10 Y0 R4", r"4: G2 radius 4.000 mm is too small for the 10.000 mm from start to end \(needs "
                     r"\|R\| >= 5.000 mm\)"),
    ("G20\nG2 X1 Y0 R0.4", r"5: G2 radius 10.160 mm is too small for the 25.400 mm from start to end "
                           r"\(needs \|R\| >= 12.700 mm\)"),
    ("G2 X10 Y0 R0", "4: G2 with R0: the radius must not be 0"),
    ("G2 X0 Y0 R5", r"4: G2 with R cannot make a full circle \(end point = start point\); use I/J/K"),
    ("G2 X10 Y0", r"4: G2: R, I, J and K words all missing for arc \(plane G17 takes I/J or R\)"),
    ("G18\nG2 X10 Z0", r"5: G2: R, I, J and K words all missing for arc \(plane G18 takes K/I or R\)"),
    ("G19\nG3 Y10 Z0", r"5: G3: R, I, J and K words all missing for arc \(plane G19 takes J/K or R\)"),
    ("G2 X10 Y0 I0 J0", "4: G2 radius 0: the centre offsets put the centre on the start point"),
])
def test_an_arc_that_cannot_be_cut_is_refused_with_the_reason_and_the_numbers(block, message):
    with pytest.raises(GcodeError, match=f"^a.ngc:{message}$"):
        arc_points(block)


@pytest.mark.parametrize("line, message", [
    ("G0 X1)", r"'\)' without an opening '\('"),
    ("G0 X1 (open", r"comment '\(' is not closed on this line \(a comment ends with '\)'\)"),
    ("#1", "a parameter at the start of a word must be assigned: #1=2.5"),
    ("G0 X1 ~", r"unexpected character '~' \(a word is a letter and a value, e.g. X12.5, X#1 or X\[#1\+2\]\)"),
    ("o# sub", r"bad O-word 'O#SUB': expected o<name> or o<number> and a keyword \(sub endsub call"),
    ("o100 frobnicate", r"unknown O-word keyword 'frobnicate' after o100 \(keywords: sub endsub call"),
])
def test_a_line_the_reader_cannot_split_into_words_is_refused_naming_it(line, message):
    with pytest.raises(GcodeError, match=f"^l.ngc:2: {message}"):
        compile_program("G21 G17 G90\n" + line + "\nM2\n", MILL, "l.ngc")


def test_line_ends_are_the_same_whatever_piece_of_the_text_they_fall_at_the_end_of(monkeypatch):
    # CR, LF and CR LF line ends, read in pieces of every size from 1 byte: a CR at the end of
    # a piece ends its line unless the next piece starts with the LF of the same line end
    text = "G0 X1\rG0 X2\r\nG0 X3\nG0 X4\r\rG0 X5\r\n\r\nG0 X6"
    whole = [(line.number, line.words) for line in LazyLines(text)]
    assert [n for n, _ in whole] == [1, 2, 3, 4, 6, 8]
    for size in range(1, len(text) + 1):
        monkeypatch.setattr(lazylines, "SCAN_BYTES", size)
        assert [(line.number, line.words) for line in LazyLines(text)] == whole, size
