"""Feeds above the machine's fastest run at the fastest, with one warning line (as LinuxCNC)."""

from __future__ import annotations

import subprocess
import sys

from retrofit.commands import PFdr
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine("grenoble-mill")          # X Y Z at 50 mm/s: 3000 mm/min


def _feeds(program) -> list[float]:
    return [c.feed for c in program.commands if isinstance(c, PFdr)]


def test_a_feed_above_the_machines_fastest_runs_at_the_fastest_with_one_warning():
    prog = compile_program("G1 X1 F[10000*225]\nG1 X2 F5000\nG1 X3 F100\nG20\nG1 X0.2 F200\nM2\n",
                           MILL, file="chips.ngc")
    assert _feeds(prog) == [3000.0, 100.0, 3000.0]       # F200 in/min is 5080 mm/min
    warnings = [m for m in prog.messages if m[2] == "WARNING"]
    assert len(warnings) == 1 and warnings[0][:2] == ("chips.ngc", 1)
    assert "3000 mm/min" in warnings[0][3] and "F2.25e+06" in warnings[0][3]


def test_a_feed_within_the_machine_is_kept_and_says_nothing():
    prog = compile_program("G1 X1 F2999\nM2\n", MILL)
    assert _feeds(prog) == [2999.0] and prog.messages == []


def test_retrofit_run_prints_the_warning_line_once(tmp_path):
    path = tmp_path / "fast.ngc"
    path.write_text("G1 X1 F90000\nG1 X2 F80000\nM2\n")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", str(path), "--machine",
                           "grenoble-mill"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if "warning" in ln]
    assert lines == ["fast.ngc:1: warning: F90000 is above machine grenoble-mill's fastest feed "
                     "3000 mm/min: feeds run at 3000 mm/min (said once)"]
