"""Fuzzing the G-code front end: no input ends in anything but a program or a one-line GcodeError.

Programs are built from G-code's own pieces (codes, words with wild numbers, O-words, expressions,
comments, odd line ends) and from raw text. For each: compiling returns a Program or raises
GcodeError naming a line that exists in the file; nothing else escapes, and a program does not
run longer than its budget. The default run makes a few hundred programs; the ``slow`` run makes
10 000 (in four tests of 2500) and prints the figures.
"""

from __future__ import annotations

import random
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.gcode.lexer import split_lines
from retrofit.machine.config import load_machine

MACHINES = [load_machine("engraver"), load_machine("chivu-lathe")]
NUMBERS = ["0", "1", "-1", ".5", "12.5", "-0", "1e308", "9" * 200, "1" + "0" * 30, "0.000001",
           "#1", "#<x>", "[1/0]", "[2**1024]", "[SQRT[-1]]", "[#1+1]", "-#2", "[10 MOD 0]",
           "[ATAN[1]/[0]]", "[EXP[1000]]", "#[#1]", "1.", "+3", "[1 EQ 1]"]
LETTERS = list("ABCDEFGHIJKLMNPQRSTUVWXYZ")
CODES = ["G0", "G1", "G2", "G3", "G4", "G10 L2 P1", "G10 L20 P0", "G17", "G18", "G19", "G20",
         "G21", "G28", "G28.1", "G30", "G33", "G43", "G49", "G53", "G54", "G59.3", "G61", "G64",
         "G73", "G76", "G80", "G81", "G83", "G90", "G90.1", "G91", "G91.1", "G92", "G92.1", "G93",
         "G94", "G98", "G99", "M0", "M2", "M3", "M5", "M6", "M7", "M9", "M30", "M104", "G5", "G41"]
OWORDS = ["o1 sub", "o1 endsub", "o1 call [1] [2]", "o<a> if [#1]", "o<a> else", "o<a> endif",
          "o2 while [#1 LT 3]", "#1=[#1+1]", "o2 endwhile", "o3 do", "o3 while [0]",
          "o4 repeat [3]", "o4 endrepeat", "o2 break", "o2 continue", "o1 return [5]",
          "o<x> call", "#<x>=2", "#<_g>=1", "(MSG, hi #1)", "%", "$H", "$J=G91 X1 F100",
          "$110=500", "/G0 X1"]
ENDS = ["\n", "\r\n", "\r", "\v", "\f", "\u2028", "\x85", ";\u2028G0 X1\n"]


def _word(rng: random.Random) -> str:
    return rng.choice(LETTERS) + rng.choice(NUMBERS)


def random_program(rng: random.Random) -> str:
    """A program of 1..12 lines mixing codes, words, O-words and odd line ends."""
    lines = []
    for _ in range(rng.randint(1, 12)):
        kind = rng.random()
        if kind < 0.5:
            parts = [rng.choice(CODES)] + [_word(rng) for _ in range(rng.randint(0, 4))]
        elif kind < 0.8:
            parts = [rng.choice(OWORDS)]
        else:
            parts = ["".join(rng.choice("GXYZIJKR#[]()<>;%$=/-.0123456789 \t@^") for _ in range(rng.randint(1, 20)))]
        lines.append(" ".join(parts) + rng.choice(ENDS))
    return "".join(lines)


def check(text: str, machine) -> tuple[str, float]:
    """Compile ``text``: 'ok' or 'error'; anything else escaping fails the test."""
    n_lines = len(split_lines(text))
    started = time.process_time()
    try:
        compile_program(text, machine, file="fuzz.ngc")
        outcome = "ok"
    except GcodeError as exc:
        assert "\n" not in str(exc), f"a multi-line error: {exc!r}"
        assert exc.line is None or 1 <= exc.line <= n_lines, f"line {exc.line} of {n_lines}: {exc}"
        if exc.file == "fuzz.ngc":
            assert exc.line is not None, f"an error without a line: {exc}"
        outcome = "error"
    return outcome, time.process_time() - started


@settings(max_examples=300, deadline=None)
@given(st.randoms(use_true_random=False), st.sampled_from(MACHINES))
def test_fuzzed_programs_end_in_a_program_or_a_one_line_error(rng, machine):
    check(random_program(rng), machine)


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=200), st.sampled_from(MACHINES))
def test_raw_text_ends_in_a_program_or_a_one_line_error(text, machine):
    check(text, machine)


TEN_THOUSAND_PARTS = 4           # the same 10 000 programs (one seed), checked 2500 a test


@pytest.mark.slow
@pytest.mark.parametrize("part", range(TEN_THOUSAND_PARTS))
def test_ten_thousand_fuzzed_programs(part, capsys):
    rng = random.Random(13)
    size = 10_000 // TEN_THOUSAND_PARTS
    outcomes = {"ok": 0, "error": 0}
    slowest = 0.0
    for n in range(size * (part + 1)):
        text = random_program(rng)               # every program before this part's is drawn too
        if n >= size * part:
            outcome, cpu = check(text, MACHINES[n % 2])
            outcomes[outcome] += 1
            slowest = max(slowest, cpu)
    with capsys.disabled():
        print(f"\nfuzzed programs {size * part + 1}-{size * (part + 1)} of 10000: {outcomes['ok']} compiled, "
              f"{outcomes['error']} refused with a line, 0 uncaught; slowest {slowest:.2f} CPU-s")
    assert sum(outcomes.values()) == size
    assert slowest < 10.0
