"""A program of ``retrofit run`` through the tick-by-tick 002 controller, as the console runs it.

Threads under the spindle's indexer and homing against switches (the carousel's ZMOV included)
depend on inputs read while the program runs, so they run on the controller driving a simulated
machine. The program goes in part by part between its pauses: each part runs to its end, so the
machine stands at a pause (M0, M1, M60, a manual tool change) as it does in the console, and the
tick of each pause is known. The tick each command began gives the program line of every tick
(the report's violations name their line).
"""

from __future__ import annotations

import numpy as np

from ..errors import GcodeError
from ..machine.config import Machine


class ControlledRun:
    """What the controller did: its log, the tick of each pause (by command index), and the
    program line of any tick (:meth:`line_of`)."""

    def __init__(self, log, pause_ticks: dict[int, int], starts: list[tuple[int, int]], lines):
        self.log, self.pause_ticks = log, pause_ticks
        self._ticks = np.array([t for t, _ in starts], np.int64)
        self._index = [i for _, i in starts]
        self._lines = lines

    def line_of(self, tick: int) -> int | None:
        """The program line of the command under way at ``tick`` (None before the first)."""
        k = int(np.searchsorted(self._ticks, tick, side="right")) - 1
        if k < 0:
            return None
        index = self._index[k]
        return self._lines[index] if 0 <= index < len(self._lines) else None


def run_controlled(expanded, machine: Machine, backlash_comp: bool = True) -> ControlledRun:
    """Run ``expanded`` (an ``atc.front.Expanded``) on the controller and a simulated machine, to
    a standstill at each pause; a GcodeError naming file:line when the controller refuses a
    command or halts with an error."""
    from ..controller import Controller
    from ..controller.program import ProgramError, run_commands
    from ..sim import SimMachine
    ctl = Controller(machine, backlash_comp=backlash_comp, sim=SimMachine(machine))
    starts: list[tuple[int, int]] = []       # (tick, serial) of every entry the controller began
    record, begin = ctl.processor.record, ctl.processor.record.begin

    def begin_and_mark(entry, tick):
        starts.append((tick, entry.serial))
        begin(entry, tick)
    record.begin = begin_and_mark
    commands = expanded.commands
    cuts = sorted({e.index for e in getattr(expanded, "pauses", ()) if 0 < e.index < len(commands)})
    pause_ticks, done = {}, 0
    for end in cuts + [len(commands)]:
        try:
            run_commands(commands[done:end], machine, controller=ctl)
        except ProgramError as exc:
            index = None if exc.command_index is None else done + exc.command_index
            line = expanded.lines[index] if index is not None and index < len(expanded.lines) else None
            raise GcodeError(str(exc), expanded.file, line) from None
        pause_ticks[end] = ctl.ticks
        done = end
    pause_ticks[0] = 0
    return ControlledRun(ctl.run_log(), pause_ticks, [(t, s - 1) for t, s in starts], expanded.lines)
