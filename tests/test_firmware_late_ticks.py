"""A step tick entered late still gives every pulse its configured width, on the pins in simavr.

A tick's pins rise at a fixed count after its match; when something held the interrupts off at
the match (the spindle encoder's interrupt, a received byte), the entry finds that count passed
and raises the pins at once. The pulse's end must then be timed from the count the pins really
rose in: timed from the count read before the rise, a pulse that rose just after a count changed
ended a few cycles early (a Z pulse of 1 599 cycles against the lathe's 1 600; 3 us pulses 44
cycles long against 48 with the encoder turning).

Oracles: the machine file's pulse width; the harness's log of the pins, in cycles.
"""

from __future__ import annotations

import shutil

import pytest

from retrofit.machine.config import load_machine

from tests.test_firmware_sim import Script

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
S = 16_000_000
CYCLES_PER_TICK_US = 16


def shortest_pulses(log, machine) -> dict[str, tuple[int, int]]:
    """Per axis: (pulses, the shortest in cycles); a pulse still high when the log ends is left
    out (its width is unknown)."""
    out = {}
    for a in machine.axis_names:
        rises, falls, _ = fs.step_times(log, machine, a)
        if len(rises) == len(falls) + 1 and (not len(falls) or rises[-1] > falls[-1]):
            rises = rises[:-1]
        assert len(rises) == len(falls), a
        out[a] = (len(rises), int((falls - rises).min()) if len(rises) else 0)
    return out


def polled(script: Script, start: int, end: int, every_ms: float) -> Script:
    t = start
    while t < end:
        script.at(t, "RDST")
        t += int(every_ms * S / 1000)
    return script


def test_lathe_pulses_ended_by_compare_b_are_as_wide_as_configured_when_ticks_come_late():
    """mitic-lathe (100 us pulses, ended by compare B's interrupt; every tick of a line that
    moves an axis with a limit switch is a slow one): X and Z at their top feed, back and forth,
    with the encoder turning at the spindle's top speed + 15 % (2 300 rpm, an INT0 every 65 us
    when this was written; its interrupt is now off outside a thread) and RDST every
    millisecond. Before, a late tick set compare B from the count read before its pins rose:
    4 Z pulses of 1 599 cycles here."""
    machine = load_machine("mitic-lathe")
    elf = fs.build(machine.name)
    script = Script(machine).at(2_000_000, "PFDR F2400")
    for k, move in enumerate(["PMOV X-10 Z-60", "PMOV X10 Z0"] * 3):
        script.at(2_020_000 + 20_000 * k, move)
    end = 4 * S
    polled(script, 2_200_000, end - 1_000_000, 1.0)
    log = fs.Harness(elf, machine, script=script.items, cycles=end, spindle_rpm=2300).run()
    pulses = shortest_pulses(log, machine)
    assert pulses["Z"][0] > 10_000 and pulses["X"][0] > 3_000
    for a in machine.axis_names:
        configured = machine.axis(a).pulse_high_ticks * machine.tick_us * CYCLES_PER_TICK_US
        assert pulses[a][1] >= configured, (a, pulses[a])


def test_the_encoder_costs_no_interrupt_while_no_thread_follows_it():
    """mitic-lathe's X and Z at their top feed with the encoder turning at 2 300 rpm (over 4 000
    counts in the run, on ICLK): outside a thread pass its counts drive nothing, and the
    encoder's interrupt (INT0) is entered at most once (the first count turns it off until an
    ISTP line starts); before, every count entered it, 5 % of the CPU at 8 200 counts/s taken
    from the main loop while the steps took the rest (the mixed stress's board 116 restarted)."""
    machine = load_machine("mitic-lathe")
    elf = fs.build(machine.name)
    script = Script(machine).at(2_000_000, "PFDR F2400")
    for k, move in enumerate(["PMOV X-10 Z-60", "PMOV X10 Z0"]):
        script.at(2_020_000 + 20_000 * k, move)
    end = 3 * S
    log = fs.Harness(elf, machine, script=script.items, cycles=end, spindle_rpm=2300,
                     stats=True).run()
    counts = [c for c, port, bit, level in log.inputs if (port, bit, level) == ("D", 0, 1)]
    assert len(counts) > 4_000
    assert shortest_pulses(log, machine)["Z"][0] > 5_000                # the steps went on
    assert log.stats.get("vector1", 0) <= 1, log.stats


@pytest.fixture(scope="module")
def late3(tmp_path_factory):
    """The stress machine (four axes, home switches, a 1 000-line encoder) with 3 us pulses,
    the longest that a tick ends itself, built in a copy."""
    tmp = tmp_path_factory.mktemp("late3")
    text = (fs.ROOT / "bench" / "stressmix.toml").read_text()
    assert "pulse_high_ticks = 2" in text
    text = text.replace("pulse_high_ticks = 2", "pulse_high_ticks = 3")
    (tmp / "late3.toml").write_text(text.replace('name = "stressmix"', 'name = "late3"'))
    machine = load_machine(tmp / "late3.toml")
    return machine, fs.build_copy(machine, tmp)


def test_short_pulses_ended_in_the_tick_are_as_wide_as_configured_when_ticks_come_late(late3):
    """Four axes in Bresenham ratios near the ceiling (the common tick) and a homing of Z (every
    tick a slow one), the encoder turning at 690 rpm (11 500 counts/s, the spindle's top + 15 %).
    Before, a late tick lowered its pins PULSE + 1 counts after the count read before they rose:
    48 Y pulses of 47 cycles against 48 here (on another run 141 on three axes, down to 44)."""
    machine, elf = late3
    start = {"Z": 49_000}                            # 1 mm below the Z home switch
    script = Script(machine)
    for k, move in enumerate(["FMOV X20 Y10 Z-5 A15", "FMOV X0 Y0 Z0 A0", "ZMOV Z"]):
        script.at(2_000_000 + 20_000 * k, move)
    end = int(2.2 * S)
    log = fs.Harness(elf, machine, script=script.items, cycles=end, spindle_rpm=690,
                     start_steps=start).run()
    pulses = shortest_pulses(log, machine)
    assert min(n for n, _ in pulses.values()) > 5_000
    for a in machine.axis_names:
        assert pulses[a][1] >= 3 * CYCLES_PER_TICK_US, (a, pulses[a])
