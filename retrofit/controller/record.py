"""What the controller did, kept for the run log: each entry's target and when it was reached."""

from __future__ import annotations

from dataclasses import dataclass

from ..machine.config import Machine
from ..runlog import RunLog, Waypoint


@dataclass
class EntryRecord:
    target: tuple[int, ...]           # commanded position at its end (machine steps)
    loaded_tick: int
    counts: tuple[int, ...] | None = None   # requests per axis made up to its end
    end_tick: int | None = None       # tick of its planned end


class RunRecord:
    """The entries started, in order (moves, dwells, ISTP moves, homings)."""

    def __init__(self, machine: Machine):
        self.machine = machine
        self.entries: list[EntryRecord] = []

    def begin(self, entry, tick: int) -> None:
        self.entries.append(EntryRecord(tuple(entry.target), tick))

    def finish(self, counts: tuple[int, ...], end_tick: int) -> None:
        last = self.entries[-1]
        if last.counts is None:
            last.counts, last.end_tick = counts, end_tick

    def run_log(self, frames, pulses) -> RunLog:
        """A RunLog as ``motion.execute.run_log`` makes one: an entry is reached on the last rising
        edge of its own steps (or at its planned end when it has none)."""
        machine = self.machine
        log = RunLog(machine, frames, start_steps=(0,) * len(machine.axes))
        rises = pulses.rises
        previous = (0,) * len(machine.axes)
        for rec in self.entries:
            counts = rec.counts if rec.counts is not None else pulses.requested()
            last = [rises[i][c - 1] for i, c in enumerate(counts)
                    if c > previous[i] and c - 1 < len(rises[i])]
            end = rec.end_tick if rec.end_tick is not None else frames.end_tick - 1
            log.waypoints.append(Waypoint(rec.target, rec.loaded_tick, max(last) if last else end))
            previous = counts
        log.steps_emitted = {a.name: len(r) for a, r in zip(machine.axes, rises)}
        log.max_following_error_steps = pulses.lag()
        return log
