"""Arcs as chords (004): every chord within the allowed radius error, the end point hit exactly."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from retrofit.gcode.state import clean_mm, clean_mm_list
from retrofit.machine.config import load_machine
from retrofit.motion.arcs import MAX_CHORD_ANGLE, arc_columns, arc_points, chord_angle, chord_length

TOL = 0.002


def formula_chord(r, e):
    """004's chord length l = 2·sqrt(r² − (r − e)²), written as in the paper."""
    return 2.0 * math.sqrt(r * r - (r - e) ** 2)


def chords_of(start, points):
    """(from, to) pairs of the chords of an arc that begins at ``start``."""
    path = [tuple(start)] + points
    return list(zip(path[:-1], path[1:]))


def max_radial_deviation(start, points, center, radius, plane=(0, 1)):
    """Largest gap between a chord and the circle: at the chord's middle (or at its ends)."""
    a, b = plane
    worst = 0.0
    for p, q in chords_of(start, points):
        for s in (0.0, 0.5, 1.0):
            x = p[a] + (q[a] - p[a]) * s - center[a]
            y = p[b] + (q[b] - p[b]) * s - center[b]
            worst = max(worst, abs(radius - math.hypot(x, y)))
    return worst


def circle_point(center, radius, degrees):
    t = math.radians(degrees)
    return (center[0] + radius * math.cos(t), center[1] + radius * math.sin(t))


# -- chord_angle --------------------------------------------------------------------------------

@pytest.mark.parametrize("radius", [0.5, 15.0, 200.0], ids=["r0.5", "r15", "r200"])
def test_chord_angle_gives_004s_chord_length_and_sagitta(radius):
    theta = chord_angle(radius, TOL)
    assert 2 * radius * math.sin(theta / 2) == pytest.approx(formula_chord(radius, TOL), rel=1e-9)
    assert radius * (1 - math.cos(theta / 2)) == pytest.approx(TOL, rel=1e-6)
    assert chord_length(radius, TOL) == pytest.approx(formula_chord(radius, TOL), rel=1e-12)


@pytest.mark.parametrize("radius, tol", [(0.001, 0.002), (0.002, 0.002), (0.0025, 0.002), (1.0, 5.0)],
                         ids=["r<e", "r=e", "r slightly > e", "coarse"])
def test_small_radius_gets_at_most_a_quarter_turn_per_chord(radius, tol):
    assert chord_angle(radius, tol) == MAX_CHORD_ANGLE
    start, center = (radius, 0.0), (0.0, 0.0)
    points = arc_points(start, start, center, False, (0, 1), tol)
    assert len(points) == 4                      # a full circle: one chord per quarter turn
    assert points[-1] == start


def test_chord_angle_shrinks_as_the_radius_grows():
    angles = [chord_angle(r, TOL) for r in (0.5, 1, 5, 15, 50, 200, 1000)]
    assert angles == sorted(angles, reverse=True)


@pytest.mark.parametrize("radius, tol", [(0.0, TOL), (-1.0, TOL), (10.0, 0.0), (10.0, -0.1)],
                         ids=["r=0", "r<0", "e=0", "e<0"])
def test_chord_angle_rejects_nonpositive_values(radius, tol):
    with pytest.raises(ValueError):
        chord_angle(radius, tol)


# -- arc_points: the properties 004 asks for -------------------------------------------------------

@pytest.mark.parametrize("radius", [0.5, 15.0, 200.0], ids=["r0.5", "r15", "r200"])
@pytest.mark.parametrize("clockwise", [False, True], ids=["G3", "G2"])
@pytest.mark.parametrize("span", [30.0, 180.0, 359.0], ids=["30deg", "180deg", "359deg"])
def test_chords_stay_within_the_allowed_radius_error(radius, clockwise, span):
    center = (3.0, -7.0)
    start = circle_point(center, radius, 20.0)
    end = circle_point(center, radius, 20.0 - span if clockwise else 20.0 + span)
    points = arc_points(start, end, center, clockwise, (0, 1), TOL)
    assert points[-1] == end
    assert max_radial_deviation(start, points, center, radius) <= TOL
    # but not needlessly fine: the fewest equal chords that meet the tolerance
    assert len(points) == max(1, math.ceil(math.radians(span) / chord_angle(radius, TOL)))


@pytest.mark.parametrize("radius", [0.5, 15.0, 200.0], ids=["r0.5", "r15", "r200"])
def test_points_lie_on_the_arc_at_equal_central_angles(radius):
    center = (0.0, 0.0)
    start = (radius, 0.0)
    end = circle_point(center, radius, 250.0)
    points = arc_points(start, end, center, False, (0, 1), TOL)
    angles = [math.atan2(p[1], p[0]) for p in [start] + points]
    steps = [(b - a) % (2 * math.pi) for a, b in zip(angles[:-1], angles[1:])]
    for p in points:
        assert math.hypot(*p) == pytest.approx(radius, abs=1e-9)
    assert max(steps) - min(steps) < 1e-9
    assert sum(steps) == pytest.approx(math.radians(250.0), abs=1e-9)


@pytest.mark.parametrize("radius", [0.5, 15.0, 200.0], ids=["r0.5", "r15", "r200"])
def test_no_chord_is_longer_than_the_formula_allows(radius):
    start, center = (radius, 0.0), (0.0, 0.0)
    points = arc_points(start, start, center, True, (0, 1), TOL)
    longest = max(math.dist(p, q) for p, q in chords_of(start, points))
    assert longest <= formula_chord(radius, TOL) + 1e-12


@pytest.mark.parametrize("radius", [0.5, 15.0, 200.0], ids=["r0.5", "r15", "r200"])
def test_full_circle_returns_to_its_start_exactly_in_steps(radius):
    engraver_steps = {"X": 80.0, "Y": 80.0}
    start = (100.0 + radius, 100.0)
    points = arc_points(start, start, (100.0, 100.0), False, (0, 1), TOL)
    steps = [tuple(round(v * k) for v, k in zip(p, engraver_steps.values())) for p in points]
    start_steps = tuple(round(v * k) for v, k in zip(start, engraver_steps.values()))
    assert steps[-1] == start_steps
    # and the step deltas chord by chord add up to zero: no step is lost going round
    deltas = [tuple(b - a for a, b in zip(p, q)) for p, q in zip([start_steps] + steps[:-1], steps)]
    assert tuple(map(sum, zip(*deltas))) == (0, 0)
    assert len(points) >= 4
    assert max_radial_deviation(start, points, (100.0, 100.0), radius) <= TOL


def test_full_circle_on_a_real_machine_ends_on_the_start_step():
    lathe = load_machine("chivu-lathe")
    start = (12.345, -67.891)                    # X, Z in mm, between steps on both axes
    center = (12.345, -60.0)
    points = arc_points(start, start, center, True, (1, 0), lathe.motion.arc_tolerance_mm)
    to_steps = [lathe.axis(n).to_steps for n in lathe.axis_names]

    def steps(p):
        return tuple(f(v) for f, v in zip(to_steps, p))
    assert steps(points[-1]) == steps(start)


def test_full_turns_add_whole_circles():
    start, center = (10.0, 0.0), (0.0, 0.0)
    one = arc_points(start, start, center, False, (0, 1), 0.01)
    three = arc_points(start, start, center, False, (0, 1), 0.01, full_turns=2)
    theta = chord_angle(10.0, 0.01)
    assert len(one) == math.ceil(2 * math.pi / theta)
    assert len(three) == math.ceil(6 * math.pi / theta)
    assert three[-1] == start
    assert max_radial_deviation(start, three, center, 10.0) <= 0.01


def test_helix_moves_the_third_axis_linearly_with_the_angle():
    start, end, center = (10.0, 0.0, 5.0), (-10.0, 0.0, -1.0), (0.0, 0.0, 0.0)
    points = arc_points(start, end, center, False, (0, 1), 0.01)
    for p in points:
        turned = math.atan2(p[1], p[0]) % (2 * math.pi)
        assert p[2] == pytest.approx(5.0 - 6.0 * turned / math.pi, abs=1e-9)
    assert points[-1] == end


def test_plane_axes_choose_the_plane_and_the_sense_of_rotation():
    # G18 on (X, Y, Z) tuples: plane (Z, X); counter-clockwise turns from Z towards X
    start, end, center = (0.0, 4.0, 10.0), (10.0, 4.0, 0.0), (0.0, 0.0, 0.0)
    ccw = arc_points(start, end, center, False, (2, 0), 0.01)
    cw = arc_points(start, end, center, True, (2, 0), 0.01)
    assert all(p[0] >= -1e-12 and p[2] >= -1e-12 for p in ccw)       # the quarter between +Z and +X
    assert any(p[0] < -5 for p in cw)                                # the long way round
    assert all(p[1] == 4.0 for p in ccw + cw)


def test_centre_on_the_start_point_is_refused():
    with pytest.raises(ValueError, match="radius is 0"):
        arc_points((1.0, 1.0), (2.0, 2.0), (1.0, 1.0), False, (0, 1), TOL)


@given(radius=st.floats(0.01, 500.0), tol=st.floats(0.0005, 0.5),
       a0=st.floats(-180.0, 180.0), span=st.floats(0.5, 720.0), clockwise=st.booleans())
def test_any_arc_stays_within_tolerance_and_ends_exactly(radius, tol, a0, span, clockwise):
    center = (1.5, -2.5)
    start = circle_point(center, radius, a0)
    end = circle_point(center, radius, a0 - span if clockwise else a0 + span)
    points = arc_points(start, end, center, clockwise, (0, 1), tol)
    assert points[-1] == end
    assert max_radial_deviation(start, points, center, radius) <= tol + 1e-9
    for p, q in chords_of(start, points):
        assert math.dist(p, q) <= chord_length(radius, tol) + 1e-9


@given(r0=st.floats(0.01, 400.0), r1=st.floats(0.01, 400.0), tol=st.floats(0.0005, 0.5),
       a0=st.floats(-180.0, 180.0), a1=st.floats(-180.0, 180.0), clockwise=st.booleans(),
       z=st.floats(-50.0, 50.0), turns=st.integers(0, 2), plane=st.sampled_from([(0, 1), (2, 0), (1, 2)]))
def test_arc_columns_are_arc_points_bit_for_bit(r0, r1, tol, a0, a1, clockwise, z, turns, plane):
    """The array form of the chords (what G-code arcs compile through) holds the very floats of
    the readable per-point form, spirals and helices included."""
    centre = [3.25, -7.5, 1.0]
    a, b = plane
    start, end = list(centre), list(centre)
    for point, radius, angle in ((start, r0, a0), (end, r1, a1)):
        point[a] += radius * math.cos(math.radians(angle))
        point[b] += radius * math.sin(math.radians(angle))
    end[3 - a - b] += z
    points = arc_points(tuple(start), tuple(end), tuple(centre), clockwise, plane, tol, turns)
    columns = arc_columns(tuple(start), tuple(end), tuple(centre), clockwise, plane, tol, turns)
    assert columns.tolist() == [list(p) for p in points]


@given(st.lists(st.floats(-1000.0, 1000.0), min_size=1, max_size=50))
def test_clean_mm_list_rounds_as_python_round(values):
    got = clean_mm_list(np.array(values))
    assert [(v, str(v)) for v in got] == [(clean_mm(v), str(clean_mm(v))) for v in values]


def test_clean_mm_list_breaks_ties_as_python_round():
    """Values a hair off a half of the last decimal, where scaling by 1e9 rounds across the half."""
    rng = np.random.default_rng(7)
    halves = rng.integers(-10 ** 12, 10 ** 12, 20000) / 1e9 + 0.5e-9
    values = np.concatenate([halves, np.nextafter(halves, 0.0), np.nextafter(halves, 1e9),
                             [0.0, -0.0, -1e-12, 2.5e-9, -2.5e-9, 1e7 + 0.5e-9]])
    got = clean_mm_list(values)
    assert [str(v) for v in got] == [str(clean_mm(v)) for v in values.tolist()]
