"""Lab 10 (G-code to motion): the reference passes every check, and every known-wrong solution in
wrong/ fails at least one, with the TODO the mistake belongs to among the failed checks; the
recorded moves are LinuxCNC's, re-made when rs274 is installed."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from retrofit.labs import check_lab, find_lab, result_lines

LAB = find_lab(Path(__file__).resolve().parent.parent / "labs", "10")
WRONG = sorted((LAB.path / "wrong").glob("*.py"))


def _todo(path):
    return re.search(r"known-wrong solution \(TODO (\d)", path.read_text(encoding="utf-8"))[1]


def test_at_least_ten_known_wrong_solutions_touching_every_todo():
    assert len(WRONG) >= 10 and {_todo(p) for p in WRONG} == {"1", "2", "3", "4"}


@pytest.mark.parametrize("wrong", WRONG, ids=[p.stem for p in WRONG])
def test_known_wrong_solution_is_caught(wrong):
    results = check_lab(LAB, target=wrong)
    failed = [r for r in results if r.status == "failed"]
    assert failed, f"{wrong.name} passes every check:\n" + "\n".join(result_lines(results))
    assert f"TODO {_todo(wrong)}" in {r.todo for r in failed}, "\n".join(result_lines(results))


@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
def test_recorded_moves_are_what_rs274_gives_today(tmp_path):
    for program in sorted((LAB.path / "programs").glob("*.ngc")):
        out = subprocess.run(["rs274", "-g", str(program)], capture_output=True, text=True, timeout=60).stdout
        moves = [line for line in out.splitlines() if re.search(r"STRAIGHT_|SET_FEED_RATE", line)]
        recorded = program.with_suffix(".canon").read_text(encoding="utf-8").splitlines()
        strip = lambda lines: [re.sub(r"^\s*\d+ N\.+ ", "", line) for line in lines]   # noqa: E731
        assert strip(moves) == strip(recorded), program.name
