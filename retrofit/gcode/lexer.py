"""G-code lexer: the text of a program into lines, each with its words, assignments and O-word.

Only ``\\n``, ``\\r\\n`` and ``\\r`` end a line (a form feed or U+2028 inside a comment stays in the
comment). On each line, as LinuxCNC reads it:

* ``( ... )`` comments end on the same line (a ``(`` inside one nests, or where the line has too
  few ``)`` to match, the first ``)`` ends it, as grbl reads it); ``;`` starts a comment to the
  end of the line;
  ``(MSG,text)``, ``(DEBUG,text)`` and ``(PRINT,text)`` are kept as messages;
* spaces are ignored and letters are upper-cased (``g 1 x - 5`` is ``G1X-5``);
* a ``/`` first (block delete) is ignored: LinuxCNC's block-delete switch is off by default and
  the line runs; a line starting with ``%`` is a program delimiter,
  a line starting with ``$`` a grbl command (:mod:`retrofit.gcode.dialect`);
* ``$n`` inside a line selects spindle n for M3/M4/M5/S (LinuxCNC; one spindle here: ``$0``);
* ``N..`` first is the line number, ignored; ``O..`` first is an O-word (subroutines, loops);
* the rest is words (a letter and a value) and parameter assignments (``#1=2``, ``#<x>=[#1*2]``).

A value is a number, a ``#`` parameter, an ``[expression]`` or a function
(:mod:`retrofit.gcode.expressions`), read once and evaluated every time the line runs::

    >>> line = lex_line(7, "n10 g1 x-.5 (rough) z[#1+1] ; pass 1")
    >>> line.number, [(letter, value) for letter, value in line.words]
    (7, [('G', 1.0), ('X', -0.5), ('Z', ('op', '+', ('#', 1.0), 1.0))])
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from .errors import RuleError
from .expressions import read_expression, read_parameter, read_value

_LINE_END = re.compile(r"\r\n|\r|\n")
_PLAIN = re.compile(r"([A-NP-Z])([-+]?(?:\d+\.?\d*|\.\d+))")   # not O: an O-word opens its line
#: a whole line of plain words and nothing else, after an optional line number (the fast path:
#: most CAM lines); group 1 is the words
_PLAIN_LINE = re.compile(r"\s*(?:[Nn]\s*\d+\s*)?((?:[A-MP-Za-mp-z]\s*[-+]?\s*(?:\d+\.?\d*|\.\d+)\s*)+)")
_LINE_NUMBER = re.compile(r"N\d*\.?\d*")
_OWORD = re.compile(r"O(<[^>]*>|\d+)([A-Z]+)")
_LABEL = re.compile(r"O(\d+)")
_NAME = re.compile(r"O(?:<[^>]*>|\d*)")
#: O-word keywords and whether they take a bracketed argument (None: no, 1: one, "*": any number)
KEYWORDS = {"SUB": None, "ENDSUB": 1, "CALL": "*", "RETURN": 1, "IF": 1, "ELSEIF": 1, "ELSE": None,
            "ENDIF": None, "WHILE": 1, "ENDWHILE": None, "DO": None, "REPEAT": 1, "ENDREPEAT": None,
            "BREAK": None, "CONTINUE": None}
#: the message comments LinuxCNC acts on
MESSAGE_KINDS = ("MSG", "DEBUG", "PRINT")
#: the keyword a line carries when its O-word cannot be read (its ``error`` says why)
UNREADABLE = "UNREADABLE"


class OwordError(RuleError):
    """An O-word that cannot be read: the file's O-word structure is unknown without it, so
    :func:`retrofit.gcode.ocode.scan` refuses the file, naming this line, before it runs."""


@dataclass(slots=True)
class Line:
    """One source line, lexed: what it holds, in the order written."""

    number: int                                     # 1-based line number in its file
    words: list = field(default_factory=list)       # (letter, value tree)
    assigns: list = field(default_factory=list)     # (parameter tree, value tree)
    oword: tuple | None = None                      # (name, KEYWORD, [argument trees])
    messages: list = field(default_factory=list)    # (kind, text) of (MSG,..) (DEBUG,..) (PRINT,..)
    dollar: str | None = None                       # a grbl '$' line, as written
    percent: bool = False                           # a '%' delimiter line
    error: str | None = None                        # why the line cannot be read (told if it runs)
    plain: bool = False                             # only letters and numbers: values are floats


def split_lines(text: str) -> list[str]:
    """The source lines of ``text``; only ``\\n``, ``\\r\\n`` and ``\\r`` end a line."""
    return _LINE_END.split(text)


def lex_lines(text: str) -> list[Line]:
    """Every line of ``text`` that holds something; a line that cannot be read carries its
    error, raised only if the program reaches it (as LinuxCNC reads a line when it runs it)."""
    lines = []
    for number, raw in enumerate(split_lines(text), start=1):
        line = lex_text_line(number, raw)
        if line is not None:
            lines.append(line)
    return lines


def lex_text_line(number: int, raw: str, plain=_PLAIN_LINE.fullmatch, findall=_PLAIN.findall) -> Line | None:
    """One line as :func:`lex_lines` reads it: None when it holds nothing, a line carrying its
    error when it cannot be read."""
    match = plain(raw)
    if match:
        code = "".join(match.group(1).split()).upper()
        return Line(number, [(a, float(b)) for a, b in findall(code)], plain=True)
    try:
        return lex_line(number, raw)
    except OwordError as exc:
        return Line(number, oword=("", UNREADABLE, []), error=str(exc))
    except RuleError as exc:
        return Line(number, error=str(exc))


def lex_line(number: int, raw: str) -> Line | None:
    """The lexed line, or None for a blank or empty line.

    Raises RuleError for an unclosed comment, a stray character or a word without a value.
    """
    stripped = raw.strip()
    if stripped.startswith("/"):         # block delete: LinuxCNC's switch is off, the line runs
        raw = stripped = stripped[1:].strip()
    if not stripped:
        return None
    if stripped[0] == "%":
        return Line(number, percent=True)
    if stripped[0] == "$":
        return Line(number, dollar=stripped)
    code, messages = _code_and_comments(raw)
    line = Line(number, messages=messages)
    if not code:
        return line if messages else None
    pos = 0
    if code[0] == "N":
        pos = _LINE_NUMBER.match(code).end()  # type: ignore[union-attr]  # N always matches
    if code.startswith("O", pos):
        try:
            line.oword = _oword(code, pos)
        except RuleError as exc:
            raise OwordError(str(exc)) from None
        return line
    if "#" not in code and "[" not in code:
        _plain_words(code, pos, line)
    else:
        _words(code, pos, line)
    return line


def _code_and_comments(raw: str) -> tuple[str, list]:
    """The line's code (comments removed, no spaces, upper case) and its message comments."""
    out, pos = [], 0
    messages: list = []
    while True:
        paren, semi = raw.find("(", pos), raw.find(";", pos)
        if semi >= 0 and (paren < 0 or semi < paren):
            out.append(raw[pos:semi])
            _message(raw[semi + 1:], messages)
            break
        if paren < 0:
            out.append(raw[pos:])
            break
        out.append(raw[pos:paren])
        close = _comment_end(raw, paren)
        _message(raw[paren + 1:close], messages)
        pos = close + 1
    code = "".join("".join(out).split()).upper()
    if ")" in code:
        raise RuleError("')' without an opening '('")
    return code, messages


def _comment_end(raw: str, paren: int) -> int:
    """Where the comment opened at ``raw[paren]`` closes. A ``(`` inside it nests, so the comment
    ends at the matching ``)``; when the line has too few ``)`` for that, at the first one, as
    grbl reads it (rs274 refuses both: "nested comment")."""
    first = raw.find(")", paren + 1)
    if first < 0:
        raise RuleError("comment '(' is not closed on this line (a comment ends with ')')")
    depth = 0
    for pos in range(paren, len(raw)):
        depth += {"(": 1, ")": -1}.get(raw[pos], 0)
        if depth == 0:
            return pos
    return first


def _message(text: str, messages: list) -> None:
    head, comma, rest = text.partition(",")
    kind = "".join(head.split()).upper()
    if comma and kind in MESSAGE_KINDS:
        messages.append((kind, rest.strip()))


def _plain_words(code: str, pos: int, line: Line) -> None:
    """The fast path: only letters and plain numbers."""
    end = pos
    for match in _PLAIN.finditer(code, pos):
        if match.start() != end:
            break
        line.words.append((match.group(1), float(match.group(2))))
        end = match.end()
    if end != len(code):
        _words(code, pos, line)          # let the full reader name the problem


def _words(code: str, pos: int, line: Line) -> None:
    line.words.clear()
    while pos < len(code):
        ch = code[pos]
        if ch == "#":
            target, pos = read_parameter(code, pos)
            if not code.startswith("=", pos):
                raise RuleError("a parameter at the start of a word must be assigned: #1=2.5")
            value, pos = read_value(code, pos + 1)
            line.assigns.append((target, value))
        elif "A" <= ch <= "Z" and ch != "O" or ch in "$@^":
            if pos + 1 >= len(code):
                raise RuleError(f"word {ch!r} has no value (expected e.g. {ch}10)")
            value, pos = read_value(code, pos + 1)
            line.words.append((ch, value))
        elif ch == "O":
            said = _NAME.match(code, pos).group()  # type: ignore[union-attr]  # O always matches
            raise OwordError(f"{said} after other words: an O-word must be the first "
                             f"word of its line (after an optional / and N number), e.g. o100 call")
        else:
            raise RuleError(f"unexpected character {ch!r} (a word is a letter and a value, "
                            f"e.g. X12.5, X#1 or X[#1+2])")


def _oword(code: str, pos: int) -> tuple:
    label = _LABEL.fullmatch(code, pos)
    if label:                                  # O1000 alone: where a Fanuc-style M98 P1000 goes
        return str(int(label.group(1))), "LABEL", []
    match = _OWORD.match(code, pos)
    if match is None:
        raise RuleError(f"bad O-word {code[pos:pos + 12]!r}: expected o<name> or o<number> and a "
                        f"keyword ({' '.join(k.lower() for k in KEYWORDS)})")
    name, rest = match.group(1), match.group(2)
    name = f"<{''.join(name[1:-1].split()).lower()}>" if name.startswith("<") else str(int(name))
    keyword = rest if rest in KEYWORDS else None
    if keyword is None:
        raise RuleError(f"unknown O-word keyword {rest.lower()!r} after o{code[pos + 1:match.start(2)].lower()}"
                        f" (keywords: {' '.join(k.lower() for k in KEYWORDS)})")
    pos = match.end()
    args = []
    while code.startswith("[", pos):
        tree, pos = read_expression(code, pos)
        args.append(tree)
    if pos != len(code):
        raise RuleError(f"o{name} {keyword.lower()}: unexpected {code[pos:pos + 8]!r} after the "
                        f"O-word; it takes {_takes(name, keyword)}")
    wanted = KEYWORDS[keyword]
    if (wanted is None and args) or (wanted == 1 and len(args) > 1) or \
            (keyword in ("IF", "ELSEIF", "WHILE", "REPEAT") and len(args) != 1):
        given = f"{len(args)} [...] expression{'s' * (len(args) > 1)}" if args else "no [...] expression"
        raise RuleError(f"o{name} {keyword.lower()} has {given}: it takes {_takes(name, keyword)}")
    return name, keyword, args


def _takes(name: str, keyword: str) -> str:
    """What the O-word ``keyword`` accepts after it, with an example."""
    said = f"o{name} {keyword.lower()}"
    if keyword == "REPEAT":
        return f"exactly one [count] ({said} [3])"
    if keyword in ("IF", "ELSEIF", "WHILE"):
        return f"exactly one [condition] ({said} [#1 LT 3])"
    if KEYWORDS[keyword] == 1:
        return f"one optional [value] ({said} or {said} [#1])"
    if KEYWORDS[keyword] == "*":
        return f"[arguments] only ({said} [1] [#2])"
    return f"nothing after it ({said})"
