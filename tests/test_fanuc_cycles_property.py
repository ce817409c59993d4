"""G71/G72 roughing on random profiles: passes come out for any profile that fits, none enters
the part (the cycle's own check would stop it), and the tool ends at the start point."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.gcode.errors import RuleError
from retrofit.gcode.fanuc_cycles import rough


@st.composite
def profiles(draw, pockets: bool):
    """Lines from (x0, 0) toward -Z; X rises (type I) or wanders (type II); radius units."""
    n = draw(st.integers(1, 6))
    x, z = draw(st.floats(1.0, 20.0)), 0.0
    points = [(x, z)]
    for _ in range(n):
        z -= draw(st.floats(0.0, 15.0))
        x = (draw(st.floats(1.0, 30.0)) if pockets else x + draw(st.floats(0.0, 8.0)))
        if (x, z) != points[-1]:
            points.append((x, z))
    if len(points) < 2:
        points.append((x + 1.0, z - 1.0))
    return [(1, a, b, None) for a, b in itertools.pairwise(points)]


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(profiles(pockets=False), st.floats(0.3, 4.0), st.floats(0.0, 1.0), st.floats(0.0, 0.5),
       st.floats(0.0, 0.3), st.booleans())
def test_type1_passes_end_at_the_start(profile, depth, retract, allow_x, allow_z, along_z):
    top = max(max(a[0], b[0]) for _, a, b, _ in profile)
    if not along_z:                        # G72: the same profile turned a quarter (Z steps)
        profile = [(1, (a[1] + top, a[0]), (b[1] + top, b[0]), None) for _, a, b, _ in profile]
        profile = [(1, (b[0], b[1]), (a[0], a[1]), None) for _, a, b, _ in reversed(profile)]
        start = (profile[0][1][0] + 2.0, max(max(a[1], b[1]) for _, a, b, _ in profile) + 2.0)
    else:
        start = (top + 2.0, 2.0)
    try:
        path = rough(profile, start, depth, retract, allow_x, allow_z, along_z, 0, 0, "G71")
    except RuleError as exc:               # a refusal says why in the cycle's terms
        assert "G71" in str(exc) and "cut into the part" not in str(exc), exc
        return
    assert path[-1][1] == start


@pytest.mark.slow
@settings(max_examples=80, deadline=None)
@given(profiles(pockets=True), st.floats(0.3, 4.0), st.floats(0.0, 1.0), st.floats(0.0, 0.5),
       st.floats(0.0, 0.3))
def test_type2_pockets_never_enter_the_part(profile, depth, retract, allow_x, allow_z):
    top = max(max(a[0], b[0]) for _, a, b, _ in profile)
    start = (top + 2.0, 2.0)
    path = rough(profile, start, depth, retract, allow_x, allow_z, True, 0, 0, "G71", type2=True)
    assert path[-1][1] == start
