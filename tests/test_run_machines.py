"""`retrofit run` for every machine: tool changes inside the run, pauses, exit codes, the summary."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_pullout import BENCH

TOOL_CYCLE = """G21 G90
T3 M6
M3 S1000
G0 X10 Y10
G1 Z-5 F200
T5 M6
G0 X5 Y5
T0 M6
M2
"""


def retrofit(*args, cwd, stdin=None):
    return subprocess.run([sys.executable, "-m", "retrofit.cli", *args], capture_output=True, text=True,
                          cwd=cwd, input=stdin, timeout=120)


def state(name: str) -> Path:
    """A file of tul-mill's state folder (the tests' XDG_STATE_HOME)."""
    return Path(os.environ["XDG_STATE_HOME"]) / "retrofit" / "tul-mill" / name


def write(tmp_path, name, text):
    (tmp_path / name).write_text(text)
    return name


def test_tool_changes_run_inside_the_run_and_end_with_an_empty_spindle(tmp_path):
    prog = write(tmp_path, "cycle.ngc", TOOL_CYCLE)
    proc = retrofit("run", prog, "--machine", "tul-mill", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"] == []
    assert [c["line"] for c in rep["tool"]["changes"]] == [2, 6, 8]
    assert rep["tool"]["end"] == 0
    # after the last change (condition 3: put back, door closed) the axes return to where the
    # program left them (G0 X5 Y5 at Z-5)
    for axis, mm in {"X": 5.0, "Y": 5.0, "Z": -5.0, "E": 0.0}.items():
        assert rep["axes"][axis]["carriage_mm"] == pytest.approx(mm, abs=0.01)
    summary = " ".join(proc.stdout.split())
    assert f"tool table: {state('tool.tbl')}; simulated spindle record: {state('spindle-sim.json')} (T0" \
        in summary
    assert json.loads(state("spindle-sim.json").read_text())["spindle_tool"] == 0
    # within 80 columns, but for a file name longer than that alone on its line (never cut)
    assert all(len(line) <= 80 or " " not in line.strip() for line in proc.stdout.splitlines())


def test_the_spindle_record_is_where_the_next_run_starts(tmp_path):
    prog = write(tmp_path, "pick.ngc", "T3 M6\nM2\n")
    assert retrofit("run", prog, "--machine", "tul-mill", cwd=tmp_path).returncode == 0
    assert json.loads(state("spindle-sim.json").read_text())["spindle_tool"] == 3
    proc = retrofit("tool", "--machine", "tul-mill", cwd=tmp_path)
    assert "T3 in the spindle" in proc.stdout and "spindle-sim.json" in proc.stdout
    again = retrofit("run", write(tmp_path, "back.ngc", "T0 M6\nM2\n"), "--machine", "tul-mill",
                     "--report", "r.json", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    changes = json.loads((tmp_path / "r.json").read_text())["tool"]["changes"]
    assert [c["says"] for c in changes] == ["tool change T3 -> T0 by the changer (condition 3)"]


def test_a_move_into_the_magazine_is_a_collision_exit_1_with_the_line(tmp_path):
    prog = write(tmp_path, "crash.ngc", "T3 M6\nG0 X23 Y28 Z-45\nG0 Y44\nG0 Y28\nM2\n")
    proc = retrofit("run", prog, "--machine", "tul-mill", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"][0]["axis"] == "ATC" and rep["violations"][0]["line"] == 3
    assert "(line 3): ATC pocket misaligned" in proc.stdout


def test_a_manual_change_on_the_engraver_is_a_recorded_pause_on_sim(tmp_path):
    prog = write(tmp_path, "eng.ngc", "G0 X1 Y1\nT2 M6\nG0 X3 Y2\nM0\nG0 X0 Y0\nM2\n")
    proc = retrofit("run", prog, "--machine", "engraver", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["pauses"] == [{"line": 2, "says": "manual tool change (M6): put T2 in the spindle"},
                             {"line": 4, "says": "program pause (M0)"}]
    assert "line 2: paused: manual tool change (M6): put T2 in the spindle" in proc.stdout
    assert rep["axes"]["X"]["carriage_mm"] == 0.0


def test_a_pause_on_a_real_output_without_a_terminal_is_refused_before_anything_moves(tmp_path):
    prog = write(tmp_path, "lathe.ngc", "G0 X1 Z1\nT2 M6\nG0 X0 Z0\nM2\n")
    proc = retrofit("run", prog, "--machine", "chivu-lathe", "--output", "parport+record://rec.bin",
                    cwd=tmp_path, stdin="")
    assert proc.returncode == 2
    assert "line 2: manual tool change (M6): put T2 in the spindle" in proc.stderr
    assert not (tmp_path / "rec.bin").exists()


def lossy(tmp_path):
    text = BENCH.replace("{extra}", "").replace("max_accel_mm_s2 = 1000.0", "max_accel_mm_s2 = 40000.0")
    (tmp_path / "bench.toml").write_text(text)
    return write(tmp_path, "lossy.ngc", "G0 X1\nG1 X41 F9000\nG0 Y2\nM2\n")


def test_lost_steps_exit_1_naming_axis_time_and_line(tmp_path):
    prog = lossy(tmp_path)
    proc = retrofit("run", prog, "--machine", "bench.toml", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr
    rep = json.loads((tmp_path / "r.json").read_text())
    lost = [v for v in rep["violations"] if v["kind"] == "lost_steps"]
    assert lost and lost[0]["axis"] == "X" and lost[0]["line"] == 2
    assert 0 < lost[0]["time_s"] < rep["duration_s"]
    assert f"at {lost[0]['time_s']:.3f} s (line 2): X lost steps" in proc.stdout
    assert all(len(line) <= 80 for line in proc.stdout.splitlines())
    assert "{" not in proc.stdout                         # words, not a raw dict
    allowed = retrofit("run", prog, "--machine", "bench.toml", "--allow-violations", cwd=tmp_path)
    assert allowed.returncode == 0 and "X lost steps" in allowed.stdout


def test_stdin_version_and_plot_name(tmp_path):
    proc = retrofit("run", "-", "--machine", "chivu-lathe", "--plot", "p", cwd=tmp_path,
                    stdin="G0 X5 Z-3\nG1 X0 F300\nM2\n")
    assert proc.returncode == 0, proc.stderr
    assert "chivu-lathe: <stdin>" in proc.stdout
    assert "  plot: p.png" in proc.stdout
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    from retrofit.cli import version
    out = retrofit("--version", cwd=tmp_path)
    assert out.returncode == 0 and out.stdout.strip() == f"retrofit {version()}"
    bad = retrofit("run", "-", cwd=tmp_path, stdin="G0 X5\nG999 X1\n")
    assert bad.returncode == 2 and bad.stderr.startswith("retrofit: error: <stdin>:2:")


@pytest.mark.parametrize("where, why", [("way", "a directory is in the way"),
                                        ("missing/r", "does not exist"),
                                        ("ro/r", "permission denied")])
def test_an_output_that_cannot_be_written_is_one_line_exit_2(tmp_path, where, why):
    import os
    for ext in ("json", "png", "vcd"):
        (tmp_path / f"way.{ext}").mkdir()
    (tmp_path / "ro").mkdir(mode=0o500)
    if os.geteuid() == 0 and why == "permission denied":
        pytest.skip("root writes anywhere")
    before = sorted(p.name for p in tmp_path.iterdir())
    prog = write(tmp_path, "p.ngc", "G0 X5 Z-3\nM2\n")
    for args in (["--report", f"{where}.json"], ["--plot", f"{where}.png"], ["--output", f"vcd://{where}.vcd"]):
        proc = retrofit("run", prog, *args, cwd=tmp_path)
        assert proc.returncode == 2, proc.stdout
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and f"{where}." in lines[0] and why in lines[0], proc.stderr
        assert "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(before + ["p.ngc"])
    assert not any((tmp_path / "ro").iterdir())
    os.chmod(tmp_path / "ro", 0o700)


def test_disk_full_is_one_line_and_leaves_nothing(tmp_path):
    write(tmp_path, "p.ngc", "G0 X5 Z-3\nM2\n")
    if not __import__("os").path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    from retrofit.atomic import staged
    from retrofit.errors import OutputError
    with pytest.raises(OutputError, match=r"r.json: cannot write the file: disk full"):
        with staged(tmp_path / "r.json"):
            with open("/dev/full", "w") as full:
                full.write("x" * 100000)
                full.flush()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.ngc"]


def test_a_run_cut_short_during_tool_changes_leaves_the_record_untrusted(tmp_path):
    from retrofit.atc.state import SpindleStore
    from retrofit.errors import ToolStateError
    from retrofit.machine.config import load_machine
    prog = write(tmp_path, "pick.ngc", "T3 M6\nM2\n")
    record = state("spindle.json")                        # the machine's, not the simulation's
    record.parent.mkdir(parents=True)
    SpindleStore("tul-mill", record).begin(0, 3)          # what a run cut short leaves behind
    url = "serial+socket://127.0.0.1:9"                  # refused before anything is sent
    proc = retrofit("run", prog, "--machine", "tul-mill", "--output", url, cwd=tmp_path)
    assert proc.returncode == 2
    assert "the change from T0 to T3 was cut short" in proc.stderr
    assert f"retrofit tool T<n> --recover --machine tul-mill --output {url}" in proc.stderr
    assert retrofit("run", prog, "--machine", "tul-mill", cwd=tmp_path).returncode == 0   # simulated
    with pytest.raises(ToolStateError):
        SpindleStore("tul-mill", record, load_machine("tul-mill").parts["atc"].pockets).load()


@pytest.mark.skipif(not __import__("shutil").which("script"), reason="script (util-linux) is not installed")
def test_a_manual_change_on_a_real_output_waits_for_enter_at_the_terminal(tmp_path):
    from tests.conformance.targets import McuTarget
    root = Path(__file__).resolve().parents[1]
    prog = write(tmp_path, "eng.ngc", "G0 X1 Y1\nT2 M6\nG0 X3 Y2\nM2\n")
    typescript = tmp_path / "typescript"
    with McuTarget("engraver") as mcu:
        cmd = (f"stty cols 80 rows 24; env PYTHONPATH={root} python3 -m retrofit.cli run {prog} "
               f"--machine engraver --output serial+socket://127.0.0.1:{mcu.port} --report r.json")
        proc = subprocess.Popen(["script", "-qefc", cmd, str(typescript)], cwd=tmp_path,
                                stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
        import time
        for _ in range(1200):                      # the prompt comes when the moves before it are done
            if "press Enter" in typescript.read_text(errors="replace") if typescript.exists() else False:
                break
            time.sleep(0.1)
        text = typescript.read_text(errors="replace")
        assert "paused: line 2: manual tool change (M6): put T2 in the spindle; press Enter to go on" in text
        assert not (tmp_path / "r.json").exists()             # the run waits
        proc.communicate(b"\n", timeout=60)
    assert proc.returncode == 0
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["remote"][0]["position_mm"]["X"] == 3.0 and rep["remote"][0]["position_mm"]["Y"] == 2.0
    assert rep["pauses"] == [{"line": 2, "says": "manual tool change (M6): put T2 in the spindle"}]
    record = Path(os.environ["XDG_STATE_HOME"]) / "retrofit" / "engraver" / "spindle.json"
    assert json.loads(record.read_text())["spindle_tool"] == 2           # the machine's record
