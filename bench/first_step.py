"""Time to first step and peak memory against program length: files of tiny G1 moves.

Each program is N lines of 0.05 mm G1 moves on ``engraver`` (a zigzag, X and Y, F3000).
``retrofit run FILE --machine engraver --output sim:// --report r.json`` runs in a fresh
process; the CPU seconds from its start to the first chunk of port frames holding a step (the
first step out of the run), its whole CPU and its peak RSS (``ru_maxrss`` of the child) are
printed, medians of ``--repeat`` runs, next to ``--previous DIR`` (another retrofit checkout)
run the same way, alternated.

    python bench/first_step.py [--lines 1000 100000 2000000] [--repeat 3] [--previous ../main]
"""

from __future__ import annotations

import os

os.environ.setdefault("RETROFIT_READ_AHEAD", "1")     # the pipeline read ahead, window by window
import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from stream_shapes import env_for, usage  # noqa: E402

#: run in the child: note the CPU time when the first chunk with a step leaves the stream, then
#: run the command line as ``retrofit run`` does
CHILD = """import json, sys, time
import retrofit.motion.stream as stream
first = []
def watching(plain):
    def watched(*args, **kwargs):
        gen = plain(*args, **kwargs)
        while True:
            try:
                chunk = next(gen)
            except StopIteration as stop:
                return stop.value
            if not first and len(chunk.ticks) > 1:
                first.append(time.process_time())
            yield chunk
    return watched
for name in ("stream_frames", "stream_blocks"):        # a plan whole, or handed on block by block
    if hasattr(stream, name):
        setattr(stream, name, watching(getattr(stream, name)))
from retrofit.cli import main
code = main(sys.argv[2:])
json.dump({"first_step_cpu": first[0] if first else None}, open(sys.argv[1], "w"))
sys.exit(code)
"""


def tiny_moves(lines: int) -> str:
    out = ["G21 G90 G17 F3000", "G0 X10 Y10"]
    for i in range(lines - 3):
        out.append(f"G1 X{10 + (i % 2) * 0.05:.2f} Y{10 + (i // 2 % 2000) * 0.05:.2f}")
    return "\n".join(out + ["M2"]) + "\n"


def measure(program: Path, folder: Path, env: dict) -> tuple[float, float, float]:
    """(CPU s to the first step, whole CPU s, peak RSS MB) of one run."""
    noted = folder / "first.json"
    argv = [sys.executable, "-c", CHILD, str(noted), "run", str(program), "--machine", "engraver",
            "--output", "sim://", "--report", str(folder / "r.json"), "--progress", "off"]
    _, cpu, rss = usage(argv, env)
    return json.loads(noted.read_text())["first_step_cpu"], cpu, rss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, nargs="+", default=[1000, 100_000, 2_000_000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--previous", type=Path)
    parser.add_argument("--previous-cache")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    sides = {"this": env_for(HERE.parent, os.environ.get("XDG_CACHE_HOME"))}
    if args.previous:
        sides["previous"] = env_for(args.previous.resolve(), args.previous_cache)
    for env in sides.values():                       # caches warm
        warm = folder / "warm.ngc"
        warm.write_text(tiny_moves(100))
        measure(warm, folder, env)
    print(f"{'lines':>9s} | " + " | ".join(f"{s + ': first step':>20s} {'CPU s':>7s} {'RSS MB':>7s}" for s in sides))
    for lines in args.lines:
        program = folder / f"t{lines}.ngc"
        program.write_text(tiny_moves(lines))
        runs: dict = {s: [] for s in sides}
        for _ in range(args.repeat if lines < 1_000_000 else 1):
            for side, env in sides.items():
                runs[side].append(measure(program, folder, env))
        cells = [" ".join(f"{statistics.median(r[k] for r in runs[s]):{w}.{p}f}" for k, w, p in
                          ((0, 20, 3), (1, 7, 2), (2, 7, 0))) for s in sides]
        print(f"{lines:9d} | " + " | ".join(cells), flush=True)
        program.unlink()
    print("(first step: CPU s from the process start to the first chunk of frames holding a step; "
          "runs of a million lines or more once)")


if __name__ == "__main__":
    main()
