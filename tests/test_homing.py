"""ZMOV against the switches of mitic-lathe, and its limit switches stopping motion.

What the machine did is read from the simulator: where the carriage stood when a switch closed,
and the step edges on the wire; what the controller reports comes from RDPS and RDST.
"""

from pathlib import Path

import pytest

from retrofit.commands import FMov, Init, PMov, Pstn, Rdst, ZMov
from retrofit.controller import Controller
from retrofit.controller.program import ProgramError, run_commands
from retrofit.errors import ConfigError, GcodeError
from retrofit.gcode import compile_program
from retrofit.link.replies import Busy
from retrofit.link.replies import StatusFlags as F
from retrofit.machine.config import load_machine
from retrofit.run.program import controller_reason, run_on_controller
from retrofit.sim import SimMachine

from tests.helpers import step_times

MITIC = load_machine("mitic-lathe")
HOME_STEPS = (4000, 1600)                     # X 40 mm at 100 steps/mm, Z 20 mm at 80 steps/mm


def trip(name):
    return MITIC.parts["switches"].named(name).trip_mm


def home_from(start):
    sim = SimMachine(MITIC, start)
    ctl = Controller(MITIC, sim=sim)
    assert ctl.submit(ZMov()) is None
    flags = []
    while not ctl.idle:
        ctl.tick()
        flags.append(ctl.submit(Rdst()).flags)
    return ctl, sim, flags


@pytest.mark.parametrize("start", [(0, 0), (-2500, -3000), (3990, 1590)],
                         ids=["at-zero", "far-out", "on-the-switches"])
def test_zmov_finds_the_precise_switches_and_sets_home(start):
    ctl, sim, flags = home_from(start)
    assert ctl.fault is None and ctl.position_steps == HOME_STEPS
    for axis, switch in (("X", "ppsx"), ("Z", "ppsz")):
        step = MITIC.axis(axis).step_mm
        assert 0.0 <= sim.carriage_mm(axis) - trip(switch) < step + 1e-9   # within one step
    st = ctl.submit(Rdst())
    assert st.flags & F.HOMED and st.flags & F.X_PRECISE and st.flags & F.Z_PRECISE
    assert not st.flags & (F.ERROR | F.MOVING)
    seen = F(0)
    for f in flags:
        seen |= f
    assert seen & F.X_POS_LIMIT and seen & F.Z_POS_LIMIT      # the seek reached both limit switches
    assert not seen & F.ERROR                                  # ... which is no error while homing


def test_homing_order_is_x_then_z_and_the_switch_stops_the_seek_on_its_tick():
    ctl, sim, _ = home_from((0, 0))
    events = sim.switches.events
    x_latch = sim.switches.first_change("ppsx", True, sim.switches.first_change("ppsx", False))
    rises = step_times(MITIC, ctl.frames())
    assert x_latch < rises["Z"][0][0]                          # Z moves only once X is home
    for name, axis in (("plsx", "X"), ("plsz", "Z")):
        closed = sim.switches.first_change(name, True)
        t = rises[axis][0]
        after = t[t > closed]
        # the step that closed the switch is the last one towards it: the next edge is the back-off
        assert after.size == 0 or rises[axis][1][list(t).index(after[0])] < 0
    assert len(events) >= 8


def test_a_homed_machine_goes_where_it_is_told():
    sim = SimMachine(MITIC, (-1234, -4321))
    ctl = run_commands([ZMov(), FMov((("X", 10.0), ("Z", -30.0)))], MITIC, sim=sim)
    assert ctl.position_steps == (1000, -2400)
    for axis, target in (("X", 10.0), ("Z", -30.0)):
        step = MITIC.axis(axis).step_mm
        assert abs(sim.carriage_mm(axis) - target) <= step


def test_zmov_of_one_axis_homes_only_that_axis():
    sim = SimMachine(MITIC, (500, -800))
    ctl = run_commands([ZMov(("Z",))], MITIC, sim=sim)
    assert ctl.position_steps == (0, 1600) and sim.motor_steps[0] == 500


def test_a_limit_switch_stops_the_motion_within_one_tick_and_shows_in_rdst():
    sim = SimMachine(MITIC, (3800, 0))                         # carriage at X 38, controller thinks 0
    ctl = Controller(MITIC, sim=sim)
    assert ctl.submit(PMov((("X", 5.0),))) is None             # 2 mm past the X+ limit switch
    ctl.run_until_idle(10**6)
    closed = sim.switches.first_change("plsx", True)
    x_rises = step_times(MITIC, ctl.frames())["X"][0]
    assert closed is not None and x_rises.max() <= closed + 1  # nothing rose after the next tick
    assert abs(sim.carriage_mm("X") - trip("plsx")) <= MITIC.axis("X").step_mm
    st = ctl.submit(Rdst())
    assert st.flags & F.ERROR and st.flags & F.X_POS_LIMIT and not st.flags & F.MOVING
    assert "limit switch plsx" in ctl.fault
    assert ctl.submit(PMov((("X", 1.0),))).code == 6            # refused until INIT
    assert ctl.submit(Init()) is None
    assert ctl.submit(Pstn((("X", 40.5),))) is None            # tell it where it is
    assert ctl.submit(PMov((("X", 39.0),))) is None            # away from the switch: allowed
    ctl.run_until_idle(10**6)
    assert ctl.fault is None and not ctl.submit(Rdst()).flags & F.X_POS_LIMIT
    assert ctl.submit(PMov((("X", 40.0),))) is None            # towards a switch that is open: fine
    ctl.run_until_idle(10**6)
    assert ctl.fault is None


def test_a_switch_that_never_closes_stops_homing_with_an_error():
    sim = SimMachine(MITIC, (4000, 1500))
    bank = sim.switches                                         # PLSZ unplugged: it never closes
    del bank.switches["plsz"]
    bank.by_axis["Z"] = [s for s in bank.by_axis["Z"] if s.spec.name != "plsz"]
    with pytest.raises(ProgramError, match=r"homing Z: switch plsz not found within 18280 steps"):
        run_commands([ZMov(("Z",))], MITIC, sim=sim)


def test_homing_names_a_missing_switch_in_the_machine_file(tmp_path):
    text = Path(MITIC.source).read_text().replace('switch = "plsz"', 'switch = "plsq"')
    (tmp_path / "typo.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"typo.toml \[homing.z\] switch = 'plsq': no such switch"):
        Controller(load_machine(tmp_path / "typo.toml"))


def test_g28_homes_through_the_controller_and_leaves_the_axes_at_home():
    program = compile_program("G28\nG0 X10 Z-5\nG28 X20 Z-5\nM30\n", MITIC, "home.ngc")
    assert controller_reason(program.commands, MITIC) == "homing against switches"
    log = run_on_controller(program, MITIC)
    assert log.waypoints[-1].steps == HOME_STEPS
    # G28 with axis words homes the named axes only (here both), as LinuxCNC and grbl do
    assert [str(c) for c in program.commands] == ["ZMOV", "FMOV X10 Z-5", "FMOV X20 Z-5", "ZMOV"]


def test_a_program_that_crashes_into_a_limit_names_its_line():
    program = compile_program("G92 X0\nG1 X30 F600\n", MITIC, "crash.ngc")   # X is really at 20
    sim = SimMachine(MITIC, (2000, 0))
    with pytest.raises(ProgramError) as err:
        run_commands(program.commands, MITIC, sim=sim)
    assert "plsx" in str(err.value) and program.lines[err.value.command_index] == 2


def test_busy_while_homing_keeps_the_queue_at_three():
    ctl = Controller(MITIC, sim=SimMachine(MITIC))
    replies = [ctl.submit(ZMov()) for _ in range(30)]
    assert isinstance(replies[-1], Busy) and ctl.submit(Rdst()).queued == 3


def test_home_is_refused_where_the_machine_has_no_switch_for_an_axis():
    with pytest.raises(GcodeError, match="axis Y is not on machine"):
        compile_program("G28 Y1\n", MITIC)
