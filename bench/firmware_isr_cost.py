"""What the step interrupt costs the firmware's CPU, by the axes' ratios: cycles an event, measured in simavr.

Each case is one long move (8 000 events on the base axis) on ``bench/steprate.toml``, built with
the firmware's own clamps lifted, at 30 000 events/s with nothing on the link; the harness counts
the cycles spent in interrupts (``--stats``), less those of a run that does not move. Printed:
cycles an event, the share of the CPU that makes at the firmware's ceiling for the case (its
``KEEP_RATE`` tables and the three-axis sum of steps, with the clamps in place), and the rate
that would leave the main loop a quarter of the CPU. firmware/planner.c's ceilings cite it.

    python3 bench/firmware_isr_cost.py
"""

from __future__ import annotations

import math
import re
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retrofit.firmware import sim as fs  # noqa: E402
from retrofit.firmware import stress as st  # noqa: E402
from retrofit.machine.config import load_machine  # noqa: E402

from tests.test_firmware_sim import Script  # noqa: E402

MACHINE = ROOT / "bench" / "steprate.toml"
CASES = [(1.0,), (1.0, 1.0, 1.0), (1.0, 0.5), (1.0, 0.99), (1.0, 0.5, 0.25), (1.0, 0.67, 0.67),
         (1.0, 0.99, 0.89), (1.0, 1.0, 0.99), (1.0, 0.5, 0.25, 0.125), (1.0, 0.75, 0.5, 0.25),
         (1.0, 0.99, 0.99, 0.98)]
EVENTS, RATE = 8000, 30_000.0


def lifted_build(tmp: Path) -> Path:
    """The firmware for the bench machine with every KEEP_RATE table lifted, built under ``tmp``."""
    machine = load_machine(MACHINE)
    copy = tmp / "firmware"
    shutil.copytree(fs.FIRMWARE, copy, ignore=shutil.ignore_patterns("build", "*.elf", "*.hex"))
    planner = (copy / "planner.c").read_text()
    tables = re.findall(r"#define (KEEP_RATE_\w+)\s+\{[^}]*\}", planner)
    lifted = "\n".join(f"#define {n} {{ 1e6f, 1e6f, 1e6f, 1e6f, 1e6f }}" for n in tables)
    (copy / "planner.c").write_text(planner.replace("#ifndef KEEP_RATE_PLAIN",
                                                    lifted + "\n#ifndef KEEP_RATE_PLAIN"))
    return fs.build_copy(machine, tmp)


def isr_cycles(elf: Path, ratios: tuple[float, ...], events: int, rate: float) -> int:
    """The cycles spent in interrupts over a run holding one move of ``events`` at ``rate``."""
    machine = load_machine(MACHINE)
    mm = {a: round(events * r) / machine.axis(a).steps_per_mm for a, r in zip("XYZA", ratios)}
    feed = rate * math.sqrt(sum(v * v for v in mm.values())) / events * 60
    start = 2_200_000
    script = Script(machine).at(2_000_000, f"FFDR F{feed:.4f}")
    script.at(start, "FMOV " + " ".join(f"{a}{v:.6f}" for a, v in mm.items()))
    end = start + int(events / rate * fs.F_CPU) + 1_000_000
    log = fs.Harness(elf, machine, script=script.items, cycles=end, stats=True).run()
    return log.stats["isr_cycles"]


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="retrofit-isr-") as tmp:
        elf = lifted_build(Path(tmp))
        idle = isr_cycles(elf, (1.0,), 1, 1000.0)
        print(f"step interrupt's cost (bench/steprate.toml, {EVENTS} events at {RATE:.0f}/s, "
              "clamps lifted):")
        print(f"  {'ratios':<20}{'cycles/event':>14}{'ceiling':>10}{'CPU there':>11}{'75 % at':>10}")
        for ratios in CASES:
            cost = (isr_cycles(elf, ratios, EVENTS, RATE) - idle) / EVENTS
            ceiling = st.keep_rate(ratios)
            name = ":".join(f"{r:g}" for r in ratios)
            print(f"  {name:<20}{cost:>14.0f}{ceiling:>10.0f}{cost * ceiling / fs.F_CPU:>11.0%}"
                  f"{0.75 * fs.F_CPU / cost:>10.0f}", flush=True)


if __name__ == "__main__":
    main()
