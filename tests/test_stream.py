"""The streamed execution equals the fast path bit for bit, whatever the window size."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_fast_equals_reference import machines, programs

from retrofit.commands import FMov, PFdr, PMov
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.motion.stream import execute_streamed, stream_frames

compiled()                      # the compiled kernels, whatever the size of the examples


def check_streamed_equals_fast(data):
    machine = data.draw(machines())
    plan = plan_program(data.draw(programs(machine)), machine, backlash_comp=data.draw(st.booleans()))
    fast = execute_fast(plan)
    streamed = execute_streamed(plan, window_steps=data.draw(st.sampled_from([1, 7, 60, 1 << 20])))
    assert streamed.frames == fast.frames
    assert streamed.waypoints == fast.waypoints
    assert streamed.steps_emitted == fast.steps_emitted
    assert streamed.max_following_error_steps == fast.max_following_error_steps


@settings(max_examples=40)
@given(st.data())
def test_streamed_equals_fast_path(data):
    check_streamed_equals_fast(data)


@pytest.mark.slow
@settings(max_examples=300)
@given(st.data())
def test_streamed_equals_fast_path_300_programs(data):
    check_streamed_equals_fast(data)


def test_chunks_are_bounded_and_follow_one_another():
    machine = load_machine("engraver")
    commands = [PFdr(3000.0)]
    for i in range(40):
        commands += [PMov((("X", 10.0 + i % 2 * 20), ("Y", 5.0 + i % 3 * 10))), FMov((("Y", 40.0),))]
    plan = plan_program(commands, machine)
    chunks = list(stream_frames(plan, window_steps=2000))
    fast = execute_fast(plan)
    assert len(chunks) > 10
    assert max(len(c) for c in chunks) < len(fast.frames) / 5          # no chunk holds the run
    for before, after in zip(chunks, chunks[1:]):
        assert after.end_tick >= before.end_tick
        assert len(before) == 0 or before.ticks[-1] < before.end_tick
        assert len(after) == 0 or after.ticks[0] >= before.end_tick
    assert chunks[-1].end_tick == fast.frames.end_tick


@pytest.mark.parametrize("text", ["G17 G2 X30 Y20 Z-3 I5 J0 F900",         # three axes step at once
                                  "G17 G2 X30 Y20 I5 J0 F900\nG1 Y25\nG1 X10 Y5"],
                         ids=["helix", "plane"])
def test_streamed_frames_of_two_or_three_moving_axes_equal_the_fast_path(text, monkeypatch):
    """Two axes' steps are walked into port bytes at once, three through the lists of changes:
    both give the fast path's frames, in windows of a few steps (pulses and turns cut across)."""
    import retrofit.motion.bitmerge as bitmerge
    from retrofit.gcode import compile_program
    machine = load_machine("engraver")
    plan = plan_program(compile_program("G21 G90\nG0 X20 Y20 Z0\n" + text, machine).commands, machine)
    walks = []
    real = bitmerge.follow_two_axes
    monkeypatch.setattr(bitmerge, "follow_two_axes", lambda *a: walks.append(1) or real(*a))
    for window in (1, 7, 1000):
        walks.clear()
        assert execute_streamed(plan, window_steps=window).frames == execute_fast(plan).frames
        assert (len(walks) < len(list(stream_frames(plan, window))) / 2) == ("Z" in text)
