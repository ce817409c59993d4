"""Rotary axes A/B/C: degrees in machine files, LinuxCNC's programs that turn them against rs274.

The golden files are rs274's canonical calls (``tests/gcode/golden``); every straight move's
end point, X Y Z and the rotary axis, must agree within 1e-4 (mm, or degrees for A/B: rs274
prints degrees whatever the length units).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from retrofit.commands import FMov, PMov
from retrofit.errors import ConfigError, GcodeError
from retrofit.gcode import compile_program, load_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

HERE = Path(__file__).resolve().parent / "gcode"
TOOLS = ToolTable.load(HERE / "tool.tbl")
_MOVE = re.compile(r"^\s*\d+ N\S* +(STRAIGHT_TRAVERSE|STRAIGHT_FEED)\((.*)\)\s*$")


def rs274_moves(name: str) -> list[tuple[float, ...]]:
    """(x, y, z, a, b) of every straight move, in mm (x y z) and degrees (a b)."""
    text = (HERE / "golden" / "linuxcnc" / f"{name}.canon").read_text()
    assert text.startswith("# rs274 exit 0")
    unit, out = 1.0, []
    for raw in text.splitlines():
        if "USE_LENGTH_UNITS" in raw:
            unit = 25.4 if "INCHES" in raw else 1.0
        m = _MOVE.match(raw)
        if m:
            v = [float(x) for x in m.group(2).split(",")]
            out.append((v[0] * unit, v[1] * unit, v[2] * unit, v[3], v[4]))
    return out


def retrofit_moves(program) -> list[tuple[float, ...]]:
    out = []
    for cmd in program.commands:
        if isinstance(cmd, (FMov, PMov)):
            d = dict(cmd.axes)
            out.append((d["X"], d["Y"], d["Z"], d.get("A", 0.0), d.get("B", 0.0)))
    return out


@pytest.mark.parametrize("name, machine", [("b-index", "rs274-mill-b.toml"),
                                           ("daisy", "rs274-mill-a.toml")])
def test_programs_that_turn_a_or_b_end_where_rs274_ends_every_move(name, machine):
    program = load_program(HERE / "linuxcnc" / f"{name}.ngc", load_machine(HERE / machine),
                           tool_table=TOOLS)
    ours, theirs = retrofit_moves(program), [m for m in rs274_moves(name)]
    theirs = [m for k, m in enumerate(theirs) if k == 0 or m != theirs[k - 1]]
    ours = [m for k, m in enumerate(ours) if k == 0 or m != ours[k - 1]]
    assert len(ours) == len(theirs)
    for k, (a, b) in enumerate(zip(ours, theirs)):
        assert all(abs(u - v) <= 1e-4 * (25.4 if i < 3 else 1) for i, (u, v) in enumerate(zip(a, b))), \
            f"move {k}: rs274 {b}, retrofit {a}"
    assert max(abs(m[3]) + abs(m[4]) for m in ours) >= 10.0     # the table really turned


def _machine(tmp_path, a_table: str):
    text = (HERE / "rs274-mill-a.toml").read_text().split("[axis.a]")[0] + "[axis.a]\n" + a_table
    path = tmp_path / "m.toml"
    path.write_text(text)
    return load_machine(path)


def test_a_is_degrees_under_g20_and_steps_per_degree_set_its_steps(tmp_path):
    m = _machine(tmp_path, "steps_per_degree = 20.0\nmin_deg = -720\nmax_deg = 720\n")
    prog = compile_program("G20 G90\nG0 X1 A90\nG91 G1 A-30 F100\nM2\n", m)
    ends = retrofit_moves(prog)
    assert ends[0][0] == pytest.approx(25.4) and ends[0][3] == 90.0 and ends[1][3] == 60.0
    a = next(x for x in m.axes if x.name == "A")
    assert a.rotary and a.to_steps(90.0) == 1800


def test_a_beyond_its_limits_is_refused_naming_the_limit(tmp_path):
    m = _machine(tmp_path, "steps_per_degree = 20.0\nmin_deg = 0\nmax_deg = 180\n")
    with pytest.raises(GcodeError, match="A.*180"):
        compile_program("G0 A190\nM2\n", m)


def test_a_wrapped_table_takes_the_shorter_way_round(tmp_path):
    m = _machine(tmp_path, "steps_per_degree = 20.0\nwrap = true\n")
    prog = compile_program("G0 A350\nG0 A10\nG0 A300\nG91 G0 A400\nM2\n", m)
    # 0 -> 350 is 10 degrees back; 350 (-10) -> 10 is 20 forward; 10 -> 300 is 70 back;
    # G91 turns as written
    assert [e[3] for e in retrofit_moves(prog)] == [-10.0, 10.0, -60.0, 340.0]


@pytest.mark.parametrize("table, message", [
    ("steps_per_mm = 20.0\nmin_deg = 0\nmax_deg = 1\n", "rotary axis.*steps_per_degree"),
    ("steps_per_degree = 20.0\nwrap = true\nmax_deg = 10\n", "limits or wrap"),
    ("steps_per_degree = 20.0\nmin_deg = 10\nmax_deg = 0\n", "must be > min_deg"),
], ids=["mm-key", "wrap-and-limit", "limits-crossed"])
def test_rotary_machine_file_mistakes_name_the_key(tmp_path, table, message):
    with pytest.raises(ConfigError, match=message):
        _machine(tmp_path, table)
