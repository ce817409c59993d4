"""The controller's side of the tool changer: which tool is in the spindle, and changing it.

:class:`ToolChanger` turns a tool number into the document's sequence and hands the commands to
an executor — anything with ``run(commands)`` and ``commanded_mm()``, such as the simulated
cell of :mod:`retrofit.atc.cell` — marking the spindle record before the first move and
clearing it after the last. It never moves anything itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from ..commands import Command, Pstn
from ..errors import ToolChangeError
from ..machine.config import Machine
from .sequences import ChangeSequence, Step, change_sequence, check_tool, recovery_steps
from .settings import atc_of
from .state import SpindleStore


class Executor(Protocol):
    """What runs commands: the simulated cell today, the controller later."""

    def run(self, commands: Sequence[Command]) -> object:
        """Execute ``commands`` from where the last ones left the machine."""

    def commanded_mm(self) -> dict[str, float]:
        """Where the axes have been sent (mm; carousel units)."""


@dataclass(frozen=True)
class ChangeMark:
    """Where a tool change sits in a compiled program: commands ``start:end``, from and to which
    tool, and the program's coordinate offsets (machine - program, mm) at that point."""

    start: int
    end: int
    current: int
    new: int
    offsets_mm: dict[str, float] = field(default_factory=dict)


class ToolChanger:
    """Knows the tool in the spindle (from its :class:`SpindleStore`) and changes it."""

    def __init__(self, machine: Machine, store: SpindleStore, read_record: bool = True):
        """``read_record=False`` starts without trusting the record: only :meth:`recover` may run."""
        self.machine = machine
        self.atc = atc_of(machine)
        self.store = store
        # the record raises ToolStateError when it cannot be trusted; None: not known
        self.spindle_tool: int | None = store.load() if read_record else None

    def sequence(self, tool) -> ChangeSequence:
        """The steps from the tool in the spindle to ``tool``; checked before anything moves."""
        if self.spindle_tool is None:
            raise ToolChangeError(f"the tool in the spindle of {self.machine.name} is not known; "
                                  "recover first (the tool you see, then T0)")
        return change_sequence(self.atc, self.spindle_tool, tool, self.machine.name)

    def change(self, tool, executor: Executor) -> ChangeSequence:
        """Change to ``tool`` on ``executor``; the record says 'changing' until the last move ran."""
        seq = self.sequence(tool)
        if seq.condition:
            self._recorded(seq.current, seq.new, lambda: executor.run(seq.commands()))
        return seq

    def recover(self, seen_tool, executor: Executor) -> list[Step]:
        """After an untrusted record: take the operator's word for the tool in the spindle, home
        the carousel and put that tool back (T0)."""
        steps = recovery_steps(self.atc, seen_tool, self.machine.name)
        seen = check_tool(self.atc, seen_tool, self.machine.name)
        self.store.save(seen)
        self.spindle_tool = seen
        commands = [c for step in steps for c in step.commands]
        self._recorded(seen, 0, lambda: executor.run(commands))
        return steps

    def run_program(self, commands: Sequence[Command], marks: Sequence[ChangeMark],
                    executor: Executor) -> None:
        """Run a compiled program whose tool changes are at ``marks``, recording each change.

        Between changes the program runs as one piece; each piece after the first starts by
        setting the program's coordinate offsets again (PSTN), as the planner starts afresh.
        """
        done, offsets = 0, {}
        for mark in marks:
            if mark.current != self.spindle_tool:
                raise ToolChangeError(f"the program was compiled with T{mark.current} in the spindle, "
                                      f"but the record says T{self.spindle_tool}; compile it again")
            executor.run(_with_offsets(executor, offsets) + list(commands[done:mark.start]))
            piece = _with_offsets(executor, mark.offsets_mm) + list(commands[mark.start:mark.end])
            self._recorded(mark.current, mark.new, lambda: executor.run(piece))  # noqa: B023 (called at once)
            done, offsets = mark.end, mark.offsets_mm
        executor.run(_with_offsets(executor, offsets) + list(commands[done:]))

    def _recorded(self, current: int, new: int, action) -> None:
        self.store.begin(current, new)
        action()
        self.store.finish(new)
        self.spindle_tool = new


def _with_offsets(executor: Executor, offsets_mm: dict[str, float]) -> list[Command]:
    """PSTN that makes the program coordinates (machine - offset) hold again, or nothing."""
    at = executor.commanded_mm()
    named = tuple((axis, round(at[axis] - off, 9)) for axis, off in offsets_mm.items() if off)
    return [Pstn(named)] if named else []
