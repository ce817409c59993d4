"""The interpreter read ahead only as far as the run asks: a program's commands in batches.

As LinuxCNC's interpreter runs ahead of its motion queue only as far as the queue takes,
:class:`ReadAhead` runs the interpreter (the same one :func:`~retrofit.gcode.compile_program`
runs whole) over lines lexed as they are reached (:mod:`.lazylines`), and hands on its commands
a batch at a time; nothing keeps them after that. The O-word structure is checked before the
first line runs, as in a whole compile. A broken rule is a GcodeError naming file and line when
the interpreter reaches it, so a run that reads ahead has moved the machine for the lines
before it (a whole compile refuses before the first move).

A code whose meaning depends on every command before it (M62-M66, timed on the program so far)
raises :class:`~retrofit.gcode.errors.NeedsWholeProgram`: such a program is compiled whole.
"""

from __future__ import annotations

from ..canon.moves import CommandList
from .lazylines import LazyLines
from .ocode import Source, scan
from .program import gcode_errors, start_interpreter

#: commands per batch handed on, and in the first batch
BATCH = 2048
FIRST_BATCH = 256


class ReadAhead:
    """One program read ahead in batches (see the module doc)."""

    def __init__(self, text: str, machine, file: str = "<string>", *, tool_table=None,
                 spindle_tool: int = 0, search_path=(), on_progress=None):
        self.file = file
        self.interpreter = start_interpreter(machine, file, None, tool_table, spindle_tool, search_path)
        self.interpreter.on_progress = on_progress
        self.interpreter.tr.streaming = True
        self.lines = LazyLines(text)
        self.count = 0                      # commands handed on so far

    @property
    def messages(self) -> list:
        """(file, line, kind, text) of the messages of the lines run so far."""
        return self.interpreter.messages

    def batches(self, size: int = BATCH):
        """(commands, lines, files) lists of at least ``size`` commands each (the last may have
        fewer), in program order."""
        tr = self.interpreter.tr
        wanted = min(size, FIRST_BATCH)                 # a small first batch: the first step early
        with gcode_errors(self.file):
            main = scan(Source(self.file, self.lines))
            for _ in self.interpreter.lines_run(main):
                if len(tr.commands) >= wanted:
                    yield self._take()
                    wanted = size
            tr.finish()
        yield self._take()

    def _take(self) -> tuple[CommandList, list[int], list[str]]:
        tr = self.interpreter.tr
        batch = tr.commands, tr.lines, tr.files
        tr.commands, tr.lines, tr.files = CommandList(), [], []
        self.count += len(batch[0])
        return batch
