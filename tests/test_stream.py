"""The streamed execution equals the fast path bit for bit, whatever the window size."""

import pytest
from hypothesis import given, settings, strategies as st

from retrofit.commands import FMov, PFdr, PMov
from retrofit.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.motion.stream import execute_streamed, stream_frames
from test_fast_equals_reference import machines, programs

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
