"""Sub-commands for students and teachers: ``retrofit lab list|run|check|export|grade``."""

from __future__ import annotations

import argparse
import sys


def add_commands(sub) -> None:
    """Add ``lab`` with its actions ``list``, ``run`` and ``check`` to the ``retrofit`` command line."""
    where = argparse.ArgumentParser(add_help=False)
    where.add_argument("--labs", metavar="DIR",
                       help="the labs folder (default: $RETROFIT_LABS, else the repository's labs/ "
                            "next to the installed package, else ./labs)")
    which = argparse.ArgumentParser(add_help=False)
    which.add_argument("lab", help="lab number (01), folder name (01_circle) or topic (circle)")
    which.add_argument("--solution", action="store_true", help="use the reference solution instead of student.py")

    lab = sub.add_parser("lab", help="lab exercises: list them, run one, check your work")
    actions = lab.add_subparsers(metavar="ACTION")
    lab.set_defaults(func=lambda args: _help(lab))
    actions.add_parser("list", parents=[where], help="list the labs").set_defaults(func=cmd_list)
    r = actions.add_parser("run", parents=[which, where], help="run a lab's file and save its plots",
                           description="Run the lab's student.py (or --solution) and save its plots as PNG.")
    r.add_argument("--out", metavar="DIR", help="where the plots go (default: out/ inside the lab's folder)")
    r.set_defaults(func=cmd_run)
    c = actions.add_parser("check", parents=[which, where], help="check a lab's file; exit 1 when a check fails",
                           description="Run the lab's checks against student.py (or --solution): one line per "
                                       "check, what was expected and what your code gave when one fails.")
    c.add_argument("--json", action="store_true",
                   help="print one result per check as JSON (title, todo, status, message, points)")
    c.add_argument("--file", metavar="PY", help="check this file instead of the lab's student.py")
    c.set_defaults(func=cmd_check)
    e = actions.add_parser("export", parents=[where], help="write a lab's handout, stub and checks, no solution",
                           description="Copy what a student gets into DIR/NN_topic/: README.md, student.py, "
                                       "checks.py, notebook.py and data files; never solution.py, wrong/ "
                                       "or teacher.md.")
    e.add_argument("lab", help="lab number (01), folder name or topic")
    e.add_argument("dir", help="the folder to write into")
    e.set_defaults(func=cmd_export)
    g = actions.add_parser("grade", parents=[where], help="grade a folder of student folders into CSV and JSON",
                           description="Check every student folder (holding student.py) in SUBMISSIONS: each "
                                       "student's code in a sandbox of its own (its own process and, as root, "
                                       "its own uid) with time, memory, process and file-size limits, the "
                                       "checks and the score in the grader; write grades.csv and grades.json.")
    g.add_argument("lab", help="lab number (01), folder name or topic")
    g.add_argument("submissions", help="a folder holding one folder per student")
    g.add_argument("--out", metavar="DIR", help="where grades.csv and grades.json go (default: SUBMISSIONS)")
    g.add_argument("--cpu", type=int, default=120, metavar="S", help="CPU seconds per student (default 120)")
    g.add_argument("--memory", type=int, default=2048, metavar="MIB", help="memory per student (default 2048)")
    g.add_argument("--check-seconds", type=float, default=20.0, metavar="S",
                   help="seconds one check may take before it counts as a hang (default 20)")
    g.add_argument("--processes", type=int, default=64, metavar="N",
                   help="processes one student's code may run at once, as root (default 64)")
    g.add_argument("--file-mb", type=int, default=64, metavar="MIB",
                   help="largest file one student's code may write (default 64)")
    g.add_argument("--jobs", type=int, default=1, metavar="N", help="students checked at once (default 1, at most 64)")
    g.set_defaults(func=cmd_grade)


def _help(parser) -> int:
    parser.print_help()
    return 2


def _ascii_only() -> bool:
    try:
        "✓✗–".encode(sys.stdout.encoding or "ascii")
        return False
    except (UnicodeEncodeError, LookupError):
        return True


def cmd_list(args) -> int:
    from ..lab.core import labs_dir, list_labs
    root = labs_dir(args.labs)
    print(f"labs in {root}:")
    for lab in list_labs(root):
        print(f"  {lab.number}  {lab.topic:20s} {lab.title}")
    print("run one with 'retrofit lab run NN', check your work with 'retrofit lab check NN'")
    return 0


def cmd_run(args) -> int:
    from ..lab.core import explain, find_lab, labs_dir, run_lab
    lab = find_lab(labs_dir(args.labs), args.lab)
    file = lab.file(args.solution)
    print(f"Lab {lab.number}: {lab.title} — running {file.name}")
    try:
        written = run_lab(lab, args.solution, args.out)
    except Exception as exc:          # the student's code: say what to do, not a traceback
        print(f"  {file.name} stopped: {explain(exc, file)}")
        print(f"  finish the TODOs in {file}, then run 'retrofit lab check {lab.number}'")
        return 1
    for path in written:
        print(f"  saved {path}")
    if not written:
        print("  (no plots written; main() should return the files it saved)")
    return 0


def cmd_check(args) -> int:
    import json
    from pathlib import Path

    from ..errors import ConfigError
    from ..lab.core import check_lab, find_lab, labs_dir, result_lines
    lab = find_lab(labs_dir(args.labs), args.lab)
    file = Path(args.file) if args.file else lab.file(args.solution)
    if not file.is_file():
        raise ConfigError(f"{file}: no such file; give the .py file to check")
    if args.json:
        results = check_lab(lab, target=file)
        print(json.dumps({"lab": lab.path.name, "file": str(file), "checks": [r.as_dict() for r in results],
                          "points": sum(r.scored for r in results),
                          "max_points": sum(r.points for r in results)}, indent=1, ensure_ascii=False))
        return 1 if any(r.status == "failed" for r in results) else 0
    print(f"Lab {lab.number}: {lab.title} — checking {file}")
    results = check_lab(lab, target=file)
    for line in result_lines(results, ascii_only=_ascii_only()):
        print(line)
    return 1 if any(r.status == "failed" for r in results) else 0


def cmd_export(args) -> int:
    from ..lab.core import find_lab, labs_dir
    from ..lab.kit import export_lab
    lab = find_lab(labs_dir(args.labs), args.lab)
    written = export_lab(lab, args.dir, warn=lambda text: print(f"warning: {text}", file=sys.stderr))
    print(f"Lab {lab.number}: {lab.title} — {len(written)} files for students in {args.dir}/{lab.path.name}")
    for path in written:
        print(f"  {path}")
    print(f"students check their work with 'retrofit lab check {lab.number} --labs {args.dir}'")
    return 0


def cmd_grade(args) -> int:
    from pathlib import Path

    from ..lab.core import find_lab, labs_dir
    from ..lab.kit import Limits, grade, write_grades
    lab = find_lab(labs_dir(args.labs), args.lab)
    limits = Limits(cpu_seconds=args.cpu, memory_mb=args.memory, check_seconds=args.check_seconds,
                    wall_seconds=max(60.0, 3.0 * args.cpu), processes=args.processes, file_mb=args.file_mb)
    out = Path(args.out or args.submissions)
    out.mkdir(parents=True, exist_ok=True)
    grades = grade(lab, args.submissions, limits, jobs=args.jobs, hide=(out,))
    write_grades(grades, lab, out / "grades.csv", out / "grades.json")
    print(f"Lab {lab.number}: {lab.title} — {len(grades)} students")
    for g in grades:
        print(f"  {g.student!s:20.20s} {g.points:3d} / {g.max_points:<3d} {g.note or ' '.join(g.failed_todos())}")
    print(f"wrote {out / 'grades.csv'} and {out / 'grades.json'}")
    return 0
