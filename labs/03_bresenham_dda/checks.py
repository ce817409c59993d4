"""Checks of lab 03 (Bresenham and digital integration): `retrofit lab check 03`, or pytest on this file.

The lines are drawn at random (seeded: RETROFIT_CHECK_SEED draws them again) in every direction,
short and long, with ties and along one axis. Bresenham's steps and error terms and 004's counters
are checked cycle by cycle against values worked here, never by retrofit's own interpolators.
"""

from fractions import Fraction
from pathlib import Path

import pytest

from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path

_DRAW = cases("03 lines")
RANDOM_LINES = ([(_DRAW.randint(-40, 40), _DRAW.randint(-40, 40)) for _ in range(40)]
                + [(_DRAW.choice([-1, 1]) * 2 * k, _DRAW.choice([-1, 1]) * k) for k in (_DRAW.randint(3, 60),)]
                + [(_DRAW.randint(-700, 700), _DRAW.randint(-700, 700)) for _ in range(3)]
                + [(7, 0), (0, -5), (6, 6), (-9, 9), (1, 0), (0, 0)])
#: the library functions that would hand over the interpolators the lab asks for
ANSWERS = {"retrofit.motion.bresenham": {"bresenham_cycles", "BresenhamExecutor", "prepare_line", "bresenham_ticks"},
           "retrofit.motion.dda": set()}


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


def _affine(got, want) -> bool:
    """``got`` = a * ``want`` + b for one a > 0 and one b (the error term counted from another zero
    or in other units, as long as it is the same term)."""
    pairs = [(float(g), float(w)) for g, w in zip(got, want)]
    distinct = sorted({w for _, w in pairs})
    if len(distinct) < 2:
        return len({g for g, _ in pairs}) <= 1
    (g0, w0), (g1, w1) = next((a, b) for a in pairs for b in pairs if a[1] != b[1])
    scale = (g1 - g0) / (w1 - w0)
    return scale > 0 and all(abs(g - (g0 + scale * (w - w0))) <= 1e-9 * max(1.0, abs(g)) for g, w in pairs)


def check_bresenham(lab, dx, dy):
    """Cycle count, half-a-step rule at every cycle, and each axis's error term, cycle by cycle.

    The error term of an axis after cycle k is, in the handout's units, 2 k |d| - 2 n (its steps so
    far): the checks work it from your own steps, so either choice at a tie is accepted.
    """
    n = max(abs(dx), abs(dy))
    trace = [tuple(row) for row in lab.bresenham_trace(dx, dy)]
    expect(len(trace) == n and all(len(row) == 4 for row in trace), f"bresenham_trace({dx}, {dy})",
           expected=f"{n} cycles (one per step of the base axis, the longer one), each (x step, y step, x error, "
                    "y error)", got=f"{len(trace)} cycles, the first {trace[:2]}")
    x = y = 0
    for k, (sx, sy, *_) in enumerate(trace, 1):
        x, y = x + int(sx), y + int(sy)
        ideal = (k * dx / n, k * dy / n)
        off = max(abs(x - ideal[0]), abs(y - ideal[1]))
        expect(off <= 0.5 + 1e-12 and sx in (-1, 0, 1) and sy in (-1, 0, 1),
               f"the point after cycle {k} of the line to ({dx}, {dy}); {seed_note()}",
               expected=f"within half a step of the ideal line at ({ideal[0]:.2f}, {ideal[1]:.2f})",
               got=f"({x}, {y}) after the steps {[row[:2] for row in trace[:k]]}"[:300],
               hint="the base axis steps every cycle; the other steps when its error term is above n "
                    "(half a step), then drops by 2n; use the sign of dx and dy for the direction")
    for axis, d in ((0, dx), (1, dy)):
        moved, want = 0, []
        for k, row in enumerate(trace, 1):
            moved += abs(int(row[axis]))
            want.append(2 * k * abs(d) - 2 * n * moved)
        got = [row[2 + axis] for row in trace]
        expect(_affine(got, want), f"the {'xy'[axis]} error term after every cycle of the line to ({dx}, {dy}); "
                                   f"{seed_note()}",
               expected=f"{want[:12]}{' ...' if n > 12 else ''} (2 k |d| - 2 n x steps so far, or the same counted "
                        "from another zero)", got=f"{got[:12]}{' ...' if n > 12 else ''}",
               hint="keep one error term per axis for the whole line: + 2|d| every cycle, - 2n when the axis steps")


def reference_counters(n, d):
    """004's counters after every base pulse: (LONG, SHORT, delay or None), worked by the checks in
    exact fractions (a float SHORT may land a hair below a whole number: see _early)."""
    count = Fraction(n, d) if d else None
    short, sent, rows = count, 0, []
    for long in range(1, n + 1):
        delay = None
        if sent < d and int(short) == long:
            delay, short, sent = short - long, short + count, sent + 1
        rows.append((long, short, delay))
    return rows


def check_dda(lab, n, d):
    got = [float(p) for p in lab.dda_short_pulses(n, d)]
    want = [long + delay for long, _, delay in reference_counters(n, d) if delay is not None]
    close = len(got) == len(want) and all(abs(g - w) <= 1e-9 for g, w in zip(got, want))
    expect(close, f"dda_short_pulses({n}, {d}); {seed_note()}", expected=[round(w, 4) for w in want][:20],
           got=[round(g, 4) for g in got][:20],
           hint="COUNT = n / d; SHORT starts at COUNT; after base pulse LONG, if int(SHORT) == LONG a "
                "short pulse sits at SHORT, then SHORT += COUNT")


def test_interpolators_are_your_own(lab):
    """TODO 1 or TODO 2: your interpolator works its steps out itself, not with retrofit's"""
    places = borrowed(target_path(Path(__file__).parent), ANSWERS,
                      within={"bresenham_trace", "bresenham_steps", "DigitalIntegrator", "dda_short_pulses"})
    expect(not places, "where your bresenham_trace and DigitalIntegrator get their answers",
           expected="your own error terms or counters", got="retrofit's interpolators: " + "; ".join(places),
           hint="the lab is to write the interpolator; retrofit's is only for the plots of the one you leave out")


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
    """TODO 1: Bresenham at 3:2 — gaps of 1 and 2 cycles, the error terms cycle by cycle"""
    _only_if_chosen(lab, "bresenham_steps", "dda_short_pulses", "TODO 1 (Bresenham)")
    check_bresenham(lab, *line)


def test_bresenham_random_lines(lab):
    """TODO 1: Bresenham on random lines in every direction, and lines along one axis"""
    _only_if_chosen(lab, "bresenham_steps", "dda_short_pulses", "TODO 1 (Bresenham)")
    for line in RANDOM_LINES:
        check_bresenham(lab, *line)


DDA_LINES = [(3, 2), (8, 4), (10, 3), (7, 5), (13, 13)] + [(n, _DRAW.randint(1, n)) for n in (_DRAW.randint(5, 90),
                                                                                           _DRAW.randint(100, 400))]


@pytest.mark.parametrize("line", DDA_LINES, ids=lambda l: f"{l[0]}-{l[1]}")
def test_dda_counters_pulse_by_pulse(lab, line):
    """TODO 2: after every base pulse, LONG and SHORT hold 004's values and the short pulse is decided then"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    n, d = line
    integrator = lab.DigitalIntegrator(n, d)
    early = False
    for long, short, delay in reference_counters(n, d):
        got = integrator.base_pulse()
        same = (got is None) == (delay is None) and (got is None or abs(float(got) - delay) <= 1e-9)
        state = (integrator.long, integrator.short)
        if not same and _early(got, delay, long, short, early):
            early = not early                      # the pulse one base pulse early, at the same place
            continue
        expect(same and state[0] == long and abs(float(state[1]) - short) <= 1e-9,
               f"DigitalIntegrator({n}, {d}), base pulse {long}: the delay returned and the counters after it; "
               f"{seed_note()}",
               expected=f"{'no short pulse' if delay is None else f'a short pulse {float(delay):.4f} intervals later'}, "
                        f"LONG {long}, SHORT {float(short):.4f}",
               got=f"{'no short pulse' if got is None else f'a short pulse {float(got):.4f} intervals later'}, "
                   f"LONG {state[0]}, SHORT {float(state[1]):.4f}",
               hint="count the base pulse in LONG first; a short pulse is due when int(SHORT) == LONG; its "
                    "delay is SHORT - LONG; then SHORT grows by COUNT")


def _early(got, delay, long, short, early) -> bool:
    """A SHORT summed in floats can sit a hair below the whole number L + 1 it should be: the pulse
    then comes after base pulse L with a delay of 1.0 instead of after L + 1 with none, at the same
    place. Accepted: that pulse, and the missing one at the next base pulse."""
    if not early:
        return got is not None and delay is None and abs(long + float(got) - float(short)) <= 1e-9
    return got is None and delay is not None and delay == 0


def test_dda_two_to_one(lab):
    """TODO 2: digital integration at 2:1 — one short pulse every 2 base pulses"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    check_dda(lab, 8, 4)


def test_dda_three_to_two(lab):
    """TODO 2: digital integration at 3:2 — one short pulse every 1.5 base pulses"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    check_dda(lab, 9, 6)


def test_dda_random_lines(lab):
    """TODO 2: digital integration on random lines, the pulses where 004's counters put them"""
    _only_if_chosen(lab, "dda_short_pulses", "bresenham_steps", "TODO 2 (digital integration)")
    for dx, dy in RANDOM_LINES:
        n, d = max(abs(dx), abs(dy)), min(abs(dx), abs(dy))
        check_dda(lab, n, d)
