"""The planner over arrays gives the readable walker's plan, float for float, and its refusals."""

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_fast_equals_reference import machines, programs

from retrofit.commands import Dely, FFdr, FMov, PFdr, PMov, Pstn, ZMov
from retrofit.errors import MotionError
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.motion.planner import plan_program, plan_walked

compiled()                      # the compiled passes, whatever the size of the examples


def same_moves(fast, walked) -> None:
    assert len(fast.moves) == len(walked.moves) and fast.end_s == walked.end_s
    for a, b in zip(fast.moves, walked.moves):
        assert (a.start, a.end, a.target, a.t0_s, a.dwell_s, a.index) == (b.start, b.end, b.target, b.t0_s,
                                                                           b.dwell_s, b.index)
        assert (a.profile is None) == (b.profile is None)
        assert a.profile is None or a.profile.tobytes() == b.profile.tobytes()      # every bit of every float


@st.composite
def extras(draw, machine):
    """Commands the execution tests leave out: offsets, homing, rapid feeds."""
    name = draw(st.sampled_from(machine.axis_names))
    return draw(st.sampled_from([[Pstn(((name, draw(st.integers(-5, 5)) / 4),))], [ZMov()], [ZMov((name,))],
                                 [FFdr(draw(st.sampled_from([300.0, 2000.0])))], [Dely(0.002)]]))


@settings(max_examples=60)
@given(st.data())
def test_array_planner_equals_the_walker(data):
    machine = data.draw(machines())
    commands = data.draw(programs(machine))
    commands = commands[:1] + data.draw(extras(machine)) + commands[1:]
    comp = data.draw(st.booleans())
    try:
        walked = plan_walked(commands, machine, comp, (0,) * len(machine.axes))
    except MotionError as refused:                     # an offset put a target outside the limits
        with pytest.raises(MotionError, match=re.escape(str(refused))):
            plan_program(commands, machine, comp)
        return
    fast = plan_program(commands, machine, comp)
    if machine.motion.profile == "trapezoid":
        assert fast._moves is None                     # really planned over arrays, no object per move
    same_moves(fast, walked)


def test_square_and_circle_plan_equals_the_walker():
    from retrofit.gcode import compile_program
    machine = load_machine("engraver")
    text = "G21 G90 F1500\nG0 X10 Y10\n" + "G1 X60 Y10\nG1 X60 Y60\nG0 X35 Y20\nG2 X35 Y20 I0 J15\n" * 4
    commands = compile_program(text, machine).commands
    fast = plan_program(commands, machine)
    same_moves(fast, plan_walked(list(commands), machine, True, (0, 0, 0)))
    assert np.array_equal(fast.arrays().targets[-1], [round(35 * 80), round(20 * 80), 0])


@pytest.mark.parametrize("commands, words, index", [
    ([PMov((("X", 1.0),)), PFdr(0.0), PMov((("X", 2.0),))], "feed must be > 0", 1),
    ([FMov((("X", 5.0),)), FMov((("X", 500.0),))], "X 500.000 mm is outside the soft limits 0..200", 1),
    ([FMov((("Q", 1.0),))], "axis Q is not on machine engraver", 0),
], ids=["zero-feed", "soft-limit", "unknown-axis"])
def test_refusals_are_worded_by_the_walker(commands, words, index):
    with pytest.raises(MotionError, match=words) as caught:
        plan_program(commands, load_machine("engraver"))
    assert caught.value.command_index == index
