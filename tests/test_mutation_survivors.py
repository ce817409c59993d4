"""What a bounded mutation run found unchecked: G54's offset read and written as #5221, M49, a bare
S under G96 held to the rpm cap, and a zero feed refused at its boundary (bench/mutation.py)."""

from __future__ import annotations

import math

import pytest

from retrofit.commands import FFdr, FMov, MFdr, PFdr, PMov, Rdst, Spin
from retrofit.controller import Controller
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.link.codec import ERR_REFUSED, ERR_VALUE, OPCODES
from retrofit.link.replies import Err
from retrofit.link.replies import StatusFlags as F
from retrofit.machine.config import load_machine

LATHE = load_machine("mitic-lathe")           # a spindle encoder: G96 works here
PLAIN = load_machine("chivu-lathe")
PRE = "G18 G21 G90\n"


def commands(text, machine=LATHE):
    return compile_program(PRE + text + "\nM30\n", machine, file="t.ngc").commands


def last_rapid_x(cmds):
    return [dict(c.axes)["X"] for c in cmds if isinstance(c, FMov) and "X" in dict(c.axes)][-1]


def test_g54_x_offset_is_parameter_5221_by_number():
    assert last_rapid_x(commands("#5221=7\nG54 G0 X0 Z0", PLAIN)) == 7.0
    assert last_rapid_x(commands("#5241=3\nG55 G0 X0 Z0", PLAIN)) == 3.0       # G55 starts 20 later
    # G10 L2 P1 writes #5221: read it back by number after the offset was cleared again
    assert last_rapid_x(commands("G10 L2 P1 X4\n#1=#5221\nG10 L2 P1 X0\nG0 X#1 Z0", PLAIN)) == 4.0


def test_m49_is_accepted_and_changes_no_move():
    body = "G0 X10 Z2\nG1 Z-5 F100"
    assert commands("M49\n" + body, PLAIN) == commands(body, PLAIN)
    assert commands("M48\n" + body, PLAIN) == commands(body, PLAIN)


def test_m49_under_cutter_compensation_is_refused_naming_the_line():
    with pytest.raises(GcodeError, match=r"t\.ngc:4: M49: cannot enable or disable overrides"):
        commands("G0 X0 Z5\nG41.1 D2 G1 X10 Z0 F100\nM49", PLAIN)


def test_m49_with_a_p_word_is_refused():
    with pytest.raises(GcodeError, match=r"t\.ngc:2: P1: P word with no G code that uses it"):
        commands("M49 P1", PLAIN)


def spins(cmds):
    return [c.rpm for c in cmds if isinstance(c, Spin) and c.direction]


def test_a_bare_s_under_g96_is_held_to_the_rpm_cap():
    # X1: 200 m/min at 1 mm radius would be 1000*200/(pi*2) = 31 831 rpm; D caps it at 1500
    cmds = commands("G0 X1 Z2\nM3 S500\nG96 S100 D1500\nS200")
    assert spins(cmds)[-1] == 1500.0
    # X20, below the cap: the new surface speed sets the speed at once (150 m/min -> 1193.662 rpm)
    cmds = commands("G0 X20 Z2\nM3 S500\nG96 S100 D1500\nS150")
    assert spins(cmds)[-1] == pytest.approx(1000.0 * 150 / (math.pi * 40.0), abs=1e-3)
    assert spins(cmds)[-1] < 1500.0


@pytest.mark.parametrize("cls", [FFdr, MFdr])
def test_an_immediate_feed_of_zero_is_refused_and_the_smallest_above_taken(cls):
    ctl = Controller(PLAIN, kernels=False)
    assert ctl.submit(cls(feed=0.0)) == Err(ERR_VALUE, OPCODES[cls])
    assert ctl.submit(cls(feed=-1.0)) == Err(ERR_VALUE, OPCODES[cls])
    assert ctl.submit(cls(feed=1e-6)) is None


def test_a_program_feed_of_zero_is_refused_as_a_fault_and_the_smallest_above_taken():
    ctl = Controller(PLAIN, kernels=False)
    assert ctl.submit(PFdr(feed=0.0)) == Err(ERR_REFUSED, OPCODES[PFdr])
    assert ctl.submit(Rdst()).flags & F.ERROR
    assert ctl.submit(PMov((("Z", -1.0),))) == Err(ERR_REFUSED, OPCODES[PMov])
    ctl = Controller(PLAIN, kernels=False)
    assert ctl.submit(PFdr(feed=1e-6)) is None and not ctl.submit(Rdst()).flags & F.ERROR
