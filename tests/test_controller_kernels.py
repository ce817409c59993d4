"""The controller's compiled tick loop gives what ticking every tick in Python gives, bit for bit.

Random programs on mitic-lathe (its switches, its spindle): homing (ZMOV), rapids and feeds,
threads under the indexer (ISTP, chained passes, different speeds and pitches), dwells; random
pulse timings, interpolators, backlash compensation and spindle load; a simulated machine that
may start off where the controller thinks it is (so a limit switch halts the run) or whose
drivers want longer pulses than the controller gives (so the simulator reports violations).
Each program runs twice -- ``kernels=False``, the readable per-tick reference, and the default --
and everything a user sees must agree: the port frames, the position register, the fault, the
carriages after every step, the switches' changes, the spindle, the violations.
"""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from retrofit.commands import CStp, Dely, FMov, IStp, PFdr, PMov, Spin, ZMov
from retrofit.controller import Controller
from retrofit.errors import MotionError
from retrofit.machine.config import load_machine
from retrofit.motion._jit import HAVE_NUMBA, compiled
from retrofit.sim import SimMachine

from tests import soak

MITIC = load_machine("mitic-lathe")
MAX_TICKS = 20_000_000


@pytest.fixture(scope="module", autouse=True)
def compiled_kernels():
    """The compiled kernels, whatever the size of the programs."""
    compiled()


@st.composite
def machines(draw):
    axes = []
    for axis in MITIC.axes:
        high, low = draw(st.integers(1, 3)), draw(st.integers(1, 3))
        axes.append(replace(axis, pulse_high_ticks=high, pulse_low_ticks=low,
                            dir_setup_ticks=draw(st.integers(0, 3)), dir_hold_ticks=draw(st.integers(0, 3))))
    motion = replace(MITIC.motion, interpolator=draw(st.sampled_from(["bresenham", "dda"])),
                     lookahead=draw(st.sampled_from([1, 3, 16])))
    spindle = MITIC.parts["spindle"]
    spindle = replace(spindle, sim=replace(spindle.sim, load_noise=draw(st.sampled_from([0.0, 0.03, 0.1])),
                                           seed=draw(st.integers(0, 99))))
    return replace(MITIC, axes=tuple(axes), motion=motion, parts={**MITIC.parts, "spindle": spindle})


def _x(draw):
    return draw(st.integers(-300, 300)) / 100.0 + 10.0


@st.composite
def programs(draw):
    """Commands of a lathe job: homing, moves, dwells and threading passes."""
    out = [ZMov()] if draw(st.booleans()) else []
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["thread", "rapid", "feed", "dwell", "thread"]))
        if kind == "rapid":
            out.append(FMov((("X", _x(draw)), ("Z", draw(st.integers(-1500, 500)) / 100.0))))
        elif kind == "feed":
            out += [PFdr(draw(st.sampled_from([60.0, 300.0, 900.0]))),
                    PMov((("X", _x(draw)), ("Z", draw(st.integers(-1500, 500)) / 100.0)))]
        elif kind == "dwell":
            out.append(Dely(draw(st.sampled_from([0.0, 0.01]))))
        else:
            out += _thread(draw)
    return out


def _thread(draw):
    """A pass: to the start, spindle on, the thread under ISTP (maybe a chained taper out)."""
    x, z0 = _x(draw), draw(st.integers(200, 500)) / 100.0
    length = draw(st.integers(300, 1200)) / 100.0
    out = [FMov((("X", x), ("Z", z0))), Spin(draw(st.sampled_from([300.0, 600.0, 1200.0])), 1), IStp(),
           PFdr(draw(st.sampled_from([0.5, 1.0, 1.5]))), PMov((("Z", z0 - length),))]
    if draw(st.booleans()):
        out.append(PMov((("X", x + 1.0), ("Z", z0 - length - 1.0))))     # chained: one helix
    return out + [CStp(), FMov((("X", x + 2.0),))]


def run(machine, commands, sim_machine, start, kernels: bool):
    sim = SimMachine(sim_machine, start)
    ctl = Controller(machine, sim=sim, kernels=kernels)
    ctl.stream(commands)
    try:
        ctl.run_until_idle(MAX_TICKS)
    except MotionError as exc:                       # still busy: compared like any other end
        return ctl, sim, str(exc)
    return ctl, sim, None


def seen(ctl, sim, busy):
    """Everything a user can see of a run."""
    traces = {name: (np.asarray(t.ticks).tolist(), np.asarray(t.motor_steps).tolist(),
                     np.asarray(t.carriage_mm).tolist()) for name, t in sim.traces.items()}
    log = ctl.run_log()
    return {"frames": ctl.frames(), "ticks": ctl.ticks, "position": ctl.position_steps, "fault": ctl.fault,
            "busy": busy, "status": ctl.status, "traces": traces, "switches": sim.switches.events,
            "violations": [(v.tick, v.axis, v.kind, v.detail) for v in sim.violations],
            "spindle": np.frombuffer(sim.spindle.history, np.int64).tolist(),
            "waypoints": log.waypoints, "steps": log.steps_emitted}


def check_compiled_equals_reference(data) -> int:
    machine = data.draw(machines())
    commands = data.draw(programs())
    # where the carriages really are when the controller starts at 0: far off, or so far out
    # that a move runs onto a limit switch
    start = data.draw(st.sampled_from([(0, 0), (-2500, -3000), (3000, 0), (0, 1500)]))
    strict = data.draw(st.booleans())               # drivers that want longer pulses than given
    sim_machine = replace(machine, axes=tuple(replace(a, pulse_high_ticks=a.pulse_high_ticks + 1,
                                                      dir_setup_ticks=a.dir_setup_ticks + 1)
                                              for a in machine.axes)) if strict else machine
    ref = seen(*run(machine, commands, sim_machine, start, kernels=False))
    ctl, sim, busy = run(machine, commands, sim_machine, start, kernels=True)
    fast = seen(ctl, sim, busy)
    for key in ref:
        assert fast[key] == ref[key], key
    return ctl.spans.ticks


@pytest.mark.skipif(not HAVE_NUMBA, reason="compares the compiled loop; without Numba it is the same Python")
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_jobs_give_the_same_frames_carriages_and_violations(data):
    check_compiled_equals_reference(data)


SHARDS = 20                 # 20 x 10 programs, each shard from its own fixed seed: no test over ~15 s


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_NUMBA, reason="compares the compiled loop; without Numba it is the same Python")
@pytest.mark.parametrize("shard", soak.parts(SHARDS, 3))           # CI: 3 of the 20 (tests/soak.py)
def test_random_jobs_give_the_same_frames_carriages_and_violations_200_programs(shard):
    @seed(20_000 + shard)
    @settings(max_examples=200 // SHARDS, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(data=st.data())
    def programs_of_the_shard(data):
        check_compiled_equals_reference(data)
    programs_of_the_shard()


def test_a_thread_runs_almost_entirely_compiled_and_cuts_the_same_helix():
    """A long G33 under the indexer: the compiled loop runs nearly every tick; the carriage
    positions after every step and the spindle's angle at each are those of the reference."""
    commands = [FMov((("X", 12.0), ("Z", 3.0))), Spin(1200.0, 1), IStp(), PFdr(1.0), PMov((("Z", -60.0),)),
                CStp(), FMov((("X", 14.0),))]
    ref_ctl, ref_sim, _ = run(MITIC, commands, MITIC, (0, 0), kernels=False)
    ctl, sim, _ = run(MITIC, commands, MITIC, (0, 0), kernels=True)
    assert ctl.frames() == ref_ctl.frames() and ctl.position_steps == ref_ctl.position_steps == (1400, -4800)
    z = sim.traces["Z"]
    assert np.array_equal(z.carriage_mm, ref_sim.traces["Z"].carriage_mm)
    assert ctl.spans.ticks > 0.99 * ctl.ticks


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 400), st.integers(1, 10**6), st.sampled_from([100, 400, 4096]),
       st.integers(0, 10**9), st.integers(1, 10**6), st.integers(0, 3000), st.integers(0, 10**6),
       st.integers(-4000, 10**6))
def test_the_compiled_indexer_counts_the_steps_of_the_exact_one(s_num, s_den, counts, o_num, o_den, lead,
                                                                steps, ahead):
    """The compiled indexer's integer target equals ``IndexerTrack.target`` (exact fractions) at
    every count the span lets it see; past that count the span hands the move back."""
    from fractions import Fraction

    from retrofit.controller import kernels as K
    from retrofit.controller.spans import SpanRunner
    from retrofit.motion.indexer import IndexerTrack
    s = Fraction(s_num, s_den)
    if s > counts:
        return
    origin = Fraction(o_num, o_den) if not lead else Fraction(o_num % 100_000)
    track = IndexerTrack(s, counts, origin, lead, steps)
    count = max(0, int(origin) + ahead)                   # around the reference index and after
    cap = SpanRunner._count_cap(type("Run", (), {"track": track})())
    if count > cap:
        return
    ix = np.zeros(K.X_N + 1, np.int64)
    ix[[K.X_SNUM, K.X_SDEN, K.X_ONUM, K.X_ODEN, K.X_LEAD, K.X_COUNTS, K.X_STEPS]] = (
        track.s_num, track.s_den, track.o_num, track.o_den, lead, counts, steps)
    assert K.index_target(ix, count) == track.target(count)


def test_the_compiled_spindle_turns_as_the_readable_one_tick_for_tick():
    """A spindle with a wandering load, sped up, reversed and stopped: advanced in long compiled
    stretches it has the angle, index pulses and speed of one stepped tick by tick in Python."""
    from retrofit.sim.spindle import SimSpindle
    settings = MITIC.parts["spindle"]
    settings = replace(settings, sim=replace(settings.sim, load_noise=0.1, seed=5))
    readable, compiled_ = SimSpindle(settings, MITIC.tick_us), SimSpindle(settings, MITIC.tick_us)
    for spindle in (readable, compiled_):
        spindle.command(0, 1200.0, 1)
    for tick, rpm, direction in ((50_000, 300.0, -1), (90_000, 0.0, 0), (120_000, 2000.0, 1)):
        for t in range(readable.tick + 1, tick):
            readable._step(t)
        readable.command(tick, rpm, direction)
        compiled_.read(tick // 3)                          # a read part way, as the controller does
        compiled_.command(tick, rpm, direction)
    for t in range(readable.tick + 1, 200_000):
        readable._step(t)
    compiled_.advance_to(199_999)
    assert np.array_equal(np.frombuffer(readable.history, np.int64), np.frombuffer(compiled_.history, np.int64))
    assert (readable.index_count, readable.index_tick, readable.rpm) == \
        (compiled_.index_count, compiled_.index_tick, compiled_.rpm)
    assert readable.index_count > 400 * 100                 # it really turned, many revolutions
