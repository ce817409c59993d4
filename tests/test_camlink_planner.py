"""camlink's trajectory is planned by the main planner: the speed at every corner of a CAM path
equals the speed a G-code program of the same path plans there, and the rows never exceed it."""

from __future__ import annotations

import pytest

from retrofit.camlink.trajectory import plan_speeds, segments
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.planner import plan_program
from retrofit.motion.profile import P_V0, P_V1

MILL = load_machine("grenoble-mill")          # trapezoid profile: both plan the same shape
PATH = [(10.0, 0.0, 0.0), (10.0, 10.0, 0.0), (20.0, 12.0, 0.0), (30.0, 12.0, -1.0), (30.0, 30.0, -1.0),
        (31.0, 30.5, -1.0), (32.0, 30.5, -1.0), (0.0, 0.0, 0.0)]     # right angles, gentle turns, a reversal


@pytest.mark.parametrize("feed", [300.0, 900.0])
def test_corner_speeds_are_the_gcode_planners(feed):
    segs = segments(MILL, (0.0, 0.0, 0.0), [(p, feed) for p in PATH])
    plan_speeds(MILL, segs)
    text = "G21 G90 G17\nG0 X0 Y0 Z0\n" + "".join(f"G1 X{x:g} Y{y:g} Z{z:g} F{feed:g}\n" for x, y, z in PATH)
    commands = compile_program(text + "M2\n", MILL, file="path.ngc").commands
    moves = [m for m in plan_program(commands, MILL, backlash_comp=False).moves if m.profile is not None]
    assert len(moves) == len(segs) == len(PATH)
    for seg, move in zip(segs, moves):
        assert seg.v_entry == pytest.approx(move.profile[P_V0], rel=2e-3, abs=1e-3)
        assert seg.v_exit == pytest.approx(move.profile[P_V1], rel=2e-3, abs=1e-3)
    assert segs[-1].v_exit == 0.0 and segs[0].v_entry == 0.0
    assert any(0.0 < s.v_exit < s.v_max for s in segs)  # a corner that slows, not only full stops
