"""Checks of lab 03 (Bresenham and digital integration): `retrofit lab check 03`, or pytest on this file."""

import random

import pytest

from retrofit.labs import expect, load_target
from retrofit.motion.bresenham import BresenhamExecutor, prepare_line
from retrofit.motion.dda import DdaExecutor, dda_positions

_DRAW = random.Random(11)
RANDOM_LINES = [(_DRAW.randint(-40, 40), _DRAW.randint(-40, 40)) for _ in range(25)] + [(7, 0), (0, -5), (6, 6)]


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def _written(function, *args) -> bool:
    try:
        function(*args)
        return True
    except NotImplementedError:
        return False


def _only_if_chosen(lab, mine: str, other: str, todo: str) -> None:
    """Skip the checks of the method a student left out, when the other one is written."""
    if not _written(getattr(lab, mine), 2, 1) and _written(getattr(lab, other), 2, 1):
        pytest.skip(f"optional: you wrote the other method; {todo} is left out")


def library_steps(dx, dy):
    executor = BresenhamExecutor(prepare_line((0, 0), (dx, dy)))
    return [executor.step() for _ in range(executor.move.n)]


def check_bresenham(lab, dx, dy):
    """Cycle count, half-a-step rule at every cycle, end point; equal to the library when n is odd."""
    n = max(abs(dx), abs(dy))
    steps = [tuple(int(v) for v in s) for s in lab.bresenham_steps(dx, dy)]
    expect(len(steps) == n, f"cycles of bresenham_steps({dx}, {dy})",
           expected=f"{n} (one per step of the base axis, the longer one)", got=len(steps))
    library = library_steps(dx, dy)
    x = y = lx = ly = 0
    for k, (step, lib) in enumerate(zip(steps, library), 1):
        x, y, lx, ly = x + step[0], y + step[1], lx + lib[0], ly + lib[1]
        ideal = (k * dx / n, k * dy / n)
        off = max(abs(x - ideal[0]), abs(y - ideal[1]))
        expect(off <= 0.5 + 1e-12 and all(v in (-1, 0, 1) for v in step),
               f"the point after cycle {k} of the line to ({dx}, {dy})",
               expected=f"within half a step of the ideal line at ({ideal[0]:.2f}, {ideal[1]:.2f}), "
                        f"e.g. ({lx}, {ly}) as retrofit's BresenhamExecutor",
               got=f"({x}, {y}) after the steps {steps[:k]}",
               hint="the base axis steps every cycle; the other steps when its error term is above n "
                    "(half a step), then drops by 2n; use the sign of dx and dy for the direction")
    if n % 2 == 1:             # n odd: the line never passes exactly half-way, one right answer
        first = next((k for k, (a, b) in enumerate(zip(steps, library), 1) if a != b), None)
        expect(first is None, f"cycle {first} of the line to ({dx}, {dy})",
               expected=f"{library[first - 1] if first else ''} (BresenhamExecutor)",
               got=f"{steps[first - 1] if first else ''}")


def check_dda(lab, n, d):
    got = [float(p) for p in lab.dda_short_pulses(n, d)]
    want = dda_positions(prepare_line((0, 0), (n, d)))[1].tolist()
    close = len(got) == len(want) and all(abs(g - w) <= 1e-9 for g, w in zip(got, want))
    expect(close, f"dda_short_pulses({n}, {d})", expected=[round(w, 4) for w in want],
           got=[round(g, 4) for g in got],
           hint="COUNT = n / d; SHORT starts at COUNT; after base pulse LONG, if int(SHORT) == LONG a "
                "short pulse sits at SHORT, then SHORT += COUNT")


def test_one_method_is_written(lab):
    """TODO 1 or TODO 2: at least one of the two interpolators is written"""
    done = [name for name in ("bresenham_steps", "dda_short_pulses") if _written(getattr(lab, name), 2, 1)]
    expect(bool(done), "which of bresenham_steps (TODO 1) and dda_short_pulses (TODO 2) you wrote",
           expected="at least one", got="neither yet", hint="pick one; the README explains both")


@pytest.mark.parametrize("line", [(8, 4), (2, 1), (-6, -3)], ids=["8-4", "2-1", "minus6-minus3"])
def test_bresenham_two_to_one(lab, line):
    """TODO 1: Bresenham at 2:1 — the short axis steps every second cycle"""
    _only_if_chosen(lab, "bresenham_steps", "dda_short_pulses", "TODO 1 (Bresenham)")
    check_bresenham(lab, *line)


@pytest.mark.parametrize("line", [(9, 6), (3, 2), (-3, 2)], ids=["9-6", "3-2", "minus3-2"])
def test_bresenham_three_to_two(lab, line):
    """TODO 1: Bresenham at 3:2 — equal to retrofit's BresenhamExecutor"""
    _only_if_chosen(lab, "bresenham_steps", "dda_short_pulses", "TODO 1 (Bresenham)")
    check_bresenham(lab, *line)


def test_bresenham_random_lines(lab):
    """TODO 1: Bresenham on random lines in every direction, and lines along one axis"""
    _only_if_chosen(lab, "bresenham_steps", "dda_short_pulses", "TODO 1 (Bresenham)")
    for line in RANDOM_LINES:
        check_bresenham(lab, *line)


def reference_counters(n, d):
    """004's counters after every base pulse: (LONG, SHORT, delay or None), worked by the checks."""
    count = n / d if d else None
    short, sent, rows = count, 0, []
    for long in range(1, n + 1):
        delay = None
        if sent < d and int(short) == long:
            delay, short, sent = short - long, short + count, sent + 1
        rows.append((long, short, delay))
    return rows


@pytest.mark.parametrize("line", [(3, 2), (8, 4), (10, 3), (7, 5), (13, 13)], ids=lambda l: f"{l[0]}-{l[1]}")
def test_dda_counters_pulse_by_pulse(lab, line):
    """TODO 2: after every base pulse, LONG and SHORT hold 004's values and the short pulse is decided then"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    n, d = line
    integrator = lab.DigitalIntegrator(n, d)
    for long, short, delay in reference_counters(n, d):
        got = integrator.base_pulse()
        same = (got is None) == (delay is None) and (got is None or abs(float(got) - delay) <= 1e-9)
        state = (integrator.long, integrator.short)
        expect(same and state[0] == long and abs(float(state[1]) - short) <= 1e-9,
               f"DigitalIntegrator({n}, {d}), base pulse {long}: the delay returned and the counters after it",
               expected=f"{'no short pulse' if delay is None else f'a short pulse {delay:.4f} intervals later'}, "
                        f"LONG {long}, SHORT {short:.4f}",
               got=f"{'no short pulse' if got is None else f'a short pulse {float(got):.4f} intervals later'}, "
                   f"LONG {state[0]}, SHORT {float(state[1]):.4f}",
               hint="count the base pulse in LONG first; a short pulse is due when int(SHORT) == LONG; its "
                    "delay is SHORT - LONG; then SHORT grows by COUNT")


def test_dda_two_to_one(lab):
    """TODO 2: digital integration at 2:1 — one short pulse every 2 base pulses"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    check_dda(lab, 8, 4)


def test_dda_three_to_two(lab):
    """TODO 2: digital integration at 3:2 — one short pulse every 1.5 base pulses"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    check_dda(lab, 9, 6)
    executor = DdaExecutor(prepare_line((0, 0), (3, 2)))
    delays = [executor.step()[1] for _ in range(3)]
    expect(delays == [0.5, None, 0.0], "retrofit's DdaExecutor at 3:2 (for reference)",
           expected="[0.5, None, 0.0]", got=delays)


def test_dda_random_lines(lab):
    """TODO 2: digital integration on random lines, equal to retrofit's dda_positions"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    for dx, dy in RANDOM_LINES:
        n, d = max(abs(dx), abs(dy)), min(abs(dx), abs(dy))
        check_dda(lab, n, d)
