"""Step rate of the firmware in simavr, measured on the pins in cycles, side by side with the
firmware of an earlier commit (default: the one before the step-timing work) built the same way.

For 1, 2, 3 and 4 moving axes it sweeps the cruise rate and prints the highest at which every
step interval of the cruise is within +-1 us of the planned period, every pulse within +-1 us of
the configured width, and every moving axis steps at the same edge. It also prints, for a move at
the machine file's 2 us / 12 us limit, the CPU share of the interrupts and the longest
interrupts-off stretch (in the main loop and in an ISR: the worst latency an interrupt can see).

    python bench/firmware_steprate.py [--base COMMIT] [--quick]
"""

from __future__ import annotations

import argparse
import math
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from retrofit import firmware_sim as fs  # noqa: E402
from retrofit.commands import parse_command  # noqa: E402
from retrofit.config import load_machine  # noqa: E402
from retrofit.link import IMMEDIATE, QUEUED, encode_command, encode_frame, seq_byte  # noqa: E402

MACHINE = ROOT / "bench" / "steprate.toml"
S = fs.F_CPU
PULSE_US = 2.0


def build(firmware_dir: Path, header: str) -> Path:
    """Build firmware_dir with the bench machine's header; the ELF."""
    (firmware_dir / "machines" / "steprate.h").write_text(header)
    subprocess.run(["make", "-C", str(firmware_dir), "MACHINE=steprate", "build/steprate/firmware.elf"],
                   check=True, capture_output=True)
    return firmware_dir / "build" / "steprate" / "firmware.elf"


def frames(machine, texts: list[tuple[int, str]]) -> list[tuple[int, bytes]]:
    out, n = [], {QUEUED: 0, IMMEDIATE: 0}
    for cycle, text in [(1_000_000, "SYNC Q"), (1_000_000, "SYNC I")] + texts:
        if text.startswith("SYNC"):
            ch = QUEUED if text.endswith("Q") else IMMEDIATE
            payload = bytes((0x7F,)) + (0x5EED0001).to_bytes(4, "big")    # SYNC with a session
        else:
            cmd = parse_command(text)
            ch, payload = (IMMEDIATE if cmd.immediate else QUEUED), encode_command(cmd, machine)
        out.append((cycle, encode_frame(seq_byte(ch, n[ch]), payload)))
        n[ch] += 1
    return out


def run_move(elf: Path, machine, axes: str, rate: float, stats: bool = False):
    """One move of ``axes`` at base rate ``rate`` (steps/s) for ~40 ms of cruise; the log."""
    steps = max(200, int(rate * 0.04))
    mm = steps / 1000.0
    feed = rate * math.sqrt(len(axes)) * 60 / 1000.0
    move = "FMOV " + " ".join(f"{a}{mm:g}" for a in axes)
    script = frames(machine, [(2_000_000, f"FFDR F{feed:.4f}"), (2_200_000, move)])
    cycles = 2_400_000 + int(steps / rate * S * 1.3) + 800_000
    return fs.Harness(elf, machine, script=script, cycles=cycles, stats=stats).run(), steps


def clean(log, machine, axes: str, rate: float, steps: int) -> bool:
    """Every cruise interval and pulse within +-1 us of the plan, all axes on the same edges."""
    rises, falls, _ = fs.step_times(log, machine, axes[0])
    if len(rises) != steps or len(falls) != steps:
        return False
    for other in axes[1:]:
        r, _, _ = fs.step_times(log, machine, other)
        if len(r) != steps or np.abs(r - rises).max() > 16:
            return False
    widths = (falls - rises) / 16.0
    cruise = np.diff(rises)[steps // 4: 3 * steps // 4] / 16.0
    return (np.abs(widths - PULSE_US).max() <= 1.0
            and np.abs(cruise - 1e6 / rate).max() <= 1.0)


def highest(elf: Path, machine, axes: str, rates: list[float]) -> float:
    best = 0.0
    for rate in rates:
        log, steps = run_move(elf, machine, axes, rate)
        if not clean(log, machine, axes, rate, steps):
            break
        best = rate
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="7ab7a00", help="the commit whose firmware runs beside")
    ap.add_argument("--quick", action="store_true", help="a coarser sweep")
    args = ap.parse_args()
    machine = load_machine(MACHINE)
    sys.path.insert(0, str(ROOT / "firmware" / "tools"))
    from machine_header import header as make_header
    header = make_header(machine)
    fs.build("mitic-lathe")                                   # the harness itself
    step = 5000 if args.quick else 2500
    rates = [float(r) for r in range(5000, 80001, step)]
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(f"git -C {ROOT} archive {args.base} firmware | tar -x -C {tmp}",
                       shell=True, check=True)
        base_dir = Path(tmp) / "firmware"
        shutil.rmtree(base_dir / "build", ignore_errors=True)
        elves = {f"base {args.base}": build(base_dir, header),
                 "this tree": build(ROOT / "firmware", header)}
        print("highest clean step rate (steps/s of each axis; +-1 us intervals and pulse width):")
        print(f"  {'axes':<6}" + "".join(f"{name:>18}" for name in elves))
        for n in range(1, 5):
            axes = "XYZA"[:n]
            row = [highest(elf, machine, axes, rates) for elf in elves.values()]
            print(f"  {n:<6}" + "".join(f"{r:>18.0f}" for r in row))
        print("interrupts during a 3-axis move at 5 kHz (cycles at 16 MHz):")
        for name, elf in elves.items():
            log, _ = run_move(elf, machine, "XYZ", 5000.0, stats=True)
            st = log.stats
            print(f"  {name:<16} ISR share {100 * st['isr_cycles'] / st['cycles']:5.2f} %, "
                  f"longest ISR {st['isr_longest']} ({st['isr_longest'] / 16:.1f} us), "
                  f"longest interrupts-off in the main loop {st['off_main_longest']} "
                  f"({st['off_main_longest'] / 16:.1f} us)")
        (ROOT / "firmware" / "machines" / "steprate.h").unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
