"""The teacher's kit: hand a lab out without its solution, and grade a class's submissions.

:func:`export_lab` copies what a student gets (the handout, the stub, the checks, the notebook
and any data files) and leaves out the reference solution, the known-wrong solutions and the
teacher's notes. :func:`grade` checks every student folder of a submissions folder in a process
of its own, with a CPU-time and a memory limit (``resource.setrlimit``) and a wall-clock limit
as a last resort, and writes one CSV and one JSON for the class. The checks used are always
the teacher's (from the labs folder), never a ``checks.py`` a student handed in.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from .errors import ConfigError
from .labs import CHECK_SECONDS_ENV, Lab, check_lab, find_lab

#: what stays with the teacher: never copied by :func:`export_lab`
TEACHER_ONLY = ("solution.py", "teacher.md", "wrong", "right", "out", "__pycache__", ".ipynb_checkpoints")


def export_lab(lab: Lab, dest: str | Path) -> list[Path]:
    """Copy the student's part of ``lab`` into ``dest/<lab folder>/``; return the files written.

    ``dest`` also gets the labs' ``pytest.ini`` so that ``pytest`` and ``retrofit lab check NN
    --labs DEST`` work on the copy. Refuses to write into the lab's own folder.
    """
    dest = Path(dest)
    target = dest / lab.path.name
    if target.resolve() == lab.path.resolve() or lab.path.resolve() in target.resolve().parents:
        raise ConfigError(f"{dest}: that is the labs folder itself; export into another folder")
    written = []
    for source in sorted(lab.path.rglob("*")):
        relative = source.relative_to(lab.path)
        if any(part in TEACHER_ONLY or part.endswith(".pyc") for part in relative.parts) or source.is_dir():
            continue
        out = target / relative
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, out)
        written.append(out)
    ini = lab.path.parent / "pytest.ini"
    if ini.is_file():
        shutil.copyfile(ini, dest / "pytest.ini")
        written.append(dest / "pytest.ini")
    return written


@dataclass
class Limits:
    """What one submission may use: CPU seconds, memory (MiB), per-check seconds, wall seconds."""

    cpu_seconds: int = 120
    memory_mb: int = 2048
    check_seconds: float = 20.0
    wall_seconds: float = 300.0


@dataclass
class Grade:
    """One student's result: the checks, the points, and a note when the run itself failed."""

    student: str
    checks: list[dict] = field(default_factory=list)
    note: str = ""

    @property
    def points(self) -> int:
        return sum(c["points"] for c in self.checks)

    @property
    def max_points(self) -> int:
        return sum(c["max_points"] for c in self.checks)

    def failed_todos(self) -> list[str]:
        """The TODOs with a failed check, each once, in order."""
        todos = [c["todo"] or c["title"] for c in self.checks if c["status"] == "failed"]
        return list(dict.fromkeys(todos))


def _limit(limits: Limits):
    """A ``preexec_fn`` setting the CPU and address-space limits in the child process."""
    def apply():
        import resource
        resource.setrlimit(resource.RLIMIT_CPU, (limits.cpu_seconds, limits.cpu_seconds + 5))
        size = limits.memory_mb * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (size, size))
    return apply


def submission_file(folder: Path) -> Path | None:
    """The file a student handed in: ``student.py`` in the folder (or in one folder below)."""
    for candidate in (folder / "student.py", *sorted(folder.glob("*/student.py"))):
        if candidate.is_file():
            return candidate
    return None


def grade_one(lab: Lab, folder: Path, limits: Limits) -> Grade:
    """Check one student's folder in a child process under ``limits``."""
    grade = Grade(folder.name)
    target = submission_file(folder)
    if target is None:
        grade.note = "no student.py handed in"
        return grade
    env = dict(os.environ, **{CHECK_SECONDS_ENV: str(limits.check_seconds), "MPLBACKEND": "Agg"})
    import tempfile
    with tempfile.TemporaryDirectory(prefix="retrofit-grade-") as scratch:
        result = Path(scratch) / "result.json"
        command = [sys.executable, "-m", "retrofit.labkit", str(lab.path), str(target.resolve()), str(result)]
        _run_child(grade, command, env, folder, limits, result)
    return grade


def _run_child(grade: Grade, command: list[str], env: dict, folder: Path, limits: Limits, result: Path) -> None:
    """Run the checking process; fill ``grade`` from the JSON it wrote, or say why it wrote none."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=folder,
                              timeout=limits.wall_seconds, preexec_fn=_limit(limits))
    except subprocess.TimeoutExpired:
        grade.note = f"stopped after {limits.wall_seconds:g} s (wall-clock limit)"
        return
    try:
        grade.checks = json.loads(result.read_text(encoding="utf-8"))["checks"]
    except (OSError, ValueError, KeyError, TypeError):
        grade.note = _death(done.returncode, done.stderr, limits)


def _death(code: int, stderr: str, limits: Limits) -> str:
    """Why a checking process ended without a result, in one line."""
    import signal
    if code in (-signal.SIGXCPU, -signal.SIGKILL):
        return f"stopped: used more than {limits.cpu_seconds} s of CPU time"
    last = [line for line in stderr.strip().splitlines() if line.strip()]
    if last and "MemoryError" in last[-1]:
        return f"stopped: used more than {limits.memory_mb} MiB of memory"
    return f"the check process ended with code {code}" + (f": {last[-1][:200]}" if last else "")


def grade(lab: Lab, submissions: str | Path, limits: Limits | None = None, jobs: int = 1) -> list[Grade]:
    """Grade every folder in ``submissions`` (one per student, sorted by name)."""
    root = Path(submissions)
    if not root.is_dir():
        raise ConfigError(f"{root}: no such folder; give a folder holding one folder per student")
    folders = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not folders:
        raise ConfigError(f"{root}: no student folders in it; put each student's student.py in a folder "
                          "named after the student")
    limits = limits or Limits()
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda folder: grade_one(lab, folder, limits), folders))


def write_grades(grades: list[Grade], lab: Lab, csv_path: str | Path, json_path: str | Path) -> None:
    """One CSV row per student (points, max, failed TODOs, note) and the full results as JSON."""
    titles = list(dict.fromkeys(c["title"] for g in grades for c in g.checks))
    with open(csv_path, "w", newline="", encoding="utf-8") as handle:
        out = csv.writer(handle)
        out.writerow(["student", "points", "max_points", "failed", "note", *titles])
        for g in grades:
            status = {c["title"]: c["status"] for c in g.checks}
            out.writerow([g.student, g.points, g.max_points, " ".join(g.failed_todos()), g.note,
                          *(status.get(t, "") for t in titles)])
    data = {"lab": lab.path.name, "title": lab.title,
            "students": [{"student": g.student, "points": g.points, "max_points": g.max_points,
                          "note": g.note, "checks": g.checks} for g in grades]}
    Path(json_path).write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def _worker(lab_path: str, target: str, result: str) -> int:
    """The child process: check ``target`` with the lab's checks, write the results as JSON."""
    lab = find_lab(Path(lab_path).parent, Path(lab_path).name)
    results = check_lab(lab, target=target)
    Path(result).write_text(json.dumps({"checks": [r.as_dict() for r in results]}), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(_worker(*sys.argv[1:4]))
