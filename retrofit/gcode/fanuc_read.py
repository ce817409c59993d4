"""Reading a Fanuc/Haas lathe program's text into blocks: N numbers kept, programs found.

A file holds ``%``, then the main program (``O0001`` or ``:0001`` first, with an optional comment),
then, after its M30, any subprograms (``O1000`` ... ``M99``), then ``%``. On each line: a ``/``
first (block delete, off) is dropped; ``( ... )`` comments and everything after ``;`` (the end of
block as manuals print it) are dropped; ``N..`` first is kept as the block's sequence number;
the rest is words, a letter and a number. Each word remembers whether it had a decimal point
(``X20`` and ``X20.`` differ on a Fanuc with DPI = 0; ``G4 P1000`` is milliseconds).
Custom-macro variables (``#1``, ``[ ]``) and direct drawing (``,C`` ``,R``) are refused here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from .errors import RuleError
from .lexer import split_lines

_WORD = re.compile(r"([A-Z])([-+]?)(\d*)(\.?)(\d*)")


@dataclass
class Word:
    """One word: its letter, its value, and whether a decimal point was written."""

    letter: str
    value: float
    point: bool


@dataclass
class FBlock:
    """One block: its source line, N number (None if none) and words in the order written."""

    line: int
    n: int | None = None
    words: list[Word] = field(default_factory=list)
    error: str | None = None

    def has(self, letter: str) -> bool:
        return any(w.letter == letter for w in self.words)

    def get(self, letter: str, default=None):
        for w in self.words:
            if w.letter == letter:
                return w.value
        return default

    def word(self, letter: str) -> Word | None:
        for w in self.words:
            if w.letter == letter:
                return w
        return None

    def codes(self, letter: str) -> list[float]:
        return [w.value for w in self.words if w.letter == letter]


@dataclass
class FProgram:
    """A file's blocks, where each O-number starts, and where each N number is (first seen)."""

    file: str
    blocks: list[FBlock]
    programs: dict[int, int]          # O-number -> index of the block after its O line
    numbers: dict[int, list[int]]     # N number -> indexes of the blocks that carry it
    main_number: int | None = None


def read_program(text: str, file: str) -> FProgram:
    """Every block of ``text``; a block that cannot be read carries its error (told if it runs)."""
    blocks, programs, main = [], {}, None
    numbers: dict[int, list[int]] = {}
    for number, raw in enumerate(split_lines(text), start=1):
        code = _code(raw)
        if not code:
            continue
        if code[0] == "%":
            continue                                   # tape start / end
        head = re.fullmatch(r"[O:](\d+)", code)
        if head:
            o = int(head.group(1))
            if o in programs:
                blocks.append(FBlock(number, error=f"program O{o} is defined twice in {file}"))
                continue
            programs[o] = len(blocks)
            if main is None and not blocks:
                main = o
            continue
        try:
            block = _block(number, code)
        except RuleError as exc:
            block = FBlock(number, error=str(exc))
        if block.n is not None:
            numbers.setdefault(block.n, []).append(len(blocks))
        blocks.append(block)
    return FProgram(file, blocks, programs, numbers, main)


def _code(raw: str) -> str:
    """The line without comments, spaces and block delete, upper case."""
    out, depth = [], 0
    for ch in raw:
        if ch == "(":
            depth += 1
        elif ch == ")" and depth:
            depth -= 1
        elif ch == ";" and not depth:
            break
        elif not depth:
            out.append(ch)
    code = "".join("".join(out).split()).upper()
    code = code.removeprefix("/")
    return code


def _block(number: int, code: str) -> FBlock:
    block, pos = FBlock(number), 0
    if "#" in code or "[" in code:
        raise RuleError("custom macro variables and expressions (#, [ ]) are not read under the "
                        "Fanuc dialect; write the numbers out")
    if "," in code:
        raise RuleError("direct drawing (,C ,R ,A) is not read under the Fanuc dialect; write the "
                        "chamfer or corner as moves")
    while pos < len(code):
        match = _WORD.match(code, pos)
        if match is None or not (match.group(3) or match.group(5)):
            raise RuleError(f"unexpected {code[pos:pos + 8]!r}: a word is a letter and a number "
                            f"(X20.5, G71, T0101)")
        letter, sign, whole, point, frac = match.groups()
        value = float(f"{sign}{whole or '0'}.{frac or '0'}")
        if letter == "N" and pos == 0:
            block.n = int(value)
        elif letter == "O":
            raise RuleError("an O program number stands on a line of its own (O1000 or :1000)")
        else:
            block.words.append(Word(letter, value, bool(point)))
        pos = match.end()
    return block
