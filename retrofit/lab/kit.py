"""The teacher's kit: hand a lab out without its solution, and write a class's grades.

:func:`export_lab` copies what a student gets (the handout, the stub, the checks, the notebook
and any data files) and leaves out the reference solution, the known-wrong solutions and the
teacher's notes; the stub comes from the pristine source (git's last commit), never from a
``student.py`` the teacher has worked in. :func:`grade` (in :mod:`retrofit.lab.grade`) checks
every student in a sandbox; :func:`write_grades` writes one CSV and one JSON for the class, each
file whole or not at all, every CSV cell safe to open in a spreadsheet.
"""

from __future__ import annotations

import csv
import io
import json
import shutil
import subprocess
from pathlib import Path

from ..atomic import write_text_atomic
from ..errors import ConfigError
from .core import Lab
from .grade import Grade, Limits, grade, submission_file  # noqa: F401  (the kit's API)
from .process import TEACHER_ONLY

_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def pristine_stub(lab: Lab) -> tuple[bytes | None, str]:
    """The stub as committed (``git show HEAD:...``), and where it came from; (None, why) without git."""
    path = lab.file(False)
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=lab.path, capture_output=True,
                             text=True, timeout=30)
        if top.returncode != 0:
            return None, "not in a git checkout"
        relative = path.resolve().relative_to(Path(top.stdout.strip()).resolve()).as_posix()
        shown = subprocess.run(["git", "show", f"HEAD:{relative}"], cwd=lab.path, capture_output=True, timeout=30)
    except (OSError, ValueError, subprocess.TimeoutExpired) as exc:
        return None, f"git: {exc}"
    if shown.returncode != 0:
        return None, f"{relative} is not committed"
    return shown.stdout, f"git HEAD:{relative}"


def _stub(lab: Lab, warn) -> bytes:
    """What goes out as student.py: the committed stub; the working file only when it still is one."""
    working = lab.file(False).read_bytes()
    committed, source = pristine_stub(lab)
    if committed is not None:
        if committed != working:
            warn(f"{lab.file(False)} differs from the committed stub ({source}); exported the committed stub. "
                 "Commit the stub if the change was meant for students.")
        return committed
    if b'raise NotImplementedError("TODO' not in working and b"raise NotImplementedError('TODO" not in working:
        raise ConfigError(f"{lab.file(False)}: no TODO is left to write in it ({source}), so it may hold answers; "
                          "put the stub back (or export from a git checkout)")
    warn(f"{lab.file(False)} exported as it is ({source}): check that it holds no answers")
    return working


def export_lab(lab: Lab, dest: str | Path, warn=None) -> list[Path]:
    """Copy the student's part of ``lab`` into ``dest/<lab folder>/``; return the files written.

    ``dest`` also gets the labs' ``pytest.ini`` so that ``pytest`` and ``retrofit lab check NN
    --labs DEST`` work on the copy. Refuses to write into the lab's own folder. ``warn(text)`` is
    told when the working ``student.py`` is not the committed stub.
    """
    dest = Path(dest)
    target = dest / lab.path.name
    if target.resolve() == lab.path.resolve() or lab.path.resolve() in target.resolve().parents:
        raise ConfigError(f"{dest}: that is the labs folder itself; export into another folder")
    stub = _stub(lab, warn or (lambda text: None))
    written = []
    for source in sorted(lab.path.rglob("*")):
        relative = source.relative_to(lab.path)
        if any(part in TEACHER_ONLY or part.endswith(".pyc") for part in relative.parts) or source.is_dir():
            continue
        out = target / relative
        out.parent.mkdir(parents=True, exist_ok=True)
        if relative.as_posix() == "student.py":
            out.write_bytes(stub)
        else:
            shutil.copyfile(source, out)
        written.append(out)
    ini = lab.path.parent / "pytest.ini"
    if ini.is_file():
        shutil.copyfile(ini, dest / "pytest.ini")
        written.append(dest / "pytest.ini")
    return written


def safe_cell(value):
    """A CSV cell a spreadsheet shows as text: one starting with = + - @ tab or CR gets a leading '."""
    if isinstance(value, str) and value.startswith(_FORMULA_START):
        return "'" + value
    return value


def write_grades(grades: list[Grade], lab: Lab, csv_path: str | Path, json_path: str | Path) -> None:
    """One CSV row per student and the full results as JSON, each written whole or not at all.

    Columns: student, points, max_points, the failed TODOs, a note, one column per TODO with why
    it failed (``ok`` when every check of it passed), then one column per check (its status).
    """
    titles = list(dict.fromkeys(c["title"] for g in grades for c in g.checks))
    todos = sorted({t for g in grades for c in g.checks for t in c.get("todos") or []},
                   key=lambda t: int(t.split()[-1]) if t.split()[-1].isdigit() else 0)
    text = io.StringIO()
    out = csv.writer(text)
    out.writerow([safe_cell(c) for c in ["student", "points", "max_points", "failed", "note", *todos, *titles]])
    for g in grades:
        status = {c["title"]: c["status"] for c in g.checks}
        reasons = g.todo_reasons()
        row = [g.student, g.points, g.max_points, " ".join(g.failed_todos()), g.note,
               *(reasons.get(t, "") for t in todos), *(status.get(t, "") for t in titles)]
        out.writerow([safe_cell(c) for c in row])
    data = {"lab": lab.path.name, "title": lab.title,
            "students": [{"student": g.student, "points": g.points, "max_points": g.max_points, "note": g.note,
                          "todos": g.todo_reasons(), "checks": g.checks} for g in grades]}
    write_text_atomic(csv_path, text.getvalue())
    write_text_atomic(json_path, json.dumps(data, indent=1, ensure_ascii=False) + "\n")
