"""Speed of the motion core, measured in one run: reference vs fast path, NumPy vs compiled.

Prints steps per CPU second of each path and their ratios, and machine-seconds simulated per CPU
second on the shipped lathe program and on a program of more than a million steps.

    python bench/motion_speed.py [--quick]
"""

from __future__ import annotations

import argparse
import time

from retrofit.commands import FMov, PFdr, PMov
from retrofit.gcode import load_program
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.motion.execute import execute_reference
from retrofit.motion.fast import execute_fast, request_steps_fast
from retrofit.motion.planner import plan_program
from retrofit.motion.vectorised import execute_numpy, request_steps_numpy
from retrofit.run.program import resolve_program
from retrofit.sim import SimMachine


def cpu(func, *args, repeat: int = 3):
    """Best CPU time of ``repeat`` calls and the last result."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        result = func(*args)
        best = min(best, time.process_time() - start)
    return best, result


def roughing(passes: int):
    """A lathe roughing cycle: cut along Z, retract, rapid back, step in."""
    commands = [PFdr(600.0)]
    for i in range(passes):
        x = 30.0 - 0.1 * i
        commands += [FMov((("X", x), ("Z", 2.0))), PMov((("Z", -180.0),)), FMov((("X", x + 1.0),)),
                     FMov((("Z", 2.0),))]
    return commands


def steps_of(log) -> int:
    return sum(log.steps_emitted.values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller programs (a smoke run)")
    quick = parser.parse_args().quick
    compiled()                                                # the compiled kernels, even on small programs
    lathe = load_machine("chivu-lathe")
    execute_fast(plan_program(roughing(1), lathe))            # compile (or load the cache) first

    small = plan_program(roughing(1 if quick else 2), lathe)
    t_ref, ref = cpu(execute_reference, small, repeat=1)
    t_fast, fast = cpu(execute_fast, small)
    assert fast.frames == ref.frames
    n = steps_of(ref)
    print(f"reference vs fast, same program ({n} steps, {ref.ticks} ticks):")
    print(f"  reference path   {n / t_ref / 1e6:10.3f} M steps/s  ({t_ref:.2f} s)")
    print(f"  fast path        {n / t_fast / 1e6:10.3f} M steps/s  ({t_fast * 1e3:.2f} ms)")
    print(f"  ratio fast/reference: {t_ref / t_fast:.0f}x")

    big = plan_program(roughing(6 if quick else 60), lathe)
    t_sched_np, req_np = cpu(request_steps_numpy, big)
    t_sched_nb, req_nb = cpu(request_steps_fast, big)
    t_np, log_np = cpu(execute_numpy, big)
    t_nb, log_nb = cpu(execute_fast, big)
    assert log_np.frames == log_nb.frames
    n = steps_of(log_nb)
    print(f"\nlarge program ({n} steps, {log_nb.ticks} ticks, {len(log_nb.frames)} port frames):")
    print(f"  schedule alone:  NumPy {n / t_sched_np / 1e6:7.1f} M steps/s   compiled {n / t_sched_nb / 1e6:7.1f} M steps/s")
    print(f"  schedule + pulses + frames:  NumPy {n / t_np / 1e6:7.1f} M steps/s   compiled {n / t_nb / 1e6:7.1f} M steps/s")
    print(f"  compiled / NumPy: {t_np / t_nb:.1f}x")

    print("\nmachine-seconds simulated per CPU second (plan + fast path, then + sim:// decoding):")
    for name, commands in (("lathe-profile.ngc", None), ("roughing (large)", big)):
        if commands is None:
            program = load_program(resolve_program("lathe-profile.ngc"), lathe)
            t_plan, plan = cpu(plan_program, program.commands, lathe)
        else:
            t_plan, plan = 0.0, commands
        t_exec, log = cpu(execute_fast, plan)
        sim = SimMachine(lathe)
        t_sim, _ = cpu(sim.feed, log.frames, repeat=1)
        seconds = log.ticks * lathe.tick_s
        print(f"  {name:20s} {seconds:8.1f} machine-s: {seconds / (t_plan + t_exec):10.0f} x real time"
              f"  (with sim:// {seconds / (t_plan + t_exec + t_sim):8.0f} x)")


if __name__ == "__main__":
    main()
