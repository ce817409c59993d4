"""Malformed O-word lines are refused before anything moves, naming the line and the accepted form.

The oracle is LinuxCNC's ``rs274``. Its O-code reference says an O-word opens its line (only a
block delete ``/`` or a line number ``N`` may come before it); rs274 refuses an ``O`` after other
words ("Bad character 'o' used"), an ``if`` or ``while`` without a bracketed condition ("Left
bracket missing"), and a second expression or stray text after an O-word's one expression
("Unexpected character after O-word"). rs274 reads a line only when it reaches it; retrofit pairs
every O-word of a file before the first line runs, so it refuses a malformed O-word line wherever
it stands, on that line -- stricter than rs274 for a line no run reaches (a sub never called).
``test_rs274_refuses_them_too`` runs rs274 itself where it is installed.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine(Path(__file__).resolve().parent / "gcode" / "rs274-mill.toml")
RS274 = shutil.which("rs274") or "/usr/bin/rs274"


def refusal(text: str) -> GcodeError:
    with pytest.raises(GcodeError) as err:
        compile_program(text, MILL, "p.ngc")
    return err.value


def x_ends(text: str) -> list[float]:
    """The X where each move of the compiled program ends (machine mm)."""
    return [dict(c.axes)["X"] for c in compile_program(text, MILL, "p.ngc").commands
            if hasattr(c, "axes")]


# -- 1. an O-word after other words -----------------------------------------------------------

AFTER_WORDS = "G21 G90\nG0 X1 O100\nM2\n"


def test_an_o_word_after_other_words_is_refused_on_its_line():
    err = refusal(AFTER_WORDS)
    assert (err.file, err.line) == ("p.ngc", 2)
    assert str(err).startswith("p.ngc:2: O100 after other words: an O-word must be the first word "
                               "of its line (after an optional / and N number")


def test_a_closing_o_word_after_other_words_is_named_not_the_block_it_leaves_open():
    err = refusal("o100 if [1]\nG0 X1 o100 endif\nM2\n")
    assert err.line == 2 and "O100 after other words" in str(err)


def test_an_o_word_after_a_block_delete_or_a_line_number_still_runs():
    assert x_ends("N10 o100 if [1]\nG0 X1\no100 endif\n/ o101 if [1]\nG0 X2\no101 endif\nM2\n") \
        == [1.0, 2.0]


# -- 2. an if (or while) without a condition --------------------------------------------------

def test_an_if_without_a_condition_is_refused_on_the_if_line_not_the_endif():
    err = refusal("G21 G90\no100 if\nG0 X1\no100 endif\nM2\n")
    assert err.line == 2
    assert str(err).startswith("p.ngc:2: o100 if has no [...] expression: it takes exactly one "
                               "[condition]")


def test_a_while_without_a_condition_in_a_branch_not_taken_is_still_refused_on_its_line():
    err = refusal("o1 if [0]\no2 while\no2 endwhile\no1 endif\nM2\n")
    assert err.line == 2 and "o2 while has no [...] expression" in str(err)


# -- 3. more than the O-word takes ------------------------------------------------------------

@pytest.mark.parametrize("text, line, accepted", [
    ("o100 sub\no100 return [1] [2]\no100 endsub\nM2\n", 2, "one optional [value]"),
    ("o100 sub\nG0 X1\no100 endsub [1] [2]\no100 call\nM2\n", 3, "one optional [value]"),
    ("o100 sub\no100 return [1] X2\no100 endsub\no100 call\nM2\n", 2, "one optional [value]"),
    ("o100 if [1] [2]\nG0 X1\no100 endif\nM2\n", 1, "exactly one [condition]"),
    ("o100 if [0]\nG0 X1\no100 elseif [1] G0\no100 endif\nM2\n", 3, "exactly one [condition]"),
    ("o100 do\nG0 X1\no100 while [0] [1]\nM2\n", 3, "exactly one [condition]"),
], ids=["return-two-values-sub-never-called", "endsub-two-values", "return-then-a-word",
        "if-two-conditions", "elseif-then-a-word", "do-while-two-conditions"])
def test_a_second_expression_or_stray_text_after_an_o_word_is_refused_on_its_line(text, line, accepted):
    err = refusal(text)
    assert err.line == line
    assert f"it takes {accepted}" in str(err) and str(err).startswith(f"p.ngc:{line}: o100 ")


def test_an_o_word_with_its_one_expression_still_runs():
    assert x_ends("o100 sub\nG0 X#1\no100 return [#1 + 1]\no100 endsub\no100 call [3]\n"
                  "o101 if [#<_value> EQ 4]\nG0 X#<_value>\no101 endif\nM2\n") == [3.0, 4.0]


# -- the oracle ---------------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.skipif(not Path(RS274).exists(), reason="LinuxCNC's rs274 is not installed")
def test_rs274_refuses_them_too(tmp_path):
    """rs274 on the programs above whose bad line a run reaches: it refuses every one."""
    programs = [AFTER_WORDS, "G21 G90\no100 if\nG0 X1\no100 endif\nM2\n",
                "o100 sub\no100 return [1] [2]\no100 endsub\no100 call\nM2\n",
                "o100 sub\nG0 X1\no100 endsub [1] [2]\no100 call\nM2\n",
                "o100 if [1] [2]\nG0 X1\no100 endif\nM2\n", "o100 do\nG0 X1\no100 while [0] [1]\nM2\n"]
    for k, text in enumerate(programs):
        path = tmp_path / f"p{k}.ngc"
        path.write_text(text)
        proc = subprocess.run([RS274, "-g", str(path)], stdin=subprocess.DEVNULL, capture_output=True,
                              text=True, timeout=60, cwd=tmp_path)
        assert proc.returncode != 0, f"rs274 runs {text!r}"
        refusal(text)
