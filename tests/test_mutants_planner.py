"""The planner on a worked program: where each move starts and ends in motor steps (the backlash
clearance taken up on each reversal, at segment boundaries), the offsets PSTN sets, dwells and
homing moves in the timeline, and the refusals; then the steps the fast path puts on the wire, a
late reversal's set-up on the NumPy path, and planning and streaming in batches."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from retrofit.commands import Dely, FFdr, FMov, PFdr, PMov, Pstn, ZMov
from retrofit.errors import MotionError
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast, plan_steps
from retrofit.motion.planner import plan_program, plan_walked

from tests.helpers import step_times

LATHE = load_machine("chivu-lathe")      # X 40 steps/mm, Z 50 steps/mm, 4 steps of clearance each

PROGRAM = [PFdr(600), PMov((("X", -2.0),)), PMov((("X", 1.0),)), PMov((("Z", -1.0),)),
           PMov((("X", 0.5), ("Z", -0.5))), Dely(0.5), ZMov()]
#: (start, end) motor steps and the commanded target of each move, worked by hand: the nut starts
#: on its negative face; turning positive adds the 4-step clearance to the motor, turning back
#: negative drops it
MOVES = [((0, 0), (-80, 0), (-80, 0)),
         ((-80, 0), (44, 0), (40, 0)),           # X reverses: 120 steps + 4
         ((44, 0), (44, -50), (40, -50)),        # X stays on its positive face
         ((44, -50), (20, -21), (20, -25)),      # X back negative, Z turns positive (+4)
         ((20, -21), (20, -21), (20, -25)),      # the dwell
         ((20, -21), (0, 4), (0, 0))]            # home: X negative, Z positive


def both_planners(commands, machine=LATHE, backlash_comp=True, start=(0, 0)):
    return [plan_program(commands, machine, backlash_comp, start),
            plan_walked(list(commands), machine, backlash_comp, tuple(start))]


def test_each_moves_motor_steps_take_up_the_clearance_on_reversal_only():
    for plan in both_planners(PROGRAM):
        moves = plan.moves
        assert [(m.start, m.end, m.target) for m in moves] == MOVES
        assert [m.index for m in moves] == [1, 2, 3, 4, 5, 6]
        assert moves[4].profile is None and moves[4].dwell_s == 0.5 and moves[4].duration_s == 0.5
        # one after the other: each starts when the one before ends, the run when the last ends
        assert moves[0].t0_s == 0.0
        for a, b in zip(moves, moves[1:]):
            assert b.t0_s == pytest.approx(a.t0_s + a.duration_s)
        assert plan.end_s == pytest.approx(moves[-1].t0_s + moves[-1].duration_s)
        # the moves into the dwell and out of it stop; the reversal X -2 -> 1 stops; ZMOV starts at rest
        assert moves[0].profile[3] == 0.0 and moves[1].profile[1] == 0.0
        assert moves[3].profile[3] == 0.0 and moves[5].profile[1] == 0.0
    uncompensated = both_planners(PROGRAM, backlash_comp=False)
    for plan in uncompensated:
        assert [m.end for m in plan.moves] == [t for _, _, t in MOVES]


def test_the_wire_carries_the_clearance_steps_on_each_reversal():
    plan = plan_program(PROGRAM, LATHE)
    assert plan_steps(plan) == 80 + 124 + 50 + (24 + 29) + (20 + 25)     # the dwell has none
    rises = step_times(LATHE, execute_fast(plan).frames)
    x, z = rises["X"][1], rises["Z"][1]
    # X: 80 down, 124 up, 24 down, 20 down; Z: 50 down, 29 up, 25 up
    assert (int(np.sum(x < 0)), int(np.sum(x > 0))) == (124, 124)
    assert (int(np.sum(z < 0)), int(np.sum(z > 0))) == (50, 54)
    assert np.all(x[:80] < 0) and np.all(x[80:204] > 0) and np.all(x[204:] < 0)


def test_pstn_sets_the_program_position_and_moves_follow_it():
    commands = [PFdr(600), PMov((("X", 1.0), ("Z", -2.0))), Pstn((("X", 0.0),)), PMov((("X", 1.0),)),
                Pstn((("Z", 5.0),)), PMov((("Z", 4.0),))]
    for plan in both_planners(commands, backlash_comp=False):
        assert [m.target for m in plan.moves] == [(40, -100), (80, -100), (80, -150)]
    for plan in both_planners(commands, start=(8, 10), backlash_comp=False):
        assert [m.target for m in plan.moves] == [(40, -100), (80, -100), (80, -150)]
        assert plan.moves[0].start == (8, 10)


def test_a_rapid_moves_at_the_rapid_feed_and_a_feed_move_at_its_feed():
    # 10 mm of Z at 1200 mm/min (rapid) or 300 mm/min: cruise speeds 20 and 5 mm/s
    for plan in both_planners([FFdr(1200), PFdr(300), FMov((("Z", -10.0),)), PMov((("Z", -20.0),))]):
        assert [m.profile[2] for m in plan.moves] == [20.0, 5.0]
    for plan in both_planners([PMov((("Z", -10.0),))]):
        assert plan.moves[0].profile[2] == pytest.approx(200 / 60)          # the machine's default feed


@pytest.mark.parametrize("commands, message", [
    ([PMov((("X", 40.025),))], r"X 40\.025 mm is outside the soft limits -40\.\.40 mm"),
    ([PMov((("Z", -200.02),))], r"Z -200\.020 mm is outside the soft limits -200\.\.20 mm"),
    ([PFdr(0.0)], r"feed must be > 0 mm/min"),
    ([FFdr(-5.0)], r"feed must be > 0 mm/min"),
    ([PMov((("Y", 1.0),))], r"axis Y is not on machine chivu-lathe \(axes: X, Z\)"),
    ([ZMov(("Y",))], r"axis Y is not on machine chivu-lathe"),
])
def test_refusals_name_what_was_wrong_and_the_command(commands, message):
    for planner in (plan_program, plan_walked):
        with pytest.raises(MotionError, match=message) as err:
            planner([PFdr(100)] + commands, LATHE, True, (0, 0))
        assert err.value.command_index == 1


def test_the_soft_limits_themselves_are_accepted_and_zmov_homes_only_the_named_axes():
    commands = [PMov((("X", 40.0), ("Z", -200.0))), ZMov(("x",)), PMov((("X", -40.0), ("Z", 20.0)))]
    for plan in both_planners(commands, backlash_comp=False):
        assert [m.target for m in plan.moves] == [(1600, -10000), (0, -10000), (-1600, 1000)]


def test_an_exponential_profile_plans_from_the_start_speed_with_a_quarter_of_the_acceleration():
    machine = replace(LATHE, motion=replace(LATHE.motion, profile="exponential"))
    plan = plan_program([PFdr(600), PMov((("Z", -10.0),)), PMov((("Z", -20.0),))], machine, False)
    first, second = plan.moves
    assert first.profile[0] == 1 and first.profile[1] == 1.0              # the ramp starts at 1 mm/s
    assert first.profile[2] == 10.0                                         # 600 mm/min
    assert first.profile[3] == pytest.approx(10.0) and second.profile[1] == first.profile[3]
    assert second.profile[3] == 1.0                                         # and ends at 1 mm/s


def test_planning_in_batches_hands_on_final_moves_and_names_a_late_refusal_by_its_program_index():
    from retrofit.commands import Wait
    from retrofit.motion.planblocks import BlockPlanner, NotInBlocks
    machine = replace(LATHE, motion=replace(LATHE.motion, lookahead=2))
    planner = BlockPlanner(machine, False)
    planner.add([PFdr(600)] + [PMov((("Z", -float(k)),)) for k in range(1, 5)])
    first = planner.planned()                       # 4 moves seen, 2 held back for the look-ahead
    assert [tuple(t) for t in first[0].targets] == [(0, -50)]
    with pytest.raises(MotionError, match=r"X 41\.000 mm is outside the soft limits") as err:
        planner.add([PMov((("Z", -5.0),)), PMov((("X", 41.0),))])
    assert err.value.command_index == 6             # counted from the program's first command
    planner.add([PMov((("Z", -5.0),))])             # the refused batch left no trace
    rest = planner.planned(final=True)
    assert [tuple(t) for t in rest[0].targets] == [(0, -100), (0, -150), (0, -200), (0, -250)]
    whole = plan_program([PFdr(600)] + [PMov((("Z", -float(k)),)) for k in range(1, 6)], machine, False)
    assert rest[1] == whole.end_s
    with pytest.raises(NotInBlocks, match="an input wait or a probing move"):
        BlockPlanner(machine).add([Wait(0, 3, 1.0)])
    with pytest.raises(NotInBlocks, match="the exponential profile"):
        BlockPlanner(replace(machine, motion=replace(machine.motion, profile="exponential")))


def test_a_reversal_seen_late_waits_for_the_set_up_on_the_numpy_path_as_on_the_tick_loop():
    # one move of look-ahead and a 1000-tick (50 ms) set-up: X turns positive only when its move
    # enters the window (when the short Z move two before it starts), and its first step waits the
    # set-up after that turn, later than the ramp alone would put it; the NumPy path (no
    # compiler) and the reference tick loop put the same frames on the wire
    from retrofit.motion.execute import execute_reference
    from retrofit.motion.vectorised import execute_numpy
    slow_x = replace(LATHE.axes[0], dir_setup_ticks=1000, dir_hold_ticks=0)
    machine = replace(LATHE, axes=(slow_x, LATHE.axes[1]), motion=replace(LATHE.motion, lookahead=1))
    commands = [PFdr(600), PMov((("X", -0.5),)), PMov((("Z", -1.0),)), PMov((("Z", -1.02),)), Dely(0.0),
                PMov((("X", 0.0),))]
    plan = plan_program(commands, machine, False)
    numpy_frames, reference = execute_numpy(plan).frames, execute_reference(plan).frames
    assert np.array_equal(numpy_frames.ticks, reference.ticks)
    assert np.array_equal(numpy_frames.values, reference.values)
    rises, dirs = step_times(machine, reference)["X"]
    assert (int(np.sum(dirs < 0)), int(np.sum(dirs > 0))) == (20, 20)
    seen = round(plan.moves[2].t0_s / machine.tick_s)              # the Z move two before X's
    assert rises[20] == seen + 1000 < round(plan.moves[4].t0_s / machine.tick_s) + 1000


def test_a_small_program_streamed_from_batches_reports_its_progress_as_command_indices():
    from retrofit.motion.planblocks import BlockPlanner
    from retrofit.motion.stream import stream_blocks
    commands = [PFdr(600), PMov((("X", -0.5),)), Dely(0.1), PMov((("Z", -1.0),))]
    planner = BlockPlanner(LATHE, False)
    planner.add(commands)
    arrays, end_s = planner.planned(final=True)
    seen = []
    chunks = list(stream_blocks(LATHE, (0, 0), iter([(arrays, end_s)]), progress=seen.append))
    whole = execute_fast(plan_program(commands, LATHE, False)).frames
    assert np.array_equal(np.concatenate([c.ticks for c in chunks]), whole.ticks)
    assert seen and seen[-1] == 4 and seen == sorted(seen) and set(seen) <= {0, 2, 3, 4}
