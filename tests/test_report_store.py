"""`retrofit run --html` keeps a bounded store of a streamed run: the timeline drawn from it is
the one drawn from every step, the pulse view gets the run's first port frames, and what it keeps
follows the timeline's points, not the run's steps."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from retrofit.console.reportstore import ReportStore, store_for
from retrofit.console.views import axis_steps, timeline
from retrofit.frames import PortFrames
from retrofit.machine.config import load_machine
from retrofit.run.program import STAGE_WEIGHTS, read_program, run_program
from retrofit.run.progress import silent


def lathe_run(store=None):
    machine = load_machine("chivu-lathe")
    text, name = read_program("lathe-profile.ngc")
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=store is None, keep_commands=True, before_outputs=None,
                           report_store=store)
    return machine, run_program(text, name, machine, opts, silent(STAGE_WEIGHTS))


@pytest.fixture(scope="module")
def whole():
    return lathe_run()


def test_the_streamed_runs_store_draws_what_every_step_draws(whole):
    machine, full = whole
    _, streamed = lathe_run(store_for)
    assert len(streamed.log.frames) == 0                       # the run itself kept no frames
    kept = streamed.kept
    end = kept.timeline_end
    assert abs(end - full.log.frames.end_tick) < 10
    every = timeline(axis_steps(full.log.frames, machine), machine, 0, end, points=20_000)
    assert timeline(kept.steps(), machine, 0, end, points=20_000) == every
    frames = kept.frames(streamed.log.frames.end_tick)
    assert kept.total == len(full.log.frames)
    assert np.array_equal(frames.ticks, full.log.frames.ticks) and np.array_equal(frames.values, full.log.frames.values)


def test_what_the_store_keeps_follows_the_points_not_the_steps(whole):
    machine, full = whole
    frames, points = full.log.frames, 200
    store = ReportStore(machine, full.log.start_steps, frames.end_tick, points, max_frames=1000)
    for lo in range(0, len(frames), 5000):                      # windows as a stream hands them on
        store.feed(PortFrames(frames.ticks[lo:lo + 5000], frames.values[lo:lo + 5000], frames.end_tick))
    every = axis_steps(frames, machine)
    kept = store.steps()
    assert timeline(kept, machine, 0, frames.end_tick, points=points) == \
        timeline(every, machine, 0, frames.end_tick, points=points)
    windows = -(-len(frames) // 5000)
    for k, e in zip(kept, every):                               # 6 queries a point, each edge with the one before
        assert len(k.ticks) <= 12 * points + 4 * windows < len(e.ticks)
    assert len(store.frames(frames.end_tick)) == 1000 and store.total == len(frames)
