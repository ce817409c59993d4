"""The spindle canned cycles G74, G84, G86, G87, G88: the order of moves, dwells, spindle starts and
stops and pauses is the order LinuxCNC's rs274 printed for the same program (the golden files of
tests/gcode); the positions themselves are compared in tests/test_gcode_rs274.py."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from retrofit.commands import Dely, FMov, Paus, PMov, Spin
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program, load_program
from retrofit.machine.config import load_machine

HERE = Path(__file__).resolve().parent / "gcode"
MILL = load_machine(HERE / "rs274-mill.toml")
_WORDS = {"STRAIGHT_TRAVERSE": "rapid", "STRAIGHT_FEED": "feed", "DWELL": "dwell",
          "START_SPINDLE_CLOCKWISE": "M3", "START_SPINDLE_COUNTERCLOCKWISE": "M4",
          "STOP_SPINDLE_TURNING": "M5", "PROGRAM_STOP": "pause",
          "ORIENT_SPINDLE": "pause"}   # G87: where rs274 orients the spindle retrofit pauses (M19)


def rs274_sequence(name: str) -> list[str]:
    """rs274's events, a reversal (stop then start) as the start alone; the end of the program
    (its spindle stop) left out."""
    out = []
    text = (HERE / "golden" / "programs" / f"{name}.canon").read_text()
    for call in re.findall(r"N\.+ ([A-Z_]+)\(", text):
        if call == "PROGRAM_END":
            break
        word = _WORDS.get(call)
        if word in ("M3", "M4") and out and out[-1] == "M5":
            out.pop()
        if word:
            out.append(word)
    if out and out[-1] == "M5":
        out.pop()                            # M2's spindle stop
    return out


def retrofit_sequence(program) -> list[str]:
    out = []
    for cmd in program.commands:
        if isinstance(cmd, Spin):
            out.append("M5" if not cmd.direction else ("M3" if cmd.direction > 0 else "M4"))
        elif isinstance(cmd, (FMov, PMov, Dely, Paus)):
            out.append({FMov: "rapid", PMov: "feed", Dely: "dwell", Paus: "pause"}[type(cmd)])
    if out and out[-1] == "M5":
        out.pop()                            # M2's spindle stop
    return out


def _drop_retract_after_pause(seq: list[str]) -> list[str]:
    return [w for k, w in enumerate(seq) if not (w == "rapid" and k and seq[k - 1] == "pause")]


@pytest.mark.parametrize("name", ["cycle-g84", "cycle-g74", "cycle-g86", "cycle-g86-m4",
                                  "cycle-g84-no-p", "cycle-g88", "cycle-g87-g98-g99",
                                  "cycle-g87-g91-l2"])
def test_spindle_cycles_run_in_rs274s_order(name):
    program = load_program(HERE / "programs" / f"{name}.ngc", MILL)
    ours = retrofit_sequence(program)
    if name == "cycle-g88":
        assert ours[ours.index("pause") + 1] == "rapid"      # retrofit retracts after the pause
        ours = _drop_retract_after_pause(ours)
    assert ours == rs274_sequence(name), name


def test_g84_reverses_at_the_bottom_and_turns_forward_again_at_r():
    program = compile_program("G21 G90 G17\nM3 S400\nG0 X0 Y0 Z5\nG99 G84 X1 Y2 Z-6 R1 P0.3 F500\n"
                              "G80\nM2\n", MILL)
    cmds = [str(c) for c in program.commands if not isinstance(c, FMov)]
    assert cmds[cmds.index("PMOV X1 Y2 Z-6"):] == [
        "PMOV X1 Y2 Z-6", "SPIN S400 D-1", "DELY P0.3", "PMOV X1 Y2 Z1", "SPIN S400 D1", "SPIN S0 D0"]


def test_g87_stops_and_pauses_for_the_orientation_before_each_sideways_move_in_the_hole():
    program = compile_program("G21 G90 G17\nM3 S400\nG0 X0 Y0 Z5\nG98 G87 X1 Y2 Z-6 R1 I0.5 J0 "
                              "K-2 F500\nG80\nM2\n", MILL)
    cmds = [str(c) for c in program.commands][-18:]
    assert cmds == [
        "FMOV X1 Y2 Z5", "FMOV X1 Y2 Z1", "FMOV X1.5 Y2 Z1", "SPIN S0 D0", "PAUS M19",
        "FMOV X1.5 Y2 Z-6", "FMOV X1 Y2 Z-6", "SPIN S400 D1", "PFDR F500", "PMOV X1 Y2 Z-2", "PMOV X1 Y2 Z-6",
        "SPIN S0 D0", "PAUS M19", "FMOV X1.5 Y2 Z-6", "FMOV X1.5 Y2 Z5", "FMOV X1 Y2 Z5",
        "SPIN S400 D1", "SPIN S0 D0"]


@pytest.mark.parametrize("text, words", [
    ("M4 S300\nG84 X1 Y1 Z-2 R1 F100", "test.ngc:3: G84: the spindle turns counterclockwise"),
    ("M3 S300\nG74 X1 Y1 Z-2 R1 F100", "test.ngc:3: G74: the spindle turns clockwise"),
    ("G86 X1 Y1 Z-2 R1 P1 F100", "test.ngc:2: G86: the spindle is not turning"),
    ("M3 S300\nG88 X1 Y1 Z-2 R1 F100", "test.ngc:3: G88: dwell time P word missing"),
    ("M3 S300\nG87 X1 Y1 Z-2 R1 I1 K-1 F100", "test.ngc:3: G87: J word missing"),
    ("G87 X1 Y1 Z-2 R1 I1 J0 K-1 F100", "test.ngc:2: G87: the spindle is not turning"),
])
def test_spindle_cycle_refusals(text, words):
    with pytest.raises(GcodeError) as err:
        compile_program("G21 G90 G17\n" + text + "\nM2\n", MILL, file="test.ngc")
    assert words in str(err.value)
