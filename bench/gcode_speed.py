"""How fast the G-code interpreter compiles a CAM program, beside LinuxCNC's own interpreter.

Usage: ``python3 bench/gcode_speed.py [--lines 40000]``

Writes a CAM-style program (a CAM preamble, then 3D-contour G1 moves with feed changes, G2/G3
arcs, G0 retracts -- the shape of FreeCAD / Fusion output), compiles it with retrofit and, where
LinuxCNC is installed, runs the same file through ``rs274`` in the same run. Figures are blocks
(program lines) per CPU-second: this process's CPU time for retrofit, the child's for rs274.
It also times the refusal of ``G2 X0 Y0 I900000000``: the limit check on the arc's geometry comes
before any chord is built.
"""

from __future__ import annotations

import argparse
import math
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from retrofit.config import load_machine
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program

MACHINE = Path(__file__).resolve().parent.parent / "tests" / "gcode" / "rs274-mill.toml"


def cam_program(lines: int) -> str:
    """A CAM-like program of about ``lines`` lines."""
    out = ["%", "(bench: CAM-style contour)", "G90 G94 G40 G49 G80 G54 G91.1 G17 G21", "T1 M6",
           "S12000 M3", "G0 X0 Y0 Z5"]
    k = 0
    while len(out) < lines - 3:
        t = k * 0.01
        x, y = 50 + 40 * math.cos(t), 50 + 40 * math.sin(t * 1.3)
        z = -1 - 0.5 * math.sin(t * 3)
        if k % 200 == 0:
            out += ["G0 Z5", f"G0 X{x:.4f} Y{y:.4f}", f"G1 Z{z:.4f} F300"]
        elif k % 50 == 0:
            out.append(f"G2 X{x:.4f} Y{y:.4f} R30 F{900 + k % 7 * 10}")
        else:
            out.append(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f}")
        k += 1
    return "\n".join(out + ["G0 Z5", "M5", "M30", "%"]) + "\n"


def time_retrofit(text: str, machine) -> tuple[float, int]:
    started = time.process_time()
    program = compile_program(text, machine, "bench.ngc")
    return time.process_time() - started, len(program.commands)


def time_rs274(path: Path) -> float | None:
    if shutil.which("rs274") is None:
        return None
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["rs274", "-g", str(path)], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=40_000)
    args = parser.parse_args()
    machine = load_machine(MACHINE)
    text = cam_program(args.lines)
    blocks = text.count("\n")
    cpu, commands = time_retrofit(text, machine)
    print(f"program: {blocks} lines (CAM-style contour, arcs every 50 moves)")
    print(f"{'interpreter':<22}{'CPU s':>8}{'blocks/CPU-s':>15}")
    print(f"{'retrofit.gcode':<22}{cpu:>8.3f}{blocks / cpu:>15,.0f}   ({commands} commands)")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.ngc"
        path.write_text(text)
        rs = time_rs274(path)
    if rs is None:
        print(f"{'LinuxCNC rs274':<22}{'(not installed)':>23}")
    else:
        print(f"{'LinuxCNC rs274':<22}{rs:>8.3f}{blocks / rs:>15,.0f}   (prints every canon call)")
    started = time.process_time()
    try:
        compile_program("G0 X50 Y50\nG2 X50 Y50 I900000000 F100\n", machine)
    except GcodeError as exc:
        refused = time.process_time() - started
        print(f"huge arc refused in {refused * 1e3:.2f} CPU-ms before any chord: {exc}")


if __name__ == "__main__":
    main()
