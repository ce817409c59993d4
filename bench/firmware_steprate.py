"""Step generation of the firmware in simavr, measured on the pins in cycles, beside the firmware
of an earlier commit (default: the one before the segment buffer) built the same way.

1. For 1, 2, 3 and 4 moving axes, the highest cruise rate at which every step interval of the
   cruise is within +-1 us of the planned period, every pulse within +-1 us of the configured
   width, every moving axis steps on the same edge, and no compare waited for a timer wrap
   (no interval longer than twice the period); the same for one axis with a 5 us pulse (too
   long to be ended inside the tick: compare B's interrupt ends it).
2. At those rates and at 5 kHz on three axes: the CPU share of the interrupts and their cycles
   per step, the longest interrupt and the longest interrupts-off stretch (in the main loop and
   in an interrupt: the worst latency another interrupt can see).
3. The 474-segment circle (3 R10 circles at F1200 on tul-mill, through the link): the time from
   the first step to the last beside the host plan's, and each axis's acceleration over 20 ms
   windows beside its limit (plus the quantisation of counting whole steps).
4. 0.6 s of damaged frames during FMOV X30 on tul-mill: NAKs answered, the end position, and how
   far any step moved from the quiet run's.
5. A thread pass on mitic-lathe (ISTP, 0.5 mm a turn, 80 Z steps) at 300 and 1 200 rpm: the
   delay from each encoder count to its step's rise and the longest interrupts-off stretch.
6. Flash and RAM of each shipped machine.
7. The rates the firmware keeps while the host polls RDST every 2 ms and every 20 ms: for 1-4
   axes stepping together and for Bresenham ratios, the highest base rate at which a 0.25 s move
   ends on its steps with every cruise interval within +-2 us and no stall (its own clamp, the
   KEEP_RATE tables of firmware/planner.c, lifted in a copy); beside them the tables themselves.
8. Thread pulses on mitic-lathe at its top spindle speed (2 000 rpm): their shortest width.

    python bench/firmware_steprate.py [--base COMMIT[,COMMIT...]] [--quick] [--only PARTS]

PARTS: a comma-separated choice of rates, thread, circle, garbage, sizes, keep, pulses (all).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from retrofit.commands import parse_command  # noqa: E402
from retrofit.firmware import runs as fr  # noqa: E402
from retrofit.firmware import sim as fs  # noqa: E402
from retrofit.link import IMMEDIATE, QUEUED, encode_command, encode_frame, seq_byte  # noqa: E402
from retrofit.link.script import KEEPALIVE_S, ScriptedHost  # noqa: E402
from retrofit.machine.config import load_machine  # noqa: E402

MACHINE = ROOT / "bench" / "steprate.toml"
S = fs.F_CPU


def frames(machine, texts: list[tuple[int, str]]) -> list[tuple[int, bytes]]:
    """The frames of ``texts`` at their cycles, bound to the firmware's sessions, and a keep-alive
    every 0.2 s so the heartbeat (docs/protocol.md §5.1) does not stop a long move."""
    host = ScriptedHost(machine)
    out = [(1_000_000, host.sync(QUEUED)), (1_000_000, host.sync(IMMEDIATE))]
    out += [(cycle, host.frame(text)) for cycle, text in texts]
    last = max(cycle for cycle, _ in out)
    every = int(KEEPALIVE_S * S)
    out += [(c, host.keepalive()) for c in range(1_100_000, last + 40 * every, every)]
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
    pulse_us = machine.axis(axes[0]).pulse_high_ticks * machine.tick_us
    rises, falls, _ = fs.step_times(log, machine, axes[0])
    if len(rises) != steps or len(falls) != steps:
        return False
    for other in axes[1:]:
        r, _, _ = fs.step_times(log, machine, other)
        if len(r) != steps or np.abs(r - rises).max() > 16:
            return False
    widths = (falls - rises) / 16.0
    period = 1e6 / rate
    cruise = np.diff(rises)[steps // 4: 3 * steps // 4] / 16.0
    no_wrap = np.diff(rises).max() / 16.0 < 2 * max(period, 1e6 / 14000.0)
    return (np.abs(widths - pulse_us).max() <= 1.0 and np.abs(cruise - period).max() <= 1.0
            and no_wrap)


def highest(elf: Path, machine, axes: str, rates: list[float]) -> float:
    best = 0.0
    for rate in rates:
        log, steps = run_move(elf, machine, axes, rate)
        if not clean(log, machine, axes, rate, steps):
            break
        best = rate
    return best


def idle_isr(elf: Path, machine) -> float:
    """Interrupt cycles per cycle with nothing moving: the 1 ms clock and the link's bytes."""
    script = frames(machine, [(2_000_000, "FFDR F100")])
    st = fs.Harness(elf, machine, script=script, cycles=3_000_000, stats=True).run().stats
    return st["isr_cycles"] / st["cycles"]


def interrupts(elf: Path, machine, axes: str, rate: float, idle: float) -> str:
    log, steps = run_move(elf, machine, axes, rate, stats=True)
    st = log.stats
    rises, _, _ = fs.step_times(log, machine, axes[0])
    span = int(rises[-1] - rises[0])
    share = (st["isr_cycles"] - idle * (st["cycles"] - span)) / span
    return (f"interrupts {100 * share:5.1f} % of the CPU while it moves ({share * span / (len(rises) - 1):.0f} "
            f"cycles a step), longest time in an ISR "
            f"{st['isr_longest'] / 16:6.1f} us (interrupts on after the pins), interrupts off at "
            f"most {st['off_main_longest'] / 16:4.1f} us in the main loop, "
            f"{st['off_isr_longest'] / 16:4.1f} us in an ISR")


def thread(sources: dict[str, Path], tmp: Path) -> None:
    """A thread pass clocked by the encoder on mitic-lathe, for each firmware."""
    lathe = load_machine("mitic-lathe")
    print("thread pass on mitic-lathe (SPIN, ISTP, PFDR F0.5, PMOV Z-1: 80 steps on encoder counts):")
    for name, src in sources.items():
        elf = fs.build_copy(lathe, tmp / "thread" / name.replace(" ", "_"), src)
        for rpm in (300, 1200):
            script = frames(lathe, [(3_100_000, f"SPIN S{rpm} D1"), (3_200_000, "ISTP"),
                                    (3_300_000, "PFDR F0.5"), (3_400_000, "PMOV Z-1")])
            log = fs.Harness(elf, lathe, script=script, cycles=int((0.3 + 240 / rpm) * S),
                             spindle_rpm=rpm, stats=True).run()
            rises, _, _ = fs.step_times(log, lathe, "Z")
            if not len(rises):
                print(f"  {name:<16} {rpm:>5} rpm: no step (the frames were not understood)")
                continue
            iclk = np.array([c for c, port, bit, level in log.inputs
                             if (port, bit, level) == ("D", 0, 1)])
            delay = (rises - iclk[np.searchsorted(iclk, rises) - 1]) / 16
            print(f"  {name:<16} {rpm:>5} rpm: {len(rises)} steps, each {delay.min():.1f}-"
                  f"{delay.max():.1f} us after its count; interrupts off at most "
                  f"{log.stats['off_isr_longest'] / 16:4.1f} us in an ISR, "
                  f"{log.stats['off_main_longest'] / 16:4.1f} us in the main loop")


def circle() -> None:
    """The 474-segment circle through the link, its time beside the host plan's."""
    from retrofit.gcode import compile_program
    from retrofit.run.program import plan_compiled
    machine = load_machine("tul-mill")
    text = "G21 G90 G17\nG0 X30 Y20\nG1 F1200\n" + "G2 X30 Y20 I-10 J0\n" * 3 + "M2\n"
    program = compile_program(text, machine, file="circle.ngc")
    _, plan = plan_compiled(program, machine)
    elf = fs.build("tul-mill")
    log, remote = fr.send_through_link(elf, machine, program.commands)
    rx, _, _ = fs.step_times(log, machine, "X")
    ry, _, _ = fs.step_times(log, machine, "Y")
    both = np.sort(np.concatenate([rx, ry]))
    took = (both[-1] - both[0]) / S
    moves = sum(type(c).__name__ == "PMov" for c in program.commands)
    print(f"circle: {moves} PMOV segments + the rapid to the start, {took:.3f} s on the firmware, "
          f"{plan.end_s:.3f} s in the host plan ({100 * (took / plan.end_s - 1):+.1f} %); "
          f"end {remote['position_steps']}; {remote['link']['busy']} BUSY answers waited out")
    window = 0.02
    for name, rises in (("X", rx), ("Y", ry)):
        a = machine.axis(name)
        limit = a.max_accel_mm_s2 * a.steps_per_mm
        seen = fr.windowed_accel(rises, window)
        print(f"  {name}: acceleration over {window * 1000:.0f} ms windows at most {seen:8.0f} "
              f"steps/s^2; limit {limit:.0f} + quantisation {2 / window ** 2:.0f}")
    report = fs.report(log, machine)
    print(f"  driver-timing violations on the pins: {len(report['violations'])}")


def garbage() -> None:
    machine = load_machine("tul-mill")
    elf = fs.build("tul-mill")
    end = int(1.0 * S)
    bad = bytearray(encode_frame(seq_byte(QUEUED, 5), encode_command(parse_command("FMOV X1"), machine)))
    bad[6] ^= 0x10
    sent = int(0.6 * S / 35_200)

    def run(noise: bool):
        texts = [(3_200_000, "FMOV X30"), (end - 200_000, "RDPS")]
        script = frames(machine, texts)
        if noise:
            script += [(3_400_000 + k * 35_200, bytes(bad)) for k in range(sent)]
        return fs.Harness(elf, machine, script=script, cycles=end).run()

    quiet, noisy = run(False), run(True)
    answers = ScriptedHost(machine).replies(noisy.answer_bytes())
    naks = sum(type(a).__name__ == "Nak" for a in answers)
    q, _, _ = fs.step_times(quiet, machine, "X")
    n, _, _ = fs.step_times(noisy, machine, "X")
    same = len(q) == len(n)
    worst = np.abs(n - q).max() / 16 if same else float("nan")
    tail = np.abs(np.diff(n)[-200:] - np.diff(q)[-200:]).max() / 16 if same else float("nan")
    print(f"garbage: {sent} damaged frames over 0.6 s during FMOV X30: {naks} NAKs, end "
          f"{dict(answers[-1].steps)['X']} steps (3000 asked), {len(n)} steps (quiet run {len(q)}); "
          f"every step within {worst:.2f} us of the quiet run, the last 200 intervals within "
          f"{tail:.2f} us")


def sizes() -> None:
    for name in fs.supported_machines():
        elf = fs.build(name)
        out = subprocess.run(["avr-size", str(elf)], check=True, capture_output=True, text=True).stdout
        text, data, bss = (int(v) for v in out.splitlines()[1].split()[:3])
        print(f"size {name}: flash {text + data} B ({100 * (text + data) / (248 * 1024):.1f} % of 248 KiB), "
              f"RAM {data + bss} B ({100 * (data + bss) / 8192:.1f} % of 8 KiB) before the stack")


KEEP_CASES = [(1.0,), (1.0, 1.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (1.0, 0.5),
              (1.0, 0.5, 0.25), (1.0, 0.67, 0.67), (1.0, 0.5, 0.25, 0.125)]


def polled(elf: Path, machine, ratios, rate: float, poll_ms: float, secs: float = 0.25) -> bool:
    """A ``secs`` move at ``rate`` on the base axis, RDST every ``poll_ms``: exact on the pins,
    every cruise interval within +-2 us, no interval 100 us longer than the period."""
    axes = "XYZA"[:len(ratios)]
    steps = int(rate * secs)
    dist = [round(steps * r) for r in ratios]
    feed = rate * math.sqrt(sum(r * r for r in ratios)) * 60 / 1000.0
    texts = [(2_000_000, f"FFDR F{feed:.4f}"),
             (2_200_000, "FMOV " + " ".join(f"{a}{d / 1000:g}" for a, d in zip(axes, dist)))]
    end = 2_200_000 + int(secs * S * 1.2) + 2_000_000
    texts += [(t, "RDST") for t in range(2_200_000, end - 1_000_000, int(poll_ms * S / 1000))]
    log = fs.Harness(elf, machine, script=frames(machine, texts), cycles=end).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    if [len(fs.step_times(log, machine, a)[0]) for a in axes] != dist:
        return False
    gaps = np.diff(rises)
    cruise = gaps[len(gaps) // 8: -len(gaps) // 8]
    return gaps.max() - S / rate < 1600 and np.abs(cruise - S / rate).max() <= 32


def keep(tmp: Path, quick: bool) -> None:
    """The highest rate kept under polling, with the firmware's own clamp lifted (item 7)."""
    import re
    import shutil
    machine = load_machine(MACHINE)
    copy = tmp / "keep" / "firmware"
    shutil.copytree(fs.FIRMWARE, copy, ignore=shutil.ignore_patterns("build", "*.elf", "*.hex"))
    planner = (copy / "planner.c").read_text()
    tables = re.findall(r"#define (KEEP_RATE_\w+)\s+(\{[^}]*\})", planner)
    lifted = "\n".join(f"#define {n} {{ 1e6f, 1e6f, 1e6f, 1e6f, 1e6f }}" for n, _ in tables)
    (copy / "planner.c").write_text(planner.replace("#ifndef KEEP_RATE_PLAIN", lifted + "\n#ifndef KEEP_RATE_PLAIN"))
    elf = fs.build_copy(machine, tmp / "keep")
    step = 5000 if quick else 2500
    print("rates kept under RDST polling (steps/s of the base axis; 0.25 s moves, exact steps, "
          "+-2 us intervals, no stall), the clamp lifted:")
    print(f"  {'ratios':<22}{'2 ms':>10}{'20 ms':>10}")
    for ratios in KEEP_CASES:
        row = []
        for poll_ms in (2.0, 20.0):
            best = 0
            for rate in range(30_000, 70_001, step):
                if not polled(elf, machine, ratios, rate, poll_ms):
                    break
                best = rate
            row.append(best)
        print(f"  {':'.join(f'{r:g}' for r in ratios):<22}{row[0]:>10}{row[1]:>10}")
    for name, table in tables:
        print(f"  firmware/planner.c {name} (1-5 moving axes): {table}")


def pulses() -> None:
    """Thread pulses at mitic-lathe's top spindle speed (item 8)."""
    lathe = load_machine("mitic-lathe")
    elf = fs.build("mitic-lathe")
    rpm = lathe.parts["spindle"].max_rpm
    script = frames(lathe, [(3_100_000, f"SPIN S{rpm:g} D1"), (3_200_000, "ISTP"),
                            (3_300_000, "PFDR F0.5"), (3_400_000, "PMOV Z-4")])
    log = fs.Harness(elf, lathe, script=script, cycles=int((0.3 + 12 * 60 / rpm) * S),
                     spindle_rpm=rpm).run()
    rises, falls, _ = fs.step_times(log, lathe, "Z")
    width = (falls - rises) / 16
    print(f"thread pulses on mitic-lathe at {rpm:g} rpm ({lathe.parts['spindle'].encoder_counts_per_rev} "
          f"counts a turn): {len(rises)} steps, each {width.min():.1f}-{width.max():.1f} us high "
          f"({lathe.axis('Z').pulse_high_ticks * lathe.tick_us:g} us configured)")


def long_pulse(machine_path: Path, tmp: Path):
    """The bench machine with a 5 us pulse (ended by compare B's interrupt, not in the tick)."""
    text = machine_path.read_text().replace("pulse_high_ticks = 2", "pulse_high_ticks = 5")
    path = tmp / "steprate5.toml"
    path.write_text(text.replace('name = "steprate"', 'name = "steprate5"'))
    return load_machine(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="6f10b11,d4e08f1,5ebf24e",
                    help="the commits whose firmware runs beside (default: before the segment "
                         "buffer, before the common tick ran whole, before the encoder's "
                         "interrupt let interrupts in)")
    ap.add_argument("--quick", action="store_true", help="a coarser sweep")
    ap.add_argument("--only", default="rates,thread,circle,garbage,sizes,keep,pulses",
                    help="the parts to run, comma-separated")
    args = ap.parse_args()
    parts = set(args.only.split(","))
    if "keep" in parts or "pulses" in parts:
        with tempfile.TemporaryDirectory() as tmp:
            if "keep" in parts:
                keep(Path(tmp), args.quick)
            if "pulses" in parts:
                pulses()
    if not parts & {"rates", "thread"}:
        for name, run in (("circle", circle), ("garbage", garbage), ("sizes", sizes)):
            if name in parts:
                run()
        return 0
    machine = load_machine(MACHINE)
    step = 5000 if args.quick else 2500
    rates = [float(r) for r in range(5000, 90001, step)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        sources = {}
        for base in args.base.split(","):
            subprocess.run(f"mkdir -p {tmp / base} && git -C {ROOT} archive {base} firmware | "
                           f"tar -x -C {tmp / base}", shell=True, check=True)
            sources[f"base {base}"] = tmp / base / "firmware"
        sources["this tree"] = fs.FIRMWARE
        m5 = long_pulse(MACHINE, tmp)
        elves, elves5 = {}, {}
        for name, src in sources.items():
            key = name.replace(" ", "_")
            elves[name] = fs.build_copy(machine, tmp / "build" / key, src)
            elves5[name] = fs.build_copy(m5, tmp / "build5" / key, src)
        print("highest clean step rate (steps/s of each axis; +-1 us intervals and pulse width, "
              "no wrap):")
        print(f"  {'axes':<16}" + "".join(f"{name:>18}" for name in elves))
        best = {}
        for n in range(1, 5):
            axes = "XYZA"[:n]
            row = [highest(elf, machine, axes, rates) for elf in elves.values()]
            best[axes] = row[-1]
            print(f"  {n:<16}" + "".join(f"{r:>18.0f}" for r in row))
        row = [highest(elf, m5, "X", rates) for elf in elves5.values()]
        print(f"  {'1, 5 us pulse':<16}" + "".join(f"{r:>18.0f}" for r in row))
        print("interrupts (cycles at 16 MHz, measured by the harness):")
        idle = {name: idle_isr(elf, machine) for name, elf in elves.items()}
        for name, elf in elves.items():
            print(f"  {name:<16} 3 axes at 5 kHz: {interrupts(elf, machine, 'XYZ', 5000.0, idle[name])}")
        for name, elf in elves.items():
            if name != "this tree":
                print(f"  {name:<16} 1 axis at 40 kHz: {interrupts(elf, machine, 'X', 40000.0, idle[name])}")
        for axes, rate in best.items():
            if rate:
                print(f"  {'this tree':<16} {len(axes)} axes at {rate / 1000:g} kHz: "
                      f"{interrupts(elves['this tree'], machine, axes, rate, idle['this tree'])}")
        print(f"  {'this tree':<16} 1 axis at 60 kHz: "
              f"{interrupts(elves['this tree'], machine, 'X', 60000.0, idle['this tree'])}")
        if "thread" in parts:
            thread(sources, tmp)
    for name, run in (("circle", circle), ("garbage", garbage), ("sizes", sizes)):
        if name in parts:
            run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
