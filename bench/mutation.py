"""A bounded mutation run over motion, gcode, controller, link and backlash: the kill rate per package.

Each package gets a seeded sample of the mutants cosmic-ray's operators make of its modules; each
mutant runs against that package's own tests (``TESTS``) in a scratch copy of the tree, so the
working tree is never touched. A mutant that survives the tests of ``--before`` (the tests without
the files named there) is tried again with the whole set, which gives both figures in one run.

    python3 bench/mutation.py [--per-package 8] [--seed 1] [--before tests/test_x.py ...]
    python3 bench/mutation.py --packages gcode --focus retrofit/gcode/params.py:28 ...   # given lines

A mutant inside an annotation (never run, modules with ``from __future__ import annotations``)
or listed in ``bench/mutation_equivalent.txt`` (with the reason) is equivalent: reported, and left
out of the rates. Prints one line per mutant and a table per package; docs/testing.md holds the
figures measured.
"""

from __future__ import annotations

import argparse
import ast
import functools
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
#: the quick cases (the interpreter alone) of files whose other tests run whole programs
GCODE_CASES = [
    "tests/test_rigid_tapping.py::test_taps_agree_with_rs274",
    "tests/test_rigid_tapping.py::test_the_golden_set_has_taps_in_inch_incremental_m4_and_subroutines",
    "tests/test_rigid_tapping.py::test_a_machine_without_a_reversible_spindle_refuses_with_the_reason",
    "tests/test_rigid_tapping.py::test_tap_words_are_checked_with_the_line",
    "tests/test_gcode_probing.py::test_a_machine_without_a_probe_input_refuses_with_the_line",
    "tests/test_gcode_probing.py::test_g38_2_along_y_meets_the_near_side_of_the_beam",
    "tests/test_gcode_probing.py::test_g38_2_without_contact_names_the_line",
    "tests/test_gcode_probing.py::test_g38_4_backs_off_until_the_beam_clears_and_g38_3_may_miss",
    "tests/test_gcode_probing.py::test_probing_from_a_tripped_beam_is_refused",
    "tests/test_gcode_probing.py::test_probing_rules_as_linuxcnc",
    "tests/test_gcode_probing.py::test_the_program_goes_on_from_the_trip_point_in_the_new_coordinates",
    "tests/test_digital_io.py::test_a_machine_without_io_refuses_m62_with_its_line",
    "tests/test_digital_io.py::test_m66_rising_edge_already_past_times_out",
    "tests/test_digital_io.py::test_outputs_come_in_rs274s_order_between_the_moves",
    "tests/test_digital_io.py::test_refusals_name_the_line_and_the_rule",
    "tests/test_read_ahead.py::test_a_late_error_names_its_line_when_read_ahead",
    "tests/test_read_ahead.py::test_a_plan_made_batch_by_batch_is_the_whole_plan_move_for_move",
    "tests/test_read_ahead.py::test_the_interpreter_runs_only_as_far_as_the_first_batch_needs",
    "tests/test_z_convention.py::test_the_same_pocket_lands_at_the_same_machine_z_on_every_mill",
]
#: the rigid tap through the controller (the spindle's turnaround), from the tapping file
CONTROLLER_CASES = [f"tests/test_rigid_tapping.py::test_{name}" for name in (
    "the_carriage_follows_the_spindle_angle_in_through_the_reversal_and_out",
    "the_tap_reaches_the_programmed_depth_and_ends_where_it_started",
    "the_spindle_turns_its_programmed_way_again_after_the_tap",
    "the_two_way_encoder_counts_down_backwards_and_indexes_both_ways",
    "a_spindle_that_turns_back_before_the_end_halts_the_move")]
TESTS = {     # the new unit tests first: a mutant they kill stops the run early (-x)
    "motion": ["tests/test_mutants_motion.py", "tests/test_mutants_profile.py", "tests/test_mutants_planner.py",
               "tests/test_mutants_indexer.py", "tests/test_mutants_pulses.py",
               "tests/test_bresenham.py", "tests/test_dda.py",
               "tests/test_profile.py", "tests/test_stepgen.py", "tests/test_arcs.py", "tests/test_plan_arrays.py",
               "tests/test_stream.py", "tests/test_fast_equals_reference.py", "tests/test_lab_12.py",
               "tests/test_stream_pauses.py",
               "tests/test_read_ahead.py::test_a_plan_made_batch_by_batch_is_the_whole_plan_move_for_move",
               "tests/test_read_ahead.py::test_a_reversal_planned_in_blocks_streams_the_fast_paths_frames_bit_for_bit"],
    "gcode": ["tests/test_gcode_paths.py", "tests/test_gcode_cycle_paths.py",
              "tests/test_mutants_gcode.py", "tests/test_mutation_survivors.py", "tests/test_gcode.py",
              "tests/test_gcode_modal.py", "tests/test_spindle_modes.py", "tests/test_gcode_language.py",
              "tests/test_gcode_cutter.py", "tests/test_splines.py", "tests/test_lathe_passes.py",
              "tests/test_fanuc_dialect.py", "tests/test_gcode_g76.py", "tests/test_fanuc_programs.py",
              "tests/test_fanuc_manuals.py", "tests/test_fanuc_twins.py", "tests/test_fanuc_rs274.py",
              "tests/test_gcode_feedcap.py", "tests/test_gcode_rotary.py", "tests/test_cycles_spindle.py",
              "tests/test_gcode_cam.py", "tests/test_gcode_corpus.py", "tests/test_plain_lines.py",
              "tests/test_plain_messages.py", "tests/test_canon_rs274.py", "tests/test_gcode_rs274.py",
              "tests/test_path_control.py", "tests/test_gcode_fuzz.py", *GCODE_CASES],
    "controller": ["tests/test_controller_paths.py", "tests/test_mutants_controller.py", "tests/test_mutation_survivors.py",
                   "tests/test_controller_pipeline.py", "tests/test_controller_equivalence.py",
                   "tests/test_controller_kernels.py", "tests/test_homing.py", "tests/test_threading.py",
                   *CONTROLLER_CASES],
    "link": ["tests/test_mutants_link.py", "tests/test_link.py", "tests/test_link_hardening.py",
             "tests/test_protocol_table.py", "tests/test_probing_link.py", "tests/test_link_faults.py"],
    "backlash": ["tests/test_backlash_units.py", "tests/test_backlash.py"],
}
#: modules that are not the package's logic (compiled-kernel plumbing, benches inside the package)
EXCLUDED = {"_aot.py", "_aot_build.py", "_jit.py", "faultbench.py"}
TIMEOUT_S = 240
#: mutants judged equivalent (no behaviour a test could see changes), one a line with the reason
EQUIVALENT = Path(__file__).with_name("mutation_equivalent.txt")


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


@functools.cache
def annotation_spans(path: str) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Where the annotations of a module with ``from __future__ import annotations`` are: text
    that never runs, so a mutant inside one is equivalent."""
    tree = ast.parse(Path(path).read_text())
    if not any(isinstance(n, ast.ImportFrom) and n.module == "__future__"
               and any(a.name == "annotations" for a in n.names) for n in tree.body):
        return []
    notes = [n.returns for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    notes += [n.annotation for n in ast.walk(tree) if isinstance(n, (ast.arg, ast.AnnAssign))]
    return [((n.lineno, n.col_offset), (n.end_lineno, n.end_col_offset)) for n in notes if n is not None]


def equivalent(mutation, judged: dict[str, str]) -> str | None:
    """Why the mutant is equivalent (an annotation, or listed in ``EQUIVALENT``), else None."""
    if any(a <= tuple(mutation.start_pos) and tuple(mutation.end_pos) <= b
           for a, b in annotation_spans(str(mutation.module_path))):
        return "an annotation"
    return judged.get(key(mutation))


def key(mutation) -> str:
    return f"{mutation.module_path}:{mutation.start_pos[0]} {mutation.operator_name} {mutation.occurrence}"


def read_judged() -> dict[str, str]:
    """``EQUIVALENT``'s lines, ``path:line operator occurrence  # reason``."""
    judged = {}
    for line in EQUIVALENT.read_text().splitlines() if EQUIVALENT.exists() else []:
        if line.strip() and not line.startswith("#"):
            what, _, why = line.partition("#")
            judged[" ".join(what.split())] = why.strip()
    return judged


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
    judged = read_judged()
    table = []
    with tempfile.TemporaryDirectory(prefix="retrofit-mutation-") as scratch:
        copy_tree(Path(scratch))
        os.chdir(scratch)
        os.environ.update(PYTHONPATH=scratch, RETROFIT_NO_AOT="1", PYTHONDONTWRITEBYTECODE="1",
                          NUMBA_CACHE_DIR=str(Path(scratch) / ".numba"), MPLBACKEND="Agg")
        drawn = {p: mutants(p, args.per_package, rng, args.focus) for p in TESTS}   # the same sample
        for package in args.packages.split(","):                                # whatever --packages
            after = TESTS[package]
            before = [t for t in after if t not in args.before]
            counts = {"before": 0, "after": 0, "valid": 0, "equivalent": 0}
            for m in drawn[package]:
                where = key(m.mutations[0])
                why = equivalent(m.mutations[0], judged)
                if why:
                    print(f"{package:10} {'equivalent':>21}  {where}  ({why})", flush=True)
                    counts["equivalent"] += 1
                    continue
                first = outcome(m.mutations[0], before) if before else "survived"
                second = first if first != "survived" or before == after else outcome(m.mutations[0], after)
                print(f"{package:10} {first:>10} {second:>10}  {where}", flush=True)
                if first in ("no-mutant", "error"):
                    continue
                counts["valid"] += 1
                counts["before"] += first != "survived"
                counts["after"] += second != "survived"
            table.append((package, counts))
    print(f"\n{'package':10} {'mutants':>7} {'equivalent':>10} {'killed before':>14} {'killed after':>13}")
    total = {k: sum(c[k] for _, c in table) for k in ("valid", "equivalent", "before", "after")}
    for package, c in [*table, ("all", total)]:
        n = max(c["valid"], 1)
        print(f"{package:10} {c['valid']:>7} {c['equivalent']:>10} {c['before']:>6} {100 * c['before'] / n:5.0f} % "
              f"{c['after']:>6} {100 * c['after'] / n:5.0f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
