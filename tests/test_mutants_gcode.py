"""G-code paths checked where a mutation run found them unchecked (bench/mutation.py): a plain
cylinder roughed in layers, an entry arc under cutter compensation, where a roughing level
meets an arc of a Fanuc profile, G71.1's pockets, the move after G40, an if block's number, G74's
pecks, a G96 move across the axis, two arcs at an inside corner, a dip roughed between its sides, G70's arc in a bore."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.gcode.fanuc_cycles import _crossing
from retrofit.gcode.fanuc_fixed import pecking
from retrofit.gcode.lathepasses import Segment, rough
from retrofit.gcode.spindle import css_breaks
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

HERE = Path(__file__).resolve().parent / "gcode"


def test_a_cylinder_whose_profile_starts_and_ends_at_one_x_is_roughed_in_layers():
    # from Z2 X12 down to a cylinder at X10 from Z0 to Z-10, 1.5 per layer: layers at X12 and
    # X10.5 (9 would pass the profile), then the contour along X10 and out to X12 at Z-10
    start = (2.0, 12.0)
    profile = [Segment("line", start, (0.0, 10.0)), Segment("line", (0.0, 10.0), (-10.0, 10.0))]
    feeds = [m.end for m in rough(profile, start, depth=1.5, retract=0.5) if m.kind == "feed"]
    assert feeds == [(-10.0, 12.0), (-10.0, 10.5), (-10.0, 10.0), (-10.0, 12.0)]


@pytest.mark.parametrize("side, end_x", [("G41.1", 19.0), ("G42.1", 21.0)], ids=["inside", "outside"])
def test_an_entry_arc_ends_one_tool_radius_off_the_programmed_end(side, end_x):
    # a CCW half circle from X0 to X20 around X10: with the tool on its left (G41) it runs
    # inside the arc and ends 1 mm (D2: radius 1) towards the centre, on its right outside
    mill = load_machine(HERE / "rs274-mill.toml")
    prog = compile_program(f"G0 X0 Y0\n{side} D2\nG3 X20 Y0 I10 J0 F100\nG40 G1 X20 Y-10\nM2\n", mill,
                           tool_table=ToolTable.load(HERE / "tool.tbl"))
    points = [tuple(v for _, v in c.axes)[:2] for c in prog.commands if hasattr(c, "axes")]
    assert points[-2] == pytest.approx((end_x, 0.0))
    assert points[-1] == pytest.approx((20.0, -10.0))


def test_a_roughing_level_meets_an_arc_of_the_profile_on_the_arc():
    # a quarter circle of radius 10 around (0, 0) from (0, 10) to (10, 0): depth 6 is met at 8
    assert _crossing([(3, (0.0, 10.0), (10.0, 0.0), (0.0, 0.0))], 6.0) == pytest.approx(8.0)
    assert _crossing([(1, (0.0, 0.0), (10.0, 20.0), None)], 5.0) == pytest.approx(10.0)


def test_g71_1_leaves_a_groove_that_g71_and_g71_2_rough():
    # a shaft at X6 with a groove down to X4 from Z-5 to Z-8: G71 roughs it with the rest,
    # G71.1 leaves pockets alone, G71.2 roughs only the pockets
    lathe = load_machine("chivu-lathe")
    in_groove, moves = {}, {}
    for g in ("G71", "G71.1", "G71.2"):
        text = ("G18 G21 G90 G94 G8\nF200\nO100 SUB\nG0 X4 Z1\nG1 X6 Z0\nZ-5\nX4\nZ-8\nX6\nZ-12\nX10\n"
                f"O100 ENDSUB\nG0 X12 Z3\n{g} Q100 X12 Z3 D0 I1 R0.5\nM2\n")
        points = [dict(c.axes) for c in compile_program(text, lathe, file="g71.ngc").commands
                  if hasattr(c, "axes")]
        moves[g] = len(points)
        in_groove[g] = any(-8 < p.get("Z", 0) < -5 and p.get("X", 99) < 6 for p in points)
    assert in_groove == {"G71": True, "G71.1": False, "G71.2": True}
    assert moves["G71.2"] < moves["G71.1"] < moves["G71"]


def test_after_g40_only_the_first_move_must_be_straight():
    # the straight move out of compensation ends the rule: the arc after it is cut
    mill = load_machine(HERE / "rs274-mill.toml")
    text = "G0 X0 Y0\nG41.1 D2\nG1 X20 Y0 F100\nG40 G1 X20 Y-10\nG2 X20 Y-30 I0 J-10\nM2\n"
    points = [tuple(v for _, v in c.axes)[:2] for c in compile_program(text, mill).commands if hasattr(c, "axes")]
    assert points[-1] == pytest.approx((20.0, -30.0))
    with pytest.raises(GcodeError, match=":5: G2: the move just after G40 must be straight"):
        compile_program(text.replace("G40 G1 X20 Y-10\n", "G40\n").replace("M2", "G1 X0\nM2"), mill)


def test_an_if_block_is_not_a_subroutine_of_its_number():
    lathe = load_machine("chivu-lathe")
    text = "G18 G21 G90\no100 if [1 GT 0]\nG0 X1 Z1\no100 endif\no100 call\nM2\n"
    with pytest.raises(GcodeError, match="t.ngc:5: o100 call: unknown subroutine o100"):
        compile_program(text, lathe, file="t.ngc")


def test_g74_pecks_q_deep_and_backs_off_between_pecks():
    # from Z0 to Z-6, Q2 pecks and 0.5 back after each but the last, then out to the start
    path = pecking((0.0, 0.0), 0.0, -6.0, 0.0, 2.0, 0.5, 0.0, True)
    assert [(kind, p[1]) for kind, p, _ in path] == [(0, 0.0), (1, -2.0), (0, -1.5), (1, -4.0), (0, -3.5),
                                                     (1, -6.0), (0, 0.0)]


def test_a_g96_move_across_the_axis_is_split_where_it_crosses():
    # 100 m/min capped at 1000 rpm: below a radius of 15.9 mm the speed is the cap, so a move
    # from X5 to X-15 is cut only where it crosses X0, a quarter of the way
    assert css_breaks(5.0, -15.0, (100.0, 1000.0)) == [0.25, 1.0]


def test_two_arcs_meeting_at_an_inside_corner_end_where_their_offsets_cross():
    # CCW around (0, 0) to (10, 0), then CCW around (10, -10): a corner to the left, inside for
    # the tool on the left (radius 1); the offset circles of radius 9 cross at
    # (5, -5) + sqrt(81 - 50) (1, 1) / sqrt(2)
    mill = load_machine(HERE / "rs274-mill.toml")
    text = "G0 X0 Y-20\nG41.1 D2\nG1 X0 Y-10 F100\nG3 X10 Y0 I0 J10\nG3 X0 Y-10 I0 J-10\nG40 G1 X-10 Y-20\nM2\n"
    points = [tuple(v for _, v in c.axes)[:2] for c in compile_program(text, mill).commands if hasattr(c, "axes")]
    corner = 5 + math.sqrt(31 / 2)
    assert any(p == pytest.approx((corner, corner - 10)) for p in points)


def test_a_dip_in_the_profile_is_roughed_in_layers_between_its_two_sides():
    # X5 from Z0, a dip from Z-2 to Z-8 (an arc of radius 3.125 around Z-5 X5.875, bottom at
    # X2.75), X5 on to Z-12, out to X12: layers 0.7 apart from X12, so in the dip X4.3, X3.6, X2.9
    start = (2.0, 12.0)
    profile = [Segment("line", start, (0.0, 5.0)), Segment("line", (0.0, 5.0), (-2.0, 5.0)),
               Segment("cw", (-2.0, 5.0), (-8.0, 5.0), (-5.0, 5.875)),
               Segment("line", (-8.0, 5.0), (-12.0, 5.0)), Segment("line", (-12.0, 5.0), (-12.0, 12.0))]
    moves = rough(profile, start, depth=0.7, retract=0.5)
    in_dip = sorted({round(m.end[1], 6) for m in moves if m.kind == "feed" and -8.0 < m.end[0] < -2.0})
    assert in_dip == [2.9, 3.6, 4.3]
    assert min(m.end[1] for m in moves) >= 2.75 - 1e-9


def test_g70_in_a_bore_runs_the_profiles_g2_the_short_way_inside_the_bore():
    # a bore: from the mouth at X30 Z0 a G2 quarter circle (centre X30 Z-5) down to X25 Z-5,
    # then along X25. The profile's X falls, so the passes are made mirrored and turned back:
    # the arc must come back a G2 through X30-5/sqrt(2) Z-5+5/sqrt(2), not a G3 the long way
    # round through X35 (into the bore's wall)
    lathe = load_machine("chivu-lathe")
    text = ("G18 G21 G90 G94 G8\nF200\nO100 SUB\nG1 X30 Z0\nG2 X25 Z-5 I0 K-5\nG1 Z-20\nO100 ENDSUB\n"
            "G0 X10 Z2\nG70 Q100 X10 Z2\nM2\n")
    points = [dict(c.axes) for c in compile_program(text, lathe, file="bore.ngc").commands
              if hasattr(c, "axes")]
    arc = points[points.index({"X": 30.0, "Z": 0.0}) + 1:points.index({"X": 25.0, "Z": -5.0}) + 1]
    assert len(arc) > 10
    assert all(25.0 - 1e-9 <= p["X"] <= 30.0 + 1e-9 and -5.0 - 1e-9 <= p["Z"] <= 0.0 + 1e-9 for p in arc)
    assert all(math.hypot(p["X"] - 30.0, p["Z"] + 5.0) == pytest.approx(5.0, abs=0.01) for p in arc)
    assert min(math.hypot(p["X"] - (30.0 - 5.0 / math.sqrt(2)), p["Z"] - (-5.0 + 5.0 / math.sqrt(2)))
               for p in arc) < 0.2
