"""Checks of lab 02 (step pulses): run with `retrofit lab check 02`, or pytest on this file.

Besides the paper's timings, the checks draw random pulse timings and random patterns of wanted
steps (seeded: RETROFIT_CHECK_SEED draws them again). The expected bits and counters are worked
here, from the paper's PasAvans and SetPasAvans, never by retrofit's own step generator.
"""

from pathlib import Path

import pytest

from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path

_DRAW = cases("02 patterns")
_LONG_HIGH = [(high, _DRAW.randint(1, high - 1)) for high in (_DRAW.randint(2, 9), _DRAW.randint(2, 9))]
TIMINGS = [(1, 1), (2, 2), (2, 3), (5, 5)] + _LONG_HIGH + [(_DRAW.randint(1, 9), _DRAW.randint(1, 9)) for _ in range(2)]
PATTERNS = {
    "a step wanted every tick": [True] * 40,
    "a step wanted every 3rd tick": [t % 3 == 0 for t in range(40)],
    "bursts of wanted steps": [t in (0, 1, 2, 3, 11, 12, 25) for t in range(40)],
    "random wanted steps": [_DRAW.random() < 0.4 for _ in range(60)],
    "random bursts and gaps": [_DRAW.random() < density for density in (0.9, 0.05, 0.6, 0.0, 0.3) for _ in range(25)],
}
COUNTER_RULE = ("while dunu > 0 the bit is 1 and both dunu and perioada count down; "
                "else while perioada > 0 the bit is 0 and perioada counts down")


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


class PaperCounters:
    """The paper's PasAvans and SetPasAvans, worked by the checks (to test timer_ticks on its own)."""

    def __init__(self, high, low):
        self.high, self.low, self.dunu, self.perioada = high, low, 0, 0

    def pas_avans(self):
        bit = int(self.dunu > 0)
        if self.dunu > 0:
            self.dunu -= 1
        if self.perioada > 0:
            self.perioada -= 1
        return bit

    def set_pas_avans(self):
        if self.perioada:
            return False
        self.dunu, self.perioada = self.high, self.high + self.low
        return True


def paper_bits(high, low, requests, counters=None):
    """The step bit of every tick when each tick runs PasAvans, then SetPasAvans while steps are wanted."""
    counters, bits, owed = counters or PaperCounters(high, low), [], 0
    for tick in range(len(requests)):
        bits += [int(counters.pas_avans())]
        owed += 1 if requests[tick] else 0
        owed -= 1 if owed > 0 and counters.set_pas_avans() else 0
    return bits


def counter_bits(lab, high, low, requests):
    """The student's counters in the paper's tick loop."""
    return paper_bits(high, low, requests, lab.PulseCounters(high, low))


def test_counters_are_your_own(lab):
    """TODO 1, 2: PulseCounters counts with its own dunu and perioada, not retrofit's StepGenerator"""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.motion.stepgen": set()})
    expect(not places, "where your counters come from", expected="your own pas_avans and set_pas_avans",
           got="retrofit's step generator: " + "; ".join(places),
           hint="the lab is to write the two counters; write pas_avans and set_pas_avans yourself")


def first_difference(got, want):
    return next((t for t, (g, w) in enumerate(zip(got, want)) if g != w), None)


def test_idle_counters_stay_low(lab):
    """TODO 1: counters with no pulse give a 0 bit and stay at 0"""
    counters = lab.PulseCounters(2, 2)
    bits = [counters.pas_avans() for _ in range(3)]
    expect(list(bits) == [0, 0, 0] and counters.dunu == 0 and counters.perioada == 0,
           "three ticks of PulseCounters(2, 2) with no step asked for",
           expected="bits [0, 0, 0], dunu 0, perioada 0",
           got=f"bits {list(bits)}, dunu {counters.dunu}, perioada {counters.perioada}", hint=COUNTER_RULE)


def test_a_step_starts_when_idle(lab):
    """TODO 2: set_pas_avans starts a pulse when perioada is 0: dunu = high, perioada = high + low"""
    counters = lab.PulseCounters(2, 3)
    started = counters.set_pas_avans()
    expect(started is True and (counters.dunu, counters.perioada) == (2, 5),
           "set_pas_avans() on idle PulseCounters(2, 3)",
           expected="True, then dunu 2 and perioada 5 (= dunu + pulse_low)",
           got=f"{started!r}, dunu {counters.dunu}, perioada {counters.perioada}",
           hint="dunu := pulse_high; perioada := dunu + pulse_low; return True")


def test_no_step_while_a_pulse_is_in_progress(lab):
    """TODO 2: a step asked for during a pulse is refused and changes nothing"""
    counters = lab.PulseCounters(2, 2)
    counters.set_pas_avans()
    counters.pas_avans()
    before = (counters.dunu, counters.perioada)
    again = counters.set_pas_avans()
    expect(again is False and (counters.dunu, counters.perioada) == before,
           "set_pas_avans() one tick into a pulse of PulseCounters(2, 2)",
           expected=f"False, counters unchanged at dunu {before[0]}, perioada {before[1]}",
           got=f"{again!r}, dunu {counters.dunu}, perioada {counters.perioada}",
           hint="only when perioada == 0 may a new pulse start; otherwise return False")


@pytest.mark.parametrize("high,low", TIMINGS, ids=[f"high{h}-low{lo}" for h, lo in TIMINGS])
def test_counters_equal_the_step_generator_tick_by_tick(lab, high, low):
    """TODO 1, 2: tick by tick, your counters give the paper's bits, for the paper's and random timings"""
    for label, requests in PATTERNS.items():
        got, want = counter_bits(lab, high, low, requests), paper_bits(high, low, requests)
        t = first_difference(got, want)
        expect(t is None, f"the step bit at tick {t} with pulse_high={high}, pulse_low={low}, {label}; {seed_note()}",
               expected=f"{want[t] if t is not None else ''} (ticks 0..{t}: {want[:t + 1 if t is not None else 0]})",
               got=f"{got[t] if t is not None else ''} (ticks 0..{t}: {got[:t + 1 if t is not None else 0]})",
               hint=COUNTER_RULE + "; a new pulse only when perioada == 0")


def paper_counters(high, low, requests):
    """(dunu, perioada) after every tick of the paper's PasAvans and SetPasAvans, worked by the checks."""
    dunu = perioada = pending = 0
    states = []
    for wanted in requests:
        if dunu > 0:
            dunu, perioada = dunu - 1, perioada - 1
        elif perioada > 0:
            perioada -= 1
        pending += int(wanted)
        if pending and perioada == 0:
            dunu, perioada, pending = high, high + low, pending - 1
        states.append((dunu, perioada))
    return states


@pytest.mark.parametrize("high,low", TIMINGS[1:], ids=[f"high{h}-low{lo}" for h, lo in TIMINGS[1:]])
@pytest.mark.parametrize("label", ["bursts of wanted steps", "random bursts and gaps"], ids=["bursts", "random"])
def test_counter_values_tick_by_tick(lab, high, low, label):
    """TODO 1, 2: after every tick, dunu and perioada hold the paper's values"""
    requests = PATTERNS[label]
    counters, pending = lab.PulseCounters(high, low), 0
    for t, want in enumerate(paper_counters(high, low, requests)):
        counters.pas_avans()
        pending += int(requests[t])
        if pending and counters.set_pas_avans():
            pending -= 1
        got = (counters.dunu, counters.perioada)
        expect(got == want, f"dunu and perioada after tick {t}, pulse_high={high}, pulse_low={low}, {label}; {seed_note()}",
               expected=f"dunu {want[0]}, perioada {want[1]}", got=f"dunu {got[0]}, perioada {got[1]}",
               hint=COUNTER_RULE + "; a pulse starts with dunu = pulse_high, perioada = dunu + pulse_low")


def test_shortest_step_period_is_high_plus_low(lab):
    """TODO 1, 2: with a step wanted every tick, rising edges come every pulse_high + pulse_low ticks"""
    for high, low in TIMINGS:
        bits = counter_bits(lab, high, low, [True] * 30)
        rises = [t for t in range(1, len(bits)) if bits[t] and not bits[t - 1]]
        gaps = sorted({b - a for a, b in zip(rises, rises[1:])})
        expect(gaps == [high + low], f"ticks between rising edges, pulse_high={high}, pulse_low={low}",
               expected=f"always {high + low}", got=f"{gaps or 'no two pulses'}",
               hint="the paper: the shortest step period is dunu + the low time, two ticks at the least")


def test_timer_tick_order(lab):
    """TODO 3: timer_ticks runs PasAvans first, then SetPasAvans, and retries refused steps

    Checked with the paper's counters, worked by the checks, behind your timer_ticks, so only TODO 3
    is tested here.
    """
    for high, low in TIMINGS:
        for label, requests in PATTERNS.items():
            got = [int(b) for b in lab.timer_ticks(PaperCounters(high, low), requests)]
            want = paper_bits(high, low, requests)
            t = first_difference(got, want)
            if t is None and len(got) == len(want):
                continue
            hint = ("one bit per tick: len(bits) == len(requests)" if len(got) != len(want) else
                    "each tick append pas_avans() first, then ask set_pas_avans(); keep a count of "
                    "wanted steps and ask again next tick when it says False")
            expect(False, f"timer_ticks with pulse_high={high}, pulse_low={low}, {label}; {seed_note()}",
                   expected=f"{len(want)} bits, tick {t}: {want[t] if t is not None else '-'}",
                   got=f"{len(got)} bits, tick {t}: {got[t] if t is not None and t < len(got) else '-'}",
                   hint=hint)
