"""The teacher's kit: a hang in a check is one line naming its TODO; ``lab check --json`` gives one
result per check; ``lab export`` leaves the solution out; ``lab grade`` grades a class folder of
right, wrong, endless and broken submissions into a CSV and a JSON, each under process limits."""

import ast
import csv
import json
import re
from pathlib import Path

import pytest

from retrofit.cli import main
from retrofit.errors import ConfigError
from retrofit.lab.core import CHECK_SECONDS_ENV, check_lab, find_lab, list_labs
from retrofit.lab.kit import Limits, export_lab, grade, write_grades
from retrofit.lab.wrong import apply_variant, variants

from tests import soak

ROOT = Path(__file__).resolve().parent.parent / "labs"
LABS = list_labs(ROOT)
IDS = [lab.path.name for lab in LABS]

# A small lab with the house's layout, so that grading 30 students costs little per process.
CHECKS = '''
"""Checks of the adder lab."""
import pytest
from retrofit.lab.core import expect, load_target

@pytest.fixture(scope="module")
def lab():
    return load_target(__file__)

def test_adds(lab):
    """TODO 1: add(2, 3) is 5"""
    expect(lab.add(2, 3) == 5, "add(2, 3)", expected=5, got=lab.add(2, 3))

def test_adds_negative(lab):
    """TODO 1: add(-2, -3) is -5"""
    expect(lab.add(-2, -3) == -5, "add(-2, -3)", expected=-5, got=lab.add(-2, -3))

@pytest.mark.points(2)
def test_steps(lab):
    """TODO 2: steps(7) counts 0..6"""
    expect(lab.steps(7) == list(range(7)), "steps(7)", expected=list(range(7)), got=lab.steps(7))
'''
RIGHT = "def add(a, b):\n    return a + b\n\ndef steps(n):\n    return list(range(n))\n"
KINDS = {
    "right": (RIGHT, 4, ""),
    "wrong": (RIGHT.replace("a + b", "a - b"), 2, "TODO 1"),             # add wrong, steps right
    "endless": (RIGHT.replace("return list(range(n))", "while True:\n        n += 1"), 2, "TODO 2"),
    "syntax": (RIGHT.replace("def steps(n):", "def steps(n)"), 0, "TODO 1 TODO 2"),
}


def make_lab(root: Path) -> Path:
    lab = root / "labs" / "01_adder"
    lab.mkdir(parents=True)
    (lab / "README.md").write_text("# Adding\n", encoding="utf-8")
    (lab / "checks.py").write_text(CHECKS, encoding="utf-8")
    (lab / "solution.py").write_text(RIGHT, encoding="utf-8")
    (lab / "student.py").write_text("def add(a, b):\n    raise NotImplementedError('TODO 1')\n", encoding="utf-8")
    return lab.parent


def make_class(root: Path, count: int) -> dict[str, str]:
    """``count`` student folders cycling through the kinds; returns student -> kind."""
    kinds, names = list(KINDS), {}
    for i in range(count):
        kind = kinds[i % len(kinds)]
        folder = root / f"student{i:02d}"
        folder.mkdir(parents=True)
        (folder / "student.py").write_text(KINDS[kind][0], encoding="utf-8")
        names[folder.name] = kind
    return names


def test_an_endless_loop_is_one_line_naming_its_todo(tmp_path, monkeypatch):
    lab = find_lab(make_lab(tmp_path), "01")
    target = tmp_path / "endless.py"
    target.write_text(KINDS["endless"][0], encoding="utf-8")
    monkeypatch.setenv(CHECK_SECONDS_ENV, "0.5")
    results = check_lab(lab, target=target)
    assert [r.status for r in results] == ["passed", "passed", "failed"]
    message = results[2].message
    assert message.startswith("TODO 2: steps(7) counts 0..6: did not finish within 0.5 s")
    assert re.search(r"it was running endless.py line [56], in steps", message) and "\n" not in message


def test_a_loop_at_module_level_is_stopped_too(tmp_path, monkeypatch):
    lab = find_lab(make_lab(tmp_path), "01")
    target = tmp_path / "hang.py"
    target.write_text("while True:\n    pass\n" + RIGHT, encoding="utf-8")
    monkeypatch.setenv(CHECK_SECONDS_ENV, "0.3")
    results = check_lab(lab, target=target)
    assert results and all(r.status == "failed" and "did not finish within 0.3 s" in r.message for r in results)


def test_check_json_gives_status_todo_message_and_points(tmp_path, capsys):
    labs = make_lab(tmp_path)
    wrong = tmp_path / "wrong.py"
    wrong.write_text(KINDS["wrong"][0], encoding="utf-8")
    assert main(["lab", "check", "01", "--labs", str(labs), "--file", str(wrong), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert [(c["todo"], c["status"], c["points"], c["max_points"]) for c in data["checks"]] == [
        ("TODO 1", "failed", 0, 1), ("TODO 1", "failed", 0, 1), ("TODO 2", "passed", 2, 2)]
    assert "expected: 5" in data["checks"][0]["message"] and "your code gave: -1" in data["checks"][0]["message"]
    assert (data["points"], data["max_points"]) == (2, 4)


def _todo_functions(path: Path) -> set[str]:
    """Names of the functions and methods the stub leaves to the student (they raise NotImplementedError)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and any(
                isinstance(n, ast.Raise) and "NotImplementedError" in ast.unparse(n) for n in ast.walk(node)):
            names.add(node.name)
    return names


def _solution_bodies(solution: Path, student: Path) -> list[str]:
    """Every run of three code lines in the bodies of the functions the student writes (not in the stub)."""
    todo, shared = _todo_functions(student), set(student.read_text(encoding="utf-8").splitlines())
    text = solution.read_text(encoding="utf-8")
    lines, bodies = text.splitlines(), []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in todo:
            start = node.body[0].lineno + isinstance(node.body[0], ast.Expr)     # after the docstring
            code = [_code(line) for line in lines[start - 1:node.end_lineno] if line not in shared]
            code = [c for c in code if c]
            bodies += ["\n".join(code[i:i + 3]) for i in range(len(code) - 2)]
    return bodies


def _code(line: str) -> str:
    """A line without its indent and comment."""
    return line.split("  #")[0].strip() if not line.strip().startswith("#") else ""


# a lab listed here fails the export check as expected (strict: the mark must go once the lab's
# exported files stop showing solution code); none does today
LEAKS: dict[str, str] = {}          # a lab whose exported files show solution code: name -> where
EXPORT_CASES = [pytest.param(lab, id=lab.path.name, marks=[pytest.mark.xfail(reason=LEAKS[lab.path.name], strict=True)]
                             if lab.path.name in LEAKS else []) for lab in LABS]


@pytest.mark.parametrize("lab", EXPORT_CASES)
def test_export_holds_no_solution_code(lab, tmp_path):
    written = export_lab(lab, tmp_path)
    names = {p.relative_to(tmp_path).as_posix() for p in written}
    assert f"{lab.path.name}/student.py" in names and f"{lab.path.name}/checks.py" in names
    assert f"{lab.path.name}/README.md" in names
    assert not any(n.endswith(("solution.py", "teacher.md")) or "/wrong/" in n or "/right/" in n for n in names), names
    bodies = _solution_bodies(lab.path / "solution.py", lab.path / "student.py")
    assert len(bodies) >= 3, f"{lab.path.name}: the solution should differ from the stub"
    code = (_code(line) for p in written for line in p.read_text(encoding="utf-8", errors="replace").splitlines())
    exported = "\n".join(line for line in code if line)
    leaked = [b for b in bodies if b in exported]
    assert not leaked, f"solution lines found in the export: {leaked[:3]}"


def test_exported_lab_is_checked_from_its_own_folder(tmp_path, capsys):
    assert main(["lab", "export", "01", str(tmp_path)]) == 0
    assert "01_circle/student.py" in capsys.readouterr().out
    assert main(["lab", "check", "01", "--labs", str(tmp_path), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert data["file"] == str(tmp_path / "01_circle" / "student.py")
    assert data["checks"] and all(c["status"] == "failed" for c in data["checks"][:2])
    assert data["checks"][0]["message"].startswith("not written yet: TODO 1")


def test_export_into_the_labs_folder_is_refused():
    with pytest.raises(ConfigError, match="labs folder itself"):
        export_lab(LABS[0], ROOT)


def _expected_row(kind):
    source, points, failed = KINDS[kind]
    return points, failed


def _grade_and_compare(tmp_path, count, jobs):
    labs = make_lab(tmp_path)
    names = make_class(tmp_path / "class", count)
    lab = find_lab(labs, "01")
    limits = Limits(cpu_seconds=30, memory_mb=1024, check_seconds=1.0, wall_seconds=120)
    grades = grade(lab, tmp_path / "class", limits, jobs=jobs)
    write_grades(grades, lab, tmp_path / "grades.csv", tmp_path / "grades.json")
    rows = list(csv.DictReader((tmp_path / "grades.csv").open(encoding="utf-8")))
    assert [r["student"] for r in rows] == sorted(names)
    for row in rows:
        points, failed = _expected_row(names[row["student"]])
        assert (int(row["points"]), row["max_points"], row["failed"]) == (points, "4", failed), row
    data = json.loads((tmp_path / "grades.json").read_text(encoding="utf-8"))
    endless = next(s for s in data["students"] if names[s["student"]] == "endless")
    assert "TODO 2: steps(7) counts 0..6: did not finish within 1 s" in endless["checks"][2]["message"]
    syntax = next(s for s in data["students"] if names[s["student"]] == "syntax")
    assert "line 4 does not read as Python" in syntax["checks"][0]["message"]
    return rows


def test_grade_four_students_one_of_each_kind(tmp_path):
    _grade_and_compare(tmp_path, 4, jobs=2)


def test_grade_notes_a_missing_file_and_a_memory_hog(tmp_path):
    labs = make_lab(tmp_path)
    (tmp_path / "class" / "empty").mkdir(parents=True)
    hog = tmp_path / "class" / "hog"
    hog.mkdir()
    (hog / "student.py").write_text("BIG = bytearray(8 * 1024 ** 3)\n" + RIGHT, encoding="utf-8")
    grades = grade(find_lab(labs, "01"), tmp_path / "class", Limits(memory_mb=1024, check_seconds=5), jobs=2)
    by_name = {g.student: g for g in grades}
    assert by_name["empty"].note == "no student.py handed in" and by_name["empty"].points == 0
    assert by_name["hog"].points == 0
    assert all("MemoryError" in c["message"] for c in by_name["hog"].checks), by_name["hog"].checks


def test_grade_on_the_command_line_writes_csv_and_json(tmp_path, capsys):
    labs = make_lab(tmp_path)
    make_class(tmp_path / "class", 2)
    assert main(["lab", "grade", "01", str(tmp_path / "class"), "--labs", str(labs), "--out",
                 str(tmp_path / "out"), "--check-seconds", "1", "--jobs", "2"]) == 0
    out = capsys.readouterr().out
    assert "student00              4 / 4" in out and "student01              2 / 4   TODO 1" in out
    assert (tmp_path / "out" / "grades.csv").is_file() and (tmp_path / "out" / "grades.json").is_file()


def test_grade_an_empty_folder_is_an_error(tmp_path, capsys):
    make_lab(tmp_path)
    (tmp_path / "class").mkdir()
    assert main(["lab", "grade", "01", str(tmp_path / "class"), "--labs", str(tmp_path / "labs")]) == 2
    assert "no student folders" in capsys.readouterr().err


@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_teacher_notes_have_objectives_time_key_and_rubric(lab):
    text = (lab.path / "teacher.md").read_text(encoding="utf-8")
    for heading in ("## Learning objectives", "## Prerequisites", "## Expected time", "## Answer key",
                    "## Marking rubric"):
        assert heading in text, f"{lab.path.name}/teacher.md has no {heading}"
    key = text.split("## Answer key")[1].split("## Marking rubric")[0]
    assert sum(ch.isdigit() for ch in key) >= 6, "the answer key gives the expected numbers"


def _first_wrong(lab):
    """Lab 10's first 14 known-wrong variants (w01..w14), the class's wrong students."""
    return [v for v in variants(lab.path, "wrong") if re.match(r"w\d\d_", v.name)]


def _class_of_thirty(lab) -> dict[str, tuple[str, str]]:
    """30 submissions of lab 10: student -> (kind, text). 8 copies of the reference, every one of its
    14 known-wrong files (4 of them twice), 2 endless loops in interpret() and 2 files that do not parse."""
    solution = lab.file(solution=True).read_text(encoding="utf-8")
    wrong = _first_wrong(lab)
    endless = solution.replace("    for line in text.splitlines():", "    while True:\n        pass\n    for line in text.splitlines():")
    broken = solution.replace("def target(state: State, words: dict[str, float])", "def target(state: State, words")
    students = {}
    for i in range(30):
        kind = ("right", "wrong", "endless", "syntax")[i % 4] if i < 8 else ("wrong" if i < 24 else "right")
        text = {"right": solution, "endless": endless, "syntax": broken}.get(kind)
        if kind == "wrong":
            source = wrong[i % len(wrong)]
            text, kind = apply_variant(source, solution), f"wrong:{source.name}"
        students[f"s{i:02d}"] = (kind, text)
    return students


# the slowest check of the reference (the first to run interpret(), importing the interpreter) takes
# 0.2-0.3 s of processor time, and the limit counts processor time, not the wall clock, so a loaded
# machine does not stretch it: 2 s is seven times that. Each endless student hangs 6 checks: 12 s.
CLASS_CHECK_SECONDS = 2.0
CLASS_PARTS = 5                     # 6 students a part, the two endless ones in different parts


@pytest.mark.slow
@pytest.mark.parametrize("part", soak.parts(CLASS_PARTS, 2))     # CI: 2 of the 5 parts (tests/soak.py)
def test_grade_a_class_of_thirty_on_lab_10(part, tmp_path):
    """30 submissions of a real lab, graded in 5 parts of 6 (every 5th student): the reference, its
    14 known-wrong files, endless loops and files that do not parse; every row of the CSV says what
    that submission deserves."""
    lab = find_lab(ROOT, "10")
    students = _class_of_thirty(lab)
    kinds = {name: kind for i, (name, (kind, _)) in enumerate(students.items()) if i % CLASS_PARTS == part}
    for name in kinds:
        folder = tmp_path / "class" / name
        folder.mkdir(parents=True)
        (folder / "student.py").write_text(students[name][1], encoding="utf-8")
    limits = Limits(cpu_seconds=60, memory_mb=2048, check_seconds=CLASS_CHECK_SECONDS, wall_seconds=240)
    grades = grade(lab, tmp_path / "class", limits, jobs=2)
    write_grades(grades, lab, tmp_path / "grades.csv", tmp_path / "grades.json")
    rows = {r["student"]: r for r in csv.DictReader((tmp_path / "grades.csv").open(encoding="utf-8"))}
    assert sorted(rows) == sorted(kinds) and len(rows) == 6
    data = json.loads((tmp_path / "grades.json").read_text(encoding="utf-8"))
    full = sum(c["max_points"] for c in data["students"][0]["checks"])
    for name, kind in kinds.items():
        row, points = rows[name], int(rows[name]["points"])
        assert int(row["max_points"]) == full, row
        if kind == "right":
            assert (points, row["failed"], row["note"]) == (full, "", ""), json.dumps(
                [c for c in data["students"] if c["student"] == name])
        elif kind == "syntax":
            assert points == 0 and row["failed"] == "TODO 1 TODO 2 TODO 3 TODO 4", row
        elif kind == "endless":                  # only the checks of interpret() hang
            assert row["failed"] == "TODO 4" and 0 < points < full, row
        else:
            todo = f"TODO {next(v.todo for v in _first_wrong(lab) if v.name == kind[6:])}"
            assert todo in row["failed"].split(" TODO ") or todo in row["failed"], (kind, row)
            assert points < full, row
    hung = [c for s in data["students"] if kinds[s["student"]] == "endless" for c in s["checks"]
            if c["status"] == "failed"]
    within = f"did not finish within {CLASS_CHECK_SECONDS:g} s"
    assert all(within in c["message"] and "in interpret" in c["message"] for c in hung)
    assert ("endless" in kinds.values()) == bool(hung)


def test_the_class_of_thirty_covers_every_kind_and_every_wrong_file():
    """The 5 parts above together grade 30 students: each known-wrong file, both hangs, both parse errors."""
    lab = find_lab(ROOT, "10")
    students = _class_of_thirty(lab)
    kinds = [kind for kind, _ in students.values()]
    assert len(students) == 30 and kinds.count("right") == 8
    assert (kinds.count("endless"), kinds.count("syntax")) == (2, 2)
    assert {k[6:] for k in kinds if k.startswith("wrong:")} == {v.name for v in _first_wrong(lab)}
    parts = [{kinds[i] for i in range(part, 30, CLASS_PARTS)} for part in range(CLASS_PARTS)]
    assert sum("endless" in p for p in parts) == 2
