"""A class graded with --jobs 2 while some students' code fights the grader: right, wrong, an
endless loop, a fork storm, a 1 GB write and a grader-killer. Every honest student gets the
grade its file deserves, the others no more than theirs, and the grader finishes."""

import csv
import json
import os
import textwrap
from pathlib import Path

import pytest

from retrofit.lab.core import find_lab
from retrofit.lab.kit import Limits, grade, write_grades
from retrofit.lab.process import processes_of, sandbox_uid

from tests.test_lab_grader_attacks import CHEATS, make_lab
from tests.test_lab_kit import KINDS, RIGHT

ROOT = os.geteuid() == 0
FORK_STORM = '''import os
for _ in range(400):
    try:
        os.fork()
    except OSError:
        break
'''
ONE_GB = '''with open("big.bin", "wb") as out:
    for _ in range(1024):
        out.write(bytes(1 << 20))
'''
SOURCES = {
    "right": RIGHT,
    "wrong": KINDS["wrong"][0],
    "endless": KINDS["endless"][0],
    "forkstorm": FORK_STORM + RIGHT,
    "onegb": ONE_GB + RIGHT,
    "killer": textwrap.dedent(CHEATS["kills_the_grader"]) + RIGHT,
}
# what each honest submission deserves, from the lab's design (add: 2 points, steps: 2 points)
HONEST = {"right": (4, ""), "wrong": (2, "TODO 1"), "endless": (2, "TODO 2")}


def grade_class(tmp_path: Path, per_kind: int):
    lab_path = make_lab(tmp_path)
    kinds = [k for k in SOURCES if ROOT or k != "killer"]     # as the grader's own user: see docs/teachers.md
    names = {}
    for i in range(per_kind * len(kinds)):
        kind = kinds[i % len(kinds)]
        folder = tmp_path / "class" / f"s{i:02d}_{kind}"
        folder.mkdir(parents=True)
        (folder / "student.py").write_text(SOURCES[kind], encoding="utf-8")
        names[folder.name] = kind
    lab = find_lab(lab_path.parent, "01")
    limits = Limits(cpu_seconds=20, memory_mb=1024, check_seconds=1.0, wall_seconds=120, processes=32)
    grades = grade(lab, tmp_path / "class", limits, jobs=2)
    write_grades(grades, lab, tmp_path / "grades.csv", tmp_path / "grades.json")
    if ROOT:
        assert not [p for slot in range(2) for p in processes_of(sandbox_uid(slot))]
    rows = {r["student"]: r for r in csv.DictReader((tmp_path / "grades.csv").open(encoding="utf-8"))}
    assert sorted(rows) == sorted(names)
    lines = SOURCES["endless"].splitlines()
    loop = {f"timeout at line {1 + lines.index(text)}" for text in ("    while True:", "        n += 1")}
    data = {s["student"]: s for s in json.loads((tmp_path / "grades.json").read_text(encoding="utf-8"))["students"]}
    for name, kind in names.items():
        row = rows[name]
        assert row["max_points"] == "4", row
        if kind in HONEST:
            assert (int(row["points"]), row["failed"], row["note"]) == (*HONEST[kind], ""), row
        else:
            assert 0 <= int(row["points"]) <= 4, row
        if kind == "endless":
            todos = data[name]["todos"]
            assert todos["TODO 1"] == "ok" and todos["TODO 2"] in loop, todos
        if kind == "onegb":              # stopped at the file-size limit (or the small /tmp) while importing
            assert int(row["points"]) == 0 and row["TODO 1"].startswith("did not import"), row
            assert not list((tmp_path / "class" / name).glob("big.bin"))
        if kind == "killer" and ROOT:    # it could kill nothing of anyone else's; its own code is right
            assert int(row["points"]) == 4, row
    return rows


def test_a_class_of_six_with_jobs_2(tmp_path):
    grade_class(tmp_path, per_kind=1)


@pytest.mark.slow
def test_a_class_of_thirty_with_jobs_2(tmp_path):
    rows = grade_class(tmp_path, per_kind=5)
    assert len(rows) == (30 if ROOT else 25)
