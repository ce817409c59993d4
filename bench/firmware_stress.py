"""The long random stress run of the firmware in simavr (retrofit.firmware.stress), per seed for
at least the given simulated minutes: runs of ``--moves`` random moves (rates up to
``--top-rate`` on the base axis, 1-4 axes, random ratios, a full queue, RDST every 2-20 ms,
garbage and dropped bytes) one after the other, each on a fresh board, until the AVR's time
reaches ``--minutes``; every rest checked on RDPS and on the pins. Prints each run's seed, its
steps and link figures, and every mismatch (exit status 1 if any).

    python bench/firmware_stress.py [--seeds 1,2] [--minutes 10] [--moves 200] [--top-rate 60000]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from retrofit.firmware import sim as fs  # noqa: E402
from retrofit.firmware import stress as st  # noqa: E402
from retrofit.machine.config import load_machine  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1", help="comma-separated seeds")
    ap.add_argument("--minutes", type=float, default=10.0, help="simulated minutes per seed")
    ap.add_argument("--moves", type=int, default=200, help="moves per run")
    ap.add_argument("--top-rate", type=float, default=60_000.0, help="the fastest base rate asked")
    args = ap.parse_args()
    machine = load_machine(ROOT / "bench" / "steprate.toml")
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        elf = fs.build_copy(machine, Path(tmp))
        for seed in (int(s) for s in args.seeds.split(",")):
            cycles = steps = runs = 0
            while cycles < args.minutes * 60 * fs.F_CPU:
                run_seed = seed * 10_000 + runs
                run = st.stress_run(elf, machine, seed=run_seed, moves=args.moves,
                                    top_rate=args.top_rate, batch=(1, 30), limit_s=3600)
                problems = st.check(run, machine)
                cycles += run.log.end_cycle
                steps += sum(len(fs.step_times(run.log, machine, a)[0]) for a in machine.axis_names)
                runs += 1
                print(f"seed {seed} run {run_seed}: {run.log.end_cycle / fs.F_CPU:7.1f} s simulated, "
                      f"{len(run.checkpoints)} rests checked, link {run.link}, "
                      f"{run.garbage_bytes} garbage bytes, {run.dropped_bytes} dropped; "
                      f"{'held' if not problems else 'FAILED'}", flush=True)
                for p in problems[:20]:
                    print("   ", p)
                bad += bool(problems)
            print(f"seed {seed}: {runs} runs, {cycles / fs.F_CPU / 60:.1f} simulated minutes, "
                  f"{steps} steps on the pins, {'all held' if not bad else f'{bad} failed'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
