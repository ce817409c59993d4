"""Canned cycles' refusals and repeats on the mill, each naming the line and the rule: the paths a
mutation run (bench/mutation.py) found no test took."""

from __future__ import annotations

from pathlib import Path

import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine(Path(__file__).resolve().parent / "gcode" / "rs274-mill.toml")
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
