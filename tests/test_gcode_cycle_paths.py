"""Canned cycles' refusals and repeats on the mill, and the Fanuc lathe cycles' and calls'
refusals, LinuxCNC's G33, G76, G10, G43 and G96 refusals on a lathe, each naming the line and
the rule: the paths a mutation run (bench/mutation.py) found no test took."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

MILL = load_machine(Path(__file__).resolve().parent / "gcode" / "rs274-mill.toml")
LATHE = load_machine("mitic-lathe")             # a spindle encoder: G33, G76 and G96 run
HEAD = "G21 G17 G90 G98\nG0 X0 Y0 Z10\nF100\n"


def holes(block: str, before: str = "") -> list[tuple[float, float, float]]:
    prog = compile_program(HEAD + before + block + "\nM2\n", MILL, file="c.ngc")
    return [tuple(v for _, v in c.axes)[:3] for c in prog.commands if hasattr(c, "axes")]


@pytest.mark.parametrize("block, before, message", [
    ("G81 X1 Y1 Z-2 R1 L2.5", "", "L2.5: L repeats a cycle 0 to 10000 times"),
    ("G81 X1 Y1 Z-2 R1 L-1", "", "L-1: L repeats a cycle 0 to 10000 times"),
    ("G81 X1 Y1 Z-2 R1 L10001", "", "L10001: L repeats a cycle 0 to 10000 times"),
    ("G81 X1 Y1 Z-2", "", "G81: R clearance plane unspecified in cycle"),
    ("G83 X1 Y1 Z-2 R1", "", r"G83: Q word missing \(the peck depth\)"),
    ("G73 X1 Y1 Z-2 R1 Q0", "", "Q0: the peck depth Q must be > 0"),
    ("G82 X1 Y1 Z-2 R1", "", r"G82: dwell time P word missing \(seconds at the bottom\)"),
    ("G89 X1 Y1 Z-2 R1", "", "G89: dwell time P word missing"),
    ("G81 X1 Y1 Z2 R1", "", r"G81: R less than Z in cycle"),
    ("G81 X1 Y1 Z-2 R1", "G18\n", r"G81: canned cycles run in the XY plane \(G17\)"),
    ("G87 X1 Y1 Z-2 R1 I1 K-1", "M3 S500\n", r"G87: J word missing \(back boring needs I J"),
    ("G86 X1 Y1 Z-2 R1 P1", "", r"G86: the spindle is not turning \(M3 or M4 with S > 0 first\)"),
    ("G84 X1 Y1 Z-2 R1", "M4 S500\n", "G84: the spindle turns counterclockwise; G84 taps right-handed "
                                      "and needs M3"),
    ("G74 X1 Y1 Z-2 R1", "M3 S500\n", "G74: the spindle turns clockwise; G74 taps left-handed and "
                                      "needs M4"),
])
def test_a_canned_cycle_missing_a_word_or_out_of_its_range_is_refused_naming_the_line(block, before, message):
    line = 4 + before.count("\n")
    with pytest.raises(GcodeError, match=f"c.ngc:{line}: .*{message}"):
        holes(block, before)


def test_l_repeats_a_cycle_and_l0_drills_no_hole():
    # G91: each repeat moves X by 5 and drills from R (9 below the start level 10) 3 deeper
    pts = holes("G91 G81 X5 Y0 Z-3 R-9 L3")
    bottoms = [p for p in pts if p[2] == pytest.approx(-2.0)]
    assert [p[0] for p in bottoms] == pytest.approx([5.0, 10.0, 15.0])
    assert not [p for p in holes("G81 X5 Y5 Z-2 R1 L0") if p[2] < 10]


DATA = Path(__file__).resolve().parent / "data" / "fanuc"
FANUC, FANUC_TOOLS = load_machine(DATA / "fanuc-school-lathe.toml"), ToolTable.load(DATA / "tools.tbl")
FANUC_HEAD = "%\nO1\nG21 G98\nT0101\nG97 S800 M03\nG00 X42. Z2.\n"
PROFILE = "N10 G00 X20.\nG01 Z-20.\nN50 X40.\n"
G76_FIRST = "G76 P020060 Q50 R0.\n"


@pytest.mark.parametrize("body, line, message", [
    ("G71 P10 Q50 U0.4 W0.2 F200.\n" + PROFILE, 7,
     r"G71 P Q: the cycle's first block \(G71 U \(depth of cut\) R \(retract\)\) must come before it"),
    ("G71 U2. R1.\nG70 F100.\n" + PROFILE, 8, "G70 needs P and Q, the N numbers of the profile's first"),
    ("G71 U2. R1.\nG71 P50 Q10 U0.4 W0.2 F200.\n" + PROFILE, 8, "G71: N10 comes before N50"),
    ("G71 U2. R1.\nG71 P10 Q60 U0.4 W0.2 F200.\n" + PROFILE, 8, "G71 Q60: no block N60 in f.nc"),
    ("G71 U2. R1.\nG71 P10 Q50 U0.4 W0.2 F200.\nN10 G00 X20.\nG04 X1.\nN50 G01 X40.\n", 8,
     r"G71: G4 in the profile \(line 10\); a profile is G0, G1, G2, G3 moves"),
    ("G71 U2. R1.\nG71 P10 Q50 U0.4 W0.2 F200.\nN10 G00 X20.\nM98 P2000\nN50 G01 X40.\n", 8,
     r"G71: a subprogram call in the profile \(line 10\)"),
    ("G71 U2. R1.\nG71 P10 Q50 U0.4 W0.2 F200.\nN10 G02 X20. Z0. R20.\nN50 G01 X40.\n", 8,
     r"G71: the profile's first block N10 must be G0 or G1 \(line 9\)"),
    ("G73 U3. W1.\nG73 P10 Q50 U0.4 W0.2 F120.\n" + PROFILE, 8,
     r"G73: the first block needs U \(X relief\) W \(Z relief\) R \(passes\)"),
    ("G76 X18.16 Z-20. P920 Q300 F1.5\n", 7, r"G76 X Z P Q F: the first block \(G76 P \(mmrraa"),
    ("G76 P020045 Q50 R0.\nG76 X18.16 Z-20. P920 Q300 F1.5\n", 8,
     "G76 P020045: the angle aa is one of 00 29 30 55 60 80"),
    (G76_FIRST + "G76 X18.16 Z-20. P920 Q300\n", 8, r"G76: the second block needs F, the lead \(> 0\)"),
    (G76_FIRST + "G76 X18.16 Z-20. P0 Q300 F1.5\n", 8,
     "G76: the thread height P and the first depth Q must be > 0"),
    ("G76 P000060 Q50 R0.\nG76 X18.16 Z-20. P920 Q300 F1.5\n", 8,
     r"G76: m \(the first two digits of the first block's P\) counts the finishing passes, 01 to 99"),
    ("G74 R0.5\nG74 Z-10. Q0 F50.\n", 8, r"G74: Q \(the peck depth\) must be > 0"),
    ("G74 R0.5\nG74 X30. Z-10. P0 Q1000 F50.\n", 8, r"G74: P \(the shift between rows\) must be > 0"),
    ("G75 R0.5\nG75 X20. Z-5. P0 Q1000 F50.\n", 8, r"G75: P \(the peck depth\) must be > 0"),
    ("G75 R0.5\nG75 X20. Z-5. P1000 Q0 F50.\n", 8, r"G75: Q \(the shift between rows\) must be > 0"),
    ("G92 X19. Z-20.\n", 7, "G92 needs F, the lead of the thread"),
    ("M99 P5\n", 7, r"M99 P \(return to a sequence number\) is not read; return with M99"),
    ("M98\n", 7, r"M98 needs P \(the program number to call\)"),
    ("M98 P1000 L2.5\n", 7, "L2.5: the number of repeats is a whole number from 0 to 9999"),
    ("M98 P1000 M03\n", 7, "M97, M98 and M99 stand on a block of their own with P and L only"),
    ("G96\n", 7, r"G96 needs S on its block \(the surface speed, m/min or ft/min\)"),
    ("T1.5\n", 7, r"T1.5: a Fanuc tool word is T<tool><offset>, e.g. T0101"),
    ("T-101\n", 7, r"T-101: a Fanuc tool word is T<tool><offset>"),
    ("G04\n", 7, r"G4 needs the dwell: P \(ms, or s with a decimal point\), X or U \(s\)"),
    ("G01 Y5. F100.\n", 7, "Y5: not read in this block under the Fanuc dialect"),
    ("G32 Z-10.\n", 7, r"G32 needs F, the lead of the thread \(mm or inch per revolution\)"),
    ("G32 X30. F1.5\n", 7, r"a thread move must move along Z \(the lead is per turn along Z\)"),
    ("G53 G02 X10. Z10.\n", 7, r"G53 takes G0 or G1 with X and Z \(machine coordinates from home\)"),
    ("G53 G00 U10.\n", 7, "G53 takes G0 or G1 with X and Z"),
    ("G50 S0\n", 7, "G50 S0: the spindle speed cap must be > 0 rpm"),
])
def test_a_fanuc_cycle_or_call_missing_a_word_is_refused_naming_the_line(body, line, message):
    with pytest.raises(GcodeError, match=f"^f.nc:{line}: {message}"):
        compile_program(FANUC_HEAD + body + "M30\n%\n", FANUC, "f.nc", tool_table=FANUC_TOOLS)


G76 = "G76 P1.5 Z-12 I-0.5 J0.25 K0.92"


@pytest.mark.parametrize("block, message", [
    ("G33 Z-10", r"G33 needs K, the distance along the move per spindle revolution"),
    ("G33 Z-10 K0", r"K0: G33's K must be > 0 \(mm per revolution\)"),
    ("G33 Z3 K1", r"G33: a synchronised move must go somewhere \(start = end\)"),
    ("G33 Z-10 K40", r"G33: 40 mm/rev at up to 345 rpm \(S300 and 15% margin\) is 230.00 mm/s; the axes "
                     r"allow 40.00 mm/s; lower S"),
    ("G1 " + G76, "G76 is a cycle of its own: no G1 in its block"),
    (G76 + " X5", r"G76 takes Z as its only axis word \(the cycle starts at the current X\); X5"),
    ("G76 P1.5 Z-12 I-0.5 J0.25", r"G76 needs P \(pitch\), Z \(end\), I \(peak offset\), J \(first depth\) "
                                  r"and K \(full depth\); missing: K"),
    (G76 + " R0.5", r"R0.5: the depth degression must be >= 1.0 \(R1 constant depth\)"),
    (G76 + " H1.5", r"G76 H \(spring passes\) must be a whole number >= 0 and L one of 0, 1, 2, 3"),
    (G76 + " L4", r"G76 H \(spring passes\) must be a whole number >= 0 and L one of 0, 1, 2, 3"),
    (G76 + " Q90", r"Q90: the compound angle must be within -90..90 deg"),
    ("G76 P1.5 Z3 I-0.5 J0.25 K0.92", "G76: Z is where the cycle starts; the thread needs a length"),
    (G76 + " E8", r"E8: the taper must be >= 0 and at most half the drive"),
    ("G76 P1.5 Z-12 I-0.5 J0.0001 K0.92 R1", "G76 would cut more than 1000 passes to reach K0.92 from "
                                             "J0.0001 with R1; raise J or lower R"),
    ("G10 L2 P1.5 X1", "P1.5: G10's P is a whole number"),
    ("G10 L2 P10 X1", r"P10: G10 L2 P is 0 \(the system in use\) to 9 \(G59.3\)"),
    ("G10 L2 P1 R5 X1", "G10 L2 R: rotated coordinate systems are not supported"),
    ("G10 L3 P1 X1", "L3: G10 takes L1, L2, L10, L11 or L20"),
    ("G43 H1.5", "H1.5: H is a tool number"), ("G43 H-1", "H-1: H is a tool number"),
    ("G96 S0", "S0: G96's surface speed must be > 0"),
    ("G70 Q100 X12 Z3\nO100 SUB\nG0 X4 Z1\nO100 ENDSUB", "G70: G7X error: the profile needs a move after "
                                                         "its first point"),
])
def test_a_lathe_thread_offset_or_speed_word_out_of_its_range_is_refused_naming_the_line(block, message):
    with pytest.raises(GcodeError, match=f"^r.ngc:4: {message}"):
        compile_program("G18 G21 G90\nG0 X12 Z3\nS300 M3\n" + block + "\nM2\n", LATHE, "r.ngc")


def test_g76_needs_the_zx_plane_and_a_bare_s_under_g96_must_be_above_0():
    with pytest.raises(GcodeError, match=r"^r.ngc:5: G76 needs the ZX plane \(G18\), not G17"):
        compile_program("G18 G21 G90\nG0 X12 Z3\nS300 M3\nG17\n" + G76 + "\nM2\n", LATHE, "r.ngc")
    with pytest.raises(GcodeError, match="^r.ngc:5: S0: G96's surface speed must be > 0"):
        compile_program("G18 G21 G90\nG0 X12 Z3\nM3 S300\nG96 S100 D1500\nS0\nM2\n", LATHE, "r.ngc")


def test_a_fanuc_g50_cap_under_g96_holds_the_spindle_below_it_and_below_the_machines_top():
    # 100 m/min: 757.88 rpm at X42 (diameter); towards X20 it would reach 1591.5 rpm: G50 S1500
    # caps it; towards X2 (15915 rpm) G50 S99999 leaves the machine's own top, 3000 rpm
    def spins(cap: str, x: str) -> list[float]:
        text = FANUC_HEAD + f"G96 S100\nG50 S{cap}\nG01 X{x} F100.\nM30\n%\n"
        prog = compile_program(text, FANUC, "f.nc", tool_table=FANUC_TOOLS)
        return [c.rpm for c in prog.commands if str(c).startswith("SPIN") and c.direction]
    low = spins("1500", "20.")
    assert low[1] == pytest.approx(100_000 / (math.pi * 42), abs=1e-3) and low[-1] == 1500.0
    assert max(low) == 1500.0
    assert spins("99999", "2.")[-1] == 3000.0 == FANUC.parts["spindle"].max_rpm


@pytest.mark.parametrize("middle, message", [
    ("#1=5", r"G71 Q100: the profile o100 may hold only moves \(line 6 sets a parameter\)"),
    ("o200 call", r"G71 Q100: o200 call in the profile \(line 6\); loops and branches only"),
    ("G4 P1", r"G71 Q100: G4 in the profile \(line 6\); the profile is G0, G1, G2, G3 moves"),
    ("G2 X8 Z-8 R1", r"G71: an arc of R1 cannot reach from Z0 X6 to Z-8 X8 \(the radius is under half "
                     r"the chord\)"),
])
def test_a_g71_profile_holding_more_than_moves_is_refused_naming_the_cycle_and_the_profile_line(middle, message):
    text = ("G18 G21 G90 G94 G8\nF200\nO100 SUB\nG0 X4 Z1\nG1 X6 Z0\n" + middle +
            "\nZ-5\nX10\nO100 ENDSUB\nG0 X12 Z3\nG71 Q100 X12 Z3 I1\nM2\n")
    with pytest.raises(GcodeError, match=f"^p.ngc:11: {message}"):
        compile_program(text, load_machine("chivu-lathe"), "p.ngc")
