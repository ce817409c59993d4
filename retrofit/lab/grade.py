"""Grade a class: every student's file checked by the lab's checks, the student's code in a sandbox,
the checks and the score in the grader's processes; grades.csv and grades.json written at the end.

How one class is graded (:func:`grade`):

1. every student's ``student.py`` is read, and the lab copied, into a private folder (mode 0700)
   before any student's code runs, so no submission can change another's or the checks;
2. each student is checked by a process of its own (``python -m retrofit.lab.grade``) running the
   copied checks; the student's code runs in a sandbox below it (:mod:`retrofit.lab.proxy`), as a
   uid of its own when the grader is root, with the limits of :class:`Limits`;
3. when that student is done, every process of the student's uid is killed; when the class is
   done and none is left, the grades are written, each file whole or not at all.
"""

from __future__ import annotations

import json
import os
import queue
import select
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ConfigError
from .process import Sandbox, become_subreaper, kill_children, kill_group, processes_of, sandbox_uid, sweep_uid

STATUSES = ("passed", "failed", "skipped")


@dataclass
class Limits:
    """What one submission may use: CPU seconds, memory (MiB), per-check seconds, wall seconds,
    processes and the size of a file it writes (MiB)."""

    cpu_seconds: int = 120
    memory_mb: int = 2048
    check_seconds: float = 20.0
    wall_seconds: float = 300.0
    processes: int = 64
    file_mb: int = 64


@dataclass
class Grade:
    """One student's result: the checks, the points, and a note when the run itself failed."""

    student: str
    checks: list[dict] = field(default_factory=list)
    note: str = ""
    max_points: int = 0             # the grader's own count: what the lab's checks are worth

    @property
    def points(self) -> int:
        earned = sum(min(c["points"], c["max_points"]) for c in self.checks if c["status"] == "passed")
        return min(earned, self.max_points)

    def failed_todos(self) -> list[str]:
        """The TODOs with a failed check, each once, in order."""
        todos = [t for c in self.checks if c["status"] == "failed" for t in (c.get("todos") or [c["title"]])]
        return list(dict.fromkeys(todos))

    def todo_reasons(self) -> dict[str, str]:
        """Per TODO: why its first failed check failed (wrong value, timeout at line 6, ...), or ok."""
        reasons: dict[str, str] = {}
        for c in self.checks:
            for todo in c.get("todos") or []:
                if c["status"] == "failed" and reasons.get(todo, "ok") == "ok":
                    reasons[todo] = c.get("reason") or "failed"
                reasons.setdefault(todo, "ok")
        return reasons


def submission_file(folder: Path) -> Path | None:
    """The file a student handed in: ``student.py`` in the folder (or in one folder below)."""
    for candidate in (folder / "student.py", *sorted(folder.glob("*/student.py"))):
        if candidate.is_file() and not candidate.is_symlink():
            return candidate
    return None


def grade(lab, submissions: str | Path, limits: Limits | None = None, jobs: int = 1,
          hide: tuple = ()) -> list[Grade]:
    """Grade every folder in ``submissions`` (one per student, sorted by name).

    ``hide``: more folders the students' code must not see (the folder the grades go to).
    """
    root = Path(submissions).resolve()
    if not root.is_dir():
        raise ConfigError(f"{root}: no such folder; give a folder holding one folder per student")
    folders = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not folders:
        raise ConfigError(f"{root}: no student folders in it; put each student's student.py in a folder "
                          "named after the student")
    limits, jobs = limits or Limits(), max(1, min(int(jobs), 64))
    handed_in = {}
    for folder in folders:                     # every file read before any student's code runs
        path = submission_file(folder)
        handed_in[folder.name] = path.read_bytes() if path is not None else None
    private = Path(tempfile.mkdtemp(prefix="retrofit-grade-"))
    try:
        lab_copy = _copy_lab(lab, private)
        most = count_points(lab_copy)
        hidden = sorted({str(Path(lab.path).resolve().parent), str(root), *(str(Path(h).resolve()) for h in hide)})
        checkers = [_Checker(slot, lab_copy, private, limits, hidden) for slot in range(jobs)]
        _preflight(lab_copy, private, checkers[0].box)
        slots: queue.Queue = queue.Queue()
        for checker in checkers:
            slots.put(checker)

        def one(item):
            index, (name, data) = item
            checker = slots.get()
            try:
                return _grade_one(name, data, index, checker, private, limits, most)
            finally:
                slots.put(checker)
        try:
            with ThreadPoolExecutor(max_workers=jobs) as pool:
                grades = list(pool.map(one, enumerate(handed_in.items())))
        finally:
            for checker in checkers:
                checker.close()
        _all_gone([sandbox_uid(slot) for slot in range(jobs)])
        return grades
    finally:
        shutil.rmtree(private, ignore_errors=True)


def _copy_lab(lab, private: Path) -> Path:
    """The lab (checks, data, the teacher's files the checks may use) copied where no student reaches."""
    target = private / "labs" / lab.path.name
    shutil.copytree(lab.path, target, ignore=shutil.ignore_patterns("__pycache__", "out", ".ipynb_checkpoints"))
    ini = Path(lab.path).parent / "pytest.ini"
    if ini.is_file():
        shutil.copyfile(ini, private / "labs" / "pytest.ini")
    os.chmod(private, 0o700)
    return target


def count_points(lab_path: Path) -> int:
    """What the lab's checks are worth, counted here by collecting them (never by a student's run)."""
    import pytest

    from .core import _QUIET, _forget_checks

    class Count:
        points = checks = 0

        def pytest_collection_modifyitems(self, items):
            for item in items:
                marker = item.get_closest_marker("points")
                Count.points += int(marker.args[0]) if marker and marker.args else 1
                Count.checks += 1
    _forget_checks()
    code = pytest.main([str(lab_path / "checks.py"), "--collect-only", "--import-mode=importlib",
                        "--rootdir", str(lab_path.parent), *_QUIET], plugins=[Count()])
    if code != 0 or not Count.checks:
        raise ConfigError(f"{lab_path / 'checks.py'}: its checks could not be collected (pytest exit code {int(code)})")
    return Count.points


def _env(**extra) -> dict:
    keep = ("PATH", "PYTHONPATH", "HOME", "LANG", "LC_ALL", "TMPDIR", "RETROFIT_CHECK_SECONDS")
    env = {k: os.environ[k] for k in keep if k in os.environ}
    env.update(MPLBACKEND="Agg", **extra)
    return env


def _preflight(lab_copy: Path, private: Path, box: Sandbox) -> None:
    """Start the sandbox once on an empty file: a grader that cannot sandbox grades no one."""
    from .proxy import close_all, open_target
    from .wire import StudentProcessEnded
    empty = private / "preflight.py"
    empty.write_text("", encoding="utf-8")
    try:
        open_target(empty, lab_copy, box)
    except StudentProcessEnded as exc:
        raise ConfigError(f"the students' sandbox does not start, so no one is graded: {exc}") from None
    finally:
        close_all()


class _Checker:
    """The checking process of one job slot: it checks one student after another, each in the
    slot's sandbox uid; it is started afresh when a student's checks outlive the wall-clock limit."""

    def __init__(self, slot, lab_copy, private, limits, hidden):
        self.uid = sandbox_uid(slot)
        self.box = box = Sandbox(uid=self.uid, gid=self.uid, hide=hidden, cpu_seconds=limits.cpu_seconds,
                                 memory_mb=limits.memory_mb, processes=limits.processes, file_mb=limits.file_mb)
        from .core import CHECK_SECONDS_ENV, SPEC_ENV
        self.env = _env(**{SPEC_ENV: box.to_env(), CHECK_SECONDS_ENV: str(limits.check_seconds),
                           "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"})   # the checks need no installed pytest plugin
        self.lab_copy, self.private, self.proc = lab_copy, private, None

    def _start(self):
        done_read, done_write = os.pipe()
        self.stderr = tempfile.TemporaryFile()
        command = [sys.executable, "-m", "retrofit.lab.grade", str(self.lab_copy), str(done_write)]
        try:
            self.proc = subprocess.Popen(command, env=self.env, cwd=self.private, start_new_session=True,
                                         stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self.stderr,
                                         pass_fds=(done_write,))
        finally:
            os.close(done_write)
        self.done = done_read

    def check(self, target: Path, result: Path, wall_seconds: float):
        """Check one file; None when done, else why not (the wall-clock limit, the process ended)."""
        if self.proc is None:
            self._start()
        try:
            self.proc.stdin.write((json.dumps({"target": str(target), "result": str(result)}) + "\n").encode())
            self.proc.stdin.flush()
            ready, _, _ = select.select([self.done], [], [], wall_seconds)
            answer = os.read(self.done, 64) if ready else None
        except OSError:
            answer = b""
        if answer:
            return None
        code = self.proc.poll()
        self.close()
        if answer is None:
            return f"stopped after {wall_seconds:g} s (wall-clock limit)"
        return f"the checks did not finish (exit code {code}; {self.tail})"

    def close(self):
        if self.proc is None:
            return
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            pass
        kill_group(self.proc)
        os.close(self.done)
        self.stderr.seek(0)
        lines = [ln for ln in self.stderr.read().decode("utf-8", "replace").splitlines() if ln.strip()]
        self.tail = lines[-1][:200] if lines else "no message"
        self.stderr.close()
        self.proc = None
        if self.uid is not None:
            sweep_uid(self.uid, self.uid)


def _grade_one(name, data, index, checker, private, limits, most) -> Grade:
    """Check one student's file; kill everything it left behind."""
    grade = Grade(name, max_points=most)
    if data is None:
        grade.note = "no student.py handed in"
        return grade
    folder = private / "students" / f"{index:04d}"
    folder.mkdir(parents=True)
    target, result = folder / "student.py", folder / "result.json"
    target.write_bytes(data)
    try:
        grade.note = checker.check(target, result, limits.wall_seconds) or ""
    finally:
        if checker.uid is not None:
            sweep_uid(checker.uid, checker.uid)
    if not grade.note:
        grade.checks, grade.note = _read_result(result)
    return grade


def _read_result(result: Path) -> tuple[list[dict], str]:
    """The checking process's results, checked for shape; or why there are none."""
    try:
        checks = json.loads(result.read_text(encoding="utf-8"))["checks"]
        clean = []
        for c in checks:
            row = {"title": str(c["title"]), "todo": str(c.get("todo", "")), "todos": [str(t) for t in c.get("todos", [])],
                   "status": c["status"], "message": str(c.get("message", "")), "reason": str(c.get("reason", "")),
                   "points": int(c["points"]), "max_points": int(c["max_points"])}
            if row["status"] not in STATUSES or not 0 <= row["points"] <= row["max_points"]:
                raise ValueError(f"a check result {row['title']!r} out of shape")
            clean.append(row)
        return clean, ""
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return [], f"the checks gave no usable result ({exc})"


def _all_gone(uids) -> None:
    """Kill what is left of every student's uid; refuse to go on while any process remains."""
    for uid in uids:
        if uid is None:
            continue
        sweep_uid(uid, uid)
        left = processes_of(uid)
        if left:
            raise ConfigError(f"processes of the students' uid {uid} outlived the grading ({left[:5]}); "
                              "no grades written")


def _worker(lab_path: str, done_fd: str) -> int:
    """A checking process: for each job read on stdin, check its file with the lab's checks, write
    the results as JSON, then say so on ``done_fd``."""
    from ..atomic import write_text_atomic
    from .core import check_lab, find_lab
    lab = find_lab(Path(lab_path).parent, Path(lab_path).name)
    become_subreaper()                  # a student's orphaned grandchildren come here, root or not
    for line in sys.stdin:
        job = json.loads(line)
        results = check_lab(lab, target=job["target"])
        kill_children()
        write_text_atomic(job["result"], json.dumps({"checks": [r.as_dict() for r in results]}))
        os.write(int(done_fd), b"done\n")
    return 0


if __name__ == "__main__":
    sys.exit(_worker(*sys.argv[1:3]))
