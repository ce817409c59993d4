"""Plain CAM lines take a short way through the interpreter (a run of canonical lines by one
pattern and arrays, a single plain line without a block object): the same commands, lines and
refusals as the full translator."""

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
