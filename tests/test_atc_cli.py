"""retrofit tool / setter and retrofit run on the mill: the records they keep and what they print."""

import json
import os
from pathlib import Path

from retrofit.cli import main


def sim_record():
    """Where the simulated tul-mill's spindle record lives (the state folder of the tests)."""
    return Path(os.environ["XDG_STATE_HOME"]) / "retrofit" / "tul-mill" / "spindle-sim.json"


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_tool_changes_and_remembers(tmp_path, capsys):
    where = ["--tool-table", str(tmp_path / "tul-mill.tbl")]
    code, out, _ = run(capsys, "tool", "T3", *where)
    assert code == 0
    assert "T0 -> T3, condition 1: pick" in out and "violations: 0" in out
    assert "sim: spindle T3; pockets 1:T1 2:T2 3:- 4:T4" in out
    assert json.loads(sim_record().read_text())["spindle_tool"] == 3
    code, out, _ = run(capsys, "tool", "T5", *where)
    assert "T3 -> T5, condition 2: put back, then pick" in out
    code, out, _ = run(capsys, "tool", *where)
    assert out.startswith("tul-mill: T5 in the spindle")


def test_tool_refuses_13_and_a_corrupt_record(tmp_path, capsys):
    where = ["--tool-table", str(tmp_path / "tul-mill.tbl")]
    code, _, err = run(capsys, "tool", "T13", *where)
    assert code == 2 and "T13: no such tool on tul-mill" in err
    sim_record().parent.mkdir(parents=True)
    sim_record().write_text("{not json")
    code, _, err = run(capsys, "tool", "T2", *where)
    assert code == 2 and "cannot be trusted" in err and "--recover" in err
    code, out, _ = run(capsys, "tool", "T4", "--recover", *where)
    assert code == 0 and "recovery with T4 in the spindle" in out and "spindle empty" in out
    code, out, _ = run(capsys, "tool", *where)
    assert "no tool in the spindle" in out


def test_setter_and_mill(tmp_path, capsys):
    where = ["--tool-table", str(tmp_path / "tul-mill.tbl")]
    code, _, err = run(capsys, "setter", "measure", "T3", *where)
    assert code == 2 and "no reference" in err
    assert not sim_record().exists()                                 # nothing moved
    assert run(capsys, "setter", "reference", *where)[0] == 0
    code, out, _ = run(capsys, "setter", "measure", "T3", "T8", *where)
    assert code == 0 and "T3 length 24.6200 mm" in out and "T8 length 10.2500 mm" in out
    code, out, _ = run(capsys, "setter", "table", *where)
    assert "T3: length 24.6200 mm" in out
    program = tmp_path / "job.ngc"
    program.write_text("G0 X10 Y10 Z-5\nT3\nG43\nG0 Z-20\nG1 X20 F300\nG49\nT0\nM30\n")
    # the measurements are in the LinuxCNC tool table: Z = length - reference length, D = diameter
    from retrofit.machine.tooltable import ToolTable
    tbl = ToolTable.load(tmp_path / "tul-mill.tbl")
    assert tbl[3].z_offset_mm == round(24.62 - 20.0, 9) and abs(tbl[3].diameter_mm - 6.0) <= 0.02
    assert tbl[8].z_offset_mm == round(10.25 - 20.0, 9)
    code, out, _ = run(capsys, "run", str(program), "--machine", "tul-mill", *where,
                       "--report", str(tmp_path / "r.json"))
    assert code == 0, out
    rep = json.loads((tmp_path / "r.json").read_text())
    assert [c["line"] for c in rep["tool"]["changes"]] == [2, 7] and rep["tool"]["end"] == 0
    assert rep["violations"] == []


def test_tool_state_that_cannot_be_trusted_names_the_recovery(tmp_path, capsys):
    where = ["--tool-table", str(tmp_path / "tul-mill.tbl")]
    record = sim_record()
    record.parent.mkdir(parents=True)
    code, _, err = run(capsys, "tool", "T\u00b2".encode().decode("unicode_escape"), *where)
    assert code == 2 and "expected T followed by a number" in err
    for text, why in [("[" * 100000 + "]" * 100000, "unreadable"),
                      ('{"machine": "tul-mill", "spindle_tool": 13}', "T13 is not a tool of this machine"),
                      ('{"machine": "engraver", "spindle_tool": 1}', "belongs to machine 'engraver'"),
                      ('{"machine": "tul-mill", "spindle_tool": 1.5}', "is not a tool number"),
                      ('[1, 2]', "unreadable")]:
        record.write_text(text)
        code, _, err = run(capsys, "tool", *where)
        assert code == 2 and why in err and "retrofit tool T<n> --recover --machine tul-mill" in err, err
        assert len(err.strip().splitlines()) == 1
    record.unlink()
    setter = tmp_path / "tul-mill.setter.json"
    setter.write_text('{"machine": "tul-mill", "reference": {"tool": 1, "length_mm": NaN, "z_break_mm": 3}}')
    code, _, err = run(capsys, "setter", "table", *where)
    assert code == 2 and "not a finite length" in err and "retrofit setter reference" in err
