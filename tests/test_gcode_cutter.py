"""Cutter compensation geometry, checked against hand computations on squares and circles."""
import math

import pytest

from retrofit.gcode.cutter import Compensator, CutterError


def run(segs, r, side):
    c = Compensator(r, side)
    out = []
    for s in segs:
        out += c.feed(s)
    return out + c.finish()


def close(p, q):
    return math.hypot(p[0] - q[0], p[1] - q[1]) < 1e-9


def test_outside_corner_of_a_square_is_rounded_around_the_corner():
    # lead-in along y=0 to (10,0), then up to (10,10); G42 puts the tool outside (right, -y side)
    out = run([("line", (-10, -0.0), (10, 0)), ("line", (10, 0), (10, 10))], 1.0, "right")
    assert close(out[0][2], (10, -1))                 # entry ends offset below the corner
    assert out[1][0] == "arc" and close(out[1][3], (10, 0)) and close(out[1][2], (11, 0))
    assert close(out[2][1], (11, 0)) and close(out[2][2], (11, 10))


def test_inside_corner_ends_both_offsets_at_their_intersection():
    out = run([("line", (-10, 0), (10, 0)), ("line", (10, 0), (10, 10))], 1.0, "left")
    assert close(out[0][2], (9, 1)) and close(out[1][1], (9, 1)) and close(out[1][2], (9, 10))


def test_inside_corner_shorter_than_the_tool_is_refused_as_a_gouge():
    with pytest.raises(CutterError, match="gouge"):
        run([("line", (-10, 0), (10, 0)), ("line", (10, 0), (10, 0.5)),
             ("line", (10, 0.5), (-10, 0.5))], 1.0, "left")


def test_entry_move_not_longer_than_the_radius_is_refused():
    with pytest.raises(CutterError, match="entry move of 0.5000 mm"):
        run([("line", (0, 0), (0.5, 0)), ("line", (0.5, 0), (5, 0))], 1.0, "left")


def test_arc_radius_grows_outside_and_shrinks_inside():
    circle = ("arc", (10, 0), (10, 0.0), (5, 0), True)      # full CCW circle of radius 5
    out = run([("line", (10, -10), (10, 0)), circle], 1.0, "left")   # tangent lead-in; left of CCW = inside
    arc = [s for s in out if s[0] == "arc" and close(s[3], (5, 0))][-1]
    assert math.isclose(math.hypot(arc[2][0] - 5, arc[2][1]), 4.0)
    out = run([("line", (10, -10), (10, 0)), circle], 1.0, "right")
    arc = [s for s in out if s[0] == "arc" and close(s[3], (5, 0))][-1]
    assert math.isclose(math.hypot(arc[2][0] - 5, arc[2][1]), 6.0)


def test_inside_arc_tighter_than_the_tool_is_refused():
    with pytest.raises(CutterError, match="arc radius 0.7071 mm"):
        run([("line", (10, 0), (1, 0)), ("arc", (1, 0), (0, 1), (0.5, 0.5), True)], 1.0, "left")


def test_outside_square_agrees_with_rs274():
    # rs274 -t tests/gcode/tool.tbl (D6 read as inches: radius 76.2 mm) on
    # G0 X-200 Y0 / G1 G42 D1 X100 Y0 / X100 Y200 / X-100 Y200 / G40 X-100 Y400 printed:
    # FEED(100,-76.2) ARC(176.2,0 c 100,0) FEED(176.2,200) ARC(100,276.2 c 100,200) FEED(-100,276.2)
    path = [("line", (-200, 0), (100, 0)), ("line", (100, 0), (100, 200)),
            ("line", (100, 200), (-100, 200))]
    out = run(path, 76.2, "right")
    ends = [s[2] for s in out]
    want = [(100, -76.2), (176.2, 0), (176.2, 200), (100, 276.2), (-100, 276.2)]
    assert all(math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-4 for a, b in zip(ends, want))
    assert len(ends) == len(want)
    assert [s[3] for s in out if s[0] == "arc"] == [(100, 0), (100, 200)]
    assert all(s[4] for s in out if s[0] == "arc")        # rs274 turn 1: counter-clockwise


def test_inside_square_and_its_gouge_agree_with_rs274():
    # rs274, G41 D1 (radius 76.2 mm) from X-200 Y0: X300 Y0 / X300 Y300 / X-100 Y300 / G40 X-100 Y500
    # printed FEED(223.8,76.2) FEED(223.8,223.8) FEED(-100,223.8); with Y50 instead of Y300 it
    # refused the third block: "Straight feed in concave corner cannot be reached ... gouging"
    def square(h):
        return [("line", (-200, 0), (300, 0)), ("line", (300, 0), (300, h)),
                ("line", (300, h), (-100, h))]
    out = run(square(300), 76.2, "left")
    want = [(223.8, 76.2), (223.8, 223.8), (-100, 223.8)]
    assert [s[0] for s in out] == ["line"] * 3
    assert all(math.hypot(s[2][0] - w[0], s[2][1] - w[1]) < 1e-4 for s, w in zip(out, want))
    c = Compensator(76.2, "left")
    c.feed(square(50)[0])
    c.feed(square(50)[1])
    with pytest.raises(CutterError, match="gouge"):
        c.feed(square(50)[2])
