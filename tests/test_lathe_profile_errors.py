"""A G70/G71/G72 profile that holds a line which cannot be read is refused, never cut without it.

The refusal names the file, the unreadable line's number and the reader's own message (the one
the interpreter gives when a program reaches that line), in the rs274 dialect (profile in an
``O.. SUB``) and in the Fanuc dialect (profile between N``P`` and N``Q``). LinuxCNC's ``rs274``
refuses the same programs (slow stage, where it is installed).
"""

from __future__ import annotations

import shutil
import subprocess

import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MACHINE = load_machine("mitic-lathe")
BAD = "Z-5 ~"
#: line 6 is the profile's Z-5; line 11 the cycle
PROGRAM = ("G18 G21 G90 G94 G40 G8\nF200\nO100 SUB\nG0 X4 Z1\nG1 X6 Z0\n{z5}\nZ-8\nX14\n"
           "O100 ENDSUB\nG0 X16 Z3\n{cycle}\nM2\n")
CYCLES = {"G70": "G70 Q100 X16 Z3", "G71": "G71 Q100 X16 Z3 I1"}


def _refusal(text: str, **kw) -> GcodeError:
    with pytest.raises(GcodeError) as info:
        compile_program(text, MACHINE, "part.ngc", **kw)
    return info.value


def _reader_message() -> str:
    """What the interpreter says when a program reaches the unreadable line (line 2 here)."""
    error = _refusal(f"G0 X16 Z3\n{BAD}\nM2\n")
    assert error.line == 2
    return error.rule


@pytest.mark.parametrize("cycle", sorted(CYCLES))
def test_an_unreadable_profile_line_refuses_the_cycle(cycle):
    good = compile_program(PROGRAM.format(z5="Z-5", cycle=CYCLES[cycle]), MACHINE, "part.ngc")
    assert any(str(c).startswith("PMOV X6 Z-5") for c in good.commands)
    error = _refusal(PROGRAM.format(z5=BAD, cycle=CYCLES[cycle]))
    assert (error.file, error.line) == ("part.ngc", 6)
    assert str(error).startswith("part.ngc:6: ")
    assert "'~'" in error.rule and _reader_message() in error.rule
    assert f"{cycle} Q100" in error.rule


def test_an_unreadable_line_in_a_profile_loop_refuses_the_cycle():
    text = ("G18 G21 G90 G94 G40 G8\nF200\nO100 SUB\nG0 X3 Z1\nO101 REPEAT [3]\nG1 Z[#<_z>-4]\n"
            "X[#<_x>+3] ~\nO101 ENDREPEAT\nO100 ENDSUB\nG0 X14 Z3\nG71 Q100 X14 Z3 I1 R0.5\nM2\n")
    error = _refusal(text)
    assert (error.file, error.line) == ("part.ngc", 7) and "'~'" in error.rule


FANUC = "O0001\nG99 G21\nG00 X40. Z2.\n{cycle}N10 G00 X20.\nG01 Z-5. ~\nZ-10.\nN20 X40.\nM30\n"


@pytest.mark.parametrize("cycle", ["G71 U1. R0.5\nG71 P10 Q20 U0.2 W0.1 F0.2\n", "G70 P10 Q20\n"],
                         ids=["G71", "G70"])
def test_fanuc_an_unreadable_profile_block_refuses_the_cycle(cycle):
    text = FANUC.format(cycle=cycle)
    bad = text.splitlines().index("G01 Z-5. ~") + 1
    error = _refusal(text, dialect="fanuc")
    assert error.file == "part.ngc"
    assert f"line {bad}:" in error.rule and "'~'" in error.rule


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
@pytest.mark.parametrize("cycle", sorted(CYCLES))
def test_rs274_refuses_the_same_programs(cycle, tmp_path):
    for z5, refused in (("Z-5", False), (BAD, True)):
        path = tmp_path / "part.ngc"
        path.write_text(PROGRAM.format(z5=z5, cycle=CYCLES[cycle]))
        proc = subprocess.run(["rs274", "-g", str(path)], stdin=subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=60, cwd=tmp_path)
        said = proc.stdout + proc.stderr
        assert ("Bad character" in said and BAD in said) == refused, said
        assert (proc.returncode != 0) == refused, said


def test_a_grbl_jog_line_in_the_profile_refuses_the_cycle():
    """``$J=`` moves the machine when the program runs it; in a profile it is not a move the
    cycle reads, so it is refused rather than left out of the cut."""
    error = _refusal(PROGRAM.format(z5="$J=G90 Z-5 F100", cycle=CYCLES["G70"]))
    assert "$J=G90 Z-5 F100" in error.rule and "line 6" in error.rule
