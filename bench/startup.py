"""Start-up: what a ``retrofit run`` costs before and around its work, in fresh processes.

Builds the ahead-of-time kernel module first when there is no current one (``retrofit kernels``),
then two measures, each side by side in one run:

* ``retrofit run lathe-profile.ngc`` (a small program) with the Python kernels (no compiler
  loaded), with Numba loaded first (``RETROFIT_NUMBA=always``), and with the ahead-of-time module
  (the default once built): median wall and CPU seconds, alternated (CPU: user + system of the
  child, which the machine's load does not inflate the way it inflates wall time);
* the fixed cost of a compiled run, split: ``retrofit run`` on Klipper's benchmark shape
  (bench/square_circle.py, N=20: 1.18 M steps) with Numba's JIT kernels (``RETROFIT_NO_AOT=1``)
  and with the ahead-of-time module: the whole command's CPU and steps per CPU-second, then a
  process that marks its CPU at each stage of the start, runs the command twice (the second run
  finds everything loaded: its CPU is the work alone) and leaves.

    python bench/startup.py [--runs 5] [--program lathe-profile.ngc] [--n 20]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from square_circle import machine_file, workload_gcode

#: the child that marks its CPU at each stage; prints its marks as JSON on its last line
SPLIT = """import time
marks = {"python": time.process_time()}
import numpy
marks["numpy"] = time.process_time()
import retrofit.cli, retrofit.cli.run, retrofit.run.program
marks["retrofit"] = time.process_time()
from retrofit.motion._jit import compiled
compiled()
marks["numba"] = time.process_time()
import sys
loads = [0.0, 0]
if "numba" in sys.modules:                 # Numba's kernels: time each load from its cache
    from numba.core import caching
    def timed(load):
        def load_overload(self, *args):
            start = time.process_time()
            try:
                return load(self, *args)
            finally:
                loads[0] += time.process_time() - start
                loads[1] += 1
        return load_overload
    caching.Cache.load_overload = timed(caching.Cache.load_overload)
import contextlib, io, json, sys
from retrofit.cli import main
for run in ("first", "second"):
    with contextlib.redirect_stdout(io.StringIO()):
        main(sys.argv[1:])
    marks[run] = time.process_time()
marks["loads"], marks["kernels"] = loads
print(json.dumps(marks))
import gc
gc.freeze()
"""


def child_cpu(argv: list[str], env: dict | None = None) -> tuple[float, float, str]:
    """(wall, CPU seconds, stdout) of one fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(argv, env=env, check=True, stdout=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), proc.stdout


SMALL = {"Python kernels": {"RETROFIT_NO_AOT": "1", "RETROFIT_NUMBA": ""},
         "Numba loaded first": {"RETROFIT_NO_AOT": "1", "RETROFIT_NUMBA": "always"},
         "ahead-of-time module": {"RETROFIT_NO_AOT": "", "RETROFIT_NUMBA": ""}}


def small_program(program: str, runs: int) -> None:
    """The small program with each kind of kernel, alternated."""
    modes = {name: dict(os.environ, **extra) for name, extra in SMALL.items()}
    argv = [sys.executable, "-m", "retrofit.cli", "run", program]
    for env in modes.values():                                  # warm the disk cache and Numba's
        child_cpu(argv, env)
    seen = {name: [] for name in modes}
    for _ in range(runs):
        for name, env in modes.items():
            seen[name].append(child_cpu(argv, env)[:2])
    print(f"retrofit run {program}: median of {runs}, alternated")
    for name, figures in seen.items():
        print(f"  {name:22s} wall {statistics.median(w for w, _ in figures):6.2f} s   "
              f"CPU {statistics.median(c for _, c in figures):6.2f} s")


def ensure_module() -> None:
    """Build the ahead-of-time module unless a current one is there."""
    status = subprocess.run([sys.executable, "-m", "retrofit.cli", "kernels", "--status"], capture_output=True)
    if status.returncode:
        print("no current ahead-of-time module: building it (retrofit kernels)", flush=True)
        subprocess.run([sys.executable, "-m", "retrofit.cli", "kernels"], check=True, stdout=subprocess.DEVNULL)


STAGES = (("python", "Python itself (interpreter, site)"), ("numpy", "import numpy"),
          ("retrofit", "import retrofit's command and run path"),
          ("numba", "compiled(): the ahead-of-time module, or Numba"))


MODES = {"Numba's JIT kernels": {"RETROFIT_NO_AOT": "1"}, "ahead-of-time module": {"RETROFIT_NO_AOT": ""}}


def split_marks(args: list[str], env: dict, runs: int) -> tuple[list[float], list[dict]]:
    """CPU of the whole command and the marks of the marking child, ``runs`` times each."""
    whole = [sys.executable, "-m", "retrofit.cli"] + args
    child_cpu(whole, env)                                       # warm the disk cache
    cpu, marks = [], []
    for _ in range(runs):
        cpu.append(child_cpu(whole, env)[1])
        _, total, out = child_cpu([sys.executable, "-c", SPLIT] + args, env)
        mark = json.loads(out.strip().splitlines()[-1])
        mark["exit"] = total
        marks.append(mark)
    return cpu, marks


def stage_rows(marks: list[dict]) -> list[tuple[str, float]]:
    """(stage, median CPU seconds) from the marks of several runs."""
    med = lambda f: statistics.median(f(m) for m in marks)           # noqa: E731
    rows, prev = [], None
    for key, label in STAGES:
        rows.append((label, med(lambda m: m[key] - (m[prev] if prev else 0.0))))  # noqa: B023 (called here)
        prev = key
    work = med(lambda m: m["second"] - m["first"])
    loads = med(lambda m: m["loads"])
    rows += [("Numba's cached kernels loaded (first run)", loads),
             ("first run's other start costs (lazy imports)", med(lambda m: m["first"] - m["numba"]) - work - loads),
             ("exit", med(lambda m: m["exit"] - m["second"]))]
    rows.append(("fixed cost: all of the above", sum(s for _, s in rows)))
    rows.append(("the work itself (a second run, all loaded)", work))
    return rows


def split(n: int, runs: int) -> None:
    """The fixed cost of a compiled run on Klipper's shape, stage by stage, JIT next to AOT."""
    folder = Path(tempfile.mkdtemp())
    program = folder / f"w{n}.ngc"
    program.write_text(workload_gcode(n))
    args = ["run", str(program), "--machine", str(machine_file(folder)), "--output", "sim://",
            "--report", str(folder / "r.json"), "--progress", "off"]
    columns = {}
    for name, extra in MODES.items():
        cpu, marks = split_marks(args, dict(os.environ, RETROFIT_NUMBA="", **extra), runs)
        columns[name] = (statistics.median(cpu), stage_rows(marks))
    report = json.loads((folder / "r.json").read_text())
    steps = sum(a["steps"] for a in report["axes"].values())
    print(f"retrofit run w{n}.ngc --output sim:// --report (Klipper's shape, N={n}, {steps} steps): "
          f"median of {runs}, CPU seconds")
    print(f"  {'':50s}" + "".join(f"{name:>24s}" for name in columns))
    print(f"  {'whole command':50s}" + "".join(f"{cpu:24.3f}" for cpu, _ in columns.values()))
    print(f"  {'M steps per CPU-second':50s}" + "".join(f"{steps / cpu / 1e6:24.2f}" for cpu, _ in columns.values()))
    print("  stage by stage (a process marking its CPU as it goes, running the command twice):")
    labels = [label for label, _ in next(iter(columns.values()))[1]]
    for i, label in enumerate(labels):
        print(f"    {label:48s}" + "".join(f"{rows[i][1]:24.3f}" for _, rows in columns.values()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--program", default="lathe-profile.ngc")
    parser.add_argument("--n", type=int, default=20, help="repetitions of Klipper's shape for the split")
    args = parser.parse_args()
    ensure_module()
    small_program(args.program, args.runs)
    split(args.n, args.runs)
    print(f"  (load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
