"""Checks of lab 02 (step pulses): run with `retrofit lab check 02`, or pytest on this file."""

import random

import pytest

from retrofit.labs import expect, load_target
from retrofit.motion.stepgen import StepGenerator, StepTiming

TIMINGS = [(1, 1), (2, 2), (2, 3), (5, 5)]
PATTERNS = {
    "a step wanted every tick": [True] * 40,
    "a step wanted every 3rd tick": [t % 3 == 0 for t in range(40)],
    "bursts of wanted steps": [t in (0, 1, 2, 3, 11, 12, 25) for t in range(40)],
    "random wanted steps": [random.Random(7).random() < 0.4 for _ in range(60)],
}
COUNTER_RULE = ("while dunu > 0 the bit is 1 and both dunu and perioada count down; "
                "else while perioada > 0 the bit is 0 and perioada counts down")


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def library_bits(high, low, requests, gen=None):
    """What retrofit's StepGenerator (or ``gen``, shaped like it) puts on the wire for the wanted steps."""
    gen = gen or StepGenerator(StepTiming(high, low))
    bits, pending = [], 0
    for wanted in requests:
        bits.append(gen.frame()[0])
        pending += int(wanted)
        if pending and gen.start_step():
            pending -= 1
    return bits


class StudentGenerator:
    """The student's counters behind StepGenerator's names, so the same tick loop drives both."""

    def __init__(self, counters):
        self.counters = counters

    def frame(self):
        return (int(self.counters.pas_avans()),)

    def start_step(self):
        return self.counters.set_pas_avans()


def counter_bits(lab, high, low, requests):
    """The student's counters in the library's tick loop."""
    return library_bits(high, low, requests, StudentGenerator(lab.PulseCounters(high, low)))


class LibraryCounters:
    """StepGenerator behind the names of the lab's counters, to check timer_ticks on its own."""

    def __init__(self, high, low):
        self.gen = StepGenerator(StepTiming(high, low))

    def pas_avans(self):
        return self.gen.frame()[0]

    def set_pas_avans(self):
        return self.gen.start_step()


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
    """TODO 1, 2: tick by tick, your counters give the bits of retrofit's StepGenerator"""
    for label, requests in PATTERNS.items():
        got, want = counter_bits(lab, high, low, requests), library_bits(high, low, requests)
        t = first_difference(got, want)
        expect(t is None, f"the step bit at tick {t} with pulse_high={high}, pulse_low={low}, {label}",
               expected=f"{want[t] if t is not None else ''} (StepGenerator; ticks 0..{t}: {want[:t + 1 if t is not None else 0]})",
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


@pytest.mark.parametrize("high,low", TIMINGS[1:3], ids=[f"high{h}-low{lo}" for h, lo in TIMINGS[1:3]])
def test_counter_values_tick_by_tick(lab, high, low):
    """TODO 1, 2: after every tick, dunu and perioada hold the paper's values"""
    requests = PATTERNS["bursts of wanted steps"]
    counters, pending = lab.PulseCounters(high, low), 0
    for t, want in enumerate(paper_counters(high, low, requests)):
        counters.pas_avans()
        pending += int(requests[t])
        if pending and counters.set_pas_avans():
            pending -= 1
        got = (counters.dunu, counters.perioada)
        expect(got == want, f"dunu and perioada after tick {t}, pulse_high={high}, pulse_low={low}, bursts of wanted steps",
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

    Checked with retrofit's own counters behind your timer_ticks, so only TODO 3 is tested here.
    """
    for high, low in TIMINGS[:3]:
        for label, requests in PATTERNS.items():
            got = [int(b) for b in lab.timer_ticks(LibraryCounters(high, low), requests)]
            want = library_bits(high, low, requests)
            t = first_difference(got, want)
            if t is None and len(got) == len(want):
                continue
            hint = ("one bit per tick: len(bits) == len(requests)" if len(got) != len(want) else
                    "each tick append pas_avans() first, then ask set_pas_avans(); keep a count of "
                    "wanted steps and ask again next tick when it says False")
            expect(False, f"timer_ticks with pulse_high={high}, pulse_low={low}, {label}",
                   expected=f"{len(want)} bits, tick {t}: {want[t] if t is not None else '-'}",
                   got=f"{len(got)} bits, tick {t}: {got[t] if t is not None and t < len(got) else '-'}",
                   hint=hint)
