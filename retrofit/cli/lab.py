"""Sub-commands for students: ``retrofit lab list``, ``retrofit lab run NN``, ``retrofit lab check NN``."""

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
    c.set_defaults(func=cmd_check)


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
    from ..labs import labs_dir, list_labs
    root = labs_dir(args.labs)
    print(f"labs in {root}:")
    for lab in list_labs(root):
        print(f"  {lab.number}  {lab.topic:20s} {lab.title}")
    print("run one with 'retrofit lab run NN', check your work with 'retrofit lab check NN'")
    return 0


def cmd_run(args) -> int:
    from ..labs import explain, find_lab, labs_dir, run_lab
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
    from ..labs import check_lab, find_lab, labs_dir, result_lines
    lab = find_lab(labs_dir(args.labs), args.lab)
    file = lab.file(args.solution)
    print(f"Lab {lab.number}: {lab.title} — checking {file}")
    results = check_lab(lab, args.solution)
    for line in result_lines(results, ascii_only=_ascii_only()):
        print(line)
    return 1 if any(r.status == "failed" for r in results) else 0
