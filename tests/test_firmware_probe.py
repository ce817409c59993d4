"""PROB on the compiled firmware in simavr: probing moves against the tool setter's beam.

The harness drives tul-mill's beam input (the ZMIN connector) from its own step counts, in the
box where a tool breaks the beam; the oracle of where that happens is
:meth:`retrofit.atc.beam.SimBeam.broken`, scanned step by step along the probing line. PROB goes
in as its raw payload (docs/protocol.md §7: opcode 0x11, flags, positions as PMOV's), and the
STAT word is read from the frame's bytes, so bit 15 (PROBED) is seen as the firmware sends it.
"""

from __future__ import annotations

import shutil

import pytest

from retrofit.atc.beam import SimBeam
from retrofit.atc.settings import tools_of
from retrofit.link import Err, Position, Status
from retrofit.link.script import ScriptedHost
from retrofit.machine.config import load_machine

from tests.test_firmware_sim import OFF_LIMIT_CYCLES, Script

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
S = 16_000_000                       # cycles a second
PROBED, MOVING, ERROR = 0x8000, 0x0001, 0x0100
TOOL = (20.0, 3.0)                   # length, diameter mm: tul-mill's reference tool T1
DEBOUNCE_S = 0.003                   # the firmware's switch debounce: 3 samples 1 ms apart
OVER_BEAM = {"X": 800, "Y": 800}     # steps: the beam's middle (8 mm, 8 mm)


class ProbeScript(Script):
    """Script with PROB frames built byte by byte."""

    def prob(self, cycle: int, flags: int, steps: dict[str, int]) -> ProbeScript:
        bits = {"X": 0, "Y": 1, "Z": 2, "E": 7}
        mask = sum(1 << bits[a] for a in steps)
        body = b"".join((steps[a] & 0xFFFFFF).to_bytes(3, "big")
                        for a in sorted(steps, key=bits.get))
        return self.payload(cycle, bytes((0x11, flags, mask)) + body)


def statuses(log) -> list[int]:
    return [int(r.flags) for r in ScriptedHost(None).replies(log.answer_bytes())
            if isinstance(r, Status)]


def positions(log, machine) -> list[dict[str, int]]:
    return [dict(r.steps) for r in ScriptedHost(machine).replies(log.answer_bytes())
            if isinstance(r, Position)]


@pytest.fixture(scope="module")
def mill():
    machine = load_machine("tul-mill")
    t1 = tools_of(machine).sim[1]
    assert (t1.length_mm, t1.diameter_mm) == TOOL         # the oracle asks SimBeam about T1
    return machine, fs.build(machine.name)


def beam_edge(machine, start: dict[str, int], axis: str, step: int, broken: bool) -> int:
    """The oracle: the first position along ``axis`` from ``start`` (steps, ``step`` = +1 / -1
    each) at which SimBeam says the beam is ``broken`` (or clear) for tool T1."""
    beam = SimBeam(machine)
    at = dict(start)
    for _ in range(10_000):
        mm = {a: at.get(a, 0) / machine.axis(a).steps_per_mm for a in "XYZ"}
        if beam.broken(mm, 1) == broken:
            return at[axis]
        at[axis] += step
    raise AssertionError("the beam never changed along the line")


def carriages(log, machine) -> dict[str, int]:
    """Where the harness's step counts left the carriages (start included)."""
    return dict(zip([a.name for a in fs.firmware_axes(machine)], log.steps))


def run(machine, elf, start, commands, cycles, tool=TOOL, **kw):
    """PSTN to the carriages' start (so RDPS reads carriage steps), then ``commands(script)``."""
    script = ProbeScript(machine)
    script.at(3_100_000, "PSTN " + " ".join(f"{a}{v / 100:g}" for a, v in start.items()))
    commands(script)
    return fs.Harness(elf, machine, script=script.items, cycles=cycles, start_steps=start,
                      tool=tool, **kw).run()


@pytest.mark.parametrize("fast", [False, True], ids=["probe-feed", "1200mm-min"])
def test_prob_down_stops_where_the_beam_breaks_and_later_moves_go_on_from_there(mill, fast):
    """Z descends over the beam at the setter's probe feed (and at 1200 mm/min, where the
    debounce is 6 steps): it stops within one step plus the debounce of the oracle's break
    point, RDPS says the same, STAT has PROBED; the FMOV queued behind the PROB waits for it and
    starts from where it stopped."""
    machine, elf = mill
    start = {**OVER_BEAM, "Z": -3100}
    feed = 1200.0 if fast else machine.parts["setter"].probe_feed_mm_min

    def commands(s):
        s.at(3_200_000, f"PFDR F{feed:g}").prob(3_300_000, 0, {"Z": -3500})
        s.at(3_400_000, "DELY P2").at(3_500_000, "FMOV Z-31")     # back to the start
        s.at(int(1.7 * S), "RDPS").at(int(1.7 * S), "RDST")
        s.at(int(3.4 * S), "RDPS").at(int(3.4 * S), "RDST")

    log = run(machine, elf, start, commands, int(3.5 * S), stats=True)
    edge = beam_edge(machine, start, "Z", -1, True)
    assert edge == -3200                            # -52 + 20 mm: the setter's own comment
    late = 1 + DEBOUNCE_S * feed / 60 * machine.axis("Z").steps_per_mm
    stop = positions(log, machine)[0]["Z"]
    assert edge - late <= stop <= edge, (stop, edge)
    mid, end = statuses(log)
    assert mid & PROBED and not mid & ERROR
    assert not end & (ERROR | MOVING) and end & PROBED     # no PROB since: still set
    assert positions(log, machine)[1]["Z"] == -3100 == carriages(log, machine)["Z"]
    assert log.stats["off_main_longest"] <= OFF_LIMIT_CYCLES
    assert log.stats["off_isr_longest"] <= OFF_LIMIT_CYCLES


@pytest.mark.parametrize("x, tool", [(3000, TOOL), (800, None)], ids=["beam-elsewhere", "no-tool"])
def test_prob_that_misses_the_beam_ends_at_its_target_with_probed_clear(mill, x, tool):
    """X 30 mm is beyond the emitter and receiver; without a tool in the spindle nothing breaks
    the beam anywhere."""
    machine, elf = mill
    start = {"X": x, "Y": 800, "Z": -3100}

    def commands(s):
        s.at(3_200_000, "PFDR F300").prob(3_300_000, 0, {"Z": -3500})
        s.at(int(1.4 * S), "RDPS").at(int(1.4 * S), "RDST")

    log = run(machine, elf, start, commands, int(1.5 * S), tool=tool)
    assert positions(log, machine)[0]["Z"] == -3500 == carriages(log, machine)["Z"]
    status = statuses(log)[0]
    assert not status & (PROBED | ERROR | MOVING)


def test_prob_with_the_beam_already_broken_makes_no_step_and_sets_probed(mill):
    machine, elf = mill
    start = {**OVER_BEAM, "Z": -3300}              # the tip 1 mm into the beam

    def commands(s):
        s.at(3_200_000, "PFDR F60").prob(3_300_000, 0, {"Z": -3500})
        s.at(int(0.5 * S), "RDPS").at(int(0.5 * S), "RDST")

    log = run(machine, elf, start, commands, int(0.6 * S))
    rises, _, _ = fs.step_times(log, machine, "Z")
    assert len(rises) == 0
    assert positions(log, machine)[0]["Z"] == -3300
    assert statuses(log)[0] & PROBED and not statuses(log)[0] & ERROR


def test_prob_until_it_opens_moves_up_out_of_the_beam_and_stops_where_it_clears(mill):
    """A rapid down into the beam first (the firmware's Z starts at the top of its travel),
    then PROB up with flags bit 0."""
    machine, elf = mill
    start = {**OVER_BEAM, "Z": -3000}
    feed = machine.parts["setter"].probe_feed_mm_min

    def commands(s):
        s.at(3_200_000, "FMOV Z-33").at(3_300_000, f"PFDR F{feed:g}")
        s.prob(3_400_000, 1, {"Z": -3000})
        s.at(int(1.9 * S), "RDPS").at(int(1.9 * S), "RDST")

    log = run(machine, elf, start, commands, int(2.0 * S))
    edge = beam_edge(machine, {**start, "Z": -3300}, "Z", +1, False)
    assert edge == -3199
    late = 1 + DEBOUNCE_S * feed / 60 * machine.axis("Z").steps_per_mm
    stop = positions(log, machine)[0]["Z"]
    assert edge <= stop <= edge + late and stop == carriages(log, machine)["Z"]
    assert statuses(log)[0] & PROBED and not statuses(log)[0] & (ERROR | MOVING)


def test_prob_with_an_unknown_flag_is_err_3(mill):
    machine, elf = mill
    script = ProbeScript(machine).prob(3_300_000, 0x02, {"Z": -100})
    log = fs.Harness(elf, machine, script=script.items, cycles=3_600_000, tool=TOOL).run()
    assert ScriptedHost(machine).replies(log.answer_bytes())[-1] == Err(3, 0x11)


def test_prob_on_a_machine_without_a_setter_is_refused_and_init_clears_the_error():
    machine = load_machine("mitic-lathe")
    assert "setter" not in machine.parts
    elf = fs.build(machine.name)
    script = ProbeScript(machine).prob(3_300_000, 0, {"Z": -100})
    script.at(3_400_000, "RDST").at(3_500_000, "INIT").at(3_600_000, "RDST")
    log = fs.Harness(elf, machine, script=script.items, cycles=3_700_000).run()
    answers = ScriptedHost(machine).replies(log.answer_bytes())
    assert Err(6, 0x11) in answers                 # refused by the controller: ERR 6
    before, after = statuses(log)
    assert before & ERROR and not after & ERROR
    rises, _, _ = fs.step_times(log, machine, "Z")
    assert len(rises) == 0
