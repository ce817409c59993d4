"""Measure the step and encoder rates the firmware keeps, in simavr, and write firmware/limits.toml.

The host plans every firmware run within these figures (retrofit/firmware/limits.py), so they are
measured here and never typed by hand. For each case the rate climbs in steps of ``--step``
until a run is not clean; the last clean rate is recorded with the margin applied.

Step rate: bench/steprate.toml (2 us pulse, 12 us shortest period, no speed limit of its own),
one move per rate of at least 3000 steps on the base axis, with the host's RDST polling on the
link (every 2 ms in one run, every 20 ms in another). Clean: every axis makes exactly its steps;
the firmware does not restart (one start line); every interval of the cruise (all but the first
and last 2 %) within +-1 us of the period and none longer than the period plus 100 us; every
pulse at least the configured width. Cases: 1 to 4 axes stepping together, and Bresenham
ratios 1:0.5, 1:0.5:0.25, 1:0.67:0.67 and 1:0.75:0.5:0.25; and 1:0.5:0.25 with a 10 us pulse
(longer than 3 us: ended by compare B's interrupt), the cap for such machines.

Encoder rate: mitic-lathe's build, a thread pass (SPIN S300, ISTP, PFDR F0.5, PMOV Z-5: 400 Z
steps on 4000 counts) with the harness's encoder turning faster and faster (RDST every 20 ms).
Clean: 400 steps; no restart; after the lead-in every step exactly 10 counts after the one
before, and risen before the next count.

    python3 bench/firmware_limits.py [--quick] [--margin 0.8]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from firmware_steprate import MACHINE, frames  # noqa: E402

from retrofit.firmware import limits as fl  # noqa: E402
from retrofit.firmware import sim as fs  # noqa: E402
from retrofit.machine.config import load_machine  # noqa: E402

S = fs.F_CPU
#: the cases measured: name -> the step count of each moving axis per 1000 base steps
CASES = {"1": (1000,), "2": (1000, 1000), "3": (1000, 1000, 1000), "4": (1000, 1000, 1000, 1000),
         "2:bresenham": (1000, 500), "3:bresenham": (1000, 500, 250),
         "3:bresenham-b": (1000, 670, 670), "4:bresenham": (1000, 750, 500, 250)}
#: the same, on a build whose pulse (10 us) the common tick cannot end itself (over 3 us)
LONG_CASES = {"3:bresenham:long-pulse": (1000, 500, 250)}
BANNER = b"retrofit firmware machine="


def long_pulse(workdir: Path):
    """The bench machine with a 10 us pulse (compare B's interrupt ends it), period 20 us."""
    workdir.mkdir(parents=True, exist_ok=True)
    text = MACHINE.read_text().replace("pulse_high_ticks = 2", "pulse_high_ticks = 10")
    path = workdir / "steprate10.toml"
    path.write_text(text.replace('name = "steprate"', 'name = "steprate10"'))
    return load_machine(path)


def restarts(log) -> int:
    """How many times the firmware started after its first start (its start line, again)."""
    return max(log.answer_bytes().count(BANNER) - 1, 0)


def step_run(elf: Path, machine, ratio: tuple[int, ...], rate: float, poll_ms: float):
    """One move at base rate ``rate`` (steps/s), RDST every ``poll_ms``; (log, steps per axis)."""
    base = max(3000, int(rate * 0.06))
    steps = [round(base * r / 1000) for r in ratio]
    letters = "XYZA"[:len(ratio)]
    length_mm = math.sqrt(sum(s * s for s in steps)) / 1000.0
    feed = length_mm / (base / rate) * 60.0
    move = "FMOV " + " ".join(f"{a}{s / 1000:g}" for a, s in zip(letters, steps))
    end = 2_200_000 + int(base / rate * S * 1.3) + 800_000
    polls = [(c, "RDST") for c in range(2_200_000, end, int(poll_ms * S / 1000))]
    script = frames(machine, [(2_000_000, f"FFDR F{feed:.4f}"), (2_200_000 - 1, move)] + polls)
    return fs.Harness(elf, machine, script=script, cycles=end).run(), dict(zip(letters, steps))


def step_clean(log, machine, steps: dict[str, int], rate: float) -> bool:
    if restarts(log):
        return False
    pulse = machine.axis("X").pulse_high_ticks * machine.tick_us * 16
    base = max(steps.values())
    for name, n in steps.items():
        rises, falls, _ = fs.step_times(log, machine, name)
        if len(rises) != n or len(falls) != n or (falls - rises).min() < pulse:
            return False
        if n != base:
            continue
        gaps = np.diff(rises)
        cruise = gaps[n // 50: n - n // 50]
        period = S / rate
        if np.abs(cruise - period).max() > 16 or gaps[n // 50:].max() > period + 1600:
            return False
    return True


def highest(test, rates) -> float:
    best = 0.0
    for rate in rates:
        if not test(rate):
            break
        best = rate
    return best


def encoder_run(elf: Path, lathe, counts_s: float):
    rpm = counts_s * 60.0 / lathe.parts["spindle"].encoder_counts_per_rev
    pass_s = 4000 / counts_s + 0.3
    end = 3_500_000 + int(pass_s * 1.5 * S)
    polls = [(c, "RDST") for c in range(3_500_000, end, int(0.02 * S))]
    script = frames(lathe, [(3_100_000, "SPIN S300 D1"), (3_200_000, "ISTP"), (3_300_000, "PFDR F0.5"),
                            (3_400_000, "PMOV Z-5")] + polls)
    return fs.Harness(elf, lathe, script=script, cycles=end, spindle_rpm=rpm).run()


def encoder_clean(log, lathe) -> bool:
    rises, _, _ = fs.step_times(log, lathe, "Z")
    if restarts(log) or len(rises) != 400:
        return False
    iclk = np.array([c for c, port, bit, level in log.inputs if (port, bit, level) == ("D", 0, 1)])
    at = np.searchsorted(iclk, rises, side="right") - 1     # the count each step belongs to
    follows = np.diff(at)[100:]                              # past any lead-in
    nxt = at + 1 < len(iclk)
    risen_before_next = np.all(rises[nxt] < iclk[at[nxt] + 1])
    return bool(np.all(follows == 10) and risen_before_next)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser steps (5 kHz, 10 k counts/s)")
    ap.add_argument("--margin", type=float, default=0.8, help="share of the measured rate recorded")
    ap.add_argument("--out", default=str(fl.TABLE), help="where to write the table")
    args = ap.parse_args()
    machine = load_machine(MACHINE)
    elf = fs.build_copy(machine, Path("/tmp") / f"retrofit-limits-{fl.build_identity()[:12]}")
    step = 5000 if args.quick else 2500
    rates = [float(r) for r in range(5000, 90001, step)]
    measured = {}
    long_machine = long_pulse(Path("/tmp") / f"retrofit-limits-{fl.build_identity()[:12]}")
    long_elf = fs.build_copy(long_machine, Path("/tmp") / f"retrofit-limits-{fl.build_identity()[:12]}-10us")
    for cases, m, e in ((CASES, machine, elf), (LONG_CASES, long_machine, long_elf)):
        for case, ratio in cases.items():
            def test(rate, ratio=ratio, m=m, e=e):
                runs = (step_run(e, m, ratio, rate, poll) for poll in (2.0, 20.0))
                return all(step_clean(log, m, steps, rate) for log, steps in runs)
            measured[case] = highest(test, rates)
            print(f"  {case:<24} clean to {measured[case]:8.0f} steps/s", flush=True)
    lathe = load_machine("mitic-lathe")
    lathe_elf = fs.build("mitic-lathe")
    counts = [float(c) for c in range(10_000, 200_001, 10_000 if args.quick else 5_000)]
    encoder = highest(lambda c: encoder_clean(encoder_run(lathe_elf, lathe, c), lathe), counts)
    print(f"  {'encoder':<24} clean to {encoder:8.0f} counts/s", flush=True)
    text = fl.table_text(measured, encoder, args.margin)
    Path(args.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
