"""T words, M6, G43 / G49 in part programs: tool changes and tool length offsets at compile time.

A tool change depends on the tool in the spindle, which only the controller's record knows, so
a program that changes tools is compiled inside a :class:`ToolSession` started from that record
(``with session.active(): compile_program(...)``). The session follows the tool through the
program; the translator then emits the document's sequence for every change (in the program's
coordinates when G92 has shifted them) and marks where each change sits, so that the run can
record it (:meth:`~retrofit.atc.changer.ToolChanger.run_program`).

G43 Hn applies the length offset of tool n from the tool table, G43 alone that of the tool in
the spindle, G49 cancels it. An offset is applied as a shift of Z's program coordinate (PSTN),
so the gauge line moves the other way by the offset: with Z counting downward (tul-mill), a
tool 5 mm longer than the reference tool is held 5 mm higher for the same programmed Z.
"""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar

from ..commands import Command, FMov, PMov, Pstn, Spin
from ..config import Machine
from ..errors import ToolChangeError
from ..gcode.state import clean_mm
from ..gcode.validate import RuleError
from .changer import ChangeMark
from .sequences import change_sequence, check_tool
from .settings import atc_of, tools_of
from .tooltable import ToolTable

_ACTIVE: ContextVar["ToolSession | None"] = ContextVar("retrofit_tool_session", default=None)


class ToolSession:
    """The tool in the spindle and the tool table while one program is compiled."""

    def __init__(self, machine: Machine, spindle_tool: int = 0, table: ToolTable | None = None):
        self.machine = machine
        self.atc = atc_of(machine) if "atc" in machine.parts else None
        self.hang = tools_of(machine).hang_sign
        self.tool = spindle_tool
        self.selected: int | None = None
        self.table = table or ToolTable(machine.name)
        self.length_offset_mm = 0.0                  # the G43 offset in force (0 after G49)
        self.changes: list[ChangeMark] = []

    @contextmanager
    def active(self):
        """Make this the session the G-code translator uses, for the ``with`` block."""
        token = _ACTIVE.set(self)
        try:
            yield self
        finally:
            _ACTIVE.reset(token)


def _session(translator, word: str) -> ToolSession:
    session = _ACTIVE.get()
    if session is None or session.machine.name != translator.machine.name:
        raise RuleError(f"{word}: a tool change or offset needs the tool in the spindle; compile "
                        f"the program in a ToolSession (retrofit.atc.gcode), e.g. with "
                        f"'retrofit mill PROGRAM --machine {translator.machine.name}'")
    return session


def change_tool(translator, block) -> None:
    """T (select; on a machine that changes on T, also change) and M6 (change) of one block."""
    word = block.texts.get("T", "M6")
    session = _session(translator, word)
    if session.atc is None:
        raise RuleError(f"{word}: machine {translator.machine.name} has no tool changer ([atc])")
    if "T" in block.values:
        session.selected = _number(session, block.values["T"], "T")
    change = "tool change" in block.m or (session.atc.change_on == "T" and "T" in block.values)
    if not change:
        return
    if session.selected is None:
        raise RuleError("M6 without a tool selected: give T<n> before it or in its block "
                        "(T0 leaves the spindle empty)")
    seq = change_sequence(session.atc, session.tool, session.selected, translator.machine.name)
    if not seq.condition:
        return
    state = translator.state
    if state.spindle:
        state.spindle = 0
        translator._emit(Spin(0.0, 0))                # the spindle stops before the change
    start = len(translator.commands)
    offsets = dict(translator.offset_mm)
    for cmd in seq.commands():
        translator._emit(_in_program_frame(cmd, offsets))
    session.changes.append(ChangeMark(start, len(translator.commands), seq.current, seq.new,
                                      {k: v for k, v in offsets.items() if v}))
    session.tool = seq.new
    for axis, mm in seq.end_mm().items():
        state.position[axis] = clean_mm(mm - offsets.get(axis, 0.0))
    state.feed_sent = None                            # the sequence set its own feeds


def tool_length(translator, block) -> None:
    """G43 [Hn] or G49: shift Z's program coordinate by the change of the length offset."""
    code = block.g["tool length"]
    session = _session(translator, f"G{code}")
    if code == 43:
        number = _number(session, block.values["H"], "H") if "H" in block.values else session.tool
        try:
            offset = session.table.length_offset(number)
        except ToolChangeError as exc:
            raise RuleError(f"G43 H{number}: {exc}") from None
    else:
        offset = 0.0
    delta = offset - session.length_offset_mm
    session.length_offset_mm = offset
    if delta:
        z = clean_mm(translator.state.position["Z"] + session.hang * delta)
        translator._emit(Pstn((("Z", z),)))
        translator.state.position["Z"] = z
        translator.offset_mm["Z"] = clean_mm(translator.offset_mm.get("Z", 0.0) - session.hang * delta)


def _number(session: ToolSession, value: float, letter: str) -> int:
    if session.atc is None:
        if not (value.is_integer() and value >= 0):
            raise RuleError(f"{letter}{value:g}: a tool number is a whole number >= 0")
        return int(value)
    try:
        return check_tool(session.atc, value, session.machine.name, letter)
    except ToolChangeError as exc:
        raise RuleError(str(exc)) from None


def _in_program_frame(cmd: Command, offsets: dict[str, float]) -> Command:
    """A machine-frame move expressed in program coordinates (program = machine - offset)."""
    if isinstance(cmd, (FMov, PMov)) and any(offsets.get(n) for n, _ in cmd.axes):
        return type(cmd)(tuple((n, clean_mm(v - offsets.get(n, 0.0))) for n, v in cmd.axes))
    return cmd
