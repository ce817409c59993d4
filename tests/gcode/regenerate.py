"""Regenerate the golden files: LinuxCNC's own interpreter (``rs274``) run on every corpus program.

Usage: ``python3 tests/gcode/regenerate.py [name ...]`` (needs ``/usr/bin/rs274``, Debian's linuxcnc-uspace).
For each ``programs/*.ngc``, ``linuxcnc/*.ngc`` and ``tapping/*.ngc`` it writes ``golden/<folder>/<name>.canon``:
a first line ``# rs274 exit <code>: <error or ok>`` and then rs274's canonical calls as printed
(``STRAIGHT_TRAVERSE(...)``, ``ARC_FEED(...)``, offsets, units). The tool table is ``tool.tbl``.
The golden files are committed, so the differential test runs where LinuxCNC is not installed. rs274 without a configuration
works in inches: the tool table it reads is ``tool.tbl`` converted (``golden/tool-inch.tbl``), and
programs that write offset parameters (#5161.., #5211..) as numbers are kept out of the corpus.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RS274 = "/usr/bin/rs274"
FOLDERS = ("programs", "linuxcnc", "g76", "tapping")


def inch_tool_table() -> Path:
    """``tool.tbl`` in inches: rs274 without a configuration reads tool tables in inches, and
    prints the offsets in the program's units. Offsets and the diameter D are lengths; T, P,
    the orientation Q and the angles I, J are not."""
    out = HERE / "golden" / "tool-inch.tbl"
    lines = []
    for raw in (HERE / "tool.tbl").read_text().splitlines():
        words = raw.split(";")[0].split()
        lines.append(" ".join(w if w[0] in "TPQIJ" else f"{w[0]}{float(w[1:]) / 25.4:.10f}" for w in words))
    text = "\n".join(lines) + "\n"
    if not out.exists() or out.read_text() != text:
        # tests run rs274 from several processes at once: never let one read a half-written table
        staged = out.with_name(f"{out.name}.{os.getpid()}")
        staged.write_text(text)
        os.replace(staged, out)
    return out


def run_rs274(program: Path) -> str:
    """rs274's output for ``program``, with the exit line first."""
    table = str(inch_tool_table())
    for _attempt in range(3):          # rs274 now and then dies of a signal: run it again
        proc = subprocess.run([RS274, "-t", table, "-g", str(program)],
                              stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60,
                              cwd=program.parent)
        if proc.returncode >= 0:
            break
    errors = [line for line in proc.stderr.splitlines() if line.strip() and line != "executing"]
    status = errors[0] if errors else "ok"
    return f"# rs274 exit {proc.returncode}: {status}\n{proc.stdout}"


def main(names: list[str]) -> int:
    """Every golden file, or only those of the programs named (by stem, e.g. ``comp-g1``)."""
    if not Path(RS274).exists():
        print(f"{RS274} not found: install linuxcnc-uspace", file=sys.stderr)
        return 2
    count = 0
    for folder in FOLDERS:
        out = HERE / "golden" / folder
        out.mkdir(parents=True, exist_ok=True)
        for program in sorted((HERE / folder).glob("*.ngc")):
            if names and program.stem not in names:
                continue
            (out / f"{program.stem}.canon").write_text(run_rs274(program))
            count += 1
    print(f"{count} golden files written")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
