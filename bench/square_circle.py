"""Klipper's benchmark shape, side by side: a 100 mm square plus an r=15 circle, repeated N times.

100 steps/mm, 3000 mm/s², F3000 on a copy of ``engraver`` (X, Y). One table, one run:

* plan + execute: CPU seconds of planning the compiled program and executing the plan by the
  streamed fast path (every chunk of port frames made, as ``retrofit run`` makes them), in this
  process, next to the CPU seconds Klipper spends in its C step generation (iterative solver +
  step compression, all threads) on the same program;
* whole run: ``retrofit run w.ngc --output sim:// --report r.json`` in a fresh process, its
  CPU (user + system, start-up included) and peak RSS, next to Klipper's whole batch-mode
  process (``klippy.py printer.cfg -i w.gcode -o out.bin -d klipper.dict``); with ``--vcd`` the
  run also writes ``vcd://`` (memory: every output at once).

Klipper's columns need ``KLIPPER_DIR`` (a checkout whose chelper builds), ``KLIPPER_DICT``
(default ``$KLIPPER_DIR/out/klipper.dict``, from ``make`` for any MCU) and a Python with
greenlet and cffi (``KLIPPER_PYTHON``, default this one); they are left out without them.

    python bench/square_circle.py [--n 20 100 500] [--vcd] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).parent

MACHINE_TOML = """\
[machine]
name = "square-circle"
description = "Klipper's benchmark machine: X, Y at 100 steps/mm, 3000 mm/s2, 50 mm/s"
tick_us = 1.0
port = "none"
{axes}
[motion]
interpolator = "dda"
profile = "trapezoid"
arc_tolerance_mm = 0.002
rapid_feed_mm_min = 3000.0
default_feed_mm_min = 600.0
lookahead = 16
junction_deviation_mm = 0.01
"""
AXIS_TOML = """
[axis.{name}]
steps_per_mm = {spm}
min_mm = {lo}
max_mm = {hi}
pulse_high_ticks = 5
pulse_low_ticks = 5
dir_setup_ticks = 5
dir_hold_ticks = 5
max_velocity_mm_s = {v}
max_accel_mm_s2 = {a}
"""

KLIPPER_CFG = """\
[mcu]
serial: /dev/null

[printer]
kinematics: cartesian
max_velocity: 50
max_accel: 3000
max_z_velocity: 10
max_z_accel: 200

[force_move]
enable_force_move: True

[gcode_arcs]
resolution: {arc_mm}
""" + "".join(f"""
[stepper_{a}]
step_pin: {step}
dir_pin: {d}
enable_pin: !{en}
microsteps: 16
rotation_distance: {rd}
endstop_pin: ^{stop}
position_endstop: 0
position_min: {lo}
position_max: 200
""" for a, step, d, en, rd, stop, lo in (("x", "PF0", "PF1", "PD7", 32, "PE5", 0),
                                         ("y", "PF6", "PF7", "PF2", 32, "PJ1", 0),
                                         ("z", "PL3", "PL1", "PK0", 8, "PD3", -20)))


def workload_gcode(n: int) -> str:
    lines = ["G21 G90 G17", "G0 X10 Y10", "F3000"]
    for _ in range(n):
        lines += ["G1 X110 Y10", "G1 X110 Y110", "G1 X10 Y110", "G1 X10 Y10",
                  "G0 X60 Y45", "G2 X60 Y45 I0 J15"]
    lines.append("M2")
    return "\n".join(lines) + "\n"


def klipper_gcode(n: int) -> str:
    """The same program in Klipper's dialect: one word group a line, F on a G1, no M2."""
    body = workload_gcode(n).replace("G21 G90 G17", "G21\nG90\nG17").replace("\nF3000", "\nG1 F3000")
    return "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n" + body.replace("M2\n", "")


def machine_file(folder: Path) -> Path:
    axes = "".join(AXIS_TOML.format(name=n, spm=spm, lo=lo, hi=hi, v=v, a=a)
                   for n, spm, lo, hi, v, a in (("x", 100.0, 0.0, 200.0, 50.0, 3000.0),
                                                ("y", 100.0, 0.0, 200.0, 50.0, 3000.0),
                                                ("z", 400.0, -20.0, 20.0, 10.0, 200.0)))
    path = folder / "square-circle.toml"
    path.write_text(MACHINE_TOML.format(axes=axes))
    return path


def machine():
    from retrofit.machine.config import load_machine
    return load_machine(machine_file(Path(tempfile.mkdtemp())))


def cpu(func, *args):
    start = time.process_time()
    result = func(*args)
    return time.process_time() - start, result


def stream_all(plan) -> int:
    """Every chunk of the plan's port frames, made and dropped (the streamed fast path)."""
    from retrofit.motion.stream import stream_frames
    frames = 0
    for chunk in stream_frames(plan, 1 << 15, on_waypoints=lambda *columns: None):
        frames += len(chunk.ticks)
    return frames


def stages(n: int, m, repeat: int = 1) -> dict:
    """CPU seconds of each stage on N repetitions (in this process; each the least of ``repeat``)."""
    from retrofit.gcode import load_program
    from retrofit.motion.fast import plan_steps
    from retrofit.run.program import plan_compiled
    with tempfile.NamedTemporaryFile("w", suffix=".ngc", delete=False) as fh:
        fh.write(workload_gcode(n))
    t_compile, program = cpu(load_program, fh.name, m)
    t_plan, (_, plan) = min((cpu(plan_compiled, program, m) for _ in range(repeat)), key=lambda r: r[0])
    t_exec = min(cpu(stream_all, plan)[0] for _ in range(repeat))
    os.unlink(fh.name)
    return {"steps": plan_steps(plan), "moves": len(plan.moves), "compile": t_compile, "plan": t_plan,
            "execute": t_exec}


#: runs one command and writes its CPU seconds and peak RSS: a small process between this one and
#: the measured one, since a child forked from this (large) process would count its RSS as its own
LAUNCHER = """import json, os, subprocess, sys
proc = subprocess.Popen(sys.argv[2:])
_, status, usage = os.wait4(proc.pid, 0)
with open(sys.argv[1], "w") as fh:
    json.dump({"code": os.waitstatus_to_exitcode(status), "cpu": usage.ru_utime + usage.ru_stime,
               "rss_mb": usage.ru_maxrss / 1024}, fh)
"""


#: both sides run as installed: Python writes and reads its bytecode cache (some shells turn it off)
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def child_usage(argv: list[str]) -> tuple[str, float, float]:
    """(stdout, CPU seconds, peak RSS MB) of one fresh process."""
    with tempfile.TemporaryDirectory() as folder:
        figures = Path(folder) / "usage.json"
        proc = subprocess.run([sys.executable, "-c", LAUNCHER, str(figures)] + argv, capture_output=True, text=True,
                              env=CHILD_ENV)
        usage = json.loads(figures.read_text()) if figures.exists() else {"code": proc.returncode}
    if usage["code"] or proc.returncode:
        raise RuntimeError(f"{' '.join(argv[:3])} ... exited {usage['code']}: {proc.stderr[-2000:]}")
    return proc.stdout, usage["cpu"], usage["rss_mb"]


def whole_run(n: int, vcd: bool, folder: Path, repeat: int = 1) -> dict:
    """``retrofit run … --output sim:// [--output vcd://] --report`` in a fresh process:
    CPU seconds, peak RSS (each the least of ``repeat`` runs) and the steps its report counts."""
    program = folder / f"w{n}.ngc"
    program.write_text(workload_gcode(n))
    argv = [sys.executable, "-m", "retrofit.cli", "run", str(program), "--machine", str(machine_file(folder)),
            "--output", "sim://", "--report", str(folder / "r.json"), "--progress", "off"]
    if vcd:
        argv += ["--output", f"vcd://{folder / 'w.vcd'}"]
    runs = [child_usage(argv) for _ in range(repeat)]
    seconds, rss = min(r[1] for r in runs), min(r[2] for r in runs)
    report = json.loads((folder / "r.json").read_text())
    steps = sum(a["steps"] for a in report["axes"].values())
    (folder / "w.vcd").unlink(missing_ok=True)
    return {"cpu": seconds, "rss_mb": rss, "steps": steps}


def klipper_run(n: int, folder: Path, arc_mm: float, repeat: int = 1) -> dict | None:
    """Klipper's batch mode on the same program (None without ``KLIPPER_DIR``): the CPU seconds
    and peak RSS of the whole process, the CPU seconds of its C step generation, and the steps
    its output commands (counted once the process has ended and its output is complete)."""
    kdir = os.environ.get("KLIPPER_DIR")
    if not kdir:
        return None
    dictionary = os.environ.get("KLIPPER_DICT", os.path.join(kdir, "out", "klipper.dict"))
    cfg, gcode, out = folder / "printer.cfg", folder / f"k{n}.gcode", folder / "k.bin"
    cfg.write_text(KLIPPER_CFG.format(arc_mm=f"{arc_mm:.4f}"))
    gcode.write_text(klipper_gcode(n))
    python = os.environ.get("KLIPPER_PYTHON", sys.executable)
    script = str(HERE / "klipper_batch.py")
    runs = [child_usage([python, script, kdir, str(cfg), str(gcode), str(out), dictionary]) for _ in range(repeat)]
    seconds, rss = min(r[1] for r in runs), min(r[2] for r in runs)
    gen_cpu = min(json.loads(r[0].strip().splitlines()[-1])["gen_cpu"] for r in runs)
    counted = subprocess.run([python, script, "--count", kdir, str(out), dictionary], capture_output=True,
                             text=True, check=True)
    return {"cpu": seconds, "rss_mb": rss, "gen_cpu": gen_cpu, "steps": int(counted.stdout)}


def chord_mm(m) -> float:
    """Chord length of the r=15 circle as retrofit cuts it (Klipper's arc resolution is set to it)."""
    import math
    r, e = 15.0, m.motion.arc_tolerance_mm
    return 2.0 * math.sqrt(r * r - (r - e) ** 2)


def row(n: int, s: dict, w: dict, v: dict | None, k: dict | None) -> str:
    steps = s["steps"]
    v_rss = f"{v['rss_mb']:7.0f}" if v else f"{'-':>7}"
    mine = steps / (s["plan"] + s["execute"]) / 1e6
    theirs = f"{k['steps'] / k['gen_cpu'] / 1e6:8.2f}" if k else f"{'-':>8}"
    whole = w["steps"] / w["cpu"] / 1e6
    k_whole = f"{k['steps'] / k['cpu'] / 1e6:8.2f}" if k else f"{'-':>8}"
    k_rss = f"{k['rss_mb']:6.0f}" if k else f"{'-':>6}"
    return (f"{n:5d} {steps:10d} {s['moves']:7d} | {steps / s['plan'] / 1e6:6.1f} {steps / s['execute'] / 1e6:6.1f} "
            f"{mine:9.2f} {theirs} | {whole:9.2f} {k_whole} | {w['cpu']:6.2f} {w['rss_mb']:6.0f} {v_rss} {k_rss}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[20, 100, 500])
    parser.add_argument("--vcd", action="store_true",
                        help="also run sim:// + vcd:// + --report for the peak RSS of every output at once")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs of each measure, both sides, the least CPU kept (the machine's other load only adds)")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    m = machine()
    from retrofit.motion._jit import compiled
    compiled()                                   # stages: kernels loaded first, as a long run does
    stages(1, m)
    whole_run(1, True, folder)                   # the compiled kernels in Numba's cache on disk
    klipper_run(1, folder, chord_mm(m))          # each side's bytecode cached before anything is timed
    print(f"{'':24s}| M steps per CPU-second            | M steps per CPU-s  | whole run: CPU s, peak RSS MB")
    print(f"{'N':>5} {'steps':>10} {'moves':>7} | {'plan':>6} {'exec':>6} {'plan+exec':>9} {'Klipper':>8} | "
          f"{'whole run':>9} {'Klipper':>8} | {'CPU s':>6} {'RSS':>6} {'+vcd':>7} {'Klipper':>6}")
    print(f"{'':24s}| {'':14s} {'':9s} {'C gen':>8} | {'sim://':>9} {'process':>8} |")
    whole = []
    for n in args.n:
        s = stages(n, m, args.repeat)
        w = whole_run(n, False, folder, args.repeat)
        v = whole_run(n, True, folder) if args.vcd else None
        k = klipper_run(n, folder, chord_mm(m), args.repeat)
        if k and k["steps"] != s["steps"]:
            print(f"  (Klipper's output file holds {k['steps']} of the {s['steps']} steps: its serial queue "
                  f"thread was stopped at exit before writing the rest; its rates use the program's steps)")
        if k:
            k["steps"] = s["steps"]
        print(row(n, s, w, v, k), flush=True)
        whole.append((w["steps"], w["cpu"]))
    if len(whole) > 1:
        (s0, c0), (s1, c1) = whole[0], whole[-1]
        print(f"whole run CPU per step, slope from N={args.n[0]} to N={args.n[-1]}: "
              f"{(c1 - c0) / (s1 - s0) * 1e9:.0f} ns (fixed part {c0 - s0 * (c1 - c0) / (s1 - s0):.2f} s)")
    print(f"(plan+exec excludes G-code compile; the whole run is the command from start to exit: Python "
          f"start-up, compile, plan, execute, sim://, report; +vcd: RSS with vcd:// too; Klipper "
          f"{'columns left out: set KLIPPER_DIR' if not os.environ.get('KLIPPER_DIR') else 'from its batch mode'})")


if __name__ == "__main__":
    main()
