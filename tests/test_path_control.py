"""G61, G61.1 and G64 P Q, judged on the simulated carriage: under G64 P the carriage passes the
programmed corner within P and without stopping; under G61 it stops there."""

from __future__ import annotations

import math

import numpy as np
import pytest

from retrofit.commands import Dely, PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.run.program import plan_compiled
from retrofit.sim import SimMachine

MILL = load_machine("tul-mill")
#: a path with shallow turns (2 and 4 degrees, a CAM polyline), where flowing through pays
SQUARE = "G1 X15 F1200\nX30 Y0.5\nX44 Y0\nM2\n"
CORNERS = [(15.0, 0.0), (30.0, 0.5)]
EVERY = 5                       # ticks between carriage samples
DISC_MM = 0.3                   # the corner is judged by the time spent within this of it


def carriage_path(text: str):
    """(ticks, x mm, y mm) of the simulated carriage, sampled every EVERY ticks."""
    program, plan = plan_compiled(compile_program("G21 G90 G17\n" + text, MILL), MILL)
    log = execute_fast(plan)
    sim = SimMachine(MILL, log.start_steps)
    ticks = np.arange(0, log.frames.end_tick, EVERY)
    sim.watch(ticks)
    sim.feed(log.frames)
    xy = np.array([[sim.state_at(int(t))[a][1] for a in "XY"] for t in ticks])
    return ticks, xy


def corner_visits(text: str):
    """For each corner: (closest approach mm, seconds the carriage spends within DISC_MM)."""
    ticks, xy = carriage_path(text)
    out = []
    for corner in CORNERS:
        d = np.hypot(xy[:, 0] - corner[0], xy[:, 1] - corner[1])
        inside = np.flatnonzero(d <= DISC_MM)
        out.append((float(d.min()), (inside[-1] - inside[0]) * EVERY * MILL.tick_s))
    return out


def from_rest_s() -> float:
    """The shortest time in and out of the disc with a stop at the corner: DISC_MM from rest
    at the highest acceleration of X and Y, twice."""
    a = max(MILL.axis(n).max_accel_mm_s2 for n in "XY")
    return 2 * math.sqrt(2 * DISC_MM / a)


@pytest.mark.parametrize("p", [0.05, 0.5])
def test_g64_p_passes_every_corner_within_p_and_faster_than_a_stop(p):
    g61 = corner_visits("G61\n" + SQUARE)
    for (closest, inside), (_, stopped) in zip(corner_visits(f"G64 P{p}\n" + SQUARE), g61):
        assert closest <= p
        assert inside < 0.8 * stopped


def test_g61_stops_exactly_at_every_corner():
    step = max(a.step_mm for a in MILL.axes)
    for closest, inside in corner_visits("G61\n" + SQUARE):
        assert closest <= step
        assert inside >= from_rest_s() - 2 * EVERY * MILL.tick_s


def test_g61_then_g64_is_slower_only_where_it_is_in_force():
    g61 = compile_program("G21 G90 G17 G61\n" + SQUARE, MILL)
    g64 = compile_program("G21 G90 G17 G64\n" + SQUARE, MILL)
    dwells = [c for c in g61.commands if isinstance(c, Dely)]
    assert len(dwells) == 2 and all(d.seconds == 0.0 for d in dwells)
    assert not any(isinstance(c, Dely) for c in g64.commands)
    t61 = plan_compiled(g61, MILL)[1].end_s
    t64 = plan_compiled(g64, MILL)[1].end_s
    assert t61 > t64


def test_g61_does_not_stop_between_the_chords_of_one_arc():
    program = compile_program("G21 G90 G17 G61\nG0 X10 Y10\nG1 X20 F600\nG3 X10 Y20 I-5 J5\nG1 X5\nM2\n", MILL)
    kinds = [(type(c).__name__, line) for c, line in zip(program.commands, program.lines)]
    arc = [k for k, (_, line) in enumerate(kinds) if line == 4]
    assert sum(1 for k in arc if kinds[k][0] == "PMov") > 10
    assert [kinds[k][0] for k in arc].count("Dely") == 1 and kinds[arc[0]][0] == "Dely"
    assert isinstance(program.commands[-1], PMov) and isinstance(program.commands[-2], Dely)


@pytest.mark.parametrize("words, rule", [("G64 P0.1 Q-0.05", "test.ngc:2: Q-0.05: G64's naive-CAM tolerance Q"),
                                         ("G64 P-1", "test.ngc:2: P-1: G64's path tolerance P")])
def test_g64_refusals(words, rule):
    with pytest.raises(GcodeError) as err:
        compile_program("G21 G90 G17\n" + words + "\nM2\n", MILL, file="test.ngc")
    assert rule in str(err.value)


def test_g64_q0_is_accepted():
    compile_program("G21 G90 G17\nG64 P0.1 Q0\nG1 X1 F100\nM2\n", MILL)


def test_g64_q_runs_every_programmed_move():
    """Nearly collinear moves are not merged: the path keeps every programmed point (within any Q)."""
    body = "G1 X1 Y0.001 F100\nG1 X2 Y0\nG1 X3 Y0.001\nG1 X4 Y0\nM2\n"
    with_q = compile_program("G21 G90 G17\nG64 P0.05 Q0.02\n" + body, MILL)
    without = compile_program("G21 G90 G17\nG64 P0.05\n" + body, MILL)
    assert [str(c) for c in with_q.commands] == [str(c) for c in without.commands]
    assert sum(1 for c in with_q.commands if str(c).startswith("PMOV")) == 4
