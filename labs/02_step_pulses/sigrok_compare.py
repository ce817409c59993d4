"""Lab 02, part 4: compare a logic-analyser capture of the step and direction pins with the VCD the
lab writes.

Wire the analyser's inputs D0..D7 to the parallel port's data pins 2..9 (D0 on pin 2, D1 on pin 3,
...) and its ground to pin 18..25; record with sigrok (README, part 4). The lab's VCD says in its
first comment which data bit carries which signal ("X.step = bit 2 pin 4"), so channel Dn of the
capture is compared with the signal on bit n. Both are turned into edge lists, in seconds from the
first edge, and matched edge by edge: every edge the same way and within one sample period of
the capture (the analyser sees an edge at the first sample after it).

    python3 sigrok_compare.py capture/lathe_steps.sr out/lathe_steps.vcd
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
RECORDED = HERE / "capture" / "lathe_steps.sr"
_BIT = re.compile(r"([A-Za-z0-9_.]+) = bit (\d+)")


def read_vcd(path) -> tuple[dict[str, list[tuple[float, int]]], str]:
    """Every signal of a VCD file as (seconds, value) changes, and the file's first comment."""
    from vcdvcd import VCDVCD
    vcd = VCDVCD(str(path))
    scale = float(vcd.timescale["timescale"])
    signals = {name.split(".", 1)[1]: [(t * scale, int(v)) for t, v in vcd[name].tv] for name in vcd.signals}
    text = Path(path).read_text(encoding="utf-8", errors="replace")
    comment = re.search(r"\$comment(.*?)\$end", text, re.S)
    return signals, comment[1].strip() if comment else ""


def read_capture(path) -> tuple[dict[str, list[tuple[float, int]]], float]:
    """A sigrok session file (``.sr``) as signals and its sample period, through ``sigrok-cli -O vcd``."""
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "capture.vcd"
        done = subprocess.run(["sigrok-cli", "-i", str(path), "-O", "vcd", "-o", str(out)],
                              capture_output=True, text=True)
        if done.returncode != 0 or not out.is_file():
            raise SystemExit(f"{path}: sigrok-cli could not read it: {done.stderr.strip()[:200]}")
        signals, comment = read_vcd(out)
    rate = re.search(r"at ([\d.]+) (k|M)?Hz", comment)
    hertz = float(rate[1]) * {"k": 1e3, "M": 1e6, None: 1.0}[rate[2]] if rate else 0.0
    return signals, (1.0 / hertz if hertz else 0.0)


def edges(changes) -> list[tuple[float, int]]:
    """The changes of a signal that really change its level (not the first value)."""
    out, level = [], None
    for t, v in changes:
        if level is not None and v != level:
            out.append((t, v))
        level = v
    return out


@dataclass
class Match:
    """One signal compared: edges in the lab's VCD and in the capture, and the worst time difference."""

    signal: str
    channel: str
    lab_edges: int
    captured_edges: int
    worst_s: float
    ok: bool


def compare(capture, vcd) -> list[Match]:
    """Compare the capture's channels D<bit> with the lab VCD's signals, edge by edge."""
    lab, comment = read_vcd(vcd)
    captured, sample_s = read_capture(capture)
    bits = {name: f"D{bit}" for name, bit in _BIT.findall(comment)}
    lab_edges = {s: edges(lab[s]) for s in lab}
    cap_edges = {s: edges(captured.get(bits.get(s, s)) or captured.get(s, [])) for s in lab}   # Dn or the name
    lab_zero = min((e[0][0] for e in lab_edges.values() if e), default=0.0)
    cap_zero = min((e[0][0] for e in cap_edges.values() if e), default=0.0)
    results = []
    for signal in lab:
        ours = [(t - lab_zero, v) for t, v in lab_edges[signal]]
        theirs = [(t - cap_zero, v) for t, v in cap_edges[signal]]
        worst = max((abs(a[0] - b[0]) for a, b in zip(ours, theirs)), default=0.0)
        same = len(ours) == len(theirs) and all(a[1] == b[1] for a, b in zip(ours, theirs))
        results.append(Match(signal, bits.get(signal, signal), len(ours), len(theirs), worst,
                             same and worst <= sample_s + 1e-12))
    return results


def main(argv=None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    capture = Path(args[0]) if args else RECORDED
    vcd = Path(args[1]) if len(args) > 1 else HERE / "out" / "lathe_steps.vcd"
    results = compare(capture, vcd)
    for r in results:
        mark = "same" if r.ok else "DIFFERENT"
        print(f"  {r.signal:8s} ({r.channel}): {r.lab_edges} edges in the lab's VCD, {r.captured_edges} "
              f"captured, worst time difference {r.worst_s * 1e6:.1f} us: {mark}")
    return 0 if all(r.ok for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
