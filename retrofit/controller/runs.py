"""The *execute* phase of clock-timed entries: straight moves and dwells, one tick at a time.

A straight move runs its interpolator (002's Bresenham or 004's digital integration) one cycle
at a time, just in time: a cycle is computed on the tick before its steps are due, its steps
timed on the move's velocity profile ("executed in determined moments according to motion
feedrate", 002). So a feed change can re-plan the rest of the move at any tick.
"""

from __future__ import annotations

from ..motion.bresenham import BresenhamExecutor, LineMove
from ..motion.dda import DdaExecutor, pulse_position
from ..motion.execute import tick_of
from ..motion.lookahead import Kinematics
from .profiles import MoveProfile, ramp_pieces


class ClockRun:
    """A straight move executing: cycles of the interpolator, each at its tick on the profile."""

    prev: Kinematics | None              # the move before it (set by the processor as it starts)

    def __init__(self, entry, line: LineMove, kin: Kinematics, profile: MoveProfile | None,
                 t0: float, rate: float, dda: bool):
        self.entry = entry
        self.line = line
        self.kin = kin
        self.profile = profile
        self.t0 = t0
        self.rate = rate
        self.cycle = 0                       # cycles (base steps) computed so far
        self.dda = DdaExecutor(line) if dda else None
        self.bresenham = None if dda else BresenhamExecutor(line)
        self.sent = [0] * line.axes          # 004: pulses of each axis so far
        self._due: int | None = None         # tick of the next cycle's base step

    @property
    def done(self) -> bool:
        return self.profile is None or self.cycle >= self.line.n

    @property
    def end_time(self) -> float:
        """Planned time (s) at which the move ends."""
        return self.t0 + (self.profile.duration if self.profile is not None else 0.0)

    def _tick_at(self, position: float) -> int:
        """The tick nearest the time the tool is ``position`` base steps along the move."""
        prof = self.profile
        assert prof is not None, "a move without a profile has no ticks"
        s = position * prof.length / self.line.n
        return tick_of(self.t0 + prof.time_at(s), self.rate)

    def next_due(self) -> int | None:
        """Tick of the next cycle's base step (None when the move is done)."""
        if self.done:
            return None
        if self._due is None:
            self._due = self._tick_at(float(self.cycle + 1))
        return self._due

    def generate(self, limit: int, pulses) -> None:
        """Compute every cycle whose base step is due by tick ``limit``; queue its steps."""
        while (due := self.next_due()) is not None and due <= limit:
            self.cycle += 1
            self._due = None
            if self.bresenham is not None:
                for axis, step in enumerate(self.bresenham.step()):
                    if step:
                        pulses.request(axis, due, step)
                continue
            line, dda = self.line, self.dda
            assert dda is not None
            for axis, delay in enumerate(dda.step()):
                if delay is not None:
                    self.sent[axis] += 1
                    d = abs(line.delta[axis])
                    position = pulse_position(self.sent[axis], line.n, d)
                    pulses.request(axis, self._tick_at(position), line.direction[axis])

    def heading(self, axis: int) -> int:
        """Direction of the axis's steps still to come in this move (0: none left)."""
        line = self.line
        if self.bresenham is not None:
            left = self.bresenham._position[axis] != line.end[axis]
        else:
            left = self.sent[axis] < abs(line.delta[axis])
        return line.direction[axis] if left and self.profile is not None else 0

    def position_mm(self) -> float:
        """How far along the move (mm) the cycles computed so far have got."""
        prof = self.profile
        return 0.0 if prof is None else float(self.cycle) * prof.length / self.line.n

    def position_at_tick(self, tick: int) -> float:
        """Where along the move (mm) the tool is on the profile at ``tick``: past the last cycle
        computed, short of the next one (whose step is due later)."""
        s = self.position_mm()
        t = tick / self.rate - self.t0
        prof = self.profile
        if self.done or prof is None or prof.time_at(s) >= t:
            return s
        nxt = min(float(self.cycle + 1) * prof.length / self.line.n, prof.length)
        return prof.position_at(t, s, nxt)

    def replan(self, kin: Kinematics, exit_speed: float, accel: float, s: float) -> None:
        """Follow a new speed cap from ``s`` mm on (see :meth:`position_at_tick`): the rest of the
        move re-planned from the speed there, so the steps owed since the last cycle come at the
        new pace, not at once."""
        self.kin = kin
        prof = self.profile
        if self.done or prof is None:
            return
        v = prof.speed_at(s)
        prof.replan(s, ramp_pieces(prof.length - s, v, kin.v_max_mm_s, exit_speed, accel))
        self._due = None


class DwellRun:
    """DELY: nothing moves until the planned end of the dwell."""

    def __init__(self, entry, t0: float, rate: float):
        self.entry = entry
        self.t0 = t0
        self.end_tick = tick_of(t0 + entry.seconds, rate)
        self.ticked = -1

    @property
    def end_time(self) -> float:
        return self.t0 + self.entry.seconds

    @property
    def done(self) -> bool:
        return self.ticked + 1 >= self.end_tick

    def next_due(self) -> int:
        return self.end_tick

    def generate(self, limit: int, pulses) -> None:
        self.ticked = limit - 1
