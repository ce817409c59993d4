"""The lathe passes from a plain profile (retrofit.gcode.lathepasses), against hand-worked paths.

The profile of every test is a shaft: from the start point (Z2, X12) in to the face at X5, along
X5 to Z-10, up a shoulder to X10, along to Z-20, out to X12. Each expected path below is worked
out by hand from the rules in the module's doc (layers I apart from the start's X, each fed
along Z to the profile and retracted R at 45 degrees; D and U/W move the contour), not by the
code under test.
"""

from __future__ import annotations

import pytest

from retrofit.gcode.lathepasses import Segment, finish, rough

START = (2.0, 12.0)
POINTS = [(0.0, 5.0), (-10.0, 5.0), (-10.0, 10.0), (-20.0, 10.0), (-20.0, 12.0)]
SHAFT = [Segment("line", START, POINTS[0])] + [Segment("line", a, b) for a, b in zip(POINTS, POINTS[1:])]


def _path(moves):
    return [(m.kind, round(m.end[0], 6), round(m.end[1], 6)) for m in moves]


def _on_approach(x: float) -> float:
    """Z of the approach line (Z2 X12 to Z0 X5) at ``x``."""
    return 2.0 + (x - 12.0) / (5.0 - 12.0) * (0.0 - 2.0)


def test_g71_layers_are_i_apart_from_the_start_and_end_along_the_contour():
    moves = rough(SHAFT, START, depth=2.5, retract=0.5)
    z95, z7 = round(_on_approach(9.5), 6), round(_on_approach(7.0), 6)
    assert _path(moves) == [
        ("rapid", 2.0, 12.0), ("rapid", 2.0, 12.0), ("rapid", 2.0, 12.0),
        # layer at X12 (the start): to the last shoulder, out 0.5, back, in
        ("feed", -20.0, 12.0), ("rapid", -19.5, 12.5), ("rapid", 1.5, 12.5), ("rapid", 2.0, 12.0),
        # X9.5 and X7: start on the approach, end on the shoulder at Z-10
        ("rapid", z95, 9.5), ("feed", -10.0, 9.5), ("rapid", -9.5, 10.0),
        ("rapid", round(z95 - 0.5, 6), 10.0), ("rapid", z95, 9.5),
        ("rapid", z7, 7.0), ("feed", -10.0, 7.0), ("rapid", -9.5, 7.5),
        ("rapid", round(z7 - 0.5, 6), 7.5), ("rapid", z7, 7.0),
        # X4.5 is below the contour: down the approach to the face, then along the contour
        ("rapid", 0.0, 5.0), ("feed", -10.0, 5.0), ("feed", -10.0, 10.0), ("feed", -20.0, 10.0),
        ("feed", -20.0, 12.0)]


def test_g71_allowance_and_shift_move_the_contour():
    """D0.5 leaves 0.5 on the faces and diameters (the shoulder's outer corner rounded by an arc
    of 0.5 about the corner); the shift (W0.1, U0.2) then moves the whole path, start included,
    as rs274 moves it."""
    moves = rough(SHAFT, START, depth=10.0, retract=0.5, allowance=0.5, shift=(0.1, 0.2))
    assert _path(moves)[1] == ("rapid", 2.1, 12.2)
    tail = _path(moves)[-5:]
    assert tail == [("feed", -9.4, 5.7), ("feed", -9.4, 10.2), ("ccw", -9.9, 10.7),
                    ("feed", -19.4, 10.7), ("feed", -19.4, 12.2)]
    assert moves[-3].centre == pytest.approx((-9.9, 10.2))


def test_g70_passes_go_from_d_to_e_off_the_contour():
    short = [Segment("line", START, (0.0, 5.0)), Segment("line", (0.0, 5.0), (-10.0, 5.0)),
             Segment("line", (-10.0, 5.0), (-10.0, 12.0))]
    moves = finish(short, START, first=0.5, last=0.0, passes=2)
    assert _path(moves) == [
        ("rapid", 2.0, 12.0),
        ("rapid", 2.0, 12.0), ("rapid", 0.0, 5.25), ("feed", -9.75, 5.25), ("feed", -9.75, 12.0),
        ("rapid", 2.0, 12.0), ("rapid", 0.0, 5.0), ("feed", -10.0, 5.0), ("feed", -10.0, 12.0)]


def test_g71_1_follows_the_contour_without_pockets_and_g71_2_cuts_only_the_pocket():
    groove = [Segment("line", START, (0.0, 8.0)), Segment("line", (0.0, 8.0), (-4.0, 8.0)),
              Segment("line", (-4.0, 8.0), (-4.0, 6.0)), Segment("line", (-4.0, 6.0), (-8.0, 6.0)),
              Segment("line", (-8.0, 6.0), (-8.0, 8.0)), Segment("line", (-8.0, 8.0), (-12.0, 8.0)),
              Segment("line", (-12.0, 8.0), (-12.0, 12.0))]
    no_pockets = _path(rough(groove, START, depth=1.0, retract=0.5, pockets="none"))
    assert all(x >= 8.0 for _, _, x in no_pockets)              # never into the groove
    only = _path(rough(groove, START, depth=1.0, retract=0.5, pockets="only"))
    layers = sorted({x for kind, z, x in only if kind == "feed" and z == -8.0}, reverse=True)
    assert layers == [8.0, 7.0, 6.0]                 # the groove's layers, then its floor
    assert only[2] == ("rapid", 0.0, 8.0) and all(z <= 0.0 for _, z, _ in only[2:])


@pytest.mark.parametrize("kwargs, message", [
    ({"depth": 0.0}, "depth"), ({"depth": 1.0, "retract": -1.0}, "retract"),
    ({"depth": 1.0, "pockets": "some"}, "pockets")], ids=["depth-0", "retract-negative", "pockets"])
def test_bad_parameters_are_refused_naming_them(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rough(SHAFT, START, **kwargs)


def test_a_profile_that_turns_back_is_not_monotonic():
    back = [Segment("line", START, (0.0, 5.0)), Segment("line", (0.0, 5.0), (-6.0, 5.0)),
            Segment("line", (-6.0, 5.0), (-6.0, 8.0)), Segment("line", (-6.0, 8.0), (-3.0, 8.0)),
            Segment("line", (-3.0, 8.0), (-3.0, 12.0))]
    with pytest.raises(ValueError, match="Not monotonic"):
        rough(back, START, depth=1.0)


def _profiles():
    from hypothesis import strategies as st
    point = st.tuples(st.integers(-40, 4).map(float), st.integers(0, 30).map(float))
    return st.lists(point, min_size=2, max_size=7)


def test_any_profile_gives_passes_or_a_reason_never_a_crash_or_a_hang():
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    @settings(max_examples=50, deadline=None, suppress_health_check=list(HealthCheck))
    @given(_profiles(), st.sampled_from(["all", "none", "only"]), st.sampled_from([0.0, 0.3]),
           st.booleans())
    def run(points, pockets, allowance, facing):
        segs = [Segment("line", a, b) for a, b in zip([START] + points, points)]
        for call in (lambda: rough(segs, START, depth=1.0, retract=0.5, allowance=allowance,
                                   facing=facing, pockets=pockets),
                     lambda: finish(segs, START, first=allowance, passes=2)):
            try:
                moves = call()
            except ValueError:
                continue
            assert all(abs(v) < 1e4 for m in moves for v in m.end)   # nothing runs away
    run()


def test_g71_on_the_shipped_lathe_never_cuts_into_the_stock_left_for_finishing():
    """Every point the roughing moves to (chord points of its arcs too) stays at least D off the
    finished contour -- a chamfer, a diameter, a G2 shoulder, a taper -- and outside it."""
    import math

    from retrofit.commands import FMov, PMov
    from retrofit.gcode import compile_program
    from retrofit.machine.config import load_machine

    program = ("G18 G21 G90 G94 G8\nF200\nO100 SUB\nG0 X4 Z1\nG1 X6 Z0\nZ-8\nG2 X9 Z-11 I3 K0\n"
               "G1 X11 Z-14\nZ-20\nG1 X14\nO100 ENDSUB\nG0 X16 Z3\nG71 Q100 X16 Z3 D0.3 I1 R0.5\nM2\n")
    prog = compile_program(program, load_machine("chivu-lathe"), file="g71.ngc")
    contour = [(1.0, 4.0), (0.0, 6.0), (-8.0, 6.0)]
    contour += [(-8.0 - 3 * math.sin(t / 200 * math.pi / 2), 9.0 - 3 * math.cos(t / 200 * math.pi / 2))
                for t in range(1, 201)]                         # the G2 shoulder, centre Z-8 X9
    contour += [(-14.0, 11.0), (-20.0, 11.0), (-20.0, 14.0)]

    def gap(z, x):
        best = math.inf
        for (z0, x0), (z1, x1) in zip(contour, contour[1:]):
            dz, dx = z1 - z0, x1 - x0
            t = max(0.0, min(1.0, ((z - z0) * dz + (x - x0) * dx) / (dz * dz + dx * dx)))
            best = min(best, math.hypot(z - z0 - t * dz, x - x0 - t * dx))
        return best

    cut = [(dict(c.axes)["Z"], dict(c.axes)["X"]) for c, line in zip(prog.commands, prog.lines)
           if isinstance(c, (FMov, PMov)) and line == 13]
    assert len(cut) > 40                                        # the layers are there
    inside = [(z, x) for z, x in cut if -20.0 <= z <= 1.0 and x < 14.0]
    def surface(z):                                             # the contour's X at z
        for (z0, x0), (z1, x1) in zip(contour, contour[1:]):
            if z1 <= z <= z0 and z1 < z0:
                return x0 + (x1 - x0) * (z - z0) / (z1 - z0)
        return max(x for zc, x in contour if abs(zc - z) < 1e-9)

    assert all(x > surface(z) for z, x in inside)               # outside the part
    assert inside and min(gap(z, x) for z, x in inside) >= 0.3 - 1e-3
    assert min(gap(z, x) for z, x in inside) <= 0.3 + 1e-3       # and the last pass is on it
