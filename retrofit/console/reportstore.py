"""What ``--html`` keeps of a streamed run, in bounded memory: the step edges the timeline reads
and the first port frames, taken from each window of frames as the run makes it.

The HTML report's timeline is computed at fixed ticks (:func:`.views.timeline_ticks`), from the
position at each and the first and last step edge of each averaging window around it. Of every
axis's steps the store keeps only those edges (and the edge before each, whose direction a
single-edge window needs), so the timeline drawn from them is the one drawn from every step,
while memory follows the timeline's points, not the run's steps. The pulse view's port frames
are the run's first :data:`.report_html.MAX_FRAMES` at most (the page holds fewer anyway).
"""

from __future__ import annotations

import numpy as np

from ..frames import PortFrames
from ..machine.config import Machine
from .views import AxisSteps, timeline_ticks


class ReportStore:
    """Fed each window of port frames (:meth:`feed`) of a run expected to end at ``end_tick``;
    then :meth:`steps`, :attr:`frames` (the first ones), :attr:`total` (frames seen)."""

    def __init__(self, machine: Machine, start_steps, end_tick: int, points: int, max_frames: int):
        self.machine, self.timeline_end = machine, max(int(end_tick), 2)
        self.start = [int(s) for s in (start_steps or (0,) * len(machine.axes))]
        ticks, half = timeline_ticks(machine, 0, self.timeline_end, points)
        self.first_q = np.unique(np.concatenate([ticks - 2 * half, ticks - half, ticks]))
        self.last_q = np.unique(np.concatenate([ticks, ticks + half, ticks + 2 * half]))
        invert = 0
        for a in machine.axes:
            invert |= (a.invert_step << a.step_bit) | (a.invert_dir << a.dir_bit)
        self.invert = np.uint8(invert)
        self.level = [0] * len(machine.axes)        # each step line's logical level so far
        self.position = list(self.start)
        self.kept = [([], []) for _ in machine.axes]
        self.max_frames, self.total = max_frames, 0
        self._ticks: list[np.ndarray] = []
        self._values: list[np.ndarray] = []

    def feed(self, chunk: PortFrames) -> None:
        """Take in the next window of the run's frames."""
        ticks, values = np.asarray(chunk.ticks, np.int64), np.asarray(chunk.values, np.uint8)
        room = self.max_frames - self.total
        if room > 0:
            self._ticks.append(ticks[:room].copy())
            self._values.append(values[:room].copy())
        self.total += len(ticks)
        if not len(ticks):
            return
        logical = values ^ self.invert
        for i, a in enumerate(self.machine.axes):
            step = (logical >> a.step_bit) & 1
            prev = np.concatenate(([self.level[i]], step[:-1]))
            rise = np.flatnonzero((step == 1) & (prev == 0))
            self.level[i] = int(step[-1])
            if not len(rise):
                continue
            r = ticks[rise]
            p = self.position[i] + np.cumsum(np.where((logical[rise] >> a.dir_bit) & 1, 1, -1).astype(np.int64))
            self.position[i] = int(p[-1])
            self._keep(i, r, p)

    def _keep(self, i: int, r: np.ndarray, p: np.ndarray) -> None:
        """Of one window's edges ``r`` (positions after them ``p``): the first and the last, those
        the timeline's queries land on, and the edge before each."""
        fq = self.first_q[(self.first_q >= r[0]) & (self.first_q <= r[-1])]
        lq = self.last_q[(self.last_q >= r[0]) & (self.last_q <= r[-1])]
        sel = np.concatenate(([0, len(r) - 1], np.searchsorted(r, fq, side="left"),
                              np.searchsorted(r, lq, side="right") - 1))
        sel = np.unique(np.concatenate((sel, sel - 1)))
        sel = sel[sel >= 0]
        self.kept[i][0].append(r[sel])
        self.kept[i][1].append(p[sel])

    def steps(self) -> list[AxisSteps]:
        """The kept edges of every axis (the timeline reads them as it reads every step)."""
        out = []
        for (ticks, pos), start in zip(self.kept, self.start):
            t = np.concatenate(ticks) if ticks else np.zeros(0, np.int64)
            p = np.concatenate(pos) if pos else np.zeros(0, np.int64)
            out.append(AxisSteps(t, p, start))
        return out

    def frames(self, end_tick: int) -> PortFrames:
        """The first port frames of the run (at most ``max_frames``)."""
        ticks = np.concatenate(self._ticks) if self._ticks else np.zeros(0, np.int64)
        values = np.concatenate(self._values) if self._values else np.zeros(0, np.uint8)
        return PortFrames(ticks, values, end_tick)


def store_for(run) -> ReportStore:
    """The store of ``run`` (a ``run.program.Run`` about to be streamed from its whole plan)."""
    from ..motion.execute import tick_of
    from .report_html import MAX_FRAMES, TIMELINE_POINTS
    plan = run.plan
    end = tick_of(plan.end_s, 1.0 / plan.machine.tick_s) + 1
    return ReportStore(plan.machine, plan.start_steps, end, TIMELINE_POINTS, MAX_FRAMES)
