"""The cheating student: every way a submission once fooled `retrofit lab grade` is tried again,
and each scores no more than the untouched stub, while every other student keeps the grade its
own file deserves. Each class: the cheat, a right file, the stub and a wrong file, graded with
--jobs 2 (the cheat runs beside another student)."""

import csv
import json
import os
import textwrap
import time
from pathlib import Path

import pytest

from retrofit.lab.core import find_lab
from retrofit.lab.kit import Limits, grade, write_grades
from retrofit.lab.process import processes_of, sandbox_uid

from tests.test_lab_kit import CHECKS, RIGHT

ROOT = os.geteuid() == 0
SECRET = "teacher-only-7f3a"
STUB = "def add(a, b):\n    raise NotImplementedError('TODO 1: add')\n\ndef steps(n):\n    raise NotImplementedError('TODO 2')\n"
WRONG = RIGHT.replace("a + b", "a - b")
# what the honest students deserve, from the lab's design: 4 points in all, add is worth 2, steps 2
HONEST = {"b_right": (4, ""), "c_stub": (0, "TODO 1 TODO 2"), "d_wrong": (2, "TODO 1")}
FORGED = {"checks": [{"title": "=HYPERLINK(\"http://x\")", "todo": "TODO 1", "todos": ["TODO 1"], "status": "passed",
                      "message": "", "reason": "", "points": 1000, "max_points": 1}]}

# Each cheat is the stub plus an attack; {LAB}, {SUBS}, {OUT} are the real paths, as a student who
# had read the teacher's screen would know them.
CHEATS = {
    "os_exit_after_writing_a_result": '''
        import json, os, sys
        def _forge():
            paths = list(sys.argv)
            for pid in (os.getpid(), os.getppid()):
                try:
                    paths += open(f"/proc/{pid}/cmdline", "rb").read().decode().split("\\0")
                except OSError:
                    pass
            for p in paths:
                if p.endswith(".json"):
                    try:
                        open(p, "w").write(json.dumps(FORGED))
                    except OSError:
                        pass
            os._exit(0)
        def add(a, b):
            _forge()
        def steps(n):
            _forge()
    ''',
    "import_solution_py": '''
        import glob
        for path in [LAB + "/solution.py", *glob.glob("/tmp/retrofit-grade-*/labs/*/solution.py"), *glob.glob("/tmp/**/01_adder/solution.py", recursive=True)[:5]]:
            try:
                exec(open(path).read())
                break
            except OSError:
                pass
    ''',
    "copy_a_neighbour": '''
        import glob
        for path in sorted(glob.glob(SUBS + "/*/student.py")):
            try:
                text = open(path).read()
                if "a + b" in text and "glob" not in text:
                    exec(text)
            except OSError:
                pass
    ''',
    "monkeypatch_the_result_class": '''
        import retrofit.lab.core as L
        L.CheckResult.scored = property(lambda self: 1000)
        L.expect = lambda *a, **k: None
        class AlwaysEqual:
            def __eq__(self, other): return True
            def __ne__(self, other): return False
            def __len__(self): return 7
            def __iter__(self): return iter(range(7))
        def add(a, b): return AlwaysEqual()
        def steps(n): return AlwaysEqual()
    ''',
    "atexit_rewrites_the_result": '''
        import atexit, json, os, glob
        def _rewrite():
            for path in glob.glob("/tmp/retrofit-grade-*/students/*/result.json") + [OUT + "/grades.csv"]:
                try:
                    open(path, "w").write(json.dumps(FORGED))
                except OSError:
                    pass
        atexit.register(_rewrite)
    ''',
    "claims_1000_of_9_points": '''
        import retrofit.lab.core, retrofit.lab.grade
        retrofit.lab.grade.Grade.points = property(lambda self: 1000)
        retrofit.lab.core.CheckResult.as_dict = lambda self: FORGED["checks"][0]
        class Thousand(int):
            def __eq__(self, other): return True
        def add(a, b): return Thousand(1000)
        def steps(n): return Thousand(1000)
    ''',
    "rewrites_checks_py": '''
        import glob
        for path in [LAB + "/checks.py", *glob.glob("/tmp/retrofit-grade-*/labs/*/checks.py")]:
            try:
                open(path, "w").write("def test_nothing():\\n    pass\\n")
            except OSError:
                pass
    ''',
    "detached_grandchild_rewrites_grades": '''
        import os, time
        if os.fork() == 0:
            os.setsid()
            if os.fork() == 0:
                for _ in range(6000):
                    try:
                        text = open(OUT + "/grades.csv").read()
                        open(OUT + "/grades.csv", "w").write(text.replace(",0,4,", ",4,4,"))
                    except OSError:
                        pass
                    time.sleep(0.01)
            os._exit(0)
    ''',
    "reads_teacher_md_and_wrong": '''
        import glob
        leaked = []
        for path in [LAB + "/teacher.md", *glob.glob(LAB + "/wrong/*.py")]:
            try:
                leaked.append(open(path).read())
            except OSError:
                pass
        def add(a, b):
            raise NotImplementedError("TODO 1: " + " ".join(leaked))
    ''',
    "overwrites_a_later_students_file": '''
        import glob
        for path in glob.glob(SUBS + "/*/student.py"):
            if "c_stub" in path or "d_wrong" in path:
                try:
                    open(path, "w").write("def add(a, b):\\n    return 0\\n")
                except OSError:
                    pass
    ''',
    "blanks_a_concurrent_student": '''
        import os, signal, glob, time
        def _blank():
            for _ in range(300):
                for entry in os.listdir("/proc"):
                    if entry.isdigit() and int(entry) != os.getpid():
                        try:
                            os.kill(int(entry), signal.SIGKILL)
                        except OSError:
                            pass
                for path in glob.glob("/tmp/retrofit-*/**/result.json", recursive=True):
                    try:
                        open(path, "w").write("{}")
                    except OSError:
                        pass
                time.sleep(0.005)
        def add(a, b):
            _blank()
    ''',
    "cancels_its_timer": '''
        import signal
        for sig in (signal.SIGUSR1, signal.SIGALRM, signal.SIGPROF, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        def add(a, b):
            while True:
                try:
                    pass
                except BaseException:
                    pass
    ''',
    "kills_the_grader": '''
        import os, signal
        for target in (os.getppid(), 1):
            for kill in (os.kill, os.killpg):
                try:
                    kill(target, signal.SIGKILL)
                except OSError:
                    pass
        for entry in os.listdir("/proc"):
            if entry.isdigit() and int(entry) != os.getpid():
                try:
                    os.kill(int(entry), signal.SIGKILL)
                except OSError:
                    pass
    ''',
    "formula_in_a_title": '''
        import json, glob
        for path in glob.glob("/tmp/retrofit-grade-*/students/*/result.json"):
            try:
                open(path, "w").write(json.dumps(FORGED))
            except OSError:
                pass
        class Formula(Exception):
            pass
        def add(a, b):
            raise Formula("=HYPERLINK(\\"http://evil\\",\\"click\\")")
    ''',
}
NEEDS_ROOT = {"kills_the_grader", "blanks_a_concurrent_student", "detached_grandchild_rewrites_grades"}


def make_lab(root: Path) -> Path:
    lab = root / "labs" / "01_adder"
    (lab / "wrong").mkdir(parents=True)
    (lab / "README.md").write_text("# Adding\n", encoding="utf-8")
    (lab / "checks.py").write_text(CHECKS, encoding="utf-8")
    (lab / "solution.py").write_text(RIGHT, encoding="utf-8")
    (lab / "student.py").write_text(STUB, encoding="utf-8")
    (lab / "teacher.md").write_text(f"# Notes\n{SECRET}: add returns a + b\n", encoding="utf-8")
    (lab / "wrong" / "subtracts.py").write_text(f'"""{SECRET}"""\n' + WRONG, encoding="utf-8")
    return lab


def cheat_source(kind: str, lab: Path, subs: Path, out: Path) -> str:
    head = f"LAB = {str(lab)!r}\nSUBS = {str(subs)!r}\nOUT = {str(out)!r}\nFORGED = {FORGED!r}\n"
    return head + STUB + textwrap.dedent(CHEATS[kind])


@pytest.mark.parametrize("kind", sorted(CHEATS))
def test_a_cheat_scores_no_more_than_the_stub_and_changes_no_one_elses_grade(kind, tmp_path):
    if kind in NEEDS_ROOT and not ROOT:
        pytest.skip("as the grader's own user a submission can signal the grader: see docs/teachers.md")
    kinds = [kind]
    lab_path, subs, out = make_lab(tmp_path), tmp_path / "class", tmp_path / "out"
    out.mkdir()
    sources = {f"a_{kind}": cheat_source(kind, lab_path, subs, out) for kind in kinds}
    sources.update({"b_right": RIGHT, "c_stub": STUB, "d_wrong": WRONG})
    for name, text in sources.items():
        (subs / name).mkdir(parents=True)
        (subs / name / "student.py").write_text(text, encoding="utf-8")
    checks_before = (lab_path / "checks.py").read_bytes()
    lab = find_lab(lab_path.parent, "01")
    limits = Limits(cpu_seconds=20, memory_mb=1024, check_seconds=1.0, wall_seconds=120)
    grades = grade(lab, subs, limits, jobs=2, hide=(out,))
    write_grades(grades, lab, out / "grades.csv", out / "grades.json")
    if ROOT:
        assert not [p for slot in range(2) for p in processes_of(sandbox_uid(slot))], "a student's process outlived grading"
    time.sleep(0.5)                          # a surviving writer would have struck by now
    rows = {r["student"]: r for r in csv.DictReader((out / "grades.csv").open(encoding="utf-8"))}
    assert set(rows) == set(sources)
    for name, (points, failed) in HONEST.items():
        assert (int(rows[name]["points"]), rows[name]["max_points"], rows[name]["failed"]) == (points, "4", failed), rows
    for kind in kinds:
        row = rows[f"a_{kind}"]
        assert int(row["points"]) <= int(rows["c_stub"]["points"]) and row["max_points"] == "4", (kind, row)
    assert (lab_path / "checks.py").read_bytes() == checks_before
    assert all((subs / n / "student.py").read_text(encoding="utf-8") == t for n, t in sources.items())
    text = (out / "grades.csv").read_text(encoding="utf-8") + (out / "grades.json").read_text(encoding="utf-8")
    assert SECRET not in text
    cells = [c for r in csv.reader((out / "grades.csv").open(encoding="utf-8")) for c in r]
    assert not [c for c in cells if c[:1] in ("=", "+", "-", "@", "\t", "\r")], cells
    if "cancels_its_timer" in kinds:
        data = json.loads((out / "grades.json").read_text(encoding="utf-8"))["students"]
        cheat = next(s for s in data if s["student"] == "a_cancels_its_timer")
        assert cheat["todos"]["TODO 1"] == "timeout", cheat["todos"]      # it ignored the signal asking where


def test_student_names_and_messages_that_look_like_formulas_are_text_in_the_csv(tmp_path):
    lab_path, subs = make_lab(tmp_path), tmp_path / "class"
    names = ["=1+2", "-3+4", "@cmd"]
    for name in names:
        (subs / name).mkdir(parents=True)
        (subs / name / "student.py").write_text(
            "def add(a, b):\n    raise ValueError('=HYPERLINK(1)')\n" + RIGHT.split("\n\n", 1)[1], encoding="utf-8")
    lab = find_lab(lab_path.parent, "01")
    grades = grade(lab, subs, Limits(check_seconds=2.0), jobs=2)
    write_grades(grades, lab, tmp_path / "grades.csv", tmp_path / "grades.json")
    rows = list(csv.reader((tmp_path / "grades.csv").open(encoding="utf-8")))
    assert sorted(r[0] for r in rows[1:]) == sorted("'" + n if n[0] in "=+-@" else n for n in names)
    assert all(int(r[1]) == 2 for r in rows[1:])             # steps right, add raises
    header = rows[0]
    reasons = [r[header.index("TODO 1")] for r in rows[1:]]
    assert all(reason == "raised ValueError at line 2" for reason in reasons), reasons
