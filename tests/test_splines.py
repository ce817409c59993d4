"""G5, G5.1, G5.2/G5.3 splines: the chords lie on the curve and stray from it by at most the
machine's arc tolerance. The curves here are written out by hand (Bernstein polynomials, and a
rational quadratic that is exactly a quarter circle), independently of retrofit's de Casteljau /
de Boor code. Where each spline ends is compared with LinuxCNC in tests/test_gcode_rs274.py."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from retrofit.commands import PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine(Path(__file__).resolve().parent / "gcode" / "rs274-mill.toml")
TOL = MILL.motion.arc_tolerance_mm
PRE = "G21 G90 G17\nG0 X0 Y0 Z0\nG1 F100\n"


def chords(program, line):
    """(x, y) of every PMOV made by ``line``, after the point where the tool was before."""
    out = []
    for cmd, n in zip(program.commands, program.lines):
        if isinstance(cmd, PMov) and n == line:
            p = dict(cmd.axes)
            out.append((p["X"], p["Y"]))
    return out


def cubic(p0, p1, p2, p3, t):
    b = ((1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t ** 3)
    return tuple(sum(w * p[k] for w, p in zip(b, (p0, p1, p2, p3))) for k in (0, 1))


def quadratic(p0, p1, p2, t):
    b = ((1 - t) ** 2, 2 * t * (1 - t), t * t)
    return tuple(sum(w * p[k] for w, p in zip(b, (p0, p1, p2))) for k in (0, 1))


def to_segment(m, p, q):
    dx, dy = q[0] - p[0], q[1] - p[1]
    n = dx * dx + dy * dy
    t = 0.0 if n == 0 else max(0.0, min(1.0, ((m[0] - p[0]) * dx + (m[1] - p[1]) * dy) / n))
    return math.hypot(m[0] - p[0] - t * dx, m[1] - p[1] - t * dy)


def assert_follows(curve, path, tol):
    """Every chord point on ``curve`` (within 1e-6 mm of a dense sampling's polyline) and every
    point of the curve within ``tol`` of the chords."""
    dense = [curve(k / 20000) for k in range(20001)]
    for p in path:
        near = min(range(len(dense)), key=lambda k: math.dist(dense[k], p))
        around = dense[max(near - 1, 0):near + 2]
        assert min(to_segment(p, a, b) for a, b in zip(around, around[1:])) < 1e-6, p
    worst = 0.0
    for k, m in enumerate(dense[::10]):
        worst = max(worst, min(to_segment(m, a, b) for a, b in zip(path, path[1:])))
    assert worst <= tol, f"the curve strays {worst:.5f} mm from its chords; tolerance {tol}"
    return worst


def test_g5_cubic_chords_lie_on_the_bezier_within_tolerance():
    prog = compile_program(PRE + "G5 I0 J3 P4 Q-1 X1 Y1\nM2\n", MILL)
    path = [(0.0, 0.0)] + chords(prog, 4)
    assert path[-1] == (1.0, 1.0)
    # control points: start, start + (I, J), end + (P, Q), end
    worst = assert_follows(lambda t: cubic((0, 0), (0, 3), (5, 0), (1, 1), t), path, TOL)
    assert worst > TOL / 4              # chords as long as the tolerance allows, not needlessly many


def test_g5_without_ij_continues_the_previous_direction():
    prog = compile_program(PRE + "G5 I0 J3 P4 Q-1 X1 Y1\nG5 P0 Q-1 X2 Y2\nM2\n", MILL)
    path = [(1.0, 1.0)] + chords(prog, 5)
    # I J default to minus the last P Q: first control point (1 - 4, 1 + 1)
    assert_follows(lambda t: cubic((1, 1), (-3, 2), (2, 1), (2, 2), t), path, TOL)


def test_g51_quadratic_in_inches_and_incremental():
    prog = compile_program(PRE + "G0 X2 Y1\nG20 G91\nG5.1 X0.2 Y0 I0.1 J0.2\nM2\n", MILL)
    path = [(2.0, 1.0)] + chords(prog, 6)
    assert path[-1] == pytest.approx((2.0 + 5.08, 1.0))
    assert_follows(lambda t: quadratic((2, 1), (4.54, 6.08), (7.08, 1), t), path, TOL)


def test_nurbs_with_corner_weight_cos45_is_a_quarter_circle():
    w = math.sqrt(0.5)
    prog = compile_program(PRE + f"G0 X10 Y0\nG5.2 X10 Y10 P{w:.12f}\nX0 Y10 P1\nG5.3\nM2\n", MILL)
    path = [(10.0, 0.0)] + chords(prog, 7)
    assert path[-1] == (0.0, 10.0)
    for p in path:
        assert math.hypot(*p) == pytest.approx(10.0, abs=1e-6)
    sagitta = [10.0 - math.hypot((a[0] + b[0]) / 2, (a[1] + b[1]) / 2) for a, b in zip(path, path[1:])]
    assert max(sagitta) <= TOL
    fewest = math.ceil((math.pi / 2) / (2 * math.acos(1 - TOL / 10.0)))   # chords of a circle
    assert fewest <= len(path) - 1 <= 3 * fewest


def test_a_finer_machine_tolerance_makes_more_chords():
    fine = replace(MILL, motion=replace(MILL.motion, arc_tolerance_mm=TOL / 10))
    text = PRE + "G5.1 X20 Y0 I10 J10\nM2\n"
    coarse, finer = chords(compile_program(text, MILL), 4), chords(compile_program(text, fine), 4)
    assert len(finer) > 2 * len(coarse)
    assert_follows(lambda t: quadratic((0, 0), (10, 10), (20, 0), t), [(0.0, 0.0)] + finer, TOL / 10)


def test_nurbs_of_order_4_with_four_points_is_the_cubic_bezier():
    prog = compile_program(PRE + "G5.2 P2 L4\nX0 Y3 P2\nX5 Y0 P2\nX1 Y1 P2\nG5.3\nM2\n", MILL)
    path = [(0.0, 0.0)] + chords(prog, 8)
    assert_follows(lambda t: cubic((0, 0), (0, 3), (5, 0), (1, 1), t), path, TOL)


def test_quadratic_nurbs_of_four_points_is_two_beziers_joined_mid_span():
    """Knots 0 0 0 1 2 2 2: the curve passes the midpoint M of the middle control points and is
    the quadratic Bezier (P0, P1, M) then (M, P2, P3)."""
    prog = compile_program(PRE + "G5.2 X0 Y8 P1\nX8 Y8 P1\nX8 Y0 P1\nG5.3\nM2\n", MILL)
    path = [(0.0, 0.0)] + chords(prog, 7)
    halves = lambda t: quadratic((0, 0), (0, 8), (4, 8), 2 * t) if t <= 0.5 else \
        quadratic((4, 8), (8, 8), (8, 0), 2 * t - 1)  # noqa: E731
    assert_follows(halves, path, TOL)


@pytest.mark.parametrize("text, line, words", [
    ("G18\nG5 I1 J1 P1 Q1 X2 Z1\n", 5, "XY plane (G17)"),
    ("G5 I1 J0 P1 Q0 X2 Y0 Z-1\n", 4, "Z-1: splines move X and Y only"),
    ("G5.2 X1 Y1 P1\nX2 Y0\nG5.3\n", 5, "weight P > 0"),
    ("G5.2 X1 Y1 P1 L4\nX2 Y0 P1\nG5.3\n", 6, "order L = 4"),
    ("G93\nG5.2 X1 Y1 P1\n", 5, "G93"),
    ("G5.2 X1 Y1 P1\nG5 I1 J1 P1 Q1 X3 Y3\n", 5, "end the NURBS with G5.3"),
])
def test_refusals_name_the_line_and_the_rule(text, line, words):
    with pytest.raises(GcodeError) as err:
        compile_program(PRE + text + "M2\n", MILL, file="s.ngc")
    assert f"s.ngc:{line}:" in str(err.value) and words in str(err.value)


def test_spline_outside_the_soft_limits_is_refused_before_any_motion():
    small = replace(MILL, axes=tuple(replace(a, max_mm=50.0) for a in MILL.axes))
    with pytest.raises(GcodeError, match="G5.1 spline is outside the soft limits"):
        compile_program(PRE + "G5.1 X40 Y0 I20 J120\nM2\n", small)
