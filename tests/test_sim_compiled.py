"""sim://'s compiled decoder equals the per-step reference: carriages, violations, switches, traces.

Random port-byte streams (steps, direction turns, pulses too short on purpose) are fed to two
simulated machines, one through the compiled chunks and one step by step, split into random
chunks and mixed with single frames as a controller feeds them; everything the machine reports
must agree exactly.
"""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.frames import PinMap, PortFrames
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.sim import SimMachine

MITIC = load_machine("mitic-lathe")          # dead band, five switches
CHIVU = load_machine("chivu-lathe")          # the largest dead band

compiled()                      # the compiled kernels, whatever the size of the examples


def random_frames(machine, seed: int, n: int, start_tick: int = 0) -> PortFrames:
    """A port-byte stream with bursts of steps one way, turns, and now and then a too-short pulse."""
    rng = np.random.default_rng(seed)
    pins = PinMap(machine)
    n_axes = len(machine.axes)
    ticks, values = [], []
    tick = start_tick
    dirs = [1] * n_axes
    steps = [0] * n_axes
    last = -1
    for _ in range(n):
        for a in range(n_axes):
            if rng.random() < 0.02:
                dirs[a] = -dirs[a]
            steps[a] = int(rng.random() < 0.5)
        value = pins.byte(steps, dirs)
        if value != last:
            ticks.append(tick)
            values.append(value)
            last = value
        tick += int(rng.choice([1, 1, 2, 3, 5]))
    return PortFrames(np.array(ticks, np.int64), np.array(values, np.uint8), tick)


def split(frames: PortFrames, cuts: list[int]) -> list[PortFrames]:
    """Consecutive chunks of ``frames`` cut before the given frame indices."""
    bounds = sorted({min(max(c, 0), len(frames)) for c in cuts} | {0, len(frames)})
    chunks = []
    for lo, hi in zip(bounds, bounds[1:]):
        end = int(frames.ticks[hi]) if hi < len(frames) else frames.end_tick
        chunks.append(PortFrames(frames.ticks[lo:hi], frames.values[lo:hi], end))
    return chunks


def observed(sim: SimMachine, probe: list[int]) -> dict:
    """Everything a user could read off the simulated machine."""
    names = sim.machine.axis_names
    return {
        "motor": list(sim.motor_steps),
        "carriage": [sim.carriage_mm(n) for n in names],
        "reversals": list(sim.reversals),
        "violations": [v.as_dict() for v in sim.violations],
        "switches": [(e.tick, e.name, e.closed) for e in sim.switches.events],
        "trace": {n: (sim.traces[n].ticks, sim.traces[n].motor_steps, sim.traces[n].carriage_mm)
                  for n in names},
        "state": [sim.state_at(t) for t in probe],
    }


def check_equal(machine, start, frames, cuts, single):
    """Feed ``frames`` compiled and by reference; frames of chunks in ``single`` go one by one."""
    fast, ref = SimMachine(machine, start), SimMachine(machine, start)
    for k, chunk in enumerate(split(frames, cuts)):
        if k in single:
            for t, v in zip(chunk.ticks.tolist(), chunk.values.tolist()):
                fast.feed_frame(t, v)
                ref.feed_frame(t, v)
            continue
        fast.feed(chunk)
        ref.feed_reference(chunk)
    probe = frames.ticks[::7].tolist()
    assert observed(fast, probe) == observed(ref, probe)
    return fast


@st.composite
def cases(draw):
    base = draw(st.sampled_from([MITIC, CHIVU]))
    axes = tuple(replace(a, pulse_high_ticks=draw(st.integers(1, 3)), pulse_low_ticks=draw(st.integers(1, 3)),
                         dir_setup_ticks=draw(st.integers(0, 4)), dir_hold_ticks=draw(st.integers(0, 4)),
                         invert_step=draw(st.booleans()), invert_dir=draw(st.booleans())) for a in base.axes)
    machine = replace(base, axes=axes)
    switches = machine.parts.get("switches")
    start = []
    for a in axes:
        near = [s.trip_mm for s in switches.specs if s.axis == a.name] if switches else []
        centre = draw(st.sampled_from(near + [0.0]))
        start.append(int(round(centre * a.steps_per_mm)) + draw(st.integers(-30, 30)))
    n = draw(st.integers(1, 600))
    cuts = draw(st.lists(st.integers(0, n), max_size=5))
    single = set(draw(st.lists(st.integers(0, 5), max_size=2)))
    return machine, tuple(start), random_frames(machine, draw(st.integers(0, 2**31)), n), cuts, single


@settings(max_examples=40)
@given(cases())
def test_compiled_sim_equals_reference(case):
    check_equal(*case)


@pytest.mark.slow
@settings(max_examples=300)
@given(cases())
def test_compiled_sim_equals_reference_300_streams(case):
    check_equal(*case)


def test_random_streams_hit_what_the_property_is_about():
    """The generator really produces violations, reversals and switch changes (else the
    equality above would be empty)."""
    start = (int(40.0 * 100), int(20.0 * 80))                        # on the precise switches
    strict = replace(MITIC, axes=tuple(replace(a, pulse_high_ticks=3, pulse_low_ticks=3, dir_setup_ticks=2,
                                               dir_hold_ticks=2) for a in MITIC.axes))
    sim = check_equal(strict, start, random_frames(strict, 7, 3000), [100, 900, 1500], {2})
    kinds = {v.kind for v in sim.violations}
    assert {"pulse_high", "pulse_low", "dir_setup", "dir_hold"} <= kinds
    assert min(sim.reversals) > 5
    assert {e.name for e in sim.switches.events} >= {"ppsx", "ppsz"}


def test_chunks_longer_than_the_kernels_buffers(monkeypatch):
    import retrofit.sim.decode as decode
    monkeypatch.setattr(decode, "SUB_CHUNK", 50)
    start = (int(40.0 * 100), int(20.0 * 80))
    frames = random_frames(MITIC, 11, 2000)
    fast, ref = SimMachine(MITIC, start), SimMachine(MITIC, start)
    fast.watch(frames.ticks[::37].tolist())
    fast.feed(frames)
    ref.feed_reference(frames)
    probe = frames.ticks[::37].tolist()
    assert observed(fast, probe) == observed(ref, probe)
    assert fast.watched_ticks.tolist() == sorted(set(probe))


def test_decimated_trace_is_bounded_and_watched_ticks_stay_exact():
    frames = random_frames(CHIVU, 3, 20000)
    full = SimMachine(CHIVU)
    small = SimMachine(CHIVU, trace_limit=500, trace_windows=((1000, 1200),))
    probe = frames.ticks[::997].tolist()
    small.watch(probe)
    for chunk in split(frames, list(range(0, len(frames), 3000))):
        full.feed(chunk)
        small.feed(chunk)
    for name in CHIVU.axis_names:
        kept, every = small.traces[name], full.traces[name]
        assert len(every) > 4000 and len(kept) <= 500 + 250              # about the limit, plus the window
        assert {t for t in every.ticks if 1000 <= t < 1200} <= set(kept.ticks)
    assert [small.state_at(t) for t in probe] == [full.state_at(t) for t in probe]
    assert small.violations == full.violations and small.motor_steps == full.motor_steps


def test_an_axis_idle_for_whole_chunks_holds_exactly_as_step_by_step():
    machine = replace(CHIVU, axes=tuple(replace(a, invert_dir=True) for a in CHIVU.axes))
    frames = random_frames(machine, 5, 3000)
    half = len(frames) // 2
    values = frames.values.copy()
    for axis, part in ((machine.axes[1], slice(0, half)), (machine.axes[0], slice(half, None))):
        mask = (1 << axis.step_bit) | (1 << axis.dir_bit)
        held = int(values[part.start or 0]) & mask & ~(1 << axis.step_bit)     # step low, direction as found
        values[part] = (values[part] & (~mask & 0xFF)) | held
    keep = np.concatenate(([True], values[1:] != values[:-1]))
    frames = PortFrames(frames.ticks[keep], values[keep], frames.end_tick)
    start = (int(10.0 * machine.axes[0].steps_per_mm), int(-5.0 * machine.axes[1].steps_per_mm))
    fast, ref = SimMachine(machine, start), SimMachine(machine, start)
    probe = frames.ticks[::5]
    fast.watch(probe)
    ref.watch(probe)
    for chunk in split(frames, list(range(0, len(frames), 97))):
        fast.feed(chunk)
        ref.feed_reference(chunk)
    assert observed(fast, probe.tolist()) == observed(ref, probe.tolist())
    assert np.array_equal(fast.states_at(probe), ref.states_at(probe))
    assert fast.motor_steps[1] != start[1] and fast.motor_steps[0] != start[0]     # both axes moved


def traces_of(sim: SimMachine) -> dict:
    return {n: (t.stride, t.seen, t.ticks, t.motor_steps, t.carriage_mm) for n, t in sim.traces.items()}


@pytest.mark.parametrize("strict, around", [(False, 0), (True, 3), (True, 0)],
                         ids=["no-violations", "kept-near-violations", "violations-not-kept"])
def test_decimated_trace_written_by_the_kernel_equals_every_point_given(strict, around):
    """A decimated trace (no windows) gets only the points it keeps from the compiled decoder
    (the points near violations in full): the same trace as when every step's point is handed to
    it (a trace with a tick window, here one before the run, takes every point)."""
    base = MITIC if strict else CHIVU
    machine = replace(base, axes=tuple(replace(a, pulse_high_ticks=3 if strict else 1,
                                               pulse_low_ticks=3 if strict else 1, dir_setup_ticks=2 if strict else 0,
                                               dir_hold_ticks=2 if strict else 0) for a in base.axes))
    start = (int(40.0 * 100), int(20.0 * 80)) if strict else None
    frames = random_frames(machine, 21, 30000)
    fast = SimMachine(machine, start, trace_limit=300, trace_around=around)
    given = SimMachine(machine, start, trace_limit=300, trace_around=around, trace_windows=((-2, -1),))
    for chunk in split(frames, list(range(0, len(frames), 2111))):
        fast.feed(chunk)
        given.feed(chunk)
    assert bool(fast.violations) == strict and fast.violations == given.violations
    assert min(t.stride for t in fast.traces.values()) > 8
    assert traces_of(fast) == traces_of(given)
    if around:
        name = machine.axis_names[0]
        marks = np.array([v.tick for v in fast.violations if v.axis == name])
        ticks = np.array(fast.traces[name].ticks)
        near = np.min(np.abs(ticks[:, None] - marks[None, :]), axis=1) <= around
        assert near.sum() > len(ticks) / 2           # most points kept are kept for a violation


def test_a_busy_axis_decoded_over_every_frame_ends_as_step_by_step():
    """An axis whose rises and falls were most of the last chunk's frames is decoded over all the
    frames (not its own sorted out first), a quiet one over its own: both end as step by step,
    with the too-short pulses of the stream reported at the same ticks."""
    machine = CHIVU
    frames = random_frames(machine, 11, 6000)
    values = frames.values.copy()
    quiet = machine.axes[1]                    # in the first half only one frame in 50 may change it
    mask = (1 << quiet.step_bit) | (1 << quiet.dir_bit)
    half = len(frames) // 2
    for k in range(1, half):
        if k % 50:
            values[k] = (values[k] & (~mask & 0xFF)) | (values[k - 1] & mask)
    frames = PortFrames(frames.ticks, values, frames.end_tick)
    fast, ref = SimMachine(machine, (0, 0)), SimMachine(machine, (0, 0))
    probe = frames.ticks[::9]
    fast.watch(probe)
    ref.watch(probe)
    ways = set()
    for chunk in split(frames, list(range(0, len(frames), 700))):
        fast.feed(chunk)
        ref.feed_reference(chunk)
        ways |= set(fast.__dict__.get("_decode_busy", {}).items())
    assert observed(fast, probe.tolist()) == observed(ref, probe.tolist())
    assert (0, True) in ways and (1, False) in ways           # both ways were taken
    assert fast.violations                                    # and the pulses too short were found
