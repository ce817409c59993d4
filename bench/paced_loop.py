"""Benchmark: the paced real-time loop at a 50 us tick (LinuxCNC's usual base period) for 10 s.

Runs the lathe circle's port bytes, repeated to fill the time, through the parport code path to
the recorder (or to a real port with ``--url parport:///dev/parport0``) and prints the lateness
of the writes: p50 / p99 / max and the count later than half a tick, for the loop writing only
the change ticks and for the loop writing every tick.

    python bench/paced_loop.py [--tick-us 50] [--seconds 10] [--mode both|changes|every]

``--compare`` instead runs, in one process and alternating round by round (``--rounds`` of
``--seconds`` each), the same frames to the same recorder through: the naive loop (busy-wait on
perf_counter_ns to each boundary, then write; no sleep, no priority), retrofit's Python pacer
and its compiled writer (both as ``parport+record://`` runs them: calibrated, SCHED_FIFO and
mlockall when permitted), and the compiled writer busy-waiting only (no sleep, no priority).
It prints one table of the pooled lateness per loop and mode.

    python bench/paced_loop.py --compare [--rounds 3] [--seconds 5] [--mode both|changes|every]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from retrofit.demo import circle_targets
from retrofit.errors import RetrofitError
from retrofit.machine.config import load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output
from retrofit.outputs.pacer import LEAD_NS, Lateness, Pacer, repeat_frames
from retrofit.outputs.record import RecordPort, load_recording


def run(machine, frames, url: str) -> None:
    out = open_output(url, machine)
    out.quiet = True
    with out:
        out.write(frames)
    print(f"\n{url}")
    for line in out.report_lines():
        print(f"  {line}")
    if "record" in url:
        same = load_recording(out.recording.path) == frames
        print(f"  recording equals the frames, every tick in order: {same}")


def naive(frames, every_tick: bool, tick_ns: int, path: Path) -> Lateness:
    """The loop anyone would write first: spin on the clock to each boundary, write, note lateness."""
    port = RecordPort(path)
    sched = Pacer(tick_ns, every_tick=every_tick, paced=False, engine="python")
    ticks, values = sched._schedule(frames)
    clock, late, write = time.perf_counter_ns, [], port.write
    t0 = clock() + LEAD_NS - int(ticks[0]) * tick_ns
    for tick, value in zip(ticks.tolist(), values.tolist()):
        due = t0 + tick * tick_ns
        while clock() < due:
            pass
        write(tick, value)
        late.append(clock() - due)
    port.hold_until(frames.end_tick)
    port.close()
    return Lateness.of(tick_ns, len(late), late)


def compiled_spin(frames, every_tick: bool, tick_ns: int, path: Path) -> Lateness:
    """The compiled writer busy-waiting to every boundary (never sleeping), at normal priority."""
    port = RecordPort(path)
    pacer = Pacer(tick_ns, every_tick=every_tick, spin_ns=-1, engine="compiled")
    pacer.play(frames, port.write)
    timing = pacer.finish()
    port.hold_until(pacer.end_tick)
    port.close()
    return timing


def retrofit_url(engine: str):
    def run_url(frames, every_tick: bool, tick_ns: int, path: Path) -> Lateness:
        query = f"tick_us={tick_ns / 1000:g}&force=1&engine={engine}" + ("&every_tick=1" if every_tick else "")
        out = open_output(f"parport+record://{path}?{query}", MACHINE[0])
        out.quiet = True
        with out:
            out.write(frames)
        assert out.pacer.engine == engine, out.pacer.engine_note
        return out.timing
    return run_url


MACHINE = []
LOOPS = {"naive busy-wait": naive, "Python pacer": retrofit_url("python"),
         "compiled pacer": retrofit_url("compiled"), "compiled, spin only": compiled_spin}


def compare(frames, tick_ns: int, modes, rounds: int, folder: str) -> bool:
    """Alternate the loops round by round; print the pooled figures; True if every recording matched."""
    samples = {(mode, name): [] for mode in modes for name in LOOPS}
    same = True
    for r in range(rounds):
        for mode in modes:
            for name, loop in LOOPS.items():
                path = Path(folder) / "cmp.bin"
                timing = loop(frames, mode == "every", tick_ns, path)
                samples[mode, name].append(timing.samples_ns)
                same &= load_recording(path) == frames
                print(f"  round {r + 1} {mode:7} {name:20} p99 {timing.p99_ns / 1000:7.1f} us  "
                      f"late {timing.late}", flush=True)
    print(f"\n{'mode':8}{'loop':22}{'writes':>9}{'p50 us':>9}{'p99 us':>9}{'max us':>10}{'late':>7}{'share':>9}")
    for (mode, name), parts in samples.items():
        lat = Lateness.of(tick_ns, sum(map(len, parts)), np.concatenate(parts))
        print(f"{mode:8}{name:22}{lat.writes:9d}{lat.p50_ns / 1000:9.1f}{lat.p99_ns / 1000:9.1f}"
              f"{lat.max_ns / 1000:10.1f}{lat.late:7d}{100 * lat.late / lat.writes:8.3f}%")
    print(f"late = later than half a tick ({tick_ns / 2000:g} us); load average now "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"every recording equals the frames, every tick in order: {same}")
    return same


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tick-us", type=float, default=50.0)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--mode", choices=("both", "changes", "every"), default="both")
    p.add_argument("--url", help="parport URL to pace (default: a temporary recording)")
    p.add_argument("--compare", action="store_true", help="the naive loop, the Python and the compiled pacer, alternated")
    p.add_argument("--rounds", type=int, default=3, help="rounds of --compare")
    args = p.parse_args(argv)
    machine = load_machine("chivu-lathe")
    MACHINE[:] = [machine]
    log = PositionErrorLoop(machine).run(circle_targets(machine))
    frames = repeat_frames(log.frames, round(args.seconds * 1e6 / args.tick_us))
    print(f"paced loop: {args.seconds:g} s at a {args.tick_us:g} us tick = {frames.end_tick} ticks, "
          f"{len(frames)} changes; {platform.python_implementation()} {platform.python_version()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    modes = ("changes", "every") if args.mode == "both" else (args.mode,)
    if args.compare:
        with tempfile.TemporaryDirectory() as folder:
            return 0 if compare(frames, round(args.tick_us * 1000), modes, args.rounds, folder) else 1
    with tempfile.TemporaryDirectory() as folder:
        for mode in modes:
            url = args.url or f"parport+record://{folder}/{mode}.bin"
            query = f"tick_us={args.tick_us:g}&force=1" + ("&every_tick=1" if mode == "every" else "")
            try:
                run(machine, frames, f"{url}{'&' if '?' in url else '?'}{query}")
            except RetrofitError as exc:
                print(f"error: {exc}", file=sys.stderr)
                return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
