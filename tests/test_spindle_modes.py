"""G95 feed per revolution and G96/G97 constant surface speed on a lathe with a spindle encoder
(mitic-lathe), against hand computations: feed = F mm/rev x rpm; G96 rpm = 1000 v / (pi d),
capped at D."""

from __future__ import annotations

import math

import pytest

from retrofit.commands import PFdr, PMov, Spin
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

LATHE = load_machine("mitic-lathe")           # has [spindle]: an encoder with an index pulse
PLAIN = load_machine("chivu-lathe")           # has none
PRE = "G18 G21 G90\nG0 X20 Z2\n"


def commands(text, machine=LATHE):
    return compile_program(PRE + text + "\nM30\n", machine, file="t.ngc").commands


def test_g95_feed_is_f_per_rev_times_rpm():
    cmds = commands("M3 S500\nG95 G1 Z-10 F0.1\nS800\nZ-20\nG20\nF0.004\nG21 Z-30")
    feeds = [c.feed for c in cmds if isinstance(c, PFdr)]
    assert feeds == [pytest.approx(0.1 * 500), pytest.approx(0.1 * 800), pytest.approx(0.004 * 25.4 * 800)]


def test_g94_after_g95_is_mm_per_minute_again():
    cmds = commands("M3 S500\nG95 G1 Z-10 F0.1\nG94 Z-20 F120")
    assert [c.feed for c in cmds if isinstance(c, PFdr)] == [pytest.approx(50.0), 120.0]


def css_pieces(cmds):
    """(rpm, start X, end X) of every feed piece, the rpm in force when it runs."""
    rpm, x, out = 0.0, 20.0, []
    for c in cmds:
        if isinstance(c, Spin):
            rpm = c.rpm
        elif isinstance(c, PMov):
            end = dict(c.axes)["X"]
            out.append((rpm, x, end))
            x = end
    return out


def hand_rpm(v_m_min, radius_mm, cap):
    return min(cap, 1000.0 * v_m_min / (math.pi * 2.0 * radius_mm))


def test_g96_speed_follows_x_within_five_percent_and_caps_at_d():
    cmds = commands("M3 S500\nG96 S100 D1500\nG1 X2 F0.2")
    spins = [c.rpm for c in cmds if isinstance(c, Spin)]
    assert spins[1] == pytest.approx(hand_rpm(100, 20.0, 1500), abs=1e-3)   # 795.775 at X20
    pieces = css_pieces(cmds)
    assert len(pieces) > 10 and pieces[-1][2] == 2.0
    for rpm, x0, x1 in pieces:
        for x in (x0, x1):
            assert hand_rpm(100, x, 1500) / 1.05 - 1e-6 <= rpm <= hand_rpm(100, x, 1500) * 1.05 + 1e-6
    assert max(spins) == 1500.0 and pieces[-1][0] == 1500.0


def test_g96_with_g95_feeds_per_revolution_of_the_changing_speed():
    cmds = commands("M3 S500\nG95 G96 S100 D1500\nG1 X10 F0.2")
    rpm = None
    for c in cmds:
        if isinstance(c, Spin):
            rpm = c.rpm
        elif isinstance(c, PFdr):
            assert c.feed == pytest.approx(0.2 * rpm, abs=1e-6)


def test_g96_in_inches_and_from_the_program_zero():
    feet = 100 / 0.3048                                     # 100 m/min in ft/min
    cmds = commands(f"M3 S500\nG20\nG96 S{feet:.6f} D1500\nG21")
    assert [c.rpm for c in cmds if isinstance(c, Spin) and c.direction][-1] == pytest.approx(795.775, abs=1e-3)
    cmds = commands("G10 L2 P1 X5\nM3 S500\nG96 S100 D1500")   # program X0 is machine X5
    assert [c.rpm for c in cmds if isinstance(c, Spin) and c.direction][-1] == pytest.approx(
        hand_rpm(100, 15.0, 1500), abs=1e-3)


def test_g97_sets_rpm_again():
    cmds = commands("M3 S500\nG96 S100 D1500\nG97 S600\nG1 X5 F100")
    assert [c.rpm for c in cmds if isinstance(c, Spin) and c.direction][-1] == 600.0


@pytest.mark.parametrize("machine, text, words", [
    (PLAIN, "G95 G1 Z-1 F0.1", "t.ngc:3: G95 needs a spindle encoder"),
    (LATHE, "G95 G1 Z-1 F0.1", "t.ngc:3: G1 under G95 with the spindle stopped"),
    (LATHE, "M3 S500\nG96 D1500", "t.ngc:4: G96 needs S"),
    (LATHE, "M3 S500\nG96 S100 D9000", "t.ngc:4: D9000: G96's D caps the spindle speed"),
    (PLAIN, "M3 S500\nG96 S100 D1500", "t.ngc:4: G96 needs a spindle encoder"),
    (LATHE, "M3 S500\nG96 S100\nG33 Z-5 K1", "t.ngc:5: G33 under G96/G95"),
    (LATHE, "M3 S500 D3", "t.ngc:3: D3: D word with no G code that uses it"),
    (LATHE, "G33.1 Z-5 K1", "t.ngc:3: G33.1: the spindle of machine mitic-lathe does not reverse on command"),
])
def test_refusals(machine, text, words):
    with pytest.raises(GcodeError) as err:
        commands(text, machine)
    assert words in str(err.value)
