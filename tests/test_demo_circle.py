"""The lathe paper's circle, end to end through sim://, as the README's first command runs it."""

import json
import subprocess
import sys

import pytest

from retrofit.machine.config import load_machine


def run_demo(tmp_path, *extra):
    png, report = tmp_path / "circle.png", tmp_path / "circle.json"
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "demo", "circle", "--machine", "chivu-lathe",
                           "--output", "sim://", "--plot", str(png), "--report", str(report), *extra],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    return proc, png, json.loads(report.read_text())


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def test_compensated_circle_ends_on_target_within_a_step(tmp_path, lathe):
    proc, png, rep = run_demo(tmp_path)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert rep["machine"] == "chivu-lathe" and rep["violations"] == []
    assert lathe.sim.dead_band_mm["X"] > 0 and lathe.sim.dead_band_mm["Z"] > 0   # the screws do have play
    for name, ax in rep["axes"].items():
        step = lathe.axis(name).step_mm
        assert abs(ax["carriage_mm"] - ax["target_mm"]) <= step + 1e-9
        assert ax["max_carriage_error_mm"] <= step + 1e-9
        assert ax["reversals"] >= 1
    assert rep["ticks"] > 0 and abs(rep["duration_s"] - rep["ticks"] * rep["tick_us"] * 1e-6) < 1e-6
    assert "circle" in proc.stdout and "violations: 0" in proc.stdout


def test_without_compensation_the_dead_band_shows(tmp_path, lathe):
    _, _, rep = run_demo(tmp_path, "--no-backlash-comp")
    for name, ax in rep["axes"].items():
        assert ax["max_carriage_error_mm"] >= lathe.sim.dead_band_mm[name] / 2


def test_report_has_the_documented_shape(tmp_path):
    _, _, rep = run_demo(tmp_path)
    assert set(rep) == {"machine", "tick_us", "ticks", "duration_s", "axes", "violations",
                        "max_following_error_steps"}
    assert set(rep["axes"]) == {"X", "Z"}
    for ax in rep["axes"].values():
        assert set(ax) == {"steps", "target_mm", "motor_mm", "carriage_mm", "reversals", "max_carriage_error_mm"}
        assert isinstance(ax["steps"], int) and isinstance(ax["reversals"], int)
    assert isinstance(rep["max_following_error_steps"], int)


def test_unknown_output_lists_known_schemes(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "demo", "circle", "--output", "parprot://"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2
    assert "unknown output 'parprot://'; known: " in proc.stderr and "sim" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_machines_lists_the_lathe():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "machines"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.startswith("chivu-lathe") or "chivu-lathe" in proc.stdout
