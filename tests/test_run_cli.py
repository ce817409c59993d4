"""`retrofit run`: part programs end to end, as the README's main command runs them."""

import json
import subprocess
import sys

import pytest

from retrofit.machine.config import load_machine


def retrofit(*args, cwd):
    return subprocess.run([sys.executable, "-m", "retrofit.cli", *args], capture_output=True, text=True, cwd=cwd)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def run_lathe_profile(tmp_path, *extra):
    proc = retrofit("run", "lathe-profile.ngc", "--machine", "chivu-lathe", "--output", "sim://",
                    "--plot", "lathe-profile.png", "--report", "lathe-profile.json", *extra, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    return proc, json.loads((tmp_path / "lathe-profile.json").read_text())


def test_readme_main_command_turns_the_profile_on_target(tmp_path, lathe):
    proc, rep = run_lathe_profile(tmp_path)
    assert (tmp_path / "lathe-profile.png").read_bytes()[:4] == b"\x89PNG"
    assert rep["violations"] == []
    for name, ax in rep["axes"].items():
        step = lathe.axis(name).step_mm
        assert abs(ax["carriage_mm"] - ax["target_mm"]) <= step + 1e-9
        assert ax["max_carriage_error_mm"] <= step + 1e-9
        assert ax["reversals"] > 0
    assert "lathe-profile.ngc" in proc.stdout


def test_profile_without_compensation_shows_the_dead_band(tmp_path, lathe):
    _, rep = run_lathe_profile(tmp_path, "--no-backlash-comp")
    for name, ax in rep["axes"].items():
        assert ax["max_carriage_error_mm"] >= lathe.sim.dead_band_mm[name] / 2


def test_reference_path_writes_the_same_report(tmp_path):
    program = tmp_path / "short.ngc"
    program.write_text("G21 G90\nG0 X2 Z1\nG1 F300 X1 Z-1\nG2 X0 Z-2 R1\nG0 X0 Z0\nM30\n")
    reports = []
    for extra in ([], ["--reference"]):
        proc = retrofit("run", str(program), "--report", "r.json", *extra, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        reports.append(json.loads((tmp_path / "r.json").read_text()))
    assert [r.pop("how") for r in reports] == ["fast path", "reference path"]
    assert reports[0] == reports[1]


def test_soft_limit_on_the_last_line_stops_everything_before_a_step(tmp_path):
    program = tmp_path / "too-far.ngc"
    program.write_text("G21 G90\nG0 X5 Z5\nG1 F200 X10 Z-20\nG1 X45\n")
    proc = retrofit("run", str(program), "--plot", "p.png", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == ""                                   # nothing ran, nothing was summarised
    assert "Traceback" not in proc.stderr and proc.stderr.strip().count("\n") == 0
    assert "too-far.ngc:4:" in proc.stderr and "soft limits" in proc.stderr
    assert not (tmp_path / "p.png").exists() and not (tmp_path / "r.json").exists()


def test_unknown_program_names_the_examples(tmp_path):
    proc = retrofit("run", "nope.ngc", cwd=tmp_path)
    assert proc.returncode == 2 and "lathe-profile.ngc" in proc.stderr


def test_engraving_runs_on_the_engraver(tmp_path):
    proc = retrofit("run", "engraving.ngc", "--machine", "engraver", "--report", "e.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rep = json.loads((tmp_path / "e.json").read_text())
    assert set(rep["axes"]) == {"X", "Y", "Z"} and rep["violations"] == []
    for ax in rep["axes"].values():
        assert abs(ax["carriage_mm"] - ax["target_mm"]) < 1e-9


def test_without_the_compiler_the_same_report(tmp_path):
    """Where Numba is absent the fast path falls back to NumPy and gives the same answer."""
    import os
    program = tmp_path / "short.ngc"
    program.write_text("G21 G90\nG0 X3 Z2\nG1 F400 X1 Z-4\nG3 X0 Z-5 R1\nG0 X0 Z0\nM30\n")
    reports = []
    for no_numba in ("", "1"):
        env = dict(os.environ, RETROFIT_NO_NUMBA=no_numba)
        proc = subprocess.run([sys.executable, "-c", "import sys, retrofit.motion._jit as j; "
                               "from retrofit.cli import main; print(j.HAVE_NUMBA, file=sys.stderr); "
                               "sys.exit(main(sys.argv[1:]))", "run", str(program), "--report", "r.json"],
                              capture_output=True, text=True, cwd=tmp_path, env=env)
        assert proc.returncode == 0, proc.stderr
        assert proc.stderr.strip().endswith(str(not no_numba))
        reports.append(json.loads((tmp_path / "r.json").read_text()))
    assert reports[0] == reports[1]
