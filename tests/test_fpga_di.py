"""004's second split: the digital integration (COUNT/LONG/SHORT) in the gateware, fed line records;
its step/dir pins equal sim://'s port frames at every tick; what the processor must still send
(the offsets of pulses between base pulses) and why; underrun, stop and refused lines."""

import os
from dataclasses import replace

import numpy as np
import pytest

from retrofit.fpga.lines import LINE, TIME, LineLayout, bus_words, compile_lines
from retrofit.fpga.simulate import di_equals, first_difference, simulate
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast, request_steps_fast
from retrofit.run.program import plan_compiled

ENGRAVER = load_machine("engraver")
COARSE = replace(ENGRAVER, tick_us=20.0)
LAY = LineLayout(3)


def plan_and_frames(text: str, machine=COARSE):
    _, plan = plan_compiled(compile_program(text, machine, file="t.ngc"), machine)
    return plan, execute_fast(plan).frames


def step_rises(frames, machine, axis: int) -> np.ndarray:
    from retrofit.frames import PinMap
    pins = PinMap(machine)
    step = ((frames.per_tick() ^ pins.invert) & pins.step_masks[axis]) != 0
    return np.flatnonzero(np.diff(step.astype(int)) == 1) + 1


def test_di_pins_equal_the_reference_on_a_short_move_with_a_reversal():
    plan, frames = plan_and_frames("G1 X0.1 Y0.05 Z0.005 F3000\nG1 X0.05 Y0.1 Z-0.005\n")
    run, diff = di_equals(plan, frames)
    assert diff is None, diff
    assert run.positions == [4, 8, -2] and not run.underrun and not run.fault
    times, lines, turns = compile_lines(plan, frames)
    assert len(lines) == 2 and len(times) == 8 + 4       # one time record per base pulse (X, then X)


def test_di_pins_equal_the_reference_when_the_fpga_clock_is_three_ticks():
    """On a board the tick is many clocks (12 at 12 MHz): the FIFO heads refill between ticks."""
    plan, frames = plan_and_frames("G1 X0.05 Y0.025 F3000\nG1 X0.025 Y0.05\n")
    run, diff = di_equals(plan, frames, clocks_per_tick=3)
    assert diff is None, diff
    assert run.positions == [2, 4, 0] and run.cycles == 3 * (frames.end_tick - 1) + 1


def test_a_3_to_2_line_under_acceleration_needs_the_processors_offsets():
    """Y pulses at SHORT = 1.5, 4.5, ... base intervals: the reference times each on the velocity
    profile, so spacing it evenly between its base pulses (004's (SHORT - LONG) / f) misses ticks;
    the gateware gets that offset from the processor and lands on every tick."""
    plan, frames = plan_and_frames("G1 X0.3 Y0.2 F3000\n")          # 24 : 16 steps, from standstill
    run, diff = di_equals(plan, frames)
    assert diff is None, diff
    x, y = step_rises(frames, COARSE, 0), step_rises(frames, COARSE, 1)
    assert len(x) == 24 and len(y) == 16
    between = [(k, rise) for k, rise in zip(range(1, 17), y) if (3 * k) % 2]   # SHORT = 1.5, 4.5, ...
    evenly = [x[(3 * k) // 2 - 1] + (x[(3 * k) // 2] - x[(3 * k) // 2 - 1]) / 2 for k, _ in between]
    assert any(abs(e - r) >= 1 for e, (_, r) in zip(evenly, between))     # the profile is not linear
    times = compile_lines(plan, frames)[TIME]
    assert sum(1 for t in times if LAY.get(LAY.time, t, "offset1")) == len(between)
    assert bus_words(compile_lines(plan, frames), LAY) < 24 + 16          # fewer words than pulse records


def test_a_wrong_offset_from_the_processor_is_caught_at_its_tick():
    plan, frames = plan_and_frames("G1 X0.3 Y0.2 F3000\n")
    records = compile_lines(plan, frames)
    k = next(i for i, t in enumerate(records[TIME]) if LAY.get(LAY.time, t, "offset1"))
    records[TIME][k] += 1 << LAY.time["offset1"][0]                       # one tick late
    run = simulate(COARSE, records, frames.end_tick, variant="di")
    diff = first_difference(frames, run.frames)
    assert diff is not None and diff.startswith(f"tick {step_rises(frames, COARSE, 1)[0]}:")


def test_a_missing_line_record_is_an_underrun_that_stops_every_axis():
    plan, frames = plan_and_frames("G1 X0.1 Y0.05 F3000\nG1 X0.2 Y0.05\n")
    records = compile_lines(plan, frames)
    records[LINE] = records[LINE][:1]                 # the second line never comes
    run = simulate(COARSE, records, frames.end_tick, variant="di")
    assert run.underrun and not run.fault and run.positions[0] == 8
    assert step_rises(run.frames, COARSE, 0)[-1] < run.fault_tick


def test_stop_drops_the_step_pins_in_the_same_tick():
    plan, frames = plan_and_frames("G1 X0.3 Y0.2 F3000\n")
    rise = int(step_rises(frames, COARSE, 0)[5])
    run = simulate(COARSE, compile_lines(plan, frames), frames.end_tick, stop_tick=rise + 1, variant="di")
    assert len(step_rises(run.frames, COARSE, 0)) == 6 and run.positions[0] == 6
    from retrofit.frames import PinMap
    steps = (run.frames.per_tick() ^ PinMap(COARSE).invert) & sum(PinMap(COARSE).step_masks)
    assert steps[rise] and not steps[rise + 1:].any()


def test_a_line_whose_short_axis_outruns_its_base_is_refused():
    line = LAY.pack(LAY.line, n=2, d0=2, d1=3, dir0=1, dir1=1)            # Y would need 3 pulses in 2 intervals
    times = [LAY.pack(LAY.time, delay=20), LAY.pack(LAY.time, delay=20)]
    run = simulate(COARSE, [times, [line], []], 80, variant="di")
    assert run.fault and run.positions == [0, 0, 0]


#: the slow stage draws 10 of the 200 random programs (every 20th seed); RETROFIT_FPGA_PROGRAMS=200
#: draws all 200 (about 4 CPU-minutes)
PROGRAMS = min(200, max(5, int(os.environ.get("RETROFIT_FPGA_PROGRAMS", "10"))))
SEEDS = list(range(0, 200, 200 // PROGRAMS))


@pytest.mark.slow
@pytest.mark.parametrize("batch", range(len(SEEDS) // 5), ids=lambda b: f"seeds-{SEEDS[5 * b]}-{SEEDS[5 * b + 4]}")
def test_di_pins_equal_the_reference_on_random_programs(batch):
    """Lines, arcs as chords, rapids, dwells, feed changes and reversals on random driver timing,
    pin inversions, profiles and look-ahead (004's interpolator: the variant runs digital integration)."""
    from tests.fpga_programs import random_machine, random_program
    for seed in SEEDS[5 * batch:5 * batch + 5]:
        rng = np.random.default_rng(seed)
        machine, text = random_machine(rng), random_program(rng)
        machine = replace(machine, motion=replace(machine.motion, interpolator="dda"))
        plan, frames = plan_and_frames(text, machine)
        run, diff = di_equals(plan, frames)
        assert diff is None, f"seed {seed}: {diff}\n{text}"
        assert not run.underrun and not run.fault, f"seed {seed}"


def engraving_window(plan, frames, fraction: float, length: int = 20_000):
    """The engraving's frames from the start of the first line with two moving axes after
    ``fraction`` of the run (plus 50 ticks), and that window's line records, compiled as the
    processor would from there: (start tick, line, frames, records)."""
    from types import SimpleNamespace

    from retrofit.fpga.lines import line_records

    from tests.test_fpga_engine import window
    req = request_steps_fast(plan)
    moved = np.diff(np.vstack([np.zeros((1, 3), np.int64), req.counts]), axis=0)
    m0 = next(m for m in range(1, len(moved)) if (moved[m] > 0).sum() == 2
              and req.move_end_ticks[m - 1] >= fraction * frames.end_tick)
    start, done = int(req.move_end_ticks[m0 - 1]) + 50, req.counts[m0 - 1]
    part = window(frames, start, length)
    assert len(part) > 10 and part.ticks[1] > 20, "a window that starts still and has pulses in it"
    sub = SimpleNamespace(counts=req.counts[m0:m0 + 3] - done, dirs=[req.dirs[a][done[a]:] for a in range(3)],
                          ticks=[req.ticks[a][done[a]:] - start for a in range(3)])
    return start, m0, part, line_records(ENGRAVER, sub, part)


@pytest.mark.slow
#: the window after 60 % runs in tests/test_fpga_compiled.py (Amaranth against the compiled engine
#: and sim://), where the whole engraving runs too
@pytest.mark.parametrize("fraction", [0.0], ids=["first-chord"])
def test_di_pins_equal_the_reference_on_windows_of_the_shipped_engraving(fraction):
    """engraving.ngc at the engraver's own 1 us tick: 20 000 ticks from the start of a line with two
    moving axes (the first arc chord, from standstill; the first such line after 60 % of the run),
    its records and the following lines' compiled as the processor would from there."""
    from importlib import resources
    text = (resources.files("retrofit") / "examples" / "engraving.ngc").read_text()
    plan, frames = plan_and_frames(text, ENGRAVER)
    start, m0, part, words = engraving_window(plan, frames, fraction)
    run = simulate(ENGRAVER, words, part.end_tick, variant="di")
    diff = first_difference(part, run.frames)
    assert diff is None, f"window from tick {start} (line {m0}): {diff}"
    assert not run.underrun and not run.fault


def test_a_pulse_whose_turn_never_comes_is_an_underrun_not_a_silent_stall():
    line = LAY.pack(LAY.line, n=2, d0=2, d1=0, dir0=1)                    # X positive; the pin shows negative
    times = [LAY.pack(LAY.time, delay=20), LAY.pack(LAY.time, delay=20)]
    run = simulate(COARSE, [times, [line], []], 400, variant="di")          # and no turn record
    assert run.underrun and run.positions == [0, 0, 0]
    assert 20 + 255 <= run.fault_tick <= 20 + 258
