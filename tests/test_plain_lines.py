"""Plain CAM lines take a short way through the interpreter (a run of canonical lines by one
pattern and arrays, a single plain line without a block object): the same commands, lines and
refusals as the full translator."""

import re

import numpy as np
import pytest

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program, plainrun, program
from retrofit.machine.config import load_machine

MILL = load_machine("engraver")
LATHE = load_machine("chivu-lathe")


def full_way(monkeypatch):
    """Every line through make_block and the translator."""
    monkeypatch.setattr(program, "take_run", lambda *args: 0)
    monkeypatch.setattr(program, "run_plain", lambda *args: None)


def listing_or_refusal(text: str, machine) -> str:
    try:
        return compile_program(text, machine, "p.ngc").listing()
    except GcodeError as exc:
        return f"refused: {exc}"


def zigzag(n: int, start: int = 0) -> list[str]:
    return [f"X{10 + (i % 7) * 0.125:.3f} Y{10 + (i % 5) * 0.2:.4f}" + (f" F{900 + i}" if i % 11 == 0 else "")
            for i in range(start, start + n)]


PROGRAMS = {
    "runs": ["G21 G90 G17", "G0 X10 Y10 Z-1", "G1 Z-2 F300"] + zigzag(40) + ["G0 Z-1"] + zigzag(30, 5),
    "inch": ["G20 G90", "G0 X0.5 Y0.5", "G1 X0.6 F20"] + [f"X{0.5 + i * 0.01:.3f} Y{0.5 + i % 3 * 0.01:.3f}"
                                                         for i in range(30)],
    "g0-g1-mix": ["G21 G90 F600"] + [f"G{i % 2} X{5 + i % 9:.1f} Y{5 + i % 4:.1f}" for i in range(50)],
    "feeds-alone": ["G21 G90", "G1 X5 Y5 F100", "F200", "X6", "G1", "F300", "Y7", "G0", "X1"],
    "g91": ["G21 G91 G1 F500"] + [f"X0.{i % 10} Y-0.{i % 7}" for i in range(40)],
    "offsets": ["G21 G90", "G10 L2 P1 X5 Y-3", "G54", "G92 X1", "G1 F400"] + zigzag(25),
    "no-motion-mode": ["G21 G90", "X5 Y5", "X6 Y6", "G1 X7 F100", "X8"],
    "feed-zero": ["G21 G90 G1 F0"] + zigzag(20),
    "outside-limits": ["G21 G90 G1 F500"] + zigzag(20) + ["X10 Y-999"] + zigzag(10),
    "huge-value": ["G21 G90 G1 F500"] + zigzag(10) + ["X1e10"] + zigzag(5),
    "axis-not-on-machine": ["G21 G90 G1 F500"] + zigzag(10) + ["X1 A5"],
    "word-twice": ["G21 G90 G1 F500"] + zigzag(10) + ["X1 X2"],
    "arcs": ["G21 G90 G17 G91.1", "G0 X50 Y50 Z1", "G1 Z-1 F300"] + zigzag(20) + [
        "G1 X20 Y20", "G2 X25 Y25 I5 J0 F700", "(a comment)", "G1 X30 Y30", "G3 X35 Y35 R5", "X40 Y40 R-5",
        "G1 X40 Y30", "G2 X40 Y30 Z-2 I0 J5", "G2 X40 Y30 I0 J2 P3", "G3 X41.5 Y30.25 I.75 J.125 F650",
        "G1"] + zigzag(10) + ["G1 X20 Y20", "G2 X17 Y23 J3 I0", "G1 X40 Y40 Z0"],
    "arc-centres-absolute": ["G21 G90 G17 G90.1", "G10 L2 P1 X5", "G0 X20 Y20", "G1 F400"] + zigzag(5) + [
        "G1 X20 Y20", "G2 X25 Y25 I25 J20", "G3 X20 Y30 I25 J30", "G1"] + zigzag(5),
    "arc-inch": ["G20 G90 G17 G91.1", "G0 X0.5 Y0.5", "G1 X0.6 F20", "G2 X0.7 Y0.5 I0.05 J0", "G1 X0.8 Y0.6",
                 "X0.9"],
    "arc-zx-plane": ["G21 G90 G18 G91.1", "G0 X20 Y20 Z0", "G1 F300"] + zigzag(5) + [
        "G1 X20 Z0", "G2 X24 Z0 I2 K0", "G1 X20"] + zigzag(3),
    "arc-radius-off": ["G21 G90 G17 G91.1 G1 F500"] + zigzag(12) + ["G2 X20 Y20 I5 J0"] + zigzag(5),
    "arc-outside-limits": ["G21 G90 G17 G91.1 G1 F500"] + zigzag(12) + ["G1 X20 Y20", "G2 X20 Y20 I-15 J0"]
    + zigzag(5),
    "arc-modal-no-centre": ["G21 G90 G17 G91.1 G1 F500"] + zigzag(8) + ["G1 X20 Y20", "G2 X25 Y25 I5 J0", "X30 Y30"],
    "arc-after-rapids": ["G21 G90 G17 G91.1 G0"] + zigzag(8) + ["G0 X20 Y20", "G2 X25 Y25 I5 J0"],
    "arc-k-in-xy": ["G21 G90 G17 G91.1 G1 F500"] + zigzag(8) + ["G1 X20 Y20", "G2 X25 Y25 I5 K0"],
    "arc-r-too-small": ["G21 G90 G17 G1 F500"] + zigzag(8) + ["G3 X30 Y30 R1"] + zigzag(3),
    "arc-no-axes": ["G21 G90 G17 G91.1 G1 F500"] + zigzag(8) + ["G2 I1 J0", "G1 X20"],
    "spellings": ["G21 G90 F500", "G01 X1.5 Y2.", "G1X2Y3Z-0", "X.5 Y+3 ", "G00 X1", "G0", "G1 Z-00012.340 ",
                  "X10.000000000000001 Y1", "X10.5 Y1.25 F.5", "X2 Y3 F100 ", "X3", "G001 X1"],
}


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_plain_lines_give_the_full_translators_commands_and_refusals(name, monkeypatch):
    text = "\n".join(PROGRAMS[name] + ["M2"]) + "\n"
    short = listing_or_refusal(text, MILL)
    full_way(monkeypatch)
    assert short == listing_or_refusal(text, MILL)
    assert short.count("\n") > 3 or short.startswith("refused: p.ngc:")


def test_a_lathe_in_diameter_mode_halves_x_the_short_way_too(monkeypatch):
    text = "G21 G90 G7 G18\nG0 X20 Z1\nG1 Z-1 F200\n" + "".join(
        f"X{20 - i * 0.1:.2f} Z{-1 - i * 0.05:.2f}\n" for i in range(40)) + "M2\n"
    short = listing_or_refusal(text, LATHE)
    assert "PMOV X9.9 " in short or "PMOV X9.9" in short.replace("X9.90", "X9.9")
    full_way(monkeypatch)
    assert short == listing_or_refusal(text, LATHE)


def test_a_run_is_taken_at_once_and_names_every_line(monkeypatch):
    taken = []
    real = program.take_run
    monkeypatch.setattr(program, "take_run", lambda *args: taken.append(real(*args)) or taken[-1])
    text = "G21 G90 G1 F500\n" + "\n".join(zigzag(100)) + "\nM2\n"
    prog = compile_program(text, MILL, "p.ngc")
    assert [t for t in taken if t] == [100]                # the 100 lines in one run
    assert prog.lines[-1] == 101 and sorted(set(prog.lines)) == list(range(2, 102))
    assert plainrun.RUN_LINES >= 100


def test_arcs_in_a_run_are_taken_with_it_and_name_their_lines(monkeypatch):
    taken = []
    real = program.take_run
    monkeypatch.setattr(program, "take_run", lambda *args: taken.append(real(*args)) or taken[-1])
    body = zigzag(30) + ["G2 X15.125 Y15.8 I5 J0 F700", "(a comment)", "G1 X20 Y20"] + zigzag(30) + ["G3 X9 Y9 R5"]
    prog = compile_program("G21 G90 G17 G91.1\nG1 F500\n" + "\n".join(body) + "\nM2\n", MILL, "p.ngc")
    assert [t for t in taken if t] == [len(body) + 1]         # arcs and the comment did not end the run
    arc_lines = [line for line, cmd in zip(prog.lines, prog.commands) if line in (33, len(body) + 2)]
    assert len(arc_lines) > 20                                 # every chord names its arc's line
    full_way(monkeypatch)
    assert prog.listing() == compile_program("G21 G90 G17 G91.1\nG1 F500\n" + "\n".join(body) + "\nM2\n",
                                             MILL, "p.ngc").listing()


#: lines of every spelling the plain pattern may or may not read, each between two plain lines
SPELLINGS = ["G0 X1", "G00 X1.5 Y-2.", "G01 X.5 Y+3 Z-0 F100", "G1X1Y2Z3F4", "X1 ", "X1  Y2", "G1 F5 ",
             "G001 X1", "G10 X1", "G2 X1", "X1.2.3", "X12345678901234.5", "X1234567890123456",
             "X0.000000000000001", "Y1 X2", "X1 X2", "X-.25 Y0.000001", "F.5", "G0", "G1 ", "Z-00012.34000",
             "x1", "X", "X-", "X.", "X+-1", "X 1", "F1 X2", "X9007199254740993", "Z-0.1e3"]


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled-scanner", "pattern"])
def test_the_scanner_reads_a_run_of_lines_as_the_pattern_does(compiled, monkeypatch):
    from retrofit.gcode import plainscan
    from retrofit.gcode.lazylines import LazyLines
    from retrofit.motion import _jit
    if compiled and not _jit.compiled():
        pytest.skip("kernels do not run compiled here (no Numba)")
    for line in SPELLINGS:
        lines = LazyLines(f"X0 Y0\n{line}\nX1 Y1\n")
        monkeypatch.setattr(plainscan, "_scanner_ready", lambda work: compiled)
        got = plainrun._table(lines, 0)
        want = plainrun._read(lines, 0, len(lines))
        python = np.empty((len(lines), 5))
        scan = getattr(plainscan.scan_plain, "py_func", plainscan.scan_plain)
        rows = scan(np.frombuffer(lines.text.encode(), np.uint8), np.array(lines.starts),
                    np.array(lines.stops), python)
        long = any(len(re.sub(r"\D", "", number)) > 15 for number in re.findall(r"[\d.]+", line))
        # a number of more than 15 digits ends the scanner's run: that line is read line by line
        for table, scanned in ((got, compiled), (python[:rows], True)):
            assert len(table) == (1 if long and scanned else len(want)), line
            assert np.array_equal(table, want[:len(table)], equal_nan=True), line
            assert np.array_equal(np.signbit(table), np.signbit(want[:len(table)])), line


def test_a_kernel_module_built_before_the_scanner_leaves_the_run_to_the_pattern(monkeypatch):
    """An ahead-of-time module without the scanner (``retrofit kernels`` not run again since) would
    load Numba at the first run of plain lines: the pattern reads it instead."""
    from retrofit.gcode import plainscan
    from retrofit.motion import _aot
    scan = getattr(plainscan.scan_plain, "py_func", plainscan.scan_plain)
    guard = _aot.Library(None, {}).guard(scan, lambda func: pytest.fail("Numba's JIT was asked for"))
    monkeypatch.setattr(plainscan, "compiled", lambda work: True)
    monkeypatch.setattr(plainscan, "scan_plain", guard)
    assert not plainscan._scanner_ready(10)
    prog = compile_program("G21 G90 G1 F500\n" + "\n".join(zigzag(20)) + "\nM2\n", MILL, "p.ngc")
    assert prog.lines[-1] == 21
