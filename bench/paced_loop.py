"""Benchmark: the paced real-time loop at a 50 us tick (LinuxCNC's usual base period) for 10 s.

Runs the lathe circle's port bytes, repeated to fill the time, through the parport code path to
the recorder (or to a real port with ``--url parport:///dev/parport0``) and prints the lateness
of the writes: p50 / p99 / max and the count later than half a tick, for the loop writing only
the change ticks and for the loop writing every tick.

    python bench/paced_loop.py [--tick-us 50] [--seconds 10] [--mode both|changes|every]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile

from retrofit.config import load_machine
from retrofit.demo import circle_targets
from retrofit.errors import RetrofitError
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output
from retrofit.outputs.pacer import repeat_frames
from retrofit.outputs.record import load_recording


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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tick-us", type=float, default=50.0)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--mode", choices=("both", "changes", "every"), default="both")
    p.add_argument("--url", help="parport URL to pace (default: a temporary recording)")
    args = p.parse_args(argv)
    machine = load_machine("chivu-lathe")
    log = PositionErrorLoop(machine).run(circle_targets(machine))
    frames = repeat_frames(log.frames, round(args.seconds * 1e6 / args.tick_us))
    print(f"paced loop: {args.seconds:g} s at a {args.tick_us:g} us tick = {frames.end_tick} ticks, "
          f"{len(frames)} changes; {platform.python_implementation()} {platform.python_version()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    modes = ("changes", "every") if args.mode == "both" else (args.mode,)
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
