"""How fast the G-code interpreter compiles a CAM program, beside other parsers of the same file.

Usage: ``python3 bench/gcode_speed.py [--lines 40000]``

Writes a CAM program shaped like Fusion 360 / FreeCAD output (a preamble, operation comments,
3D-contour ``G1 X Y Z`` lines with 3-4 decimals, modal axis-only lines, feed changes, ``G2`` arcs
with I J, ``G0`` retracts) and, in one run, reads it with:

* ``retrofit.gcode`` -- the whole interpreter: modal state, offsets, soft limits, arcs into
  chords, commands out (a run's moves and chords as arrays, ``retrofit/canon/moves.py``: every
  number final, no object per command); again with every command read as an object (what a
  reader of ``Program.commands`` one by one pays); and with runs of plain lines read by the
  pattern instead of the compiled scanner (``retrofit/gcode/plainscan.py``);
* a naive regex reader -- every word of every line to a float, no semantics at all (the floor
  any Python reader pays);
* ``gcodeparser`` and ``pygcode`` from PyPI where installed (``pip install gcodeparser pygcode``);
* LinuxCNC's ``rs274`` where installed (its CPU time as a child process).

Figures are blocks (program lines) per CPU-second (``time.process_time``). It also times two
refusals that must come before any chord is built: an arc far outside the soft limits, and an
arc inside them that would need more chords than the interpreter allows.
"""

from __future__ import annotations

import argparse
import math
import re
import resource
import shutil
import subprocess
import tempfile
import time
import warnings
from pathlib import Path

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MACHINE = Path(__file__).resolve().parent.parent / "tests" / "gcode" / "rs274-mill.toml"
_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def cam_program(lines: int) -> str:
    """A CAM-like program of about ``lines`` lines."""
    out = ["%", "(retrofit bench: CAM-style 3D contour)", "(T1  D=6. CR=0. - ZMIN=-1.5 - flat end mill)",
           "G90 G94 G17 G91.1", "G21", "T1 M6", "S12000 M3", "G54", "G0 X0 Y0 Z5"]
    k, x, y, after_arc = 0, 0.0, 0.0, False
    while len(out) < lines - 3:
        t = k * 0.01
        nx, ny = 50 + 40 * math.cos(t), 50 + 40 * math.sin(t * 1.3)
        z = -1 - 0.5 * math.sin(t * 3)
        if k % 500 == 0:
            out.append(f"(2D Contour{k // 500 + 1})")
        if k % 200 == 0:
            out += ["G0 Z5", f"G0 X{nx:.3f} Y{ny:.3f}", f"G1 Z{z:.3f} F300"]
        elif k % 50 == 0:                         # a clockwise arc about (x - 3, y + 4)
            cx, cy, a = x - 3.0, y + 4.0, -0.6
            nx = cx + (x - cx) * math.cos(a) - (y - cy) * math.sin(a)
            ny = cy + (x - cx) * math.sin(a) + (y - cy) * math.cos(a)
            out.append(f"G2 X{nx:.3f} Y{ny:.3f} I-3.0 J4.0 F{900 + k % 7 * 10}")
            after_arc = True
        elif after_arc:
            out.append(f"G1 X{nx:.3f} Y{ny:.3f} Z{z:.3f}")
            after_arc = False
        elif k % 9 == 0:
            out.append(f"X{nx:.3f} Y{ny:.3f} Z{z:.4f} F1000")
        else:
            out.append(f"X{nx:.3f} Y{ny:.3f} Z{z:.3f}")
        x, y = round(nx, 3), round(ny, 3)
        k += 1
    return "\n".join(out + ["G0 Z5", "M5", "M30", "%"]) + "\n"


def naive(text: str) -> int:
    """Every word of every line as (letter, float), comments dropped: no semantics."""
    count = 0
    for line in text.splitlines():
        code = line.split(";")[0]
        code = re.sub(r"\([^)]*\)", "", code).upper()
        count += len([(a, float(b)) for a, b in _WORD.findall(code)])
    return count


def by_pattern(text: str, machine) -> int:
    """The interpreter with the compiled scanner of plain lines turned off."""
    from retrofit.gcode import plainscan
    ready = plainscan._scanner_ready
    plainscan._scanner_ready = lambda work: False
    try:
        return len(compile_program(text, machine, "bench.ngc").commands)
    finally:
        plainscan._scanner_ready = ready


def with_gcodeparser(text: str) -> int:
    import gcodeparser
    return sum(1 for _ in gcodeparser.parse_gcode_lines(text))


def with_pygcode(text: str) -> int:
    import pygcode
    return sum(len(pygcode.Line(line).block.words) for line in text.splitlines())


def with_pygcode_machine(text: str) -> int:
    import pygcode
    machine = pygcode.Machine()
    for line in text.splitlines():
        machine.process_block(pygcode.Line(line).block)
    return 1


def cpu(fn, *args) -> tuple[float, object]:
    started = time.process_time()
    result = fn(*args)
    return time.process_time() - started, result


def time_rs274(path: Path) -> float | None:
    if shutil.which("rs274") is None:
        return None
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["rs274", "-g", str(path)], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def row(name: str, seconds: float | None, blocks: int, note: str) -> None:
    if seconds is None:
        print(f"{name:<26}{'-':>8}{'-':>14}   {note}")
    else:
        print(f"{name:<26}{seconds:>8.3f}{blocks / max(seconds, 1e-9):>14,.0f}   {note}")


def readers(text: str, machine):
    """(name, function, what it does) of every reader timed, retrofit first."""
    yield "retrofit.gcode", lambda t: len(compile_program(t, machine, "bench.ngc").commands), \
        "interpreter: modal state, offsets, limits, arcs -> {} commands"
    yield "retrofit, objects", lambda t: sum(1 for _ in compile_program(t, machine, "bench.ngc").commands), \
        "the same, every command then read as an object ({} commands)"
    yield "retrofit, pattern", lambda t: by_pattern(t, machine), \
        "the same, runs of plain lines read by the pattern, not the compiled scanner ({} commands)"
    yield "naive regex", naive, "words to floats only, no semantics ({} words)"
    for name, fn, what in (("gcodeparser", with_gcodeparser, "parse; yields {} command lines "
                            "(axis-only lines dropped)"),
                           ("pygcode Line", with_pygcode, "parse only ({} words)"),
                           ("pygcode Machine", with_pygcode_machine, "parse + modal state, positions")):
        try:
            __import__(name.split()[0])
        except ImportError:
            yield name, None, "not installed (pip install gcodeparser pygcode)"
            continue
        yield name, fn, what


def refusals(machine) -> None:
    """Arcs that must be refused from their geometry, before any chord is built."""
    for what, program in (("huge arc (outside the limits)", "G0 X50 Y50\nG2 X50 Y50 I900000000 F100\n"),
                          ("1000-turn arc (too many chords)", "G0 X0 Y0\nG2 X0 Y0 I2000 P1000 F100\n")):
        started = time.process_time()
        try:
            compile_program(program, machine)
        except GcodeError as exc:
            spent = time.process_time() - started
            print(f"{what}: refused in {spent * 1e3:.2f} CPU-ms: {exc}")
        else:
            print(f"{what}: compiled (expected a refusal)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=40_000)
    args = parser.parse_args()
    machine = load_machine(MACHINE)
    text = cam_program(args.lines)
    blocks = text.count("\n")
    print(f"program: {blocks} lines, CAM-style (G1 X Y Z with 3-4 decimals, G2 I J every 50 moves, "
          f"comments)")
    print(f"{'reader':<26}{'CPU s':>8}{'blocks/CPU-s':>14}   what it does")
    warnings.simplefilter("ignore")
    spent = {}
    for name, fn, what in readers(text, machine):
        if fn is None:
            row(name, None, blocks, what)
            continue
        seconds, result = cpu(fn, text)
        spent[name] = seconds
        row(name, seconds, blocks, what.format(result))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.ngc"
        path.write_text(text)
        rs = time_rs274(path)
    row("LinuxCNC rs274", rs, blocks, "C++ interpreter, prints every canon call" if rs is not None
        else "not installed")
    if rs is not None:
        print(f"retrofit / rs274, blocks per CPU-second in this run: {rs / spent['retrofit.gcode']:.2f} "
              f"({rs / spent['retrofit, objects']:.2f} with every command read as an object)")
    refusals(machine)


if __name__ == "__main__":
    main()
