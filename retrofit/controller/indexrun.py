"""The *execute* phase of an ISTP move: the spindle's encoder, not the clock, times the steps.

A pass runs in four phases:

1. **take-up** -- an axis that reverses first turns through its backlash clearance, at the clock's
   pace, so that the synchronised part starts with every nut already engaged;
2. **synchronise** -- it waits for the spindle to be at speed and for an index pulse (SIND);
3. **armed** -- from that index it picks the reference index ``c_ref`` (a later index when the
   lead-in needs more than the counts left) and waits for the lead-in's first count;
4. **run** -- each tick the encoder count (ICLK) sets the base axis's target
   (:class:`~retrofit.motion.indexer.IndexerTrack`), and the line's Bresenham steps every axis.

A move that follows another ISTP move directly is *chained*: it continues the first one's line
from the exact count where it ended, with no new synchronisation, so a tapered entry, the thread
and a tapered exit form one helix.

On a spindle whose encoder counts both ways (``reverse_rpm_s`` in ``[spindle]``) the count is the
signed angle. A move reads it in its own frame, the sign of the spindle's direction when it
starts, so that its count rises as it advances; a move chained after a reversal runs back along
the same helix. When the spindle is to reverse right after a move, the move turns it round in
time (:class:`~retrofit.controller.turnaround.Turnaround`): a rigid tap's way in and way out.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

from ..errors import MotionError
from ..motion.bresenham import LineMove
from ..motion.indexer import IndexerExecutor, IndexerTrack, lead_in_counts, steps_per_rev
from .turnaround import Turnaround

#: a pass that sees no index pulse this long while it waits to synchronise stops with an error
#: (the firmware's INDEX_TIMEOUT_MS too)
INDEX_TIMEOUT_S = 5.0


class IndexRun:
    """One ISTP move executing."""

    needs_spindle = True

    def __init__(self, entry, line: LineMove, takeup: tuple[int, ...], spindle, rpm: float,
                 chained_from: Fraction | None, machine, direction: int = 1):
        self.entry = entry
        self.rate = 1e6 / machine.tick_us
        self.axis_accel = [a.max_accel_mm_s2 * a.steps_per_mm for a in machine.axes]   # steps/s^2
        self.line = line
        self.takeup = takeup                  # signed steps per axis to issue first
        self.spindle = spindle                # SpindleSettings
        self.rpm = rpm                        # commanded spindle speed (magnitude)
        self.signed = spindle.reverse_rpm_s is not None   # the encoder counts both ways
        self.sign = -1 if self.signed and direction < 0 else 1   # the move's frame of counts
        # where the previous ISTP move's line ended (given in the encoder's counts)
        self.origin = None if chained_from is None else chained_from * self.sign
        self.turn: Turnaround | None = None   # a Turnaround when the spindle reverses at the end
        self.phase = "takeup"
        self.seen: int | None = None          # the index count last seen while waiting
        self.index_at: int | None = None      # the tick it was last seen to change
        self._last_index = -1                 # the index count at that tick
        self.timeout_ticks = round(INDEX_TIMEOUT_S * self.rate)
        self.track: IndexerTrack | None = None
        self.executor: IndexerExecutor | None = None
        self.s = steps_per_rev(entry.feed_mm_rev, entry.path.length_mm, line.n) if line.n else Fraction(0)

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def end_count(self) -> Fraction | None:
        """The exact count at which this move's line ends (a chained move starts there)."""
        return self.track.end_count if self.track is not None else None

    @property
    def end_raw(self) -> Fraction | None:
        """The same count as the encoder gives it (the next move's frame may differ)."""
        return self.track.end_count * self.sign if self.track is not None else None

    def _frame(self, inputs):
        """The encoder's inputs in the move's frame (counts rise as it advances)."""
        if self.sign > 0:
            return inputs
        index = inputs.index_count if inputs.index_tick < 0 else -inputs.index_count
        return replace(inputs, count=-inputs.count, index_count=index)

    def step(self, tick: int, inputs, pulses) -> None:
        """Advance after frame ``tick`` with the spindle ``inputs`` of that tick."""
        inputs = self._frame(inputs)
        if self.phase == "takeup":
            self._take_up(tick, pulses)
            if self.line.n == 0:
                self.phase = "done"
                return
            if self.origin is not None:       # chained: no synchronisation, no lead-in
                self._arm(self.origin, 0)
            else:
                self.phase = "sync"
        if self.phase != "takeup":
            self._watch_index(tick, inputs)
        if self.phase == "sync":
            self._synchronise(inputs, pulses)
        track, executor = self.track, self.executor
        if self.phase == "armed" and track is not None and inputs.count >= track.start_count:
            self.phase = "run"
        if self.phase == "run":
            assert track is not None and executor is not None, "a run without its track"
            if self.turn is not None:
                self._turning(tick, inputs.count, track)
            for cycle in executor.advance(inputs.count):
                for axis, step in enumerate(cycle):
                    if step:
                        pulses.request(axis, tick + 1, step)
            if executor.done:
                self.phase = "done"
                if self.turn is not None and self.turn.issued_at is None:
                    self.turn.issue(tick)         # not due earlier (a very short move): now

    def _turning(self, tick: int, count: int, track: IndexerTrack) -> None:
        turn = self.turn
        assert turn is not None
        step_counts = self.spindle.encoder_counts_per_rev / float(self.s)
        turn.watch(tick, count, float(track.start_count), float(track.end_count), step_counts)
        turn.check(count, step_counts, str(self.entry.cmd))

    def _take_up(self, tick: int, pulses) -> None:
        """The clearance steps, timed as a start from rest at the axis's acceleration."""
        for axis, steps in enumerate(self.takeup):
            accel = self.axis_accel[axis]
            for k in range(1, abs(steps) + 1):
                pulses.request(axis, tick + 1 + math.ceil(math.sqrt(2.0 * k / accel) * self.rate),
                               1 if steps > 0 else -1)

    def index_deadline(self) -> int:
        """The tick after which, with no new index pulse, the pass ends in an error."""
        return (self.index_at if self.index_at is not None else 0) + self.timeout_ticks + 1

    def _watch_index(self, tick: int, inputs) -> None:
        """MotionError when no index pulse has come for INDEX_TIMEOUT_S, waiting or running."""
        if self.index_at is None or inputs.index_count != self._last_index:
            self.index_at, self._last_index = tick, inputs.index_count
        elif tick - self.index_at > self.timeout_ticks:
            raise MotionError(f"{self.entry.cmd} under ISTP: no spindle index pulse for "
                              f"{INDEX_TIMEOUT_S:g} s; the spindle is not turning (stalled, or not "
                              "started); motion halted")

    def _synchronise(self, inputs, pulses) -> None:
        """Wait for the take-up to finish, the spindle to be at speed and a fresh index pulse."""
        if pulses.pending or not inputs.at_speed or self.seen is None:
            self.seen = inputs.index_count
            return
        if inputs.index_count == self.seen:
            return
        lead = self.lead_in()
        c = self.spindle.encoder_counts_per_rev
        revolutions = math.ceil(lead / c) if lead else 0
        self._arm(Fraction(inputs.index_count + revolutions * c), lead)

    def _arm(self, origin: Fraction, lead: int) -> None:
        self.track = IndexerTrack(self.s, self.spindle.encoder_counts_per_rev, origin, lead, self.line.n)
        self.executor = IndexerExecutor(self.line, self.track)
        self.phase = "armed" if lead else "run"

    def lead_in(self) -> int:
        """Counts of lead-in for the planned spindle speed; MotionError when the move cannot have it."""
        entry, path, spindle = self.entry, self.entry.path, self.spindle
        per_mm = self.line.n / path.length_mm                      # base steps per mm of path
        rpm = self.rpm * (1.0 + spindle.speed_tolerance)
        speed = entry.feed_mm_rev * rpm / 60.0
        if speed > path.v_max_mm_s * (1.0 + 1e-9):
            raise MotionError(f"{entry.cmd}: thread speed {speed:.2f} mm/s ({entry.feed_mm_rev:g} mm/rev at "
                              f"up to {rpm:.0f} rpm) exceeds the axes' {path.v_max_mm_s:.2f} mm/s; "
                              f"lower the spindle speed")
        accel = path.a_max_mm_s2 * spindle.sync_accel_share
        lead = lead_in_counts(self.s, spindle.encoder_counts_per_rev, rpm, accel * per_mm)
        lead_mm = float(self.s) * lead / spindle.encoder_counts_per_rev / per_mm
        if lead_mm > path.length_mm:
            raise MotionError(f"{entry.cmd}: the lead-in to thread speed takes {lead_mm:.2f} mm at "
                              f"{rpm:.0f} rpm and {accel:g} mm/s^2, longer than the {path.length_mm:.2f} mm "
                              f"move; start the pass further out or lower the spindle speed")
        return lead
