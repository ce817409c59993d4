"""One Z convention on every shipped mill: Z+ up, so one program runs on each of them."""

import json
import os
from pathlib import Path

import pytest

from retrofit.commands import FMov, PMov
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

from tests.test_run_machines import retrofit, write

# A 10 x 10 mm pocket 3 mm deep in 1 mm passes, with the safe height Z5 above the work. The work
# offset puts work zero 10 mm below machine Z 0, inside the Z travel of every mill.
POCKET = "\n".join(["(pocket, Z5 safe height above the work)", "G21 G90 G17",
                    "G10 L2 P1 X0 Y0 Z-10", "G54", "G0 Z5", "G0 X10 Y10"]
                   + [f"G1 Z-{depth} F100\nG1 X20 F300\nG1 Y20\nG1 X10\nG1 Y10" for depth in (1, 2, 3)]
                   + ["G0 Z5", "M2", ""])
MILLS = ["tul-mill", "grenoble-mill", "engraver"]


@pytest.mark.parametrize("name", MILLS)
def test_the_same_pocket_lands_at_the_same_machine_z_on_every_mill(name):
    program = compile_program(POCKET, load_machine(name))
    z = [dict(c.axes)["Z"] for c in program.commands if isinstance(c, (FMov, PMov)) and "Z" in dict(c.axes)]
    # by hand: work zero at machine Z -10, so the safe height is -10 + 5 and the floor -10 - 3
    assert (max(z), min(z)) == (-5.0, -13.0)


@pytest.mark.parametrize("name", MILLS)
def test_the_same_pocket_runs_clean_on_every_mill(tmp_path, name):
    prog = write(tmp_path, "pocket.ngc", POCKET)
    proc = retrofit("run", prog, "--machine", name, "--report", "r.json", "--progress", "off", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"] == []
    ends = {axis: rep["axes"][axis]["carriage_mm"] for axis in "XYZ"}
    assert ends == pytest.approx({"X": 10.0, "Y": 10.0, "Z": -5.0}, abs=0.001)   # where the program ends


CYCLE = """G21 G90
T3 M6
G43 H3
M3 S1000
G0 X10 Y10 Z-5
G1 Z-15 F200
G1 X20 F300
G0 Z-5
G49
T0 M6
G0 X5 Y5 Z-5
M2
"""


def test_a_tool_change_cycle_with_g43_on_tul_mill_ends_with_an_empty_spindle(tmp_path):
    for step in (["setter", "reference"], ["setter", "measure", "T3"], ["tool", "T0"]):
        proc = retrofit(*step, "--machine", "tul-mill", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr + proc.stdout
    from retrofit.machine.tooltable import ToolTable
    # T3 is 24.62 mm long, the reference T1 20 mm: a longer tool has a positive offset (Z+ up)
    table = Path(os.environ["XDG_STATE_HOME"]) / "retrofit" / "tul-mill" / "tool.tbl"
    assert ToolTable.load(table)[3].z_offset_mm == pytest.approx(4.62, abs=0.01)
    prog = write(tmp_path, "cycle.ngc", CYCLE)
    proc = retrofit("run", prog, "--machine", "tul-mill", "--report", "r.json", "--progress", "off",
                    cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"] == []
    assert [c["line"] for c in rep["tool"]["changes"]] == [2, 10]
    assert (rep["tool"]["start"], rep["tool"]["end"]) == (0, 0)
    assert json.loads(table.with_name("spindle-sim.json").read_text())["spindle_tool"] == 0
    # G49 leaves the machine where it is (as rs274); the last move goes to Z-5 with no offset
    ends = {axis: rep["axes"][axis]["carriage_mm"] for axis in "XYZE"}
    assert ends == pytest.approx({"X": 5.0, "Y": 5.0, "Z": -5.0, "E": 0.0}, abs=0.001)
