"""A plan's port frames to the outputs as they are made: the streamed run.

Program → plan → step schedule → port frames → outputs → report, a window at a time
(``motion.stream``): each chunk of frames goes to every output (``sim://`` decodes it with its
compiled kernels, ``vcd://`` appends it to its file) and is dropped. The simulated machine keeps
a trace decimated to what a plot can show, in full near violations, and the exact state at every
waypoint the report measures, so memory does not grow with the program's steps.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..failsafe import stop_all
from ..frames import PortFrames
from ..runlog import RunLog, WaypointTable
from . import open_output
from .sim import SimOutput

#: trace points kept per axis for plots of a streamed run, and full detail this close to a violation
TRACE_POINTS = 100_000
AROUND_VIOLATION_TICKS = 200


def deliver_plan(plan, urls: list[str], progress: Callable[[float], None] | None = None,
                 window_steps: int = 1 << 18, blocks=None, taps=()):
    """Stream ``plan``'s frames to every output in ``urls``; return (run log, simulated machine).

    The run log holds the waypoints, steps and following error but no frames (its ``frames`` is
    empty, with the run's ``end_tick``); ``progress`` gets the fraction of moves done.
    ``blocks``: (machine, iterator of (PlanArrays, end time or None)), a plan handed on block by
    block from the start position, in place of ``plan`` (``motion.stream.stream_blocks``); then
    ``progress`` gets the index of the command after the last one stepped. ``taps``: more
    callables that get each chunk of frames (what an HTML report keeps of them).
    """
    from ..motion.stream import stream_blocks, stream_frames
    from ..sim import SimMachine
    machine = plan.machine if blocks is None else blocks[0]
    start_steps = plan.start_steps if blocks is None else (0,) * len(machine.axes)
    trace = {"trace_limit": TRACE_POINTS, "trace_around": AROUND_VIOLATION_TICKS}
    outputs = [open_output(url, machine) for url in urls]
    hand_plan(outputs, plan if blocks is None else None)
    sims = [out for out in outputs if isinstance(out, SimOutput)]
    for out in sims:
        out.start_steps, out.trace_options = start_steps, trace
    log = RunLog(machine, PortFrames([], [], 0), start_steps=start_steps)
    try:
        for out in outputs:
            out.open()
        sim = sims[0].sim if sims else SimMachine(machine, start_steps, **trace)
        for s in [sim] + [out.sim for out in sims]:
            s.keep_watched = blocks is None       # read ahead: nothing plots the run afterwards
        feeds = [out.write for out in outputs] + ([] if sims else [sim.feed]) + list(taps)
        table = log.waypoints = WaypointTable(len(machine.axes), keep_all=blocks is None)
        watched, errors = [], _WorstError(machine)

        def waypoints(steps, loaded, reached) -> None:
            table.add(steps, loaded, reached)
            watched.append(reached)
            errors.add(steps, reached)
        gen = (stream_frames(plan, window_steps, on_waypoints=waypoints, progress=progress) if blocks is None
               else stream_blocks(machine, start_steps, blocks[1], window_steps, on_waypoints=waypoints,
                                 progress=progress))
        while True:
            try:
                chunk = next(gen)
            except StopIteration as stop:
                stats = stop.value
                break
            for s in {id(x.sim): x.sim for x in sims}.values() if sims else (sim,):
                s.watch(np.concatenate(watched) if watched else ())
            watched.clear()
            for feed in feeds:
                feed(chunk)
            errors.settle(sim, chunk.end_tick)
        errors.settle(sim, None)
        table.worst_mm = errors.worst
    except BaseException:
        stop_all(outputs)                  # the machine stops before anything else
        raise
    finally:
        for out in outputs:
            out.close()
    log.frames = PortFrames([], [], stats.end_tick)
    log.steps_emitted = {a.name: int(n) for a, n in zip(machine.axes, stats.steps)}
    log.max_following_error_steps = int(stats.lag)
    return log, sim


def hand_plan(outputs, plan) -> None:
    """The one place a run gives its outputs more than port frames: each output whose
    ``wants_plan()`` says so gets the run's ``plan`` (None: the run has none) before it is
    opened; what it makes of it (``fpga-sim://?variant=di``: the plan's step requests as line
    records) is its own. Called by every path that delivers a run (``deliver_plan`` and
    ``run.runner.deliver``)."""
    for out in outputs:
        if out.wants_plan():
            out.take_plan(plan)


class _WorstError:
    """The worst |carriage - target| per axis (mm) at the waypoints' reached ticks, settled after
    each chunk from the states the simulated machine watched in it (nothing kept per waypoint)."""

    def __init__(self, machine):
        self.spm = np.array([a.steps_per_mm for a in machine.axes])
        self.worst = np.zeros(len(machine.axes))
        self.pending: list[tuple[np.ndarray, np.ndarray]] = []

    def add(self, steps: np.ndarray, reached: np.ndarray) -> None:
        self.pending.append((steps, reached))

    def settle(self, sim, end_tick: int | None) -> None:
        """Take in the waypoints reached before ``end_tick`` (None: all)."""
        if not self.pending:
            return
        steps = np.concatenate([p[0] for p in self.pending])
        reached = np.concatenate([p[1] for p in self.pending])
        now = reached >= 0 if end_tick is None else (reached >= 0) & (reached < end_tick)
        later = (reached >= end_tick) if end_tick is not None else np.zeros(len(reached), bool)
        self.pending = [(steps[later], reached[later])] if later.any() else []
        if now.any():
            carriage = sim.carriages_at(reached[now])
            self.worst = np.maximum(self.worst, np.abs(carriage - steps[now] / self.spm).max(axis=0))
