"""004's FPGA pulse engine in Amaranth's simulator: its step/dir pins equal sim://'s port frames at
every tick; pulse width and direction set-up measured on its pins; underrun, stop and refused
records. Runs are short (a coarse tick); the long ones are in the slow stage."""

import os
from dataclasses import replace

import numpy as np
import pytest

from retrofit.fpga.record import pack
from retrofit.fpga.simulate import gateware_equals, simulate
from retrofit.frames import PinMap
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.run.program import plan_compiled

ENGRAVER = load_machine("engraver")
COARSE = replace(ENGRAVER, tick_us=20.0)      # 20 us ticks: a short program is a few thousand


def frames_of(text: str, machine=COARSE):
    program = compile_program(text, machine, file="t.ngc")
    _, plan = plan_compiled(program, machine)
    return execute_fast(plan).frames


def pin_levels(machine, frames, axis: int):
    """(step, dir) level of one axis at every tick, as a driver reads the pins."""
    pins = PinMap(machine)
    logical = frames.per_tick() ^ pins.invert
    return (logical & pins.step_masks[axis]) != 0, (logical & pins.dir_masks[axis]) != 0


def test_pins_equal_the_reference_on_a_short_move_with_a_reversal():
    frames = frames_of("G1 X0.1 Y0.05 Z0.005 F3000\nG1 X0.05 Y0.1 Z-0.005\n")
    run, diff = gateware_equals(COARSE, frames)
    assert diff is None, diff
    assert run.positions == [4, 8, -2] and not run.underrun and not run.fault


def test_pins_equal_the_reference_when_the_fpga_clock_is_three_ticks():
    frames = frames_of("G1 X0.025 Y0.0125 F3000\nG1 Y0\n")
    run, diff = gateware_equals(COARSE, frames, clocks_per_tick=3)
    assert diff is None, diff
    assert run.cycles == 3 * (frames.end_tick - 1) + 1      # tick n is read at clock 3n + 1


def test_pulse_width_and_direction_setup_measured_on_the_gateware_pins():
    machine = replace(COARSE, axes=tuple(replace(a, pulse_high_ticks=3, dir_setup_ticks=4) for a in COARSE.axes))
    frames = frames_of("G1 X0.1 F3000\nG1 X0.0\n", machine)
    run, diff = gateware_equals(machine, frames)
    assert diff is None, diff
    step, direction = pin_levels(machine, run.frames, 0)
    rises = np.flatnonzero(np.diff(step.astype(int)) == 1) + 1
    falls = np.flatnonzero(np.diff(step.astype(int)) == -1) + 1
    turns = np.flatnonzero(np.diff(direction.astype(int)) != 0) + 1
    assert len(rises) == 16 and set((falls - rises).tolist()) == {3}
    assert len(turns) == 2                     # out (+) and back (-)
    for turn in turns:
        next_rise = rises[rises >= turn][0]
        assert next_rise - turn >= 4           # set-up before the rise after a turn


def records(*events):
    """Packed records (delay, dir, width) for one axis."""
    return [pack(d, s, w) for d, s, w in events]


def test_underrun_stops_every_axis_and_latches():
    words = [records((2, 0, 5), *[(20, 0, 5)] * 6), records((3, 0, 5), *[(20, 0, 5)] * 6), []]
    run = simulate(COARSE, words, 200, late_feed={0: 60})    # X's second record comes at tick 60
    assert run.underrun and not run.fault
    step_y, _ = pin_levels(COARSE, run.frames, 1)
    assert run.positions[0] == -1                 # only X's first pulse went out
    assert 60 <= run.fault_tick <= 63             # flagged when the late record reaches the head
    step_x, _ = pin_levels(COARSE, run.frames, 0)
    assert step_y[:run.fault_tick].sum() > 0
    assert not step_y[run.fault_tick + 1:].any() and not step_x[run.fault_tick + 1:].any()


@pytest.mark.parametrize("clocks", [1, 3], ids=["one-clock-a-tick", "registered"])
def test_stop_drops_the_step_pins_in_the_same_tick_and_empties_the_fifos(clocks):
    words = [records((1, 1, 0), *[(10, 1, 8)] * 10), records(*[(11, 0, 8)] * 10), []]
    run = simulate(COARSE, words, 120, clocks_per_tick=clocks, stop_tick=33)    # in X's fourth pulse
    step_x, _ = pin_levels(COARSE, run.frames, 0)
    assert step_x[31:33].all() and not step_x[33:].any()       # cut at once, never again
    assert run.positions == [3, -2, 0]                          # Y's rise due at 33 never came


def test_a_record_breaking_the_direction_setup_is_refused_and_stops():
    words = [records((5, 0, 2), (6, 1, 0), (2, 1, 2)), [], []]      # a rise 2 ticks after a turn
    run = simulate(COARSE, words, 60)
    assert run.fault
    step_x, _ = pin_levels(COARSE, run.frames, 0)
    assert int(np.sum(np.diff(step_x.astype(int)) == 1)) == 1     # the refused pulse never rose


#: batches of five random programs: the slow stage draws 2 (10 programs) within CI's time;
#: RETROFIT_FPGA_PROGRAMS=200 draws the 200 of docs/fpga.md (about 7 CPU-minutes)
BATCHES = max(1, int(os.environ.get("RETROFIT_FPGA_PROGRAMS", "10")) // 5)


@pytest.mark.slow
@pytest.mark.parametrize("batch", range(BATCHES), ids=[f"seeds-{5 * b}-{5 * b + 4}" for b in range(BATCHES)])
def test_pins_equal_the_reference_on_200_random_programs(batch):
    from tests.fpga_programs import random_machine, random_program
    for seed in range(5 * batch, 5 * batch + 5):
        rng = np.random.default_rng(seed)
        machine, text = random_machine(rng), random_program(rng)
        frames = frames_of(text, machine)
        run, diff = gateware_equals(machine, frames)
        assert diff is None, f"seed {seed}: {diff}\n{text}"
        assert not run.underrun and not run.fault, f"seed {seed}"


def quiet_start(frames, near: int, quiet: int = 300) -> int:
    """A tick at or after ``near`` with no pin change in the ``quiet`` ticks before it and the 20
    after it: there the gateware can start from the pins' levels alone (its guards are past)."""
    ticks = frames.ticks
    for i in range(int(np.searchsorted(ticks, near)), len(ticks) - 1):
        if ticks[i + 1] - ticks[i] >= quiet + 20:
            return int(ticks[i]) + quiet
    raise AssertionError(f"no quiet stretch after tick {near}")


def window(frames, start: int, length: int):
    """The frames of ticks start..start+length-1, counted from 0 (the levels at ``start`` first)."""
    from retrofit.frames import PortFrames
    lo = int(np.searchsorted(frames.ticks, start, side="right"))
    hi = int(np.searchsorted(frames.ticks, start + length))
    ticks = np.concatenate(([0], frames.ticks[lo:hi] - start))
    values = np.concatenate(([frames.value_at(start)], frames.values[lo:hi]))
    return PortFrames(ticks, values, length)


@pytest.fixture(scope="module")
def engraving_frames():
    from importlib import resources
    text = (resources.files("retrofit") / "examples" / "engraving.ngc").read_text()
    return frames_of(text, ENGRAVER)


@pytest.mark.slow
#: the window after 60 % runs in tests/test_fpga_compiled.py (Amaranth against the compiled engine
#: and sim://), where the whole engraving runs too
@pytest.mark.parametrize("fraction", [0.0], ids=["start"])
def test_pins_equal_the_reference_on_windows_of_the_shipped_engraving(engraving_frames, fraction):
    """engraving.ngc at the engraver's own 1 us tick (95 M ticks in all): 30 000-tick windows that
    start where the pins have been still for 300 ticks, at two places along the run (the start and 60 %)."""
    frames = engraving_frames
    start = 0 if fraction == 0 else quiet_start(frames, int(frames.end_tick * fraction))
    part = window(frames, start, 30_000)
    assert len(part) > 20, "a window with pulses in it"
    run, diff = gateware_equals(ENGRAVER, part)
    assert diff is None, f"window from tick {start}: {diff}"
    assert not run.underrun and not run.fault


@pytest.mark.slow
@pytest.mark.parametrize("batch", range(min(4, BATCHES)), ids=[f"seeds-{1000 + 5 * b}-{1004 + 5 * b}" for b in range(4)][:min(4, BATCHES)])
def test_pins_equal_the_reference_with_two_fpga_clocks_a_tick(batch):
    """With two or more clocks a tick (every board build) the engine decides a clock ahead of the
    tick (registered): 20 more random programs with the FPGA clock twice the tick."""
    from tests.fpga_programs import random_machine, random_program
    for seed in range(1000 + 5 * batch, 1005 + 5 * batch):
        rng = np.random.default_rng(seed)
        machine, text = random_machine(rng), random_program(rng)
        run, diff = gateware_equals(machine, frames_of(text, machine), clocks_per_tick=2)
        assert diff is None, f"seed {seed}: {diff}\n{text}"
        assert not run.underrun and not run.fault, f"seed {seed}"
