"""The tick step generator: the lathe paper's counters and direction timing, seen on the wire."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from retrofit.motion.stepgen import StepGenerator, StepTiming


def drive(timing, requests, ticks=None):
    """Run one generator; requests[n] is None (idle) or +1/-1 (a step wanted after frame n).

    A request that cannot start is kept and retried each tick (never lost). Returns the step and
    direction bits per tick and the number of steps started.
    """
    gen = StepGenerator(timing)
    pending = []
    steps, dirs, started = [], [], 0
    n_ticks = ticks or len(requests) * (timing.period + timing.dir_setup + timing.dir_hold + 2) + 10
    for n in range(n_ticks):
        s, d = gen.frame()
        steps.append(s)
        dirs.append(d)
        if n < len(requests) and requests[n] is not None:
            pending.append(requests[n])
        if pending:
            want = pending[0]
            if gen.set_direction(want) and gen.start_step():
                pending.pop(0)
                started += 1
    assert not pending, "requests left undone"
    return np.array(steps), np.array(dirs), started


def rising_edges(steps):
    prev = np.concatenate(([0], steps[:-1]))
    return np.flatnonzero((steps == 1) & (prev == 0))


def test_request_during_pulse_is_deferred_not_lost():
    timing = StepTiming(pulse_high=3, pulse_low=2)
    steps, _, started = drive(timing, [1, 1, None, None, None, None, None, None, None, None])
    rises = rising_edges(steps)
    assert started == 2
    assert list(rises) == [1, 6]          # second request waited for the period (3 + 2) to end
    assert list(steps[:11]) == [0, 1, 1, 1, 0, 0, 1, 1, 1, 0, 0]


def test_shortest_period_is_high_plus_space():
    timing = StepTiming(pulse_high=2, pulse_low=3)
    steps, _, _ = drive(timing, [1] * 20)
    assert set(np.diff(rising_edges(steps))) == {5}


def test_two_tick_minimum_with_one_one():
    steps, _, _ = drive(StepTiming(1, 1), [1] * 10)
    rises = rising_edges(steps)
    assert set(np.diff(rises)) == {2}
    assert list(steps[1:9]) == [1, 0, 1, 0, 1, 0, 1, 0]


def test_direction_waits_for_hold_and_setup():
    timing = StepTiming(pulse_high=1, pulse_low=1, dir_setup=3, dir_hold=2)
    steps, dirs, _ = drive(timing, [1, -1] + [None] * 10)
    rises = rising_edges(steps)
    assert dirs[rises[0]] == 1 and dirs[rises[1]] == -1
    changes = np.flatnonzero(np.diff(dirs) != 0) + 1
    change = changes[changes > rises[0]][0]
    assert rises[0] - changes[0] >= 3        # set-up before the first edge too
    assert change - rises[0] >= 2            # hold after the first edge
    assert rises[1] - change >= 3            # set-up before the second


requests = st.lists(st.one_of(st.none(), st.sampled_from([1, -1])), min_size=1, max_size=60)


@given(requests, st.integers(1, 4), st.integers(1, 4), st.integers(0, 5), st.integers(0, 5))
def test_random_requests_seen_by_the_simulated_driver(reqs, high, low, setup, hold):
    """No overlap, nothing lost, no set-up / hold breach, as sim:// decodes the wire."""
    from dataclasses import replace

    from retrofit.frames import PortFrames
    from retrofit.machine.config import load_machine
    from retrofit.sim.drivers import DriverInput

    timing = StepTiming(high, low, setup, hold)
    steps, dirs, started = drive(timing, reqs)
    wanted = [r for r in reqs if r is not None]
    axis = replace(load_machine("chivu-lathe").axes[0], pulse_high_ticks=high, pulse_low_ticks=low,
                   dir_setup_ticks=setup, dir_hold_ticks=hold, step_bit=0, dir_bit=1,
                   invert_step=False, invert_dir=False)
    byte = steps | ((dirs > 0).astype(np.uint8) << 1)
    frames = PortFrames.from_per_tick(byte)
    driver = DriverInput(axis)
    rises, rise_dirs = driver.edges(frames.ticks, frames.values)
    assert started == len(wanted) == len(rises)
    assert list(rise_dirs) == wanted                     # every request, in order, right direction
    assert driver.violations == []
    if len(rises) > 1:
        assert np.diff(rises).min() >= high + low         # never overlapping
