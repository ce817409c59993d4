"""grbl 1.1 and this firmware side by side in simavr: the highest clean step rate of each.

grbl is fetched at run time at a pinned commit (``git clone`` of github.com/gnea/grbl, or of
``--grbl-src``: any clone or mirror of it) into a cache directory, never into this repository,
built by its own Makefile with avr-gcc for the ATmega328P at 16 MHz, and run in simavr by
``bench/grbl_hil.c`` (streamed G-code with grbl's character counting; port D logged). This tree's
firmware is built for ``bench/steprate.toml`` and run on simavr's ATmega2560 at 16 MHz by the
project's harness, its commands sent through the host's link endpoint in lockstep.

Both get the same moves: 1000 steps/mm, 100 000 mm/s^2 on every axis, no speed limit of their own
(grbl: ``$100-$102=1000``, ``$110-$112=100000``, ``$120-$122=100000``, ``$0=3``, its shortest
pulse; ours: its 2 us), nothing else on the link. Cases: X alone, X Y Z equal, X:Y:Z = 1:0.5:0.25
(each one line of at least 3 000 base steps), and 60 colinear segments of 0.5 mm on X (short
segments, streamed). The base rate climbs in 2.5 kHz steps from 10 kHz (short segments: from
2.5 kHz) until a run is not clean (below 5 kHz grbl's own timer rounding puts an interval 1.1 us
off). Clean: every axis makes exactly its steps; every base-axis interval of the middle half
within +-1 us of the period (none shorter: no period below the minimum, none longer: no stall;
short segments: within +-10 %, the chain holds its feed across the joints); no interval of
another axis there shorter than the base period less 1 us. (At low rates both tick faster than the base
axis steps, AMASS, so the other axes step between its steps.)

    python3 bench/grbl_side_by_side.py [--grbl-src PATH_OR_URL] [--cache DIR] [--top 70000]
                                       [--ours-only] [--case NAME]

(``--ours-only``: this firmware's column alone, grbl neither fetched nor run; ``--case``: the
cases whose name starts with NAME.)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from retrofit.commands import parse_command  # noqa: E402
from retrofit.firmware import sim as fs  # noqa: E402
from retrofit.firmware.lockstep import Lockstep  # noqa: E402
from retrofit.link.host import HostEndpoint  # noqa: E402
from retrofit.link.replies import StatusFlags  # noqa: E402
from retrofit.machine.config import load_machine  # noqa: E402

GRBL_URL = "https://github.com/gnea/grbl.git"
GRBL_COMMIT = "40eb439bf2afc4c6f3003836c396e183ba72c45b"          # tag v1.1h.20190825
GRBL_SETTINGS = ["$0=3", "$1=255"] + [f"${k}{n}={v}" for k, v in (("10", 1000), ("11", 100000),
                                                                   ("12", 100000)) for n in "012"]
S = fs.F_CPU
CASES = {"1 axis": (1.0,), "3 axes, equal": (1.0, 1.0, 1.0), "1 : 0.5 : 0.25": (1.0, 0.5, 0.25),
         "short segments (60 x 0.5 mm, X)": "segments"}
SEGMENTS, SEGMENT_STEPS = 60, 500


def fetch_grbl(src: str, cache: Path) -> Path:
    """grbl's ELF built at GRBL_COMMIT in ``cache`` (cloned from ``src`` the first time)."""
    tree = cache / f"grbl-{GRBL_COMMIT[:12]}"
    elf = tree / "build" / "main.elf"
    if not elf.exists():
        if not (tree / ".git").exists():
            subprocess.run(["git", "clone", "--quiet", src, str(tree)], check=True)
        subprocess.run(["git", "-C", str(tree), "checkout", "--quiet", GRBL_COMMIT], check=True)
        subprocess.run(["make", "-C", str(tree)], check=True, capture_output=True)
    head = subprocess.run(["git", "-C", str(tree), "rev-parse", "HEAD"], check=True,
                          capture_output=True, text=True).stdout.strip()
    if head != GRBL_COMMIT:
        raise SystemExit(f"{tree}: at {head}, not the pinned {GRBL_COMMIT}; remove it and run again")
    return elf


def build_harness(cache: Path) -> Path:
    out = cache / "grbl_hil"
    flags = subprocess.run("pkg-config --cflags --libs simavr 2>/dev/null || echo -lsimavr",
                           shell=True, capture_output=True, text=True).stdout.split()
    subprocess.run(["cc", "-O2", "-o", str(out), str(ROOT / "bench" / "grbl_hil.c"), *flags, "-lm"],
                   check=True)
    return out


def grbl_run(hil: Path, elf: Path, lines: list[str], seconds: float) -> dict[str, np.ndarray]:
    """Run ``lines`` on grbl; each axis's step rises and falls (cycles) from port D."""
    with tempfile.TemporaryDirectory() as tmp:
        program, log = Path(tmp) / "p.gcode", Path(tmp) / "pins.log"
        program.write_text("\n".join(GRBL_SETTINGS + ["G21 G91"] + lines) + "\n")
        out = subprocess.run([str(hil), str(elf), str(program), str(log), str(int((seconds + 1) * S))],
                             check=True, capture_output=True, text=True).stdout
        if "error=0" not in out:
            raise SystemExit(f"grbl refused a line: {out}")
        harness_log = fs.HarnessLog.read(log, "")
    out = {}
    for axis, bit in zip("XYZ", (2, 3, 4)):
        cycles, levels = harness_log.pin("D", bit)
        prev = np.concatenate(([0], levels[:-1]))
        out[axis] = (cycles[(levels == 1) & (prev == 0)], cycles[(levels == 0) & (prev == 1)])
    return out


def grbl_lines(case, rate: float) -> tuple[list[str], dict[str, int], float]:
    """The G-code of a case at a base rate: (lines, steps per axis, seconds it takes)."""
    if case == "segments":
        feed = rate * 60 / 1000
        steps = {"X": SEGMENTS * SEGMENT_STEPS}
        return [f"G1 X{SEGMENT_STEPS / 1000:g} F{feed:.3f}"] * SEGMENTS, steps, steps["X"] / rate
    base = max(3000, int(rate * 0.05))
    steps = {a: round(base * r) for a, r in zip("XYZ", case)}
    feed = rate * np.sqrt(sum(r * r for r in case)) * 60 / 1000
    move = "G1 " + " ".join(f"{a}{v / 1000:g}" for a, v in steps.items()) + f" F{feed:.3f}"
    return [move], steps, base / rate


def _pump(host: HostEndpoint, board: Lockstep, cycles: int) -> None:
    host.poll(board.now)
    board.write(host.take_output())
    data = board.advance(cycles)
    if data:
        host.receive(data, board.now)


def ours_run(elf: Path, machine, lines: list[str], steps: dict[str, int], seconds: float):
    """The same moves as commands through the host endpoint in lockstep; each axis's edges."""
    board = Lockstep(elf, machine).start()
    host = HostEndpoint(machine, timeout_s=0.05, max_tries=20, nonce=1)
    try:
        board.advance(2_000_000)
        pos = {a: 0 for a in machine.axis_names}
        texts = []
        for line in lines:                       # "G1 X0.5 F..." -> PFDR, PMOV (absolute, mm)
            words = {w[0]: float(w[1:]) for w in line.split()[1:]}
            texts.append(f"PFDR F{words.pop('F'):.3f}")
            for a, mm in words.items():
                pos[a] += round(mm * 1000)
            texts.append("PMOV " + " ".join(f"{a}{v / 1000:g}" for a, v in pos.items() if v))
        texts = [t for k, t in enumerate(texts) if not (t.startswith("PFDR") and t in texts[:k])]
        end = S * (seconds + 3)
        for text in texts:                       # each sent once the one before is taken
            t = host.send(parse_command(text), board.now)
            while not t.done and board.cycle < end:
                _pump(host, board, 8_000)
        while board.cycle < end:                 # then a look every 10 ms until nothing moves
            t = host.send(parse_command("RDST"), board.now)
            while not t.done:
                _pump(host, board, 160_000)
            if not int(t.reply.flags) & StatusFlags.MOVING and t.reply.queued == 0:
                break
    finally:
        log = board.stop()
    out = {}
    for a in steps:
        rises, falls, _ = fs.step_times(log, machine, a)
        out[a] = (rises, falls)
    return out


def clean(edges: dict, steps: dict[str, int], rate: float, tol_us: float = 1.0) -> bool:
    """Exact steps, the middle half's base intervals within +-``tol_us``, no other axis's interval
    there shorter than the base period (less 1 us)."""
    base = max(steps, key=lambda a: steps[a])
    if any(len(edges[a][0]) != n or len(edges[a][1]) != n for a, n in steps.items()):
        return False
    rises = edges[base][0]
    lo, hi = len(rises) // 4, 3 * len(rises) // 4
    gaps = np.diff(rises)[lo:hi]
    if np.abs(gaps - S / rate).max() > tol_us * 16:
        return False
    for a in steps:
        r = edges[a][0]
        r = r[(r >= rises[lo]) & (r <= rises[hi])]
        if a != base and len(r) > 1 and np.diff(r).min() < S / rate - 16:
            return False
    return True


def pulse_us(edges: dict) -> tuple[float, float]:
    widths = np.concatenate([(f - r) / 16 for r, f in edges.values() if len(r) == len(f)])
    return float(widths.min()), float(widths.max())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grbl-src", default=GRBL_URL, help="where to clone grbl from (a URL or a local clone)")
    ap.add_argument("--cache", type=Path, default=Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "retrofit",
                    help="where grbl is cloned and built (never this repository)")
    ap.add_argument("--top", type=float, default=70_000.0, help="the highest base rate tried")
    ap.add_argument("--ours-only", action="store_true", help="this firmware alone (no grbl)")
    ap.add_argument("--case", default="", help="only the cases whose name starts with this")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    runners = ("ours",) if args.ours_only else ("grbl", "ours")
    grbl = None if args.ours_only else fetch_grbl(args.grbl_src, args.cache)
    hil = None if args.ours_only else build_harness(args.cache)
    machine = load_machine(ROOT / "bench" / "steprate.toml")
    with tempfile.TemporaryDirectory() as tmp:
        ours = fs.build_copy(machine, Path(tmp))
        sizes = {name: subprocess.run(["avr-size", str(e)], check=True, capture_output=True,
                                      text=True).stdout.splitlines()[1].split()[:3]
                 for name, e in (("grbl", grbl), ("ours", ours)) if e is not None}
        sizes.setdefault("grbl", ["0", "0", "0"])
        print((f"grbl 1.1h at {GRBL_COMMIT[:12]} (ATmega328P, 16 MHz): flash "
               f"{int(sizes['grbl'][0]) + int(sizes['grbl'][1])} B, RAM {int(sizes['grbl'][1]) + int(sizes['grbl'][2])} B; "
               if grbl else "") +
              f"this tree's firmware (ATmega2560, 16 MHz, bench/steprate.toml): flash "
              f"{int(sizes['ours'][0]) + int(sizes['ours'][1])} B, RAM {int(sizes['ours'][1]) + int(sizes['ours'][2])} B")
        print("highest clean base-axis rate (steps/s; exact steps, middle-half intervals within "
              "+-1 us (short segments +-10 %), no period below the base period), pulse widths seen:")
        print(f"  {'case':<34}{'grbl 1.1h':>12}{'this firmware':>16}   pulses grbl / ours (us)")
        for name, case in CASES.items():
            if not name.startswith(args.case):
                continue
            best, widths, past = {"grbl": 0.0}, {"grbl": (0.0, 0.0)}, {"grbl": ""}
            for who in runners:
                best[who], widths[who], past[who] = 0.0, (0.0, 0.0), ""
                first = 2_500.0 if case == "segments" else 10_000.0
                for rate in np.arange(first, args.top + 1, 2_500.0):
                    lines, steps, seconds = grbl_lines(case, float(rate))
                    edges = (grbl_run(hil, grbl, lines, seconds) if who == "grbl"
                             else ours_run(ours, machine, lines, steps, seconds))
                    tol = 0.1e6 / rate if case == "segments" else 1.0
                    if not clean(edges, steps, float(rate), tol):
                        made = " ".join(f"{a} {len(edges[a][0])}/{n}" for a, n in steps.items())
                        past[who] = f"{rate:.0f}: steps {made}"
                        break
                    best[who], widths[who] = float(rate), pulse_us(edges)
            print(f"  {name:<34}{best['grbl']:>12.0f}{best['ours']:>16.0f}   "
                  f"{widths['grbl'][0]:.1f}-{widths['grbl'][1]:.1f} / {widths['ours'][0]:.1f}-{widths['ours'][1]:.1f}",
                  flush=True)
            print(f"    first unclean rate: grbl {past['grbl'] or '-'}; this firmware {past['ours'] or '-'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
