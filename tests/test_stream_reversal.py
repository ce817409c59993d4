"""A reversal far ahead (plunge, passes, retract) holds back no frame of the stream, and the
streamed, fast, reference and controller paths still give the same frames."""

from dataclasses import replace

import numpy as np

from retrofit.commands import PFdr, PMov
from retrofit.controller.program import run_commands
from retrofit.frames import PinMap
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.motion.execute import execute_reference
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.motion.stream import execute_streamed, stream_frames

compiled()                      # the compiled kernels, whatever the size of the examples


def lathe(lookahead: int = 16):
    """The lathe with a slow driver on X (set-up and hold times) and its backlash."""
    machine = load_machine("chivu-lathe")
    x = replace(machine.axes[0], dir_setup_ticks=3, dir_hold_ticks=2, pulse_low_ticks=2)
    assert x.backlash_mm > 0
    return replace(machine, axes=(x,) + machine.axes[1:],
                   motion=replace(machine.motion, lookahead=lookahead))


def plunge_and_return(passes: int = 30):
    """X in, Z along in short moves, X back out: X reverses once, at the very end."""
    commands = [PFdr(600.0), PMov((("X", -0.5),))]
    commands += [PMov((("Z", -1.0 - i),)) for i in range(passes)]
    return commands + [PMov((("X", 0.0),))]


def x_dir_turns(machine, frames) -> list[int]:
    bits = frames.values.astype(np.int64) & PinMap(machine).dir_masks[0]
    return frames.ticks[np.flatnonzero(np.diff(bits)) + 1].tolist()


def test_a_reversal_far_ahead_holds_back_no_chunk():
    machine = lathe()
    plan = plan_program(plunge_and_return(), machine)
    chunks = list(stream_frames(plan, window_steps=100))
    total = sum(len(c) for c in chunks)
    assert len(chunks) > 10
    assert len(chunks[0]) > 1                             # the plunge's steps come first
    assert all(len(c) for c in chunks[:-1])               # every chunk carries frames
    assert len(chunks[-1]) < total / 5                    # the last one no more than its share


def test_the_direction_turns_when_the_reversing_move_enters_the_look_ahead():
    machine = lathe(lookahead=3)
    plan = plan_program(plunge_and_return(), machine)
    log = execute_fast(plan)
    loaded = [w.loaded_tick for w in log.waypoints]
    turns = x_dir_turns(machine, log.frames)
    assert turns[-1] == loaded[-1 - 4]                    # the retract is 4 moves behind then


def test_plunge_and_return_streamed_equals_fast_and_reference():
    machine = lathe(lookahead=3)
    plan = plan_program(plunge_and_return(), machine)
    reference = execute_reference(plan)
    for log in (execute_fast(plan), execute_streamed(plan, window_steps=40)):
        assert log.frames == reference.frames
        assert log.waypoints == reference.waypoints
        assert log.steps_emitted == reference.steps_emitted
        assert log.max_following_error_steps == reference.max_following_error_steps


def test_the_controller_turns_the_direction_where_the_planner_path_does():
    machine = lathe(lookahead=3)
    commands = plunge_and_return(passes=12)
    fast = execute_fast(plan_program(commands, machine))
    ctl = run_commands(commands, machine)
    assert ctl.frames() == fast.frames
