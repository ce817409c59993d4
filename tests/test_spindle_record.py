"""The record of the tool in the spindle: one per machine, found from any folder; a simulation never
spoils the machine's record; a Ctrl-C leaves a record the next run accepts; the recovery command
printed works when pasted, for a machine given by path and for one changed by hand."""

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from retrofit.cli import main
from retrofit.machine.config import load_machine, machines_dir

ROOT = Path(__file__).resolve().parents[1]
STATE = lambda: Path(os.environ["XDG_STATE_HOME"]) / "retrofit"        # noqa: E731


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def manual_machine(folder: Path, name: str = "mymill2") -> Path:
    """A machine file of the user's with no tool changer (tools are changed by hand)."""
    text = (Path(str(machines_dir())) / "engraver.toml").read_text()
    path = folder / f"{name}.toml"
    path.write_text(text.replace('name = "engraver"', f'name = "{name}"'))
    return path


def changer_machine(folder: Path, name: str = "mymill") -> Path:
    """A machine file of the user's with the carousel of tul-mill."""
    text = (Path(str(machines_dir())) / "tul-mill.toml").read_text()
    path = folder / f"{name}.toml"
    path.write_text(text.replace('name = "tul-mill"', f'name = "{name}"'))
    return path


def test_the_record_is_found_from_any_folder(tmp_path, capsys, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    (a / "t3.ngc").write_text("G0 X10 Y10\nT3 M6\nG0 X20\nM30\n")
    monkeypatch.chdir(a)
    code, out, err = run(capsys, "run", "t3.ngc", "--machine", "tul-mill")
    assert code == 0, err
    monkeypatch.chdir(b)
    code, out, _ = run(capsys, "tool", "--machine", "tul-mill")
    assert code == 0 and out.startswith("tul-mill: T3 in the spindle"), out
    assert not list(a.glob("*.json")) and not list(b.iterdir())           # nothing in the folders
    assert (STATE() / "tul-mill").is_dir()


def test_the_state_folder_never_depends_on_the_working_folder(monkeypatch):
    from retrofit.atc.state import default_state_dir, state_dir
    tul = load_machine("tul-mill")
    assert state_dir(tul) == STATE() / "tul-mill"               # the tests' own, not the home's
    assert not str(state_dir(tul)).startswith(str(Path.home() / ".local"))
    monkeypatch.setenv("XDG_STATE_HOME", "relative/state")          # ignored, as XDG says
    assert default_state_dir() == Path.home() / ".local" / "state" / "retrofit"
    monkeypatch.setenv("RETROFIT_STATE_DIR", "/srv/mill-state")
    assert state_dir(tul) == Path("/srv/mill-state/tul-mill")


def test_a_users_machine_keeps_its_record_beside_its_file_from_any_folder(tmp_path, capsys, monkeypatch):
    a, b, files = tmp_path / "a", tmp_path / "b", tmp_path / "machines"
    for d in (a, b, files):
        d.mkdir()
    changer_machine(files)
    (a / "t3.ngc").write_text("T3 M6\nG0 X20\nM30\n")
    monkeypatch.chdir(a)
    assert run(capsys, "run", "t3.ngc", "--machine", "../machines/mymill.toml")[0] == 0
    monkeypatch.chdir(b)
    code, out, _ = run(capsys, "tool", "--machine", str(files / "mymill.toml"))
    assert out.startswith("mymill: T3 in the spindle"), out
    assert json.loads((files / "mymill.spindle-sim.json").read_text())["spindle_tool"] == 3


def test_a_simulated_run_never_touches_the_machines_record(tmp_path, capsys, monkeypatch):
    from retrofit.atc.state import spindle_store
    monkeypatch.chdir(tmp_path)
    mill = load_machine("tul-mill")
    _, real = spindle_store(mill, "tul-mill", ["serial:///dev/ttyACM0"])
    real.save(2)
    before = real.path.read_bytes()
    Path("t1.ngc").write_text("T1 M6\nG0 X20\nM30\n")
    code, out, err = run(capsys, "run", "t1.ngc", "--machine", "tul-mill")
    assert code == 0, err
    assert "T0 -> T1" in " ".join(out.split())              # the simulated spindle was empty
    assert real.path.read_bytes() == before                  # the machine's record: not touched
    code, out, _ = run(capsys, "tool", "--machine", "tul-mill")
    assert out.startswith("tul-mill: T1 in the spindle") and "simulated" in out
    code, out, _ = run(capsys, "tool", "--machine", "tul-mill", "--output", "serial:///dev/ttyACM0")
    assert out.startswith("tul-mill: T2 in the spindle") and "simulated" not in out


def test_t1_to_t1_is_no_change_on_a_manual_machine(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    machine = manual_machine(tmp_path)
    Path("t1.ngc").write_text("T1 M6\nG0 X5\nM30\n")
    for pauses in ([{"line": 1, "says": "manual tool change (M6): put T1 in the spindle"}], []):
        code, _, err = run(capsys, "run", "t1.ngc", "--machine", "./mymill2.toml", "--report", "r.json")
        assert code == 0, err
        report = json.loads(Path("r.json").read_text())
        assert report["pauses"] == pauses and report["tool"]["end"] == 1
    assert json.loads((machine.parent / "mymill2.spindle-sim.json").read_text())["spindle_tool"] == 1


def recovery_command(err: str) -> list[str]:
    """The command the error message says to run, with n = 1, as a shell would split it."""
    found = re.search(r"(retrofit tool T<n> --recover .*)$", err.strip())       # the message's end
    assert found, err
    argv = shlex.split(found.group(1).replace("T<n>", "T1"))
    assert argv[0] == "retrofit"
    return argv[1:]


@pytest.mark.parametrize("given", ["./mymill2.toml", "my mill/mymill2.toml"])
def test_the_printed_recovery_works_for_a_manual_machine_given_by_path(tmp_path, capsys, monkeypatch,
                                                                       given):
    from retrofit.atc.state import spindle_store
    monkeypatch.chdir(tmp_path)
    (tmp_path / given).parent.mkdir(exist_ok=True)
    machine = manual_machine((tmp_path / given).parent)
    real_url = "parport:///dev/parport-none"
    _, store = spindle_store(load_machine(machine), "x", [real_url])
    store.begin(0, 1)                        # a run on the machine cut short during T1 M6
    Path("t1.ngc").write_text("T1 M6\nG0 X5\nM30\n")
    code, _, err = run(capsys, "run", "t1.ngc", "--machine", given, "--output", real_url)
    assert code == 2 and "was cut short" in err
    argv = recovery_command(err)
    assert argv[argv.index("--machine") + 1] == given                 # as it was given
    code, out, err = run(capsys, *argv)
    assert code == 0, err
    assert "T1 in the spindle" in out
    code, _, err = run(capsys, "run", "t1.ngc", "--machine", given, "--output", real_url)
    assert "cut short" not in err and "parport-none" in err       # the record is accepted; no such port
    code, out, _ = run(capsys, "tool", "--machine", str(machine), "--output", real_url)
    assert out.startswith("mymill2: T1 in the spindle"), out


def test_the_printed_recovery_works_for_a_changer_machine_given_by_path(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    changer_machine(tmp_path)
    (tmp_path / "mymill.spindle-sim.json").write_text("{not json")
    code, _, err = run(capsys, "tool", "T2", "--machine", "mymill.toml")
    assert code == 2 and "cannot be trusted" in err
    argv = recovery_command(err)
    assert argv[argv.index("--machine") + 1] == "mymill.toml"
    code, out, err = run(capsys, *argv)
    assert code == 0 and "recovery with T1 in the spindle" in out and "violations: 0" in out, err
    code, out, _ = run(capsys, "tool", "T2", "--machine", "mymill.toml")
    assert code == 0 and "T0 -> T2" in out


def test_a_manual_machine_is_not_changed_by_retrofit_tool(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    manual_machine(tmp_path)
    code, _, err = run(capsys, "tool", "T3", "--machine", "./mymill2.toml")
    assert code == 2 and "no tool changer" in err
    assert "retrofit tool T3 --recover --machine ./mymill2.toml" in err


def long_program(path: Path) -> Path:
    """T1 M6, then three million steps on the manual machine: the outputs' stage (the simulated
    machine decoding the frames) lasts about a second here, longer on a loaded computer."""
    moves = "".join(f"G1 X{190 if i % 2 else 0} Y{i % 7} F6000\n" for i in range(200))
    path.write_text("G21 G90\nT1 M6\n" + moves + "M30\n")
    return path


#: the progress bar shows every step it takes (tqdm's own settings), so a test can wait for one
EVERY_STEP = {"TQDM_MINITERS": "1", "TQDM_MININTERVAL": "0"}


def wait_for(proc, pattern: str, ceiling_s: float = 50.0) -> str:
    """Read the process's standard error until ``pattern`` shows; what was read."""
    seen, found = [], threading.Event()

    def read():
        while True:
            chunk = os.read(proc.stderr.fileno(), 4096)
            if not chunk:
                break
            seen.append(chunk.decode(errors="replace"))
            if re.search(pattern, "".join(seen)):
                found.set()
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    assert found.wait(ceiling_s), "".join(seen)
    return "".join(seen)


@pytest.mark.slow          # a run long enough to be interrupted past its half: a long run
def test_ctrl_c_in_a_simulated_run_leaves_a_record_the_next_run_accepts(tmp_path):
    manual_machine(tmp_path)
    program = long_program(tmp_path / "long.ngc")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", **EVERY_STEP)
    cmd = [sys.executable, "-m", "retrofit.cli", "run", str(program), "--machine", "./mymill2.toml"]
    proc = subprocess.Popen(cmd + ["--progress", "on", "--report", "r.json"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        # past half: the run, read ahead (its bar one stage, the share of the lines stepped), has
        # moved the machine after the tool change, with time left to interrupt on a busy computer
        wait_for(proc, r"\b([5-9]\d)%")
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130
    assert not (tmp_path / "r.json").exists()
    assert not list(tmp_path.glob("mymill2.spindle*.json"))       # no record: the spindle is empty
    again = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    assert "paused: manual tool change (M6): put T1 in the spindle" in " ".join(again.stdout.split())
