"""Checks of lab 13 (the same motion three ways): run with `retrofit lab check 13`, or pytest on this file.

The expected pins are worked here from the record's rule (delay after the last event, direction
at the event, step high for the width), never by retrofit's own gateware (retrofit.fpga); the
random records are seeded (RETROFIT_CHECK_SEED draws them again).
"""

from pathlib import Path

import pytest

from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path

_DRAW = cases("13 records")


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def rule_pins(records, ticks):
    """Step and direction pins by the record's rule, tick by tick."""
    step, direction = [0] * ticks, [0] * ticks
    tick = 0
    for delay, d, width in records:
        tick += delay
        for t in range(tick, ticks):
            direction[t] = d
        for t in range(tick, min(tick + width, ticks)):
            step[t] = 1
    return step, direction


def first_difference(want, got):
    return next((t for t, (a, b) in enumerate(zip(want, got)) if a != b), None)


def drawn_records(count, widths=True, turns_in_pulses=False):
    """Random records: delays 1..30 (longer than the pulse before), widths 1..9, turns now and then."""
    records, d, width = [(_DRAW.randint(1, 4), 1, 0)], 1, 0          # first: the direction turns to 1
    for _ in range(count):
        if turns_in_pulses and width > 3 and _DRAW.random() < 0.5:
            d, into = 1 - d, _DRAW.randint(1, width - 2)
            records.append((into, d, 0))                              # the direction turns mid-pulse
            width -= into                                             # ticks the pulse still holds
            continue
        new = _DRAW.randint(1, 9) if widths and _DRAW.random() < 0.8 else 0
        if new == 0 or _DRAW.random() < 0.3:
            d = 1 - d                                                 # a record without a pulse turns
        records.append((_DRAW.randint(width + 1, width + 30), d, new))
        width = new
    return records


def test_the_gateware_and_the_records_are_your_own(lab):
    """TODOs 1-3: the counters and the records are written here, not taken from retrofit.fpga."""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.fpga": set()})
    expect(not places, "your file takes the engine or the records from retrofit.fpga",
           expected="counters and records written in your file", got="; ".join(places),
           hint="retrofit.fpga is the answer: write the counters with Signals and m.d.sync yourself")


def check_pins(lab, records, what, pin):
    ticks = sum(d for d, _, _ in records) + 20
    want = rule_pins(records, ticks)[0 if pin == "step" else 1]
    got = lab.run_gateware(records, ticks)[pin]
    t = first_difference(want, got)
    expect(t is None, f"{what}: the {pin} pin differs from the record's rule at tick {t}",
           expected=want[max((t or 0) - 3, 0):(t or 0) + 4], got=got[max((t or 0) - 3, 0):(t or 0) + 4],
           hint=f"records {records[:6]}...; ticks shown from {max((t or 0) - 3, 0)}; {seed_note()}")


def test_direction_turns_after_each_delay(lab):
    """TODO 1: records without pulses turn the direction pin exactly `delay` ticks after the last event."""
    check_pins(lab, drawn_records(25, widths=False), "direction-only records", "dir")


def test_a_record_is_taken_in_the_tick_it_fires(lab):
    """TODO 1: `ready` is high in the cycle a record fires, once per record."""
    records = drawn_records(15, widths=False)
    ticks = sum(d for d, _, _ in records) + 20
    got = lab.run_gateware(records, ticks)["taken"]
    want, tick = [], 0
    for delay, _, _ in records:
        tick += delay
        want.append(tick)
    expect(got == want, "records are taken at the wrong ticks", expected=want, got=got,
           hint=f"a record fires when `since` equals its delay, and `since` starts again after it; {seed_note()}")


def test_pulses_last_their_width(lab):
    """TODO 2: the step pin rises at the record's tick and stays high `width` ticks."""
    check_pins(lab, drawn_records(25), "pulses of random widths", "step")


def test_a_turn_during_a_pulse_leaves_the_pulse_whole(lab):
    """TODO 2: a direction-only record that fires while the step pin is high does not cut the pulse."""
    check_pins(lab, drawn_records(25, turns_in_pulses=True), "turns inside pulses", "step")


def test_records_from_random_pins(lab):
    """TODO 3: records_of gives back the records that made the pins."""
    for _ in range(5):
        records = drawn_records(20, turns_in_pulses=True)
        ticks = sum(d for d, _, _ in records) + 20
        step, direction = rule_pins(records, ticks)
        got = lab.records_of(step, direction)
        expect(got == records, "records_of does not give back the records that made the pins",
               expected=records[:8], got=got[:8], hint=f"first 8 shown; {seed_note()}")


def test_a_turn_at_a_rise_is_one_record(lab):
    """TODO 3: a rise that comes with a turn is one record carrying the new direction."""
    step, direction = [0, 0, 0, 1, 1, 0, 0, 0], [0, 0, 0, 1, 1, 1, 1, 1]
    expect(lab.records_of(step, direction) == [(3, 1, 2)], "a turn at a rise",
           expected=[(3, 1, 2)], got=lab.records_of(step, direction),
           hint="the record of a rise carries the direction at that tick")


@pytest.mark.parametrize("axis", ["X", "Y", "Z"])
def test_the_gateware_makes_the_tick_loops_pins(lab, axis):
    """TODOs 1-3: fed records_of the tick loop's pins, your gateware makes the same pins at every tick."""
    ref, _ = lab.reference_pins()
    step, direction = ref[axis]
    got = lab.run_gateware(lab.records_of(step, direction), len(step))
    for name, want, have in (("step", step, got["step"]), ("dir", direction, got["dir"])):
        t = first_difference(want, have)
        expect(t is None, f"{axis}.{name} differs from the tick loop's at tick {t}",
               expected=want[max((t or 0) - 3, 0):(t or 0) + 4], got=have[max((t or 0) - 3, 0):(t or 0) + 4],
               hint="the three TODOs together: check the two counters first, then records_of")
