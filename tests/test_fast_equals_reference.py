"""The fast path and the reference path give the same port frames, bit for bit."""

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.commands import Dely, FMov, PFdr, PMov
from retrofit.machine.config import load_machine
from retrofit.motion.execute import execute_reference
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program
from retrofit.motion.vectorised import execute_numpy

LATHE = load_machine("chivu-lathe")
ENGRAVER = replace(load_machine("engraver"), tick_us=20.0)    # coarser tick keeps the per-tick loop short


@st.composite
def machines(draw):
    base = draw(st.sampled_from([LATHE, ENGRAVER]))
    axes = []
    for axis in base.axes:
        # slow drivers (long pulses, long set-up / hold) make the generator defer requests
        slow = draw(st.booleans())
        most = 15 if slow else 4
        axes.append(replace(axis, pulse_high_ticks=draw(st.integers(1, most)), pulse_low_ticks=draw(st.integers(1, most)),
                            dir_setup_ticks=draw(st.integers(0, 3 * most)), dir_hold_ticks=draw(st.integers(0, 3 * most)),
                            invert_step=draw(st.booleans()), invert_dir=draw(st.booleans()),
                            max_velocity_mm_s=draw(st.sampled_from([5.0, 20.0, 60.0]))))
    motion = replace(base.motion, interpolator=draw(st.sampled_from(["dda", "bresenham"])),
                     profile=draw(st.sampled_from(["trapezoid", "exponential"])),
                     lookahead=draw(st.sampled_from([1, 3, 16])))
    return replace(base, axes=tuple(axes), motion=motion)


@st.composite
def programs(draw, machine):
    commands = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["G0", "G1", "G1", "G4"]))
        if kind == "G4":
            commands.append(Dely(draw(st.sampled_from([0.0, 0.001, 0.003]))))
            continue
        target = tuple((a.name, draw(st.integers(-80, 80)) / a.steps_per_mm)
                       for a in machine.axes if draw(st.booleans()))
        target = tuple((n, min(max(v, machine.axis(n).min_mm), machine.axis(n).max_mm)) for n, v in target)
        if kind == "G0":
            commands.append(FMov(target))
        else:
            commands += [PFdr(draw(st.sampled_from([120.0, 900.0, 3000.0]))), PMov(target)]
    return commands


def check_fast_equals_reference(data):
    machine = data.draw(machines())
    commands = data.draw(programs(machine))
    plan = plan_program(commands, machine, backlash_comp=data.draw(st.booleans()))
    ref = execute_reference(plan)
    for fast in (execute_fast(plan), execute_numpy(plan)):       # compiled, and plain NumPy
        assert fast.frames == ref.frames                        # every port byte at every tick
        assert [w.reached_tick for w in fast.waypoints] == [w.reached_tick for w in ref.waypoints]
        assert fast.steps_emitted == ref.steps_emitted
        assert fast.max_following_error_steps == ref.max_following_error_steps


@settings(max_examples=30)
@given(st.data())
def test_fast_path_equals_reference_bit_for_bit(data):
    check_fast_equals_reference(data)


@pytest.mark.slow
@settings(max_examples=200)
@given(st.data())
def test_fast_path_equals_reference_bit_for_bit_200_programs(data):
    check_fast_equals_reference(data)


def test_equal_when_the_driver_forces_deferred_steps():
    """Drivers slower than the plan: steps wait for the period and the direction set-up."""
    axes = tuple(replace(a, pulse_high_ticks=12, pulse_low_ticks=12, dir_setup_ticks=30, dir_hold_ticks=25,
                         max_velocity_mm_s=60.0, max_accel_mm_s2=5000.0) for a in LATHE.axes)
    machine = replace(LATHE, axes=axes)
    zigzag = [PMov((("X", x), ("Z", -x))) for x in (2.0, -1.0, 1.5, -2.0, 0.0)]
    plan = plan_program([PFdr(3000.0)] + zigzag, machine)
    ref = execute_reference(plan)
    assert ref.max_following_error_steps > 0              # the generator really deferred steps
    for fast in (execute_fast(plan), execute_numpy(plan)):
        assert fast.frames == ref.frames
        assert fast.max_following_error_steps == ref.max_following_error_steps
