"""Lab 10 (G-code to motion): the recorded moves are LinuxCNC's, re-made when rs274 is installed (the
lab's wrong/ and right/ variants are checked in tests/test_lab_wrong_solutions.py)."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from retrofit.lab.core import find_lab

LAB = find_lab(Path(__file__).resolve().parent.parent / "labs", "10")


@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
def test_recorded_moves_are_what_rs274_gives_today(tmp_path):
    for program in sorted((LAB.path / "programs").glob("*.ngc")):
        out = subprocess.run(["rs274", "-g", str(program)], capture_output=True, text=True, timeout=60).stdout
        moves = [line for line in out.splitlines() if re.search(r"STRAIGHT_|SET_FEED_RATE", line)]
        recorded = program.with_suffix(".canon").read_text(encoding="utf-8").splitlines()
        strip = lambda lines: [re.sub(r"^\s*\d+ N\.+ ", "", line) for line in lines]   # noqa: E731
        assert strip(moves) == strip(recorded), program.name
