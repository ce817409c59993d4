"""A bounded mutation run over motion, gcode, controller, link and backlash: the kill rate per package.

Each package gets a seeded sample of the mutants cosmic-ray's operators make of its modules; each
mutant runs against that package's own tests (``TESTS``) in a scratch copy of the tree, so the
working tree is never touched. A mutant that survives the tests of ``--before`` (the tests without
the files named there) is tried again with the whole set, which gives both figures in one run.

    python3 bench/mutation.py [--per-package 8] [--seed 1] [--before tests/test_x.py ...]
    python3 bench/mutation.py --packages gcode --focus retrofit/gcode/params.py:28 ...   # given lines

Prints one line per mutant and a table per package; docs/testing.md holds the figures measured.
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from cosmic_ray.commands.init import _all_work_items
from cosmic_ray.mutating import mutate_and_test
from cosmic_ray.work_item import TestOutcome, WorkerOutcome

ROOT = Path(__file__).resolve().parent.parent
TESTS = {
    "motion": ["tests/test_bresenham.py", "tests/test_dda.py", "tests/test_profile.py", "tests/test_stepgen.py",
               "tests/test_arcs.py", "tests/test_plan_arrays.py", "tests/test_stream.py",
               "tests/test_fast_equals_reference.py"],
    "gcode": ["tests/test_gcode.py", "tests/test_gcode_modal.py", "tests/test_spindle_modes.py",
              "tests/test_mutation_survivors.py"],
    "controller": ["tests/test_controller_pipeline.py", "tests/test_controller_equivalence.py",
                   "tests/test_controller_kernels.py", "tests/test_mutation_survivors.py"],
    "link": ["tests/test_link.py", "tests/test_link_hardening.py"],
    "backlash": ["tests/test_backlash.py", "tests/test_backlash_units.py"],
}
#: modules that are not the package's logic (compiled-kernel plumbing, benches inside the package)
EXCLUDED = {"_aot.py", "_aot_build.py", "_jit.py", "faultbench.py"}
TIMEOUT_S = 240


def copy_tree(dest: Path) -> None:
    """The committed tree plus the working changes, without caches, into ``dest``."""
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT, check=True,
                           capture_output=True, text=True).stdout.splitlines()
    for name in files:
        src = ROOT / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)


def mutants(package: str, count: int, rng: random.Random, focus: list[str]) -> list:
    """A seeded sample of the package's mutants; with ``focus`` (``path:line``), every mutant on
    those lines of the package instead."""
    paths = sorted(p for p in (Path("retrofit") / package).rglob("*.py") if p.name not in EXCLUDED)
    items = list(_all_work_items(paths, {}))
    if focus:
        return [m for m in items if f"{m.mutations[0].module_path}:{m.mutations[0].start_pos[0]}" in focus]
    return rng.sample(items, min(count, len(items)))


def command(tests: list[str]) -> str:
    return f"{sys.executable} -m pytest -q -x -n 0 -p no:cacheprovider -p no:randomly " + " ".join(tests)


def outcome(mutation, tests: list[str]) -> str:
    result = mutate_and_test([mutation], command(tests), TIMEOUT_S)
    if result.worker_outcome == WorkerOutcome.NO_TEST:
        return "no-mutant"
    if result.worker_outcome != WorkerOutcome.NORMAL:
        return "error"
    return {TestOutcome.KILLED: "killed", TestOutcome.SURVIVED: "survived",
            TestOutcome.INCOMPETENT: "incompetent"}[result.test_outcome]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-package", type=int, default=8, help="mutants sampled per package (default 8)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--packages", default=",".join(TESTS), help="comma-separated, default all five")
    ap.add_argument("--before", nargs="*", default=[], help="test files left out of the 'before' figure")
    ap.add_argument("--focus", nargs="*", default=[], help="every mutant on these lines (path:line) instead")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    table = []
    with tempfile.TemporaryDirectory(prefix="retrofit-mutation-") as scratch:
        copy_tree(Path(scratch))
        os.chdir(scratch)
        os.environ.update(PYTHONPATH=scratch, RETROFIT_NO_AOT="1", PYTHONDONTWRITEBYTECODE="1",
                          NUMBA_CACHE_DIR=str(Path(scratch) / ".numba"), MPLBACKEND="Agg")
        for package in args.packages.split(","):
            after = TESTS[package]
            before = [t for t in after if t not in args.before]
            counts = {"before": 0, "after": 0, "valid": 0}
            for m in mutants(package, args.per_package, rng, args.focus):
                where = f"{m.mutations[0].module_path}:{m.mutations[0].start_pos[0]} {m.mutations[0].operator_name}"
                first = outcome(m.mutations[0], before) if before else "survived"
                second = first if first != "survived" or before == after else outcome(m.mutations[0], after)
                print(f"{package:10} {first:>10} {second:>10}  {where}", flush=True)
                if first in ("no-mutant", "error"):
                    continue
                counts["valid"] += 1
                counts["before"] += first != "survived"
                counts["after"] += second != "survived"
            table.append((package, counts))
    print(f"\n{'package':10} {'mutants':>7} {'killed before':>14} {'killed after':>13}")
    for package, c in table:
        n = max(c["valid"], 1)
        print(f"{package:10} {c['valid']:>7} {c['before']:>6} {100 * c['before'] / n:5.0f} % "
              f"{c['after']:>6} {100 * c['after'] / n:5.0f} %")
    total = {k: sum(c[k] for _, c in table) for k in ("valid", "before", "after")}
    n = max(total["valid"], 1)
    print(f"{'all':10} {total['valid']:>7} {total['before']:>6} {100 * total['before'] / n:5.0f} % "
          f"{total['after']:>6} {100 * total['after'] / n:5.0f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
