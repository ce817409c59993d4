"""A school's set of Fanuc/Haas lathe programs runs whole under the Fanuc dialect.

tests/data/fanuc/programs holds programs written the way students and shops write them for Fanuc
0i-T and Haas lathes (metric and inch, O and ``:`` numbers, ``%``, T0101 and T101, G50, G96/G97,
G98/G99, every cycle, M98/M97/M99, M31/M41/M10 ...). Each names in a ``(END X.. Z..)`` comment
where a Fanuc control leaves the slides (machine position, X as a diameter, in the program's
units; the programs start at the home position), or ``(END HOME)``; every program must run and
end there.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

DATA = Path(__file__).parent / "data" / "fanuc"
PROGRAMS = sorted((DATA / "programs").glob("*.nc"))
HOME = {"X": 130.0, "Z": 200.0}            # the school lathe's [homing] home_mm


@pytest.fixture(scope="module")
def lathe():
    return load_machine(DATA / "fanuc-school-lathe.toml")


def last_position(program) -> dict[str, float]:
    where = dict(HOME)
    for command in program.commands:
        name, *words = str(command).split()
        if name in ("FMOV", "PMOV"):
            where = {w[0]: float(w[1:]) for w in words}
        elif name == "ZMOV":
            where = dict(HOME)
    return where


@pytest.mark.parametrize("path", PROGRAMS, ids=[p.stem for p in PROGRAMS])
def test_program_runs_and_ends_where_the_control_would(path, lathe):
    text = path.read_text()
    program = compile_program(text, lathe, path.name, start_mm=HOME)
    end = re.search(r"\(END (HOME|X(\S+) Z(\S+))\)", text)
    where = last_position(program)
    if end.group(1) == "HOME":
        assert where == HOME
    else:
        unit = 25.4 if re.search(r"\bG20\b", text) else 1.0
        assert 2 * where["X"] == pytest.approx(float(end.group(2)) * unit, abs=1e-6)
        assert where["Z"] == pytest.approx(float(end.group(3)) * unit, abs=1e-6)
    assert sum(str(c).startswith(("FMOV", "PMOV")) for c in program.commands) >= 4


@pytest.mark.parametrize("path", PROGRAMS, ids=[p.stem for p in PROGRAMS])
def test_program_runs_with_the_tool_table_offsets(path, lathe):
    table = ToolTable.load(DATA / "tools.tbl")
    program = compile_program(path.read_text(), lathe, path.name, start_mm=HOME, tool_table=table)
    assert not any("offset" in m[3] for m in program.messages)


def test_the_set_covers_the_dialect():
    text = "\n".join(p.read_text() for p in PROGRAMS)
    for feature in ("G71", "G72", "G73", "G70", "G76", "G92", "G90", "G94", "G74", "G75", "G32",
                    "G50 S", "G50 X", "G96", "G97", "G98", "G99", "G28 U0", "M98", "M97", "M99",
                    "M31", "M41", "M08", "T0101", "T101", "U", "W", ":0", "%", "G20", "G04 P"):
        assert feature in text, feature
