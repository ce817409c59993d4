"""A clock-timed program through the controller gives what the whole-program planner gives.

The controller prepares commands one at a time into a window of look-ahead moves and executes
them tick by tick; ``plan_program`` + ``execute_fast`` plan the whole program at once. With the
same look-ahead the two must agree: same steps, same end positions -- and, with a look-ahead of 3
or more, the very same port frames (on both a direction turns once the move needing it is in the
window, ``motion.stepshape``; tests/test_stream_reversal.py runs a program longer than it).
"""

import json
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.controller import Controller
from retrofit.controller.program import run_commands
from retrofit.gcode import load_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.run.program import resolve_program
from retrofit.sim import SimMachine

from tests.test_fast_equals_reference import machines, programs


def final_motor_steps(log):
    sim = SimMachine(log.machine, log.start_steps)
    sim.feed(log.frames)
    return tuple(sim.motor_steps)


def test_the_shipped_lathe_profile_gives_the_same_frames_bit_for_bit():
    lathe = load_machine("chivu-lathe")
    program = load_program(resolve_program("lathe-profile.ngc"), lathe)
    ref = execute_fast(plan_program(program.commands, lathe))
    ctl = run_commands(program.commands, lathe)
    log = ctl.run_log()
    assert ctl.frames() == ref.frames                         # 3.2 million ticks, every byte
    assert ctl.spans.ticks > 0.9 * ctl.ticks                  # ... nearly all by the compiled tick loop
    assert log.steps_emitted == ref.steps_emitted
    assert [w.reached_tick for w in log.waypoints] == [w.reached_tick for w in ref.waypoints]
    assert log.max_following_error_steps == ref.max_following_error_steps == 0


def check_controller_equals_fast(data):
    machine = data.draw(machines())
    commands = data.draw(programs(machine))
    comp = data.draw(st.booleans())
    ref = execute_fast(plan_program(commands, machine, backlash_comp=comp))
    ctl = run_commands(commands, machine, backlash_comp=comp)
    log = ctl.run_log()
    assert log.steps_emitted == ref.steps_emitted
    assert final_motor_steps(log) == final_motor_steps(ref)
    if machine.motion.lookahead >= 3:
        assert ctl.frames() == ref.frames
        assert [w.reached_tick for w in log.waypoints] == [w.reached_tick for w in ref.waypoints]
        assert log.max_following_error_steps == ref.max_following_error_steps


@settings(max_examples=25)
@given(st.data())
def test_random_programs_end_alike_and_give_the_same_frames(data):
    check_controller_equals_fast(data)


@pytest.mark.slow
@settings(max_examples=200)
@given(st.data())
def test_random_programs_end_alike_and_give_the_same_frames_200_programs(data):
    check_controller_equals_fast(data)


def test_the_controller_stepped_tick_by_tick_equals_its_fast_forward():
    """run_until_idle passes quiet ticks over; ticking every single tick gives the same frames."""
    lathe = replace(load_machine("chivu-lathe"), tick_us=200.0)
    program = load_program(resolve_program("lathe-profile.ngc"), lathe).commands[:30]
    fast = run_commands(program, lathe)
    slow = Controller(lathe)
    slow.stream(program)
    while not slow.idle:
        slow.tick()
    assert slow.frames() == fast.frames()
    assert slow.position_steps == fast.position_steps


def test_retrofit_run_with_the_controller_reports_what_the_planner_path_reports(tmp_path, capsys):
    from retrofit.cli import main
    assert main(["run", "lathe-profile.ngc", "--report", str(tmp_path / "plan.json")]) == 0
    assert main(["run", "lathe-profile.ngc", "--controller", "--report", str(tmp_path / "ctl.json")]) == 0
    out = capsys.readouterr().out
    assert "002 controller (--controller)" in out
    ctl, plan = (json.loads((tmp_path / name).read_text()) for name in ("ctl.json", "plan.json"))
    assert (ctl.pop("how"), plan.pop("how")) == ("002 controller (--controller)", "fast path")
    assert ctl == plan


def test_retrofit_run_takes_threads_through_the_controller_by_itself(tmp_path, capsys):
    from retrofit.cli import main
    program = tmp_path / "thread.ngc"
    program.write_text("G0 X12 Z3\nS600 M3\nG33 Z-6 K1.5\nG0 X14\nM30\n")
    assert main(["run", str(program), "--machine", "mitic-lathe", "--report", str(tmp_path / "t.json")]) == 0
    assert "002 controller (threads under the spindle's indexer)" in " ".join(capsys.readouterr().out.split())
    report = json.loads((tmp_path / "t.json").read_text())
    assert report["violations"] == [] and report["axes"]["Z"]["target_mm"] == -6.0
