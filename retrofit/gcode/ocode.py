"""O-words: subroutines, conditions and loops, as LinuxCNC's interpreter runs them.

Before a file runs, :func:`scan` pairs every O-word with its partners (``sub``/``endsub``,
``if``/``elseif``/``else``/``endif``, ``while``/``endwhile``, ``do``/``while``,
``repeat``/``endrepeat``) by their O-number or name, so that a jump is one lookup and a broken
structure is refused, with its line, before anything moves::

    o100 sub            o<loop> while [#1 LT 3]       o1 repeat [4]
      G0 X#1              #1 = [#1 + 1]                 G91 G1 X1
    o100 endsub         o<loop> endwhile              o1 endrepeat
    o100 call [5]

Fanuc-style subprograms are read too: ``M98 P1000 L2`` runs the lines from ``O1000`` (alone on
its line, in the same file) to ``M99`` twice, sharing the caller's parameters
(:mod:`retrofit.gcode.fanuc`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .errors import RuleError
from .lazylines import LazyLines
from .lexer import UNREADABLE, Line

LOOPS = ("WHILE", "DO", "REPEAT")


@dataclass
class Source:
    """The lexed lines of one file and the structure of its O-words."""

    file: str
    lines: list[Line] | LazyLines
    subs: dict[str, tuple[int, int]] = field(default_factory=dict)   # name -> (sub, endsub) index
    branches: dict[int, list[int]] = field(default_factory=dict)     # if index -> branch indexes
    end: dict[int, int] = field(default_factory=dict)                # opening index -> closing
    start: dict[int, int] = field(default_factory=dict)              # closing/break -> opening
    labels: dict[str, int] = field(default_factory=dict)             # O1000 alone -> its index
    fanuc: set[int] = field(default_factory=set)                     # indexes of M98 and M99 lines

    def where(self, index: int) -> int:
        return self.lines[index].number


def _err(line: Line, text: str) -> RuleError:
    err = RuleError(text)
    err.line = line.number
    return err


def scan(source: Source) -> Source:
    """Pair the O-words of ``source``; raise RuleError (with ``.line``) on a broken structure."""
    stack: list[tuple[str, str, int]] = []        # (KEYWORD, name, index)
    items = source.lines.candidates() if hasattr(source.lines, "candidates") else enumerate(source.lines)
    for i, line in items:
        if line.oword is None:
            if any(letter == "M" and value in (98.0, 99.0) for letter, value in line.words):
                source.fanuc.add(i)
            continue
        name, kw, _ = line.oword
        if kw == UNREADABLE:                      # its partners cannot be known: refuse it here
            raise _err(line, line.error or "")
        if kw == "LABEL":
            if name in source.labels:
                raise _err(line, f"O{name} marks two places (lines {source.where(source.labels[name])} "
                                 f"and {line.number}); M98 P{name} must know where to go")
            source.labels[name] = i
            continue
        top = stack[-1] if stack else None
        if kw in ("SUB", "IF", "DO", "REPEAT") or (kw == "WHILE" and not _closes_do(top, name)):
            if kw == "SUB" and any(k == "SUB" for k, _, _ in stack):
                raise _err(line, f"o{name} sub: a subroutine cannot be defined inside another")
            stack.append((kw, name, i))
            if kw == "IF":
                source.branches[i] = [i]
        elif kw in ("ENDSUB", "ENDIF", "ENDWHILE", "ENDREPEAT") or kw == "WHILE":
            opening = {"ENDSUB": "SUB", "ENDIF": "IF", "ENDWHILE": "WHILE", "ENDREPEAT": "REPEAT",
                       "WHILE": "DO"}[kw]
            if top is None or top[0] != opening or top[1] != name:
                raise _err(line, f"o{name} {kw.lower()} without a matching o{name} "
                                 f"{opening.lower()}" + (f" (the open O-word is o{top[1]} "
                                                         f"{top[0].lower()})" if top else ""))
            stack.pop()
            source.end[top[2]] = i
            source.start[i] = top[2]
            if kw == "ENDSUB":
                if name in source.subs:
                    raise _err(line, f"o{name} sub is defined twice")
                source.subs[name] = (top[2], i)
        elif kw in ("ELSEIF", "ELSE"):
            if top is None or top[0] != "IF" or top[1] != name:
                raise _err(line, f"o{name} {kw.lower()} without a matching o{name} if")
            source.branches[top[2]].append(i)
        elif kw in ("BREAK", "CONTINUE"):
            loop = next((s for s in reversed(stack) if s[0] in LOOPS and s[1] == name), None)
            if loop is None:
                raise _err(line, f"o{name} {kw.lower()} outside an o{name} loop (while, do, "
                                 f"repeat)")
            source.start[i] = loop[2]
        elif kw in ("RETURN",):
            if not any(k == "SUB" for k, _, _ in stack):
                raise _err(line, f"o{name} return outside a subroutine")
    if stack:
        kw, name, i = stack[-1]
        raise _err(source.lines[i], f"o{name} {kw.lower()} is never closed (no o{name} "
                                    f"{_CLOSER[kw]})")
    return source


_CLOSER = {"SUB": "endsub", "IF": "endif", "WHILE": "endwhile", "DO": "while", "REPEAT": "endrepeat"}


def _closes_do(top, name: str) -> bool:
    return top is not None and top[0] == "DO" and top[1] == name
