"""A run read ahead from the first line to the last step: interpreter, planner, steps and outputs
each holding a bounded window.

:func:`run_read_ahead` is ``retrofit run``'s run for every program it can take this way: the
interpreter hands on its commands in batches (:mod:`retrofit.gcode.readahead`), tool changes and
pauses become the run's events batch by batch (:mod:`retrofit.atc.front`), the planner plans
each batch as far as its look-ahead allows (:mod:`retrofit.motion.planblocks`), and the stream
makes and delivers the frames a window at a time (:mod:`retrofit.motion.stream`). Nothing holds
the whole program: memory follows the look-ahead and the windows, not the program's length,
and the first step leaves after the first window's lines have been read.

It takes runs of RS274NGC programs on ``sim://`` and ``vcd://`` only (nothing waits at a
pause), by the fast path, on a machine without a tool changer, planned with the trapezoid
profile. A program that turns
out to need more (threads or homing through the controller, M62-M66, an input wait, a probing
move) raises :class:`ReadWhole` as soon as it is read; the run starts again the whole-program
way (its files staged, so nothing half-written is left).
"""

from __future__ import annotations

from array import array
from dataclasses import replace

import numpy as np

from ..errors import GcodeError, MotionError


class ReadWhole(Exception):
    """This program runs the whole-program way (see the module doc)."""


def reads_ahead(machine, opts, urls) -> bool:
    """Whether the run may be read ahead (see the module doc): every run it can serve, unless
    RETROFIT_READ_AHEAD=0 asks for the whole-program way (to compare the two)."""
    import os
    if os.environ.get("RETROFIT_READ_AHEAD", "1") == "0":
        return False
    from ..outputs import OutputURL
    from .program import STREAM_SCHEMES
    return (not opts.reference and not opts.controller and "atc" not in machine.parts
            and (getattr(opts, "dialect", None) or machine.dialect) == "rs274"
            and machine.motion.profile == "trapezoid"
            and not getattr(opts, "keep_frames", False) and not getattr(opts, "keep_commands", True)
            and all(OutputURL.parse(u).scheme in STREAM_SCHEMES for u in urls))


class _Program:
    """What the report reads of a program read ahead: its messages; no commands are kept."""

    def __init__(self, file: str, messages: list):
        self.file, self.messages, self.commands, self.lines, self.files = file, messages, [], [], []


def run_read_ahead(run, text: str, opts, progress, tool_table=None, spindle_tool: int = 0):
    """Fill ``run`` (a ``runprogram.Run``) by reading ``text`` ahead; raise ReadWhole when it
    cannot be (see the module doc)."""
    from ..atc.front import Expanded
    from ..gcode.errors import NeedsWholeProgram
    from ..gcode.readahead import ReadAhead
    from ..motion.planblocks import BlockPlanner, NotInBlocks
    from .program import stream_outputs
    machine, name = run.machine, run.name
    reader = ReadAhead(text, machine, name, tool_table=tool_table, spindle_tool=spindle_tool,
                       on_progress=lambda done: progress.fraction("compile", done))
    run.program = _Program(name, reader.messages)
    run.expanded = Expanded([], [], [], spindle_tool, spindle_tool, name)
    feed = _Feed(run, reader, BlockPlanner(machine, opts.backlash_comp))
    lines = text.count("\n") + 1          # the bar: the share of the program's lines stepped
    run.line_of = feed.line_of
    run.how = "fast path"
    if getattr(opts, "before_outputs", None):
        opts.before_outputs(run)
    try:
        run.sim = stream_outputs(run, opts.urls, progress, blocks=(machine, feed.blocks()),
                                 on_index=lambda index: progress.whole(feed.share_done(index, lines)))
    except (NeedsWholeProgram, NotInBlocks, ReadWhole) as exc:
        again = ReadWhole(str(exc))
        again.warned = feed.warned          # the whole-program way prints only the messages after
        raise again from None
    feed.warn()
    run.command_count = reader.count
    for stage in ("compile", "plan", "execute"):
        progress.done(stage)
    return run


class _Feed:
    """The program's plan handed on block by block, and the program line of every move."""

    def __init__(self, run, reader, planner):
        self.run, self.reader, self.planner = run, reader, planner
        self.lines = array("i")            # program line of every command after host commands
        self.move_t0s: list[np.ndarray] = []
        self.move_lines: list[np.ndarray] = []
        self.warned = 0                    # the program's messages printed so far

    def warn(self) -> None:
        """Print the WARNING messages of the lines read since the last call, as they are read."""
        from .program import print_warnings
        messages = self.reader.messages
        print_warnings(messages[self.warned:])
        self.warned = len(messages)

    def blocks(self):
        """(PlanArrays, None) while the program goes on, (PlanArrays, end time) at its end."""
        from ..motion.columns import _empty
        planner = self.planner
        for commands, lines, _ in self.reader.batches():
            self.warn()
            planner_commands = self._expand(commands, lines)
            try:
                planner.add(planner_commands)
            except MotionError as exc:
                index = getattr(exc, "command_index", None)
                line = self.lines[index] if index is not None and index < len(self.lines) else None
                raise GcodeError(str(exc), self.run.name, line or None) from None
            got = planner.planned(final=False)
            if got is not None:
                yield self._noted(got[0]), None
        got = planner.planned(final=True)
        yield (self._noted(got[0]) if got else _empty(len(self.run.machine.axes))), planner.t

    def _expand(self, commands: list, lines: list) -> list:
        """The batch with its tool changes and pauses made events (``expand_host_commands``)."""
        from ..atc.front import expand_host_commands
        from ..commands import Dout, IStp, Prob, Wait, ZMov
        machine = self.run.machine
        for cmd in commands.parts() if hasattr(commands, "parts") else commands:   # blocks: moves only
            if isinstance(cmd, (IStp, Dout, Wait, Prob)) or (isinstance(cmd, ZMov) and "homing" in machine.parts):
                raise ReadWhole(f"{cmd}")
        exp = self.run.expanded
        batch = _Program(self.run.name, [])
        batch.commands, batch.lines = commands, lines
        part = expand_host_commands(batch, machine, exp.end_tool)
        exp.events += [replace(e, index=e.index + len(self.lines)) for e in part.events]
        exp.end_tool = part.end_tool
        self.lines.extend(n or 0 for n in part.lines)
        return part.commands

    def _noted(self, arrays):
        self.move_t0s.append(arrays.t0s)
        self.move_lines.append(np.frombuffer(self.lines, np.int32)[arrays.index].copy())
        return arrays

    def share_done(self, index: int, lines: int) -> float:
        """The share of the program's ``lines`` stepped when the commands before ``index`` are."""
        return self.lines[index - 1] / lines if 0 < index <= len(self.lines) else 0.0

    def line_of(self, tick: int):
        """The program line of the move under way at ``tick`` (None when not known)."""
        if not self.move_t0s:
            return None
        starts, lines = np.concatenate(self.move_t0s), np.concatenate(self.move_lines)
        k = max(int(np.searchsorted(starts, tick * self.run.machine.tick_s + 1e-12, side="right")) - 1, 0)
        return int(lines[k]) or None
