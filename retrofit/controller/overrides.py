"""FFDR and MFDR: the operator's feed changes, acted on at once, even in the middle of a move.

002: FFDR "allows to operator continual changing of maximal traverse speed during fast movement";
MFDR "allows to operator continual changing machining speed". Both take effect on the tick they
arrive: the move running is re-planned from where it is, at its current speed, towards the new
feed within the acceleration limits, and the moves already prepared get the new feed too.

Which moves a new machining feed reaches: the PMOV running and the prepared PMOVs that share its
programmed feed. A PFDR already prepared behind them still takes over at its own move (it is the
program's next feed), and moves under ISTP keep their pitch.

The heartbeat's stop (a host gone silent, docs/protocol.md §5) is the same re-planning with every
move's feed at BRAKE_FEED_MM_MIN: the tool slows at the moves' acceleration, and once it is below
twice that speed the controller halts, as from rest.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..commands import FFdr
from ..motion.planner import kinematics
from .prepare import LineEntry
from .runs import ClockRun

if TYPE_CHECKING:
    from collections import deque

    from ..machine.config import Machine
    from ..motion.lookahead import Kinematics
    from .homing import HomeRun
    from .indexrun import IndexRun
    from .prepare import Walker
    from .runs import DwellRun
    from .window import WindowPlanner

#: the feed every move gets when the heartbeat brakes the machine
BRAKE_FEED_MM_MIN = 1.0


class FeedOverrides:
    """Mixin of :class:`~retrofit.controller.processor.Processor`: FFDR and MFDR."""

    # the processor's state these methods read and set (see Processor.__init__)
    machine: Machine
    walker: Walker
    planner: WindowPlanner
    window: deque
    run: ClockRun | DwellRun | IndexRun | HomeRun | None
    prev_kin: Kinematics | None
    exit_speed: float
    t_plan: float

    def override(self, cmd, tick: int) -> None:
        """Set the fast (FFDR) or machining (MFDR) feed now."""
        if isinstance(cmd, FFdr):
            self.walker.rapid = cmd.feed
            reached = lambda e: isinstance(e, LineEntry) and e.rapid              # noqa: E731
        else:
            group = self._feed_group()
            if self.walker.group == group:
                self.walker.feed = cmd.feed
            reached = lambda e: isinstance(e, LineEntry) and not e.rapid and e.group == group  # noqa: E731
        for entry in self.window:
            if reached(entry):
                entry.kin = self._with_feed(entry, cmd.feed)
        run = self.run
        if isinstance(run, ClockRun) and reached(run.entry):
            run.entry.kin = self._with_feed(run.entry, cmd.feed)
            self._replan(run, run.position_at_tick(tick))

    def window_grew(self) -> None:
        """A move was prepared while one runs: if what the window now holds lets the running move
        end faster than it was planned to (it had to stop at the end of the window), re-plan its
        rest. A move that starts with a full window is never re-planned."""
        run = self.run
        if not isinstance(run, ClockRun) or run.done or run.profile is None:
            return
        s = run.position_mm()
        rest = run.profile.length - s
        v = run.profile.speed_at(s)
        moves = [run.kin] + [e.kin for e in self.window if e.is_move]
        exit_v, accel = self.planner.plan(run.prev, moves, v, length=rest)
        if exit_v <= run.profile.exit_speed:
            return
        self._replan(run, s)

    def _feed_group(self) -> int:
        """The programmed feed an MFDR changes: the running PMOV's, else the next PMOV's."""
        run = self.run
        if isinstance(run, ClockRun) and not run.entry.rapid:
            return run.entry.group
        for entry in self.window:
            if isinstance(entry, LineEntry) and not entry.rapid:
                return entry.group
        return self.walker.group

    def _with_feed(self, entry: LineEntry, feed_mm_min: float):
        kin = kinematics(self.machine, entry.start, entry.end, feed_mm_min / 60.0)
        assert entry.kin is not None              # a line entry has its kinematics (Walker._line)
        kin.stop_before = entry.kin.stop_before
        return kin

    def _replan(self, run: ClockRun, s: float) -> None:
        """Re-plan the rest of the running move, from ``s`` mm on, with its new speed cap."""
        if run.done or run.profile is None:
            return
        kin = run.entry.kin
        rest = run.profile.length - s
        v = run.profile.speed_at(s)
        moves = [kin] + [e.kin for e in self.window if e.is_move]
        exit_v, accel = self.planner.plan(run.prev, moves, v, length=rest)
        exit_v = max(exit_v, math.sqrt(max(v * v - 2.0 * accel * rest, 0.0)))   # braking takes room
        run.replan(kin, exit_v, accel, s)
        self.t_plan = run.end_time
        self.exit_speed = run.profile.exit_speed
        self.prev_kin = kin

    def brake(self, tick: int) -> bool:
        """Slow every prepared move and the one running to BRAKE_FEED_MM_MIN; False when there
        is no straight move running to slow down (a dwell, a homing or a thread pass: the
        controller halts at once)."""
        for entry in self.window:
            if isinstance(entry, LineEntry):
                entry.kin = self._with_feed(entry, BRAKE_FEED_MM_MIN)
        run = self.run
        if not isinstance(run, ClockRun) or run.done or run.profile is None:
            return False
        run.entry.kin = self._with_feed(run.entry, BRAKE_FEED_MM_MIN)
        self._replan(run, run.position_at_tick(tick))
        return True

    def braked(self) -> bool:
        """True once the move running is slow enough to halt (or no straight move runs)."""
        run = self.run
        if not isinstance(run, ClockRun) or run.done or run.profile is None:
            return True
        return run.profile.speed_at(run.position_mm()) <= 2.0 * BRAKE_FEED_MM_MIN / 60.0
