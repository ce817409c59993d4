"""Controller paths a mutation run (bench/mutation.py) found no test took: a move entered faster
than its feed after MFDR lowered it too late for the move before to slow down, a thread
pass's backlash take-up of an odd number of steps, a tick budget counted from the tick it is
given at."""

from __future__ import annotations

from dataclasses import replace

import pytest

from retrofit.commands import MFdr, PFdr
from retrofit.controller import Controller
from retrofit.controller.program import run_commands
from retrofit.errors import MotionError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.sim import SimMachine

from tests.helpers import limit_breaches
from tests.test_controller_pipeline import LATHE, feed, intervals_near, rises, z


def test_a_move_entered_above_a_feed_lowered_late_slows_at_the_acceleration_then_cruises():
    # 10 mm/s to Z-10 then Z-11; MFDR 60 mm/min (1 mm/s) when 0.1 mm of the first move is left:
    # it cannot slow in 0.1 mm, so the second move starts faster than 1 mm/s and brakes in it,
    # timed over its whole length (it once ran at 100 mm/s, timed as if only its braking part)
    ctl = Controller(LATHE)
    feed(ctl, [PFdr(600.0), z(-10), z(-11)])
    while ctl.position_steps[1] > -495:                         # Z 50 steps/mm: 9.9 mm done
        ctl.tick()
    assert ctl.submit(MFdr(60.0)) is None
    at = ctl.ticks
    ctl.run_until_idle(10**7)
    assert ctl.position_steps == (0, -550)
    assert limit_breaches(LATHE, ctl.frames()) == []
    t = rises(ctl)
    step = LATHE.axis("Z").step_mm
    # the second move (from step 500) brakes over its first steps, then cruises at 1 mm/s
    assert step / (sum(intervals_near(t, t[500], 4)) / 4 * LATHE.tick_s) > 2.0
    assert step / (sum(intervals_near(t, t[530], 4)) / 4 * LATHE.tick_s) == pytest.approx(1.0, rel=0.03)
    assert t[499] > at


def test_a_thread_pass_takes_up_an_odd_backlash_before_it_cuts_and_ends_at_its_z():
    # mitic-lathe's Z with 3 steps (0.0375 mm) of backlash: the rapid to Z3 leaves it on the +Z
    # side; G33 to Z-2 first turns the motor 3 steps through the clearance, then cuts 5 mm
    base = load_machine("mitic-lathe")
    machine = replace(base, axes=tuple(replace(a, backlash_mm=3 / a.steps_per_mm) if a.name == "Z" else a
                                       for a in base.axes))
    assert machine.axis("Z").backlash_steps == 3
    prog = compile_program("G18 G21 G90\nG0 X12 Z-3\nG0 Z3\nS300 M3\nG33 Z-2 K1.5\nG0 X20\nM2\n",
                           machine, "t.ngc")
    sim = SimMachine(machine)
    ctl = run_commands(list(prog.commands), machine, sim=sim)
    assert ctl.fault is None
    trace = sim.traces["Z"]
    assert trace.carriage_mm[-1] == pytest.approx(-2.0, abs=1e-9)
    assert trace.motor_steps[-1] - max(trace.motor_steps) == -(5 * 80 + 3)


def test_run_until_idle_gives_exactly_the_ticks_asked_counted_from_the_tick_it_is_called_at():
    def started():
        ctl = Controller(LATHE)
        feed(ctl, [PFdr(600.0), z(-1)])
        for _ in range(3):
            ctl.tick()
        return ctl
    ctl = started()
    ctl.run_until_idle(10**6)
    needed = ctl.ticks - 3                                   # the 1 mm move's ticks from tick 3
    ctl = started()
    ctl.run_until_idle(needed)
    assert ctl.ticks == 3 + needed and ctl.position_steps == (0, -50)
    with pytest.raises(MotionError, match=f"still busy after {needed - 1} ticks"):
        started().run_until_idle(needed - 1)
