"""Real programs through the compiler: how many run on a shipped machine, and why the rest do not.

Usage: ``python3 bench/gcode_corpus.py [--list]``

Every ``.ngc`` of the corpus -- LinuxCNC's own nc_files (``tests/gcode/linuxcnc``), the plasma
CAM outputs, probe subroutines and macros LinuxCNC ships (``tests/gcode/corpus``, see the README
there) and retrofit's shipped examples -- is compiled twice:

* on a suitable shipped machine: a lathe program (its name says lathe, or it selects G18/G7) on
  ``chivu-lathe``, anything else on ``grenoble-mill``; the machine's travel, axes and parts apply;
* on the wide test mill of the differential test (``tests/gcode/rs274-mill.toml``: XYZ within
  +-5000 mm, a tool table), which leaves only what the *language* refuses; there the plasma
  programs' HAL feed pin ``#<_hal[plasmac.cut-feed-rate]>`` is given the operator's value
  (1000), as ``tests/test_gcode_corpus.py`` does; a program refused there for turning A or B
  is compiled again on the same mill with that rotary axis (``rs274-mill-a.toml``,
  ``rs274-mill-b.toml``).

It prints how many ran on each, and the first refusal reason of the others by count (the reason
with its numbers taken out, so that alike reasons fall together). ``--list`` prints every file's
result.
"""

from __future__ import annotations

import argparse
import re
from collections import Counter
from pathlib import Path

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = (ROOT / "tests" / "gcode" / "linuxcnc", ROOT / "tests" / "gcode" / "corpus",
           ROOT / "retrofit" / "examples")
_LATHE = re.compile(r"\bG\s*(18|7)(?![\d.])", re.IGNORECASE)


def corpus() -> list[Path]:
    return sorted(p for folder in FOLDERS for p in folder.rglob("*.ngc"))


#: shipped examples and the machine each is written for
EXAMPLES = {"engraving.ngc": "engraver", "lathe-profile.ngc": "chivu-lathe"}


def shipped_machine(path: Path) -> str:
    if path.name in EXAMPLES and path.parent.name == "examples":
        return EXAMPLES[path.name]
    text = path.read_text(encoding="utf-8", errors="replace")
    return "chivu-lathe" if "lathe" in str(path.relative_to(ROOT)).lower() or _LATHE.search(text) \
        else "grenoble-mill"


def reason(exc: GcodeError) -> str:
    """The rule of a refusal, without the file, line and numbers."""
    text = str(exc).split(": ", 1)[-1]
    text = re.sub(r"([A-Za-z]?)([-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?)(?![A-Za-z])",
                  lambda m: m.group(0) if m.group(1) in ("G", "M") or m.group(1).islower()
                  else m.group(1) + "#", text)
    return re.sub(r"'[^']*'|\"[^\"]*\"", "'..'", text)[:110]


HAL_FEED = "#<_hal[plasmac.cut-feed-rate]>"


def compile_one(path: Path, machine, tools, hal_feed: str | None = None) -> str | None:
    """None when the program compiles, else the refusal's reason."""
    text = path.read_text(encoding="utf-8")
    if hal_feed is not None:
        text = text.replace(HAL_FEED, hal_feed)
    try:
        compile_program(text, machine, path.name, tool_table=tools, search_path=[path.parent])
    except GcodeError as exc:
        return reason(exc)
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--list", action="store_true", help="print every file's result")
    args = parser.parse_args()
    machines = {name: load_machine(name) for name in ("chivu-lathe", "grenoble-mill", "engraver")}
    wide = load_machine(ROOT / "tests" / "gcode" / "rs274-mill.toml")
    tools = ToolTable.load(ROOT / "tests" / "gcode" / "tool.tbl")
    files = corpus()
    shipped, language, rows = Counter(), Counter(), []
    for path in files:
        name = shipped_machine(path)
        on_shipped = compile_one(path, machines[name], None)
        on_wide = compile_one(path, wide, tools, hal_feed="1000")
        rotary = re.match(r"axis ([AB]) is not on machine", on_wide or "")
        if rotary:
            on_wide = compile_one(path, load_machine(ROOT / "tests" / "gcode" /
                                                     f"rs274-mill-{rotary.group(1).lower()}.toml"),
                                  tools, hal_feed="1000")
        shipped[on_shipped or "ran"] += 1
        language[on_wide or "ran"] += 1
        rows.append((path.relative_to(ROOT), name, on_shipped, on_wide))
    print(f"corpus: {len(files)} programs ({', '.join(str(f.relative_to(ROOT)) for f in FOLDERS)})")
    for title, counts in (("on a shipped machine (chivu-lathe / grenoble-mill)", shipped),
                          ("on the wide test mill (language only; HAL feed 1000)", language)):
        print(f"\n{title}: {counts['ran']} of {len(files)} ran")
        for why, n in counts.most_common():
            if why != "ran":
                print(f"  {n:>3}  {why}")
    if args.list:
        print()
        for path, name, a, b in rows:
            print(f"{str(path):<58} {name:<14} {'ran' if a is None else 'refused':<8} "
                  f"{'ran' if b is None else 'refused: ' + b}")


if __name__ == "__main__":
    main()
