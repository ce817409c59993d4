"""The gateware compiled (Yosys's CXXRTL, g++): the same pins at the same clocks, the same positions
and alarms as Amaranth's simulator of it, for both variants; and the whole shipped engraving, both
variants, bit for bit against sim://'s port frames at the engraver's 1 us tick."""

import os
import shutil
from dataclasses import replace

import numpy as np
import pytest

from retrofit.errors import OutputError
from retrofit.fpga.compiled import CompiledSim, compiler
from retrofit.fpga.host import compile_records
from retrofit.fpga.lines import compile_lines
from retrofit.fpga.record import pack
from retrofit.fpga.simulate import GateSim, first_difference
from retrofit.frames import PortFrames
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.outputs import open_output
from retrofit.run.program import plan_compiled

from tests import soak

pytestmark = pytest.mark.skipif(shutil.which(compiler()) is None,
                                reason=f"the compiled gateware needs a C++ compiler: {compiler()!r} not on PATH")

ENGRAVER = load_machine("engraver")
COARSE = replace(ENGRAVER, tick_us=20.0)


def plan_and_frames(text: str, machine):
    _, plan = plan_compiled(compile_program(text, machine, file="t.ngc"), machine)
    return plan, execute_fast(plan).frames


def words_of(variant: str, plan, frames):
    return compile_lines(plan, frames) if variant == "di" else compile_records(plan.machine, frames)


def both(machine, words, end_tick: int, **kw):
    """The Amaranth run and the compiled run of the same records."""
    runs = []
    for backend in (GateSim, CompiledSim):
        gate = backend(machine, **kw)
        gate.add(words)
        runs.append(gate.result(end_tick))
    return runs


def assert_same(amaranth, compiled, what: str) -> None:
    assert first_difference(amaranth.frames, compiled.frames) is None, \
        f"{what}: {first_difference(amaranth.frames, compiled.frames)}"
    assert amaranth.frames == compiled.frames, what
    assert (compiled.cycles, compiled.positions, compiled.underrun, compiled.fault, compiled.fault_tick) == \
        (amaranth.cycles, amaranth.positions, amaranth.underrun, amaranth.fault, amaranth.fault_tick), what


def records(*events):
    return [pack(d, s, w) for d, s, w in events]


def test_compiled_pulse_engine_equals_amaranth_on_a_reversal_a_stop_and_an_underrun():
    """A move with a reversal, through fpga-sim://?sim=compiled; a stop inside a pulse; a record
    held back until its tick has passed; a turn too close to a rise (the output's error)."""
    plan, frames = plan_and_frames("G1 X0.1 Y0.05 Z0.005 F3000\nG1 X0.05 Y0.1 Z-0.005\n", COARSE)
    with open_output("fpga-sim://?sim=compiled", COARSE) as out:
        out.write(frames)
    assert isinstance(out.gate, CompiledSim) and out.run.positions == [4, 8, -2]
    amaranth, compiled = both(COARSE, words_of("pulse", plan, frames), frames.end_tick)
    assert_same(amaranth, compiled, "reversal")
    assert first_difference(frames, compiled.frames) is None and compiled.frames == out.run.frames
    stopped = both(COARSE, [records((1, 1, 0), *[(10, 1, 8)] * 10), records(*[(11, 0, 8)] * 10), []], 120,
                   stop_tick=33)
    assert_same(*stopped, "stop")
    assert stopped[1].positions == [3, -2, 0]
    late = both(COARSE, [records((2, 0, 5), *[(20, 0, 5)] * 6), records((3, 0, 5), *[(20, 0, 5)] * 6), []], 200,
                late_feed={0: 60})
    assert_same(*late, "underrun")
    assert late[1].underrun and 60 <= late[1].fault_tick <= 63
    x_dir, x_step = 1 << COARSE.axes[0].dir_bit, 1 << COARSE.axes[0].step_bit
    bad = PortFrames(np.array([0, 10, 11, 16]), np.array([0, x_dir, x_dir | x_step, x_dir]), 40)
    with pytest.raises(OutputError, match="stopped at tick 11 .a record refused"):
        with open_output("fpga-sim://?sim=compiled", COARSE) as out:
            out.write(bad)


#: random programs compared (compiled against Amaranth), two FPGA clocks a tick (the registered
#: decision): each is its own design (random driver timing), a g++ build of about 5 CPU-seconds;
#: RETROFIT_FPGA_COMPILED_PROGRAMS=N compares N a variant
PROGRAMS = int(os.environ.get("RETROFIT_FPGA_COMPILED_PROGRAMS", "1"))


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["pulse", "di"])
def test_compiled_equals_amaranth_on_random_programs(variant):
    from tests.fpga_programs import random_machine, random_program
    for seed in range(7, 7 + PROGRAMS):
        rng = np.random.default_rng(seed)
        machine, text = random_machine(rng), random_program(rng)
        if variant == "di":                  # the variant runs 004's interpolator
            machine = replace(machine, motion=replace(machine.motion, interpolator="dda"))
        plan, frames = plan_and_frames(text, machine)
        amaranth, compiled = both(machine, words_of(variant, plan, frames), frames.end_tick, variant=variant,
                                  clocks_per_tick=2)
        assert_same(amaranth, compiled, f"seed {seed}\n{text}")
        assert first_difference(frames, compiled.frames) is None, f"seed {seed}"


@pytest.fixture(scope="module")
def engraving():
    from importlib import resources
    text = (resources.files("retrofit") / "examples" / "engraving.ngc").read_text()
    return plan_and_frames(text, ENGRAVER)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["pulse", "di"])
def test_compiled_equals_amaranth_on_a_window_of_the_shipped_engraving(engraving, variant):
    """12 000 ticks of engraving.ngc at 1 us after 60 % of the run, records read from that window
    alone (the windows of tests/test_fpga_engine.py and tests/test_fpga_di.py)."""
    from tests.test_fpga_di import engraving_window
    from tests.test_fpga_engine import quiet_start, window
    plan, frames = engraving
    if variant == "di":
        _, _, part, words = engraving_window(plan, frames, 0.6, 12_000)
    else:
        part = window(frames, quiet_start(frames, int(frames.end_tick * 0.6)), 12_000)
        words = compile_records(ENGRAVER, part)
    amaranth, compiled = both(ENGRAVER, words, part.end_tick, variant=variant)
    assert_same(amaranth, compiled, "window")
    assert first_difference(part, compiled.frames) is None and len(part) > 10


def whole(engraving, variant: str):
    plan, frames = engraving
    gate = CompiledSim(ENGRAVER, variant=variant)
    gate.add(words_of(variant, plan, frames))
    run = gate.result(frames.end_tick)
    assert frames.end_tick > 90_000_000 and len(frames) > 100_000      # the whole run, 95 s at 1 us
    assert first_difference(frames, run.frames) is None, first_difference(frames, run.frames)
    assert run.frames == frames and not run.underrun and not run.fault
    return run


@pytest.mark.slow
@pytest.mark.parametrize("variant", [("pulse", "di")[k] for k in soak.parts(2, 1)])
def test_the_whole_shipped_engraving_on_the_compiled_gateware_equals_sim(engraving, variant):
    """The whole engraving, 95 M ticks, on one variant a CI run (about 20 CPU-s for the pulse
    engine, 36 for the digital integration; the printed seed picks which, RETROFIT_SOAK=1 both)."""
    run = whole(engraving, variant)
    assert run.cycles == engraving[1].end_tick


def test_an_unknown_simulator_is_refused_naming_the_choices():
    with pytest.raises(OutputError, match="sim amaranth or compiled.*sim=amaranth.compiled"):
        with open_output("fpga-sim://?sim=verilog", COARSE):
            pass
