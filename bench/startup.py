"""Start-up: ``retrofit run lathe-profile.ngc`` from the command to the end, in fresh processes.

Alternates, in one run, the default (kernels stay Python for a small program, no compiler loaded)
with ``RETROFIT_NUMBA=always`` (Numba and its cached kernels loaded first, the previous
behaviour); prints the median wall and CPU seconds of each (CPU: user + system of the child,
which the machine's load does not inflate the way it inflates wall time).

    python bench/startup.py [--runs 5] [--program lathe-profile.ngc]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time


def one_run(program: str, env: dict) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "retrofit.cli", "run", program], env=env, check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--program", default="lathe-profile.ngc")
    args = parser.parse_args()
    modes = {"lazy (default)": dict(os.environ, RETROFIT_NUMBA=""),
             "Numba loaded first": dict(os.environ, RETROFIT_NUMBA="always")}
    for env in modes.values():                                  # warm the disk cache and Numba's
        one_run(args.program, env)
    seen = {name: [] for name in modes}
    for _ in range(args.runs):
        for name, env in modes.items():
            seen[name].append(one_run(args.program, env))
    print(f"retrofit run {args.program}: median of {args.runs}, alternated")
    for name, runs in seen.items():
        print(f"  {name:20s} wall {statistics.median(w for w, _ in runs):6.2f} s   "
              f"CPU {statistics.median(c for _, c in runs):6.2f} s")
    print(f"  (load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
