"""A compiled part program, and the two ways to get one: from text or from a file."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..commands import Command
from ..config import Machine, load_machine
from ..errors import GcodeError
from .lexer import iter_lines, lex_line
from .parser import parse_block
from .state import ModalState
from .translate import Translator
from .validate import RuleError


@dataclass
class Program:
    """The commands of a part program and the source line (1-based) each came from."""

    commands: list[Command]
    lines: list[int]
    file: str

    def __len__(self) -> int:
        return len(self.commands)

    def listing(self) -> str:
        """One ``file:line: COMMAND`` text line per command."""
        return "\n".join(f"{self.file}:{line}: {cmd}" for cmd, line in zip(self.commands, self.lines))


def compile_program(text: str, machine: Machine, file: str = "<string>",
                    start_mm: dict | None = None, *, tool_table=None, spindle_tool: int = 0) -> Program:
    """Translate G-code ``text`` for ``machine`` into retrofit commands.

    The whole program is checked before anything is returned: on the first broken rule a
    :class:`~retrofit.errors.GcodeError` names ``file:line`` and the rule, and no command at all
    reaches the caller. ``start_mm`` is where the machine stands when the program starts
    (axes not named there at 0 mm). Everything after M2 or M30 is ignored. ``tool_table``
    (a :class:`retrofit.tooltable.ToolTable`) gives G43 its offsets; ``spindle_tool`` is the
    tool in the spindle at the start.

    >>> from retrofit.config import load_machine
    >>> prog = compile_program("G0 X10 Z2\\nG1 Z-5 F100", load_machine("chivu-lathe"))
    >>> [str(c) for c in prog.commands]
    ['FMOV X10 Z2', 'PFDR F100', 'PMOV X10 Z-5']
    """
    try:
        state = ModalState.start(machine, start_mm)
    except ValueError as exc:
        raise GcodeError(str(exc), file) from None
    translator = Translator(machine, state)
    translator.tool_table, translator.spindle_tool = tool_table, spindle_tool
    for line, raw in iter_lines(text):
        try:
            words = lex_line(raw)
            if words and translator.run(parse_block(line, words, machine)):
                break
        except RuleError as exc:
            raise GcodeError(str(exc), file, line) from None
    return Program(translator.commands, translator.lines, file)


def load_program(path: str | Path, machine: Machine | str, *, tool_table=None,
                 spindle_tool: int = 0) -> Program:
    """Read and compile a G-code file (``.ngc``); ``machine`` is a Machine or a machine name.

    Errors name the file by its name, e.g. ``prog.ngc:12: ...``.
    """
    path = Path(path)
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise GcodeError("no such G-code file", str(path)) from None
    except UnicodeDecodeError as exc:
        raise GcodeError(f"not a UTF-8 text file (byte {exc.start})", path.name) from None
    return compile_program(text, machine, file=path.name, tool_table=tool_table,
                           spindle_tool=spindle_tool)
