"""CAM and hobby programs from a local folder: how many run, how many LinuxCNC runs, and why not.

Usage: ``python3 bench/cam_corpus.py FOLDER [--rs274] [--list]``

Every file under FOLDER ending in ``.nc .ngc .gcode .gc .tap .cnc .g`` is compiled on the wide
test mill of the differential test (``tests/gcode/rs274-mill.toml``: XYZ within +-5000 mm, the
tool table ``tests/gcode/tool.tbl``), which leaves the *language* as the main reason to refuse.
Each refusal is put in one of two kinds:

* **machine** -- the program asks for something this machine has not (an axis it lacks, travel,
  a probe input, a spindle's range): another machine file would run it;
* **language** -- a code, word or construct the interpreter refuses on any machine.

With ``--rs274`` each file also goes through LinuxCNC's ``rs274`` (the tool table in inches, as
``tests/gcode/regenerate.py`` runs it); the table then says how many LinuxCNC runs, how many of
those retrofit runs, and on how many of both the last move ends at the same point (2e-3 mm: rs274 prints 4 decimals).

The programs are not part of the repository (their licences vary): gather them in a folder of
your own, e.g. the example and test G-code of cncjs, Universal G-code Sender, bCNC, CAMotics,
GRBL-Plotter, svg2gcode and pcb2gcode.
"""

from __future__ import annotations

import argparse
import re
import shutil
import tempfile
from collections import Counter
from pathlib import Path

from gcode_corpus import reason  # bench/ is the script's folder: the same reasons, by count

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

ROOT = Path(__file__).resolve().parent.parent
SUFFIXES = {".nc", ".ngc", ".gcode", ".gc", ".tap", ".cnc", ".g"}
#: refusals another machine file would lift
_MACHINE = re.compile(r"soft limits|is not on machine|probe input|the machine file names|"
                      r"spindle range|has no \[spindle\]|has one spindle|tool table", re.IGNORECASE)
#: rs274 prints 4 decimals, of an inch under G20: 0.0000 5 inch is 0.00127 mm
END_TOL_MM = 0.002
#: where both interpreters start (machine mm): a program without moves ends there
START = (0.0, 0.0, 0.0)


def programs(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)


def compile_one(path: Path, machine, tools):
    """(program or None, the refusal or None)."""
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        return compile_program(text, machine, path.name, tool_table=tools,
                               search_path=[path.parent]), None
    except GcodeError as exc:
        return None, exc


def rs274_end(path: Path):
    """(LinuxCNC ran it, the end point of its last move in machine mm or None)."""
    from tests.gcode.regenerate import run_rs274  # noqa: PLC0415 (only with --rs274)
    from tests.test_gcode_rs274 import canon_events  # noqa: PLC0415
    with tempfile.TemporaryDirectory() as tmp:      # rs274 needs a name it can read as a path
        copy = Path(tmp) / "program.ngc"
        copy.write_bytes(path.read_bytes())
        head, _, body = run_rs274(copy).partition("\n")
    accepted = head.startswith("# rs274 exit 0") or "File ended with no percent sign" in head
    events = canon_events(body) if accepted else []
    return accepted, (events[-1][1] if events else START), head.partition(": ")[2]


def retrofit_end(program):
    from tests.test_gcode_rs274 import retrofit_points  # noqa: PLC0415
    points = retrofit_points(program)
    return points[-1][0] if points else START


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--rs274", action="store_true", help="also run LinuxCNC's rs274")
    parser.add_argument("--list", action="store_true", help="print every file's result")
    args = parser.parse_args()
    if args.rs274 and not shutil.which("rs274") and not Path("/usr/bin/rs274").exists():
        parser.error("--rs274 needs LinuxCNC's rs274 (Debian package linuxcnc-uspace)")
    wide = load_machine(ROOT / "tests" / "gcode" / "rs274-mill.toml")
    tools = ToolTable.load(ROOT / "tests" / "gcode" / "tool.tbl")
    files = programs(args.folder)
    kinds, reasons, rows = Counter(), Counter(), []
    lcnc = Counter()
    for path in files:
        program, exc = compile_one(path, wide, tools)
        why = None if exc is None else reason(exc)
        kind = "ran" if exc is None else ("machine" if _MACHINE.search(why) else "language")
        kinds[kind] += 1
        if why:
            reasons[(kind, why)] += 1
        row = [str(path.relative_to(args.folder)), kind, why or ""]
        if args.rs274:
            ran, end, status = rs274_end(path)
            lcnc["rs274 ran"] += ran
            if ran and program is not None:
                lcnc["both ran"] += 1
                mine = retrofit_end(program)
                same = all(abs(a - b) <= END_TOL_MM for a, b in zip(end, mine))
                lcnc["same end"] += same
                row.append("rs274 ran, " + ("same end" if same else f"ends differ {end} {mine}"))
            else:
                row.append("rs274 ran" if ran else f"rs274 refused: {status}")
        rows.append(row)
    n = len(files)
    print(f"{n} programs under {args.folder}")
    print(f"ran: {kinds['ran']} of {n}; refused for the machine: {kinds['machine']}; "
          f"refused for the language: {kinds['language']}")
    if args.rs274:
        print(f"LinuxCNC rs274 ran {lcnc['rs274 ran']}; retrofit ran {lcnc['both ran']} of those, "
              f"{lcnc['same end']} ending where rs274 ends")
    for (kind, why), count in reasons.most_common():
        print(f"  {count:>3}  {kind:<8} {why}")
    if args.list:
        print()
        for row in rows:
            print("  ".join(row))


if __name__ == "__main__":
    main()
