"""Real programs LinuxCNC ships (tests/gcode/corpus, see the README there) against LinuxCNC's
own interpreter, run live, and the small language features they showed missing: the P of
M50-M53, the ``$`` spindle selection, and a clear refusal of HAL pins.

The plasma CAM outputs read their feed from a HAL pin (``#<_hal[plasmac.cut-feed-rate]>``),
which neither rs274 nor retrofit has; the operator's value (here 1000) is put in its place, and
the same text goes to both interpreters.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from retrofit.commands import FMov, Spin
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program

from tests.gcode.regenerate import run_rs274
from tests.test_gcode_rs274 import MACHINE, TOOLS, canon_events, compare, retrofit_points

CORPUS = Path(__file__).resolve().parent / "gcode" / "corpus"
HAL_FEED = "#<_hal[plasmac.cut-feed-rate]>"
PROGRAMS = sorted(CORPUS.rglob("*.ngc"))
needs_rs274 = pytest.mark.skipif(shutil.which("rs274") is None and not Path("/usr/bin/rs274").exists(),
                                 reason="LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace)")


def test_the_corpus_holds_real_programs_with_their_source_noted():
    assert len(PROGRAMS) >= 30
    readme = (CORPUS / "README.md").read_text()
    for folder in {p.parent.name for p in CORPUS.rglob("*.ngc")}:
        assert f"`{folder}/`" in readme


@needs_rs274
@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_corpus_program_agrees_with_rs274(program, tmp_path):
    text = program.read_text(encoding="utf-8").replace(HAL_FEED, "1000")
    copy = tmp_path / program.name
    copy.write_text(text)
    head, _, body = run_rs274(copy).partition("\n")
    accepted = head.startswith("# rs274 exit 0") or "File ended with no percent sign" in head
    if not accepted:        # the air scribe's second spindle ($1), plasmac's own M190
        with pytest.raises(GcodeError):
            compile_program(text, MACHINE, program.name, tool_table=TOOLS)
        return
    compiled = compile_program(text, MACHINE, program.name, tool_table=TOOLS)
    compare(canon_events(body), retrofit_points(compiled))


def test_plasma_lines_m52_p_and_spindle_zero_run_as_rs274_reads_them():
    # rs274: ENABLE_ADAPTIVE_FEED, SET_SPINDLE_SPEED(0, 100), START_SPINDLE_CLOCKWISE(0),
    # STRAIGHT_TRAVERSE(1, 0, 0), STOP_SPINDLE_TURNING(0)
    program = compile_program("G21\nM52 P1\nM3 $0 S100\nG0 X1\nM5 $0\nM2\n", MACHINE, "p.ngc")
    assert program.commands == [Spin(100.0, 1), FMov((("X", 1.0), ("Y", 0.0), ("Z", 0.0))),
                                Spin(0.0, 0)]


@pytest.mark.parametrize("text, rule", [
    ("G0 X1 $0\n", r"p.ngc:1: \$0: \$ \(spindle selection\) word with no M3, M4, M5"),
    ("M3 $1 S100\n", r"p.ngc:1: \$1: machine rs274-mill has one spindle, \$0"),
    ("M48 P1\n", r"p.ngc:1: P1: P word with no G code that uses it"),
    (f"G1 X1 F{HAL_FEED}\n", r"p.ngc:1: #<_hal\[plasmac.cut-feed-rate\]>: HAL pins are LinuxCNC's"),
], ids=["dollar-without-spindle-code", "second-spindle", "m48-takes-no-p", "hal-pin"])
def test_refusals_name_the_line_and_the_rule(text, rule):
    with pytest.raises(GcodeError, match=rule):
        compile_program(text, MACHINE, "p.ngc")
