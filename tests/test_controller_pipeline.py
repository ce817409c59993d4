"""The controller's pipeline (002): three commands ahead, immediate commands, feed changes, STOP.

Step times are read from the port frames, as a driver decodes them; positions from the simulated
machine the controller drove.
"""

from dataclasses import replace

import numpy as np
import pytest

from retrofit.commands import Dely, FMov, Init, IStp, MFdr, PFdr, PMov, Pstn, Rdps, Rdst, Stop
from retrofit.controller import Controller
from retrofit.link.codec import ERR_REFUSED
from retrofit.link.replies import Busy, Err, Position, Status
from retrofit.link.replies import StatusFlags as F
from retrofit.machine.config import load_machine
from retrofit.sim import SimMachine

from tests.helpers import limit_breaches, step_times

LATHE = load_machine("chivu-lathe")          # 50 us ticks; X 40, Z 50 steps/mm


def z(mm):
    return PMov((("Z", float(mm)),))


def feed(ctl, commands):
    """Submit like a host: each command until it is taken (ticking while the queue is full)."""
    for cmd in commands:
        while isinstance(ctl.submit(cmd), Busy):
            ctl.tick()


def rises(ctl, axis="Z"):
    return step_times(LATHE, ctl.frames())[axis][0]


def intervals_near(times, tick, span=6):
    """Step intervals (ticks) of the steps just after ``tick``."""
    after = times[times > tick][:span + 1]
    return np.diff(after)


def test_consecutive_pmovs_at_one_feed_flow_with_no_idle_tick():
    ctl = Controller(LATHE)
    feed(ctl, [PFdr(600.0)] + [z(-k) for k in range(1, 7)])   # six collinear 1 mm moves, 10 mm/s
    moving = []
    while not ctl.idle:
        ctl.tick()
        moving.append(bool(ctl.submit(Rdst()).flags & F.MOVING))
    t = rises(ctl)
    assert len(t) == 300 and ctl.position_steps == (0, -300)
    first, last = int(t[0]), int(t[-1])
    assert all(moving[first:last + 1])                        # moving on every tick, start to end
    cruise = 1 / (10.0 * 50) / LATHE.tick_s                    # 40 ticks a step at 10 mm/s
    for boundary in (50, 100, 150, 200, 250):                  # each move's last step / next's first
        assert abs(t[boundary] - t[boundary - 1] - cruise) <= 1


def test_the_queue_holds_three_and_busy_comes_after():
    machine = LATHE.__class__(**{**LATHE.__dict__, "motion": LATHE.motion.__class__(
        **{**LATHE.motion.__dict__, "lookahead": 1})})          # a window of two moves
    ctl = Controller(machine)
    replies = [ctl.submit(z(-k)) for k in range(1, 8)]
    assert replies[:5] == [None] * 5 and isinstance(replies[5], Busy)
    st = ctl.submit(Rdst())                                    # immediate: answered with a full queue
    assert st.queued == 3 and st.flags & F.QUEUE_FULL
    assert isinstance(ctl.submit(Rdps()), Position)


def test_stop_halts_within_one_tick_with_a_full_queue():
    sim = SimMachine(LATHE)
    ctl = Controller(LATHE, sim=sim)
    program = [PFdr(900.0)] + [PMov((("X", float(k % 3)), ("Z", -k * 0.5))) for k in range(1, 40)]
    taken = 0
    while not isinstance(ctl.submit(program[taken]), Busy):
        taken += 1
    for _ in range(3000):
        ctl.tick()
    while not isinstance(ctl.submit(program[taken]), Busy):   # the host tops the queue up
        taken += 1
    assert ctl.submit(Rdst()).queued == 3                     # the queue is full when STOP comes
    stop_tick = ctl.ticks                                      # the next frame to be written
    assert ctl.submit(Stop()) is None
    ctl.run_until_idle(1000)
    for axis in ("X", "Z"):
        assert rises(ctl, axis).max() <= stop_tick            # no pulse rose after the next tick
    st = ctl.submit(Rdst())
    assert st.flags & F.STOPPED and not st.flags & F.MOVING and st.queued == 0
    for i, axis in enumerate(LATHE.axes):                      # the register is where the carriage is
        assert abs(sim.carriage_mm(axis.name) - axis.to_mm(ctl.position_steps[i])) <= 1.5 * axis.step_mm
    assert ctl.submit(z(-1)) == Err(ERR_REFUSED, 0x04)         # refused until INIT
    assert ctl.submit(Init()) is None and ctl.position_steps == (0, 0)
    assert ctl.submit(z(-1)) is None and not ctl.submit(Rdst()).flags & F.STOPPED


def test_rdps_answers_while_moving_with_where_the_motors_are():
    sim = SimMachine(LATHE)
    ctl = Controller(LATHE, sim=sim)
    feed(ctl, [PFdr(300.0), z(-5)])
    seen = []
    for _ in range(6):
        for _ in range(3000):
            ctl.tick()
        pos = ctl.submit(Rdps())
        seen.append(dict(pos.steps)["Z"])
        assert 0 <= sim.motor_steps[1] - dict(pos.steps)["Z"] <= 1   # a pulse may be about to rise
        assert ctl.submit(Rdst()).flags & F.MOVING
    assert seen == sorted(seen, reverse=True) and -250 < seen[-1] < seen[0] < 0


def speed_mm_s(times, tick, step_mm):
    """Z speed (mm/s) from the four step intervals after ``tick``."""
    gaps = intervals_near(times, tick, 4)
    return step_mm / (np.mean(gaps) * LATHE.tick_s)


def test_pfdr_takes_effect_at_the_next_move_mfdr_at_once():
    step = LATHE.axis("Z").step_mm
    at = 30_000                                                # 1.5 s: at cruise in the first move

    def run(override):
        ctl = Controller(LATHE)
        feed(ctl, [PFdr(300.0), z(-10)])                       # 5 mm/s: 2 s of cruise
        for _ in range(at):
            ctl.tick()
        feed(ctl, override + [z(-15)])
        ctl.run_until_idle(10**6)
        return ctl, rises(ctl)

    ctl, t = run([PFdr(600.0)])
    boundary = t[499]                                          # the first move's last step
    assert speed_mm_s(t, at, step) == pytest.approx(5.0, rel=0.03)
    assert speed_mm_s(t, boundary - 400, step) == pytest.approx(5.0, rel=0.03)   # unchanged to its end
    assert speed_mm_s(t, boundary + 2000, step) == pytest.approx(10.0, rel=0.03)  # the next move
    ctl, t = run([MFdr(600.0)])
    assert speed_mm_s(t, at, step) > 5.2                       # speeding up at once
    assert speed_mm_s(t, at + 800, step) == pytest.approx(10.0, rel=0.03)
    assert t[499] < boundary - 5000                            # the first move ends much earlier
    assert limit_breaches(LATHE, ctl.frames()) == []          # within the acceleration limit
    assert ctl.position_steps == (0, -750)


def test_a_move_that_starts_alone_flows_into_the_next_one_when_it_comes():
    ctl = Controller(LATHE)
    feed(ctl, [PFdr(600.0), z(-5)])                             # starts with nothing behind it
    for _ in range(5000):
        ctl.tick()
    feed(ctl, [z(-10)])                                        # arrives in time: no stop between
    ctl.run_until_idle(10**6)
    t = rises(ctl)
    cruise = 1 / (10.0 * 50) / LATHE.tick_s
    assert abs(t[250] - t[249] - cruise) <= 1


def test_mfdr_during_a_rapid_changes_nothing_but_ffdr_slows_it():
    ctl = Controller(LATHE)
    feed(ctl, [FMov((("Z", -30.0),))])                         # 1200 mm/min = 20 mm/s
    for _ in range(12000):
        ctl.tick()
    assert ctl.submit(MFdr(60.0)) is None
    for _ in range(2000):
        ctl.tick()
    from retrofit.commands import FFdr
    assert ctl.submit(FFdr(300.0)) is None                    # 5 mm/s, at once
    at = ctl.ticks
    ctl.run_until_idle(10**6)
    t = rises(ctl)
    step = LATHE.axis("Z").step_mm
    assert speed_mm_s(t, at - 1000, step) == pytest.approx(20.0, rel=0.05)
    assert speed_mm_s(t, at + 3000, step) == pytest.approx(5.0, rel=0.03)
    assert limit_breaches(LATHE, ctl.frames()) == []


def test_dwell_shows_in_the_status_and_lasts_its_time():
    ctl = Controller(LATHE)
    feed(ctl, [z(-1), Dely(0.25), z(-2)])
    dwelling = []
    while not ctl.idle:
        ctl.tick()
        dwelling.append(bool(ctl.submit(Rdst()).flags & F.DWELLING))
    t = rises(ctl)
    gap = (t[50] - t[49]) * LATHE.tick_s
    assert 0.25 <= gap < 0.27
    assert sum(dwelling) == pytest.approx(0.25 / LATHE.tick_s, abs=2)


def test_pstn_sets_the_position_in_program_order():
    sim = SimMachine(LATHE)
    ctl = Controller(LATHE, sim=sim)
    feed(ctl, [z(-1), Pstn((("Z", 0.0),)), z(-1)])           # -1 mm, call it 0, -1 mm again
    ctl.run_until_idle(10**6)
    assert ctl.position_steps == (0, -50) and sim.motor_steps[1] == -100


def test_a_move_outside_the_soft_limits_is_refused_with_an_error():
    ctl = Controller(LATHE)
    reply = ctl.submit(PMov((("X", 55.0),)))
    assert isinstance(reply, Err) and reply.code == ERR_REFUSED
    st = ctl.submit(Rdst())
    assert st.flags & F.ERROR and not st.flags & F.MOVING
    assert "X 55.000 mm is outside the soft limits -40..40 mm" in ctl.fault
    assert ctl.submit(Init()) is None and not ctl.submit(Rdst()).flags & F.ERROR


def test_a_refused_command_met_as_the_next_move_starts_stops_the_carriage_there():
    """The queue refills when a move starts; a command refused then halts everything, the move
    that was about to start included: the carriage stays where the last move ended."""
    lathe = replace(LATHE, motion=replace(LATHE.motion, lookahead=1))     # two moves prepared, two queued
    ctl = Controller(lathe, backlash_comp=False, sim=SimMachine(lathe))
    feed(ctl, [FMov((("X", 1.0),)), FMov((("X", 2.0),)), FMov((("X", 3.0),)), FMov((("X", 99.0),))])
    ctl.run_until_idle(1_000_000)
    assert "X 99.000 mm is outside the soft limits" in ctl.fault
    x = ctl.position_steps[0]
    assert 39 <= x <= 40                    # X 1 mm (its last step may be cut by the halt), no step of X 2
    assert ctl.sim.state_at(ctl.ticks)["X"][0] == x


def test_istp_without_a_spindle_stops_with_a_clear_error():
    ctl = Controller(LATHE)
    feed(ctl, [IStp(), PFdr(1.0), z(-5)])
    ctl.run_until_idle(1000)
    assert ctl.submit(Rdst()).flags & F.ERROR
    assert "no spindle encoder" in ctl.fault and ctl.position_steps == (0, 0)


def test_status_word_of_an_idle_controller_is_plain():
    ctl = Controller(LATHE)
    st = ctl.submit(Rdst())
    assert isinstance(st, Status) and st.flags == F(0) and st.queued == 0 and ctl.idle
