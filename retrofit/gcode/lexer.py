"""G-code lexer: the lines of a part program into blocks of words, each with its line number.

One line is one block. Comments ``( ... )`` and ``; ...`` are dropped, a line whose first
character is ``/`` is a deleted block (skipped whole, never checked), a line holding only ``%``
is a program delimiter, whitespace is ignored (``G 1 X - 5`` is ``G1X-5``) and letters are
upper-cased. Each word is a letter and a number::

    >>> [w.text for w in lex_line("n10 g1 x-.5 (rough) z2 ; pass 1")]
    ['N10', 'G1', 'X-.5', 'Z2']
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from .validate import RuleError

_NUMBER = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)")
_NOT_SUPPORTED = {"#": "parameters", "[": "expressions", "<": "named parameters"}


@dataclass(frozen=True)
class Word:
    """One word: its letter, its value and its text as written (upper case, e.g. ``'G01'``)."""

    letter: str
    value: float
    text: str


def iter_lines(text: str) -> Iterator[tuple[int, str]]:
    """(line number, text) of every source line, numbered from 1."""
    return enumerate(text.splitlines(), start=1)


def lex_line(raw: str) -> tuple[Word, ...]:
    """The words of one line; empty for a blank, comment-only, deleted or ``%`` line.

    Raises RuleError for an unclosed comment, a stray character or a letter without a number.
    """
    stripped = raw.strip()
    if stripped.startswith("/") or stripped == "%":
        return ()
    code = "".join(_strip_comments(raw).split()).upper()
    words = []
    pos = 0
    while pos < len(code):
        letter = code[pos]
        if not ("A" <= letter <= "Z"):
            raise RuleError(_stray(letter))
        match = _NUMBER.match(code, pos + 1)
        if match is None:
            after = code[pos + 1:pos + 2]
            if after in _NOT_SUPPORTED:
                raise RuleError(_stray(after))
            raise RuleError(f"word {letter!r} has no number (expected e.g. {letter}10)")
        words.append(Word(letter, float(match.group()), letter + match.group()))
        pos = match.end()
    return tuple(words)


def _strip_comments(raw: str) -> str:
    """The line without its ``( ... )`` and ``; ...`` comments."""
    out = []
    pos = 0
    while pos < len(raw):
        ch = raw[pos]
        if ch == ";":
            break
        if ch == "(":
            close = raw.find(")", pos + 1)
            if close < 0:
                raise RuleError("comment '(' is not closed on this line (a comment ends with ')')")
            pos = close + 1
            continue
        if ch == ")":
            raise RuleError("')' without an opening '('")
        out.append(ch)
        pos += 1
    return "".join(out)


def _stray(ch: str) -> str:
    what = _NOT_SUPPORTED.get(ch)
    if what:
        return f"unexpected character {ch!r}: {what} are not supported"
    return f"unexpected character {ch!r} (a word is a letter and a number, e.g. X12.5)"
