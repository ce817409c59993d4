"""Peak memory of ``retrofit run --html`` on a generated program of many moves (default 40 000).

Writes a zig-zag facing program for chivu-lathe (short cuts along Z, steps along X), runs
``retrofit run PROGRAM --machine chivu-lathe --html OUT.html`` in a child process and prints
its peak resident memory (the child's ru_maxrss), CPU time, the report's size and machine time.

    PYTHONPATH=. python3 bench/html_memory.py [--moves 40000]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path


def program(moves: int) -> str:
    """``moves`` moves of a facing zig-zag within chivu-lathe's travel."""
    lines = ["; Stock: bar of 40 mm diameter", "G21 G90 G18", "G0 X18 Z1", "F200"]
    for k in range(moves // 2):
        x = 18 - (k % 160) * 0.1
        lines += [f"G1 Z{-2 - (k % 7):.1f}", f"G1 X{x - 0.05:.2f} Z0.5"]
    lines.append("M30")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=40_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        prog = Path(tmp) / "many.ngc"
        prog.write_text(program(args.moves))
        out, rep = Path(tmp) / "many.html", Path(tmp) / "many.json"
        done = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", str(prog), "--machine",
                               "chivu-lathe", "--html", str(out), "--report", str(rep)],
                              capture_output=True, text=True)
        use = resource.getrusage(resource.RUSAGE_CHILDREN)
        if not out.exists():
            sys.exit(f"no report: {done.stderr.strip()[-500:]}")
        report = json.loads(rep.read_text())
        print(f"{args.moves} moves, {report['ticks'] * report['tick_us'] / 1e6:.1f} s of machine time, "
              f"{sum(a['steps'] for a in report['axes'].values())} steps")
        print(f"peak RSS {use.ru_maxrss / 1024:.0f} MB, CPU {use.ru_utime + use.ru_stime:.1f} s, "
              f"report {out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
