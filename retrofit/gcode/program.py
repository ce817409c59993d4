"""A compiled part program, and the interpreter that runs a program's lines to get one.

The interpreter follows the program as LinuxCNC does: line after line, O-words jumping
(:mod:`retrofit.gcode.ocode`), each line's values evaluated against the parameters of that
moment, then its parameter assignments made, then its block translated
(:mod:`retrofit.gcode.translate`). It stops at M2/M30, at the ``%`` closing a file that opened
with ``%``, or at the end of the file.
"""

from __future__ import annotations

from collections.abc import Callable, MutableSequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from ..commands import Command
from ..errors import GcodeError
from ..machine.config import Machine, load_machine
from . import fanuc, lathecycles, modalsave
from .blocks import make_block
from .dialect import run_dollar
from .errors import RuleError
from .expressions import evaluate
from .lazylines import LazyLines
from .lexer import Line, lex_lines
from .ocode import Source, scan
from .plainline import run_plain
from .plainrun import RUN_LINES, take_run
from .state import ModalState
from .translate import Translator

#: the most lines one run may execute beyond the lines of its main program (a long program from
#: CAM runs whole): a loop that never ends is refused, not run for ever
MAX_STEPS = 500_000
#: the deepest nesting of subroutine calls
MAX_CALL_DEPTH = 50


@dataclass
class Program:
    """The commands of a part program and the source line (1-based) each came from.

    ``files`` names the file of each command (a called subroutine file, or ``file``);
    ``messages`` holds the (file, line, kind, text) of ``(MSG,..)``, ``(DEBUG,..)``,
    ``(PRINT,..)`` comments and of grbl lines skipped.
    """

    commands: MutableSequence[Command]
    lines: list[int]
    file: str
    files: list[str] = field(default_factory=list)
    messages: list[tuple[str, int, str, str]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.commands)

    def listing(self) -> str:
        """One ``file:line: COMMAND`` text line per command."""
        files = self.files or [self.file] * len(self.commands)
        return "\n".join(f"{f}:{line}: {cmd}" for cmd, line, f in zip(self.commands, self.lines, files))


class Interpreter:
    """Runs the lines of one program (and the subroutine files it calls) through a Translator."""

    def __init__(self, machine: Machine, translator: Translator, search_path=()):
        self.machine = machine
        self.tr = translator
        self.params = translator.state.params
        self.search_path = [Path(p) for p in search_path]
        self.sources: dict[str, Source] = {}
        self.messages: list[tuple[str, int, str, str]] = translator.messages
        self.steps = 0
        #: called now and then with the share of the main program's lines run (a progress bar)
        self.on_progress = None

    def run(self, main: Source) -> None:
        """Run ``main`` from its first line; RuleErrors carry ``.file`` and ``.line``."""
        for _ in self.lines_run(main):
            pass

    def lines_run(self, main: Source):
        """:meth:`run` one line at a time: a generator that yields after each line (the
        translator's commands so far are then complete)."""
        src, pc = main, 0
        calls: list = []                    # (source, index) to return to, or fanuc.Call
        repeats: dict[tuple[int, int, int], int] = {}
        most = len(main.lines) + MAX_STEPS
        first = main.lines.first() if hasattr(main.lines, "first") else \
            ((0, main.lines[0]) if main.lines else None)
        closing_percent = first is not None and first[1].percent
        if closing_percent:
            assert first is not None            # a closing % needs an opening line
            pc = first[0] + 1
        while pc < len(src.lines):
            line = src.lines[pc]
            if line is None or (line.plain and not line.words):     # a comment or spaces only
                pc += 1
                continue
            if line.plain and self.tr.plain_path and self.steps + RUN_LINES <= most and \
                    hasattr(src.lines, "text"):
                taken = take_run(self.tr, src.lines, pc, src.file)      # a run of plain CAM lines
                if taken:
                    self.steps += taken
                    pc += taken
                    if self.on_progress is not None and src is main and self.steps & 4095 < taken:
                        self.on_progress(pc / len(main.lines))
                    yield
                    continue
            self.steps += 1
            if not self.steps & 4095 and self.on_progress is not None and src is main:
                self.on_progress(pc / len(main.lines))
            try:
                if self.steps > most:
                    raise RuleError(f"the program runs more than {most} lines, {MAX_STEPS} more than "
                                    f"it has (a loop that never ends?)")
                if line.error:
                    raise RuleError(line.error)
                if line.percent:
                    if closing_percent and src is main:
                        return
                    pc += 1
                    continue
                if line.oword is not None:
                    src, pc = self._oword(src, pc, line, calls, repeats)
                    continue
                if pc in src.fanuc:
                    nxt = fanuc.run_line(self, src, pc, line, calls)
                    if nxt is None:
                        return
                    src, pc = nxt
                    yield
                    continue
                if self._line(src, line):
                    return
            except RuleError as exc:
                if not hasattr(exc, "file"):
                    exc.file, exc.line = src.file, line.number
                raise
            pc += 1
            yield

    def _value(self, tree) -> float:
        return tree if type(tree) is float else evaluate(tree, self._read, self.params.exists)

    def _read(self, ref) -> float:
        if isinstance(ref, str) and ref in _PREDEFINED:
            return _PREDEFINED[ref](self.tr.state)
        if not isinstance(ref, str) and 5420 <= ref <= 5428 and ref == int(ref):
            if self.tr.comp.on:
                raise RuleError(f"#{ref:g}: cannot read the current position with cutter radius "
                                f"compensation on (it is the programmed point, not the tool's)")
            axis = "XYZABCUVW"[int(ref) - 5420]
            s = self.tr.state
            return s.program_position(axis) / (25.4 if s.inch else 1.0)
        return self.params.read(ref)

    def _line(self, src: Source, line) -> bool:
        """One line of words; True when it ends the program."""
        if line.plain and self.tr.plain_path:
            done = run_plain(self.tr, line.words, line.number, src.file)
            if done is not None:
                return done
            if not lathecycles.is_cycle(line.words):
                return self.tr.run(make_block(line.number, line.words, self.machine), src.file)
        for kind, text in line.messages:
            self.messages.append((src.file, line.number, kind, self._substitute(text)))
        if line.dollar is not None:
            run_dollar(self, line)
            return False
        words = [(letter, self._value(tree)) for letter, tree in line.words]
        if line.assigns:
            values = [(self._ref(target), self._value(tree)) for target, tree in line.assigns]
            for ref, value in values:
                self.params.write(ref, value)
        if not words:
            return False
        if lathecycles.is_cycle(words):
            return lathecycles.run_cycle(self, src, line, words)
        return self.tr.run(make_block(line.number, words, self.machine), src.file)

    def _ref(self, target):
        return target[1] if target[0] == "#<" else self._value(target[1])

    def _substitute(self, text: str) -> str:
        import re

        def one(match):
            try:
                ref = match.group(1).lower() if match.group(1) else float(match.group(2))
                return f"{self._read(ref):.6g}"
            except RuleError:
                return match.group(0)
        return re.sub(r"#<([^>]*)>|#(\d+)", one, text)

    # -- O-words -------------------------------------------------------------------------------
    def _oword(self, src: Source, pc: int, line, calls: list, repeats: dict):
        name, kw, args = line.oword
        if kw == "LABEL":                                # O1000 alone: M98's target, run through
            return src, pc + 1
        if kw == "SUB":
            return src, src.end[pc] + 1
        if kw == "CALL":
            return self._call(src, pc, name, [self._value(a) for a in args], calls)
        if kw in ("ENDSUB", "RETURN"):
            if args:
                self.params.globals["_value"] = self._value(args[0])
                self.params.globals["_value_returned"] = 1.0
            if not calls:
                raise RuleError(f"o{name} {kw.lower()} reached outside a call")
            if isinstance(calls[-1], fanuc.Call):
                raise RuleError(f"o{name} {kw.lower()} inside a subprogram called with M98 (it ends "
                                f"with M99)")
            self.params.leave()
            modalsave.leaving(self.tr, line.number)
            return calls.pop()
        if kw == "IF":
            for branch in src.branches[pc]:
                _, bkw, bargs = _oword_of(src, branch)
                if bkw == "ELSE" or self._value(bargs[0]):
                    return src, branch + 1
            return src, src.end[pc] + 1
        if kw in ("ELSEIF", "ELSE"):
            opening = next(i for i, b in src.branches.items() if pc in b)
            return src, src.end[opening] + 1
        if kw in ("ENDIF", "DO"):
            return src, pc + 1
        if kw == "WHILE" and pc in src.start:            # the end of a do loop
            return src, (src.start[pc] + 1 if self._value(args[0]) else pc + 1)
        if kw == "WHILE":
            return src, (pc + 1 if self._value(args[0]) else src.end[pc] + 1)
        if kw == "ENDWHILE":
            return src, src.start[pc]
        if kw == "REPEAT":
            count = self._value(args[0])
            if count > MAX_STEPS:
                raise RuleError(f"o{name} repeat [{count:g}]: more than {MAX_STEPS} times")
            key = (len(calls), id(src), pc)
            if count < 1:
                return src, src.end[pc] + 1
            repeats[key] = int(count)
            return src, pc + 1
        if kw == "ENDREPEAT":
            key = (len(calls), id(src), src.start[pc])
            repeats[key] = repeats.get(key, 1) - 1
            return src, (src.start[pc] + 1 if repeats[key] > 0 else pc + 1)
        loop = src.start[pc]                             # BREAK, CONTINUE
        lkw = _oword_of(src, loop)[1]
        if kw == "BREAK":
            repeats.pop((len(calls), id(src), loop), None)
            return src, src.end[loop] + 1
        return src, (loop if lkw == "WHILE" else src.end[loop])
        # DO: continue evaluates the closing while; REPEAT: counts at endrepeat

    def _call(self, src: Source, pc: int, name: str, args: list, calls: list):
        if len(calls) >= MAX_CALL_DEPTH:
            raise RuleError(f"o{name} call: subroutine calls nest deeper than {MAX_CALL_DEPTH}")
        target = src if name in src.subs else self._sub_file(name, src)
        start, _ = target.subs[name]
        self.params.enter(args)
        modalsave.entered(self.tr)
        calls.append((src, pc + 1))
        return target, start + 1

    def _sub_file(self, name: str, src: Source) -> Source:
        if name in self.sources:
            return self.sources[name]
        for folder in self.search_path:
            path = folder / f"{name.strip('<>')}.ngc"
            if path.is_file():
                try:
                    source = scan(Source(path.name, lex_lines(_read_text(path))))
                except RuleError as exc:
                    exc.file = path.name
                    raise
                if name not in source.subs:
                    raise RuleError(f"o{name} call: {path.name} does not define o{name} sub")
                self.sources[name] = source
                return source
        where = ", ".join(str(p) for p in self.search_path) or "no folder given"
        raise RuleError(f"o{name} call: unknown subroutine o{name} (not in {src.file}, and no "
                        f"{name.strip('<>')}.ngc in {where})")


def _oword_of(src: Source, index: int) -> tuple:
    oword = src.lines[index].oword
    assert oword is not None, "scan() pairs O-words with O-word lines only"
    return oword


_PREDEFINED: dict[str, Callable[..., float]] = {
    "_metric": lambda s: 0.0 if s.inch else 1.0, "_imperial": lambda s: 1.0 if s.inch else 0.0,
    "_absolute": lambda s: 0.0 if s.incremental else 1.0,
    "_incremental": lambda s: 1.0 if s.incremental else 0.0,
    "_current_tool": lambda s: float(s.tool),
    "_feed": lambda s: s.feed_mm_min / 25.4 if s.inch and not s.inverse_time else s.feed_mm_min,
    "_rpm": lambda s: s.rpm,
    **{f"_{a.lower()}": (lambda s, a=a: s.program_position(a) / (25.4 if s.inch else 1.0))
       for a in "XYZABCUVW"},
}


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise GcodeError("no such G-code file", str(path)) from None
    except UnicodeDecodeError as exc:
        raise GcodeError(f"not a UTF-8 text file (byte {exc.start})", path.name) from None
    except OSError as exc:
        raise GcodeError(f"cannot read the file ({exc.strerror})", str(path)) from None


def compile_program(text: str, machine: Machine, file: str = "<string>",
                    start_mm: dict | None = None, *, tool_table=None, spindle_tool: int = 0,
                    search_path=(), probe=None, on_progress=None, dialect: str | None = None) -> Program:
    """Translate G-code ``text`` for ``machine`` into retrofit commands.

    The whole program is run through the interpreter before anything is returned: on the first
    broken rule a :class:`~retrofit.errors.GcodeError` names ``file:line`` (the subroutine file
    where the line is) and the rule, and no command at all reaches the caller. ``start_mm`` is
    where the machine stands when the program starts (axes not named there at 0 mm);
    ``tool_table`` a :class:`~retrofit.machine.tooltable.ToolTable` for G43 and G10 L1;
    ``spindle_tool`` the tool in the spindle; ``search_path`` the folders where ``o<name> call``
    finds ``name.ngc``; ``probe`` makes G38 probing moves on the machine
    (:mod:`retrofit.gcode.probing`); ``on_progress(share)`` is called now and then with the
    share (0..1) of the work done, for a progress bar; ``dialect`` "fanuc" reads a Fanuc/Haas
    lathe program (:mod:`retrofit.gcode.fanuc_lathe`; default: the machine file's ``dialect``).

    >>> from retrofit.machine.config import load_machine
    >>> prog = compile_program("G0 X10 Z2\\nG1 Z-5 F100", load_machine("chivu-lathe"))
    >>> [str(c) for c in prog.commands]
    ['FMOV X10 Z2', 'PFDR F100', 'PMOV X10 Z-5']
    """
    interpreter = start_interpreter(machine, file, start_mm, tool_table, spindle_tool, search_path, probe)
    interpreter.on_progress = on_progress
    translator = interpreter.tr
    dialect = dialect or machine.dialect
    if dialect not in ("rs274", "fanuc"):
        raise GcodeError(f"unknown dialect {dialect!r}; known: rs274, fanuc", file)
    with gcode_errors(file):
        if dialect == "fanuc":
            from .fanuc_lathe import run_fanuc
            run_fanuc(text, translator, file, interpreter.messages)
            lines: list[Line] | LazyLines = []
        else:
            lines = LazyLines(text)
        interpreter.run(scan(Source(file, lines)))
        translator.finish()
    return Program(translator.commands, translator.lines, file, translator.files,
                   interpreter.messages)


def start_interpreter(machine: Machine, file: str, start_mm=None, tool_table=None, spindle_tool: int = 0,
                      search_path=(), probe=None) -> Interpreter:
    """An interpreter at the start of a program (see :func:`compile_program` for the arguments)."""
    try:
        state = ModalState.start(machine, start_mm)
    except ValueError as exc:
        raise GcodeError(str(exc), file) from None
    state.tool = int(spindle_tool)
    state.params.write(5400, float(spindle_tool))
    return Interpreter(machine, Translator(machine, state, tool_table, probe), search_path)


@contextmanager
def gcode_errors(file: str):
    """A broken rule inside as a GcodeError naming its file and line."""
    try:
        yield
    except RuleError as exc:
        raise GcodeError(str(exc), getattr(exc, "file", file), getattr(exc, "line", None)) from None
    except RecursionError:
        raise GcodeError("an expression nests too deeply", file) from None


def load_program(path: str | Path, machine: Machine | str, *, tool_table=None,
                 spindle_tool: int = 0, search_path=(), probe=None,
                 dialect: str | None = None) -> Program:
    """Read and compile a G-code file (``.ngc``); ``machine`` is a Machine or a machine name.

    Errors name the file by its name, e.g. ``prog.ngc:12: ...``. Subroutine files are looked
    for next to the program, then in ``search_path``.
    """
    path = Path(path)
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    text = _read_text(path)
    return compile_program(text, machine, file=path.name, tool_table=tool_table,
                           spindle_tool=spindle_tool,
                           search_path=[path.parent, *search_path], probe=probe, dialect=dialect)
