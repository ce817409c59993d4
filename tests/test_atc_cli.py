"""retrofit tool / setter / mill: the records they keep and what they print."""

import json

from retrofit.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_tool_changes_and_remembers(tmp_path, capsys):
    where = ["--state-dir", str(tmp_path)]
    code, out, _ = run(capsys, "tool", "T3", *where)
    assert code == 0
    assert "T0 -> T3, condition 1: pick" in out and "violations: 0" in out
    assert "sim: spindle T3; pockets 1:T1 2:T2 3:- 4:T4" in out
    assert json.loads((tmp_path / "tul-mill-spindle.json").read_text())["spindle_tool"] == 3
    code, out, _ = run(capsys, "tool", "T5", *where)
    assert "T3 -> T5, condition 2: put back, then pick" in out
    code, out, _ = run(capsys, "tool", *where)
    assert out.startswith("tul-mill: T5 in the spindle")


def test_tool_refuses_13_and_a_corrupt_record(tmp_path, capsys):
    where = ["--state-dir", str(tmp_path)]
    code, _, err = run(capsys, "tool", "T13", *where)
    assert code == 2 and "T13: no such tool on tul-mill" in err
    (tmp_path / "tul-mill-spindle.json").write_text("{not json")
    code, _, err = run(capsys, "tool", "T2", *where)
    assert code == 2 and "cannot be trusted" in err and "--recover" in err
    code, out, _ = run(capsys, "tool", "T4", "--recover", *where)
    assert code == 0 and "recovery with T4 in the spindle" in out and "spindle empty" in out
    code, out, _ = run(capsys, "tool", *where)
    assert "no tool in the spindle" in out


def test_setter_and_mill(tmp_path, capsys):
    where = ["--state-dir", str(tmp_path)]
    code, _, err = run(capsys, "setter", "measure", "T3", *where)
    assert code == 2 and "no reference" in err
    assert not (tmp_path / "tul-mill-spindle.json").exists()          # nothing moved
    assert run(capsys, "setter", "reference", *where)[0] == 0
    code, out, _ = run(capsys, "setter", "measure", "T3", "T8", *where)
    assert code == 0 and "T3 length 24.6200 mm" in out and "T8 length 10.2500 mm" in out
    code, out, _ = run(capsys, "setter", "table", *where)
    assert "T3: length 24.6200 mm" in out
    program = tmp_path / "job.ngc"
    program.write_text("G0 X10 Y10 Z5\nT3\nG43\nG0 Z20\nG1 X20 F300\nG49\nT0\nM30\n")
    code, out, _ = run(capsys, "mill", str(program), *where)
    assert code == 0 and "2 tool change(s), T0 in the spindle at the end" in out
