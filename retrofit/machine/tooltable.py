"""The tool table in LinuxCNC's ``tool.tbl`` format: one tool a line, read and written here.

A line is a set of words and an optional comment after ``;``::

    T1 P1 Z12.700 D3.000 ;3 mm end mill
    T7 P7 X0.250 Z-1.500 D0.8 I95 J155 Q2 ;lathe insert

``T`` is the tool number and ``P`` its pocket (both whole numbers); ``X Y Z A B C U V W`` are the
tool's offsets (``Z`` is the length offset that G43 applies, ``X`` the lathe's radial offset);
``D`` is the diameter, ``I``/``J`` the front and back angles and ``Q`` the orientation of a lathe
insert. Any word may be left out; an absent offset is 0. Lengths are in the machine's units (mm
here). Blank lines and lines holding only a comment are kept out of the table.

Every value is checked on reading: whole numbers where LinuxCNC wants them, finite numbers
everywhere, a tool number at most once, so a hand-edited table fails with the file and line
instead of moving a machine by a wrong offset::

    >>> t = ToolTable.parse("T1 P1 Z12.7 D3 ;end mill\\n")
    >>> t[1].z_offset_mm, t[1].diameter_mm, t[1].comment
    (12.7, 3.0, 'end mill')
    >>> print(t.format(), end="")
    T1 P1 Z12.7 D3 ;end mill
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..atomic import write_text_atomic
from ..errors import RetrofitError

#: offset words in the order LinuxCNC writes them
OFFSET_AXES = "XYZABCUVW"
_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
#: the largest magnitude accepted for any offset or diameter (mm): a metre of tool is already absurd
LIMIT_MM = 1.0e4


class ToolTableError(RetrofitError, ValueError):
    """A tool table line that cannot be read: names the file, the line and the rule."""


@dataclass(frozen=True)
class Tool:
    """One tool of the table. Offsets in mm by axis letter (absent: 0)."""

    number: int
    pocket: int | None = None
    offsets_mm: dict[str, float] = field(default_factory=dict)
    diameter_mm: float = 0.0
    front_angle: float | None = None      # I
    back_angle: float | None = None       # J
    orientation: int | None = None        # Q
    comment: str = ""

    @property
    def z_offset_mm(self) -> float:
        """The length offset (G43 H<n> applies it to Z)."""
        return self.offsets_mm.get("Z", 0.0)

    @property
    def x_offset_mm(self) -> float:
        """The lathe's radial offset."""
        return self.offsets_mm.get("X", 0.0)

    def line(self) -> str:
        """This tool as one ``tool.tbl`` line."""
        words = [f"T{self.number}"]
        if self.pocket is not None:
            words.append(f"P{self.pocket}")
        words += [f"{a}{_num(self.offsets_mm[a])}" for a in OFFSET_AXES if a in self.offsets_mm]
        if self.diameter_mm:
            words.append(f"D{_num(self.diameter_mm)}")
        for letter, value in (("I", self.front_angle), ("J", self.back_angle), ("Q", self.orientation)):
            if value is not None:
                words.append(f"{letter}{_num(value)}")
        text = " ".join(words)
        return f"{text} ;{self.comment}" if self.comment else text


class ToolTable:
    """Tools by number, as a ``tool.tbl`` file holds them (``table[3]``, ``3 in table``)."""

    def __init__(self, tools: dict[int, Tool] | None = None, path: Path | None = None):
        self.tools: dict[int, Tool] = dict(tools or {})
        self.path = path

    def __getitem__(self, number: int) -> Tool:
        return self.tools[number]

    def __contains__(self, number: object) -> bool:
        return number in self.tools

    def __iter__(self):
        return iter(sorted(self.tools.values(), key=lambda t: t.number))

    def __len__(self) -> int:
        return len(self.tools)

    def get(self, number: int) -> Tool | None:
        return self.tools.get(number)

    def with_tool(self, tool: Tool) -> ToolTable:
        """A copy with ``tool`` added or replaced (the table itself is not changed)."""
        return ToolTable({**self.tools, tool.number: tool}, self.path)

    def set_offset(self, number: int, axis: str, value_mm: float) -> ToolTable:
        """A copy with one offset of tool ``number`` set (a new tool when it is not there)."""
        tool = self.tools.get(number) or Tool(number, pocket=number)
        return self.with_tool(replace(tool, offsets_mm={**tool.offsets_mm, axis: _finite(value_mm, axis)}))

    @classmethod
    def parse(cls, text: str, name: str = "tool.tbl") -> ToolTable:
        """Read ``text``; a ToolTableError names ``name:line`` and the rule broken."""
        tools: dict[int, Tool] = {}
        for lineno, raw in enumerate(re.split(r"\r\n|\r|\n", text), 1):
            tool = _parse_line(raw, f"{name}:{lineno}")
            if tool is None:
                continue
            if tool.number in tools:
                raise ToolTableError(f"{name}:{lineno}: tool T{tool.number} is listed twice; "
                                     f"a tool number may appear once")
            tools[tool.number] = tool
        return cls(tools)

    @classmethod
    def load(cls, path: str | Path) -> ToolTable:
        """Read a ``tool.tbl`` file (a missing file is an empty table)."""
        path = Path(path)
        if not path.exists():
            return cls(path=path)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ToolTableError(f"{path}: cannot read the tool table ({exc})") from None
        table = cls.parse(text, str(path))
        table.path = path
        return table

    def format(self) -> str:
        """The whole table as ``tool.tbl`` text, tools in number order."""
        return "".join(t.line() + "\n" for t in self)

    def save(self, path: str | Path | None = None) -> Path:
        """Write the table atomically (temporary file, fsync, rename); returns the path."""
        target = Path(path or self.path or "tool.tbl")
        write_text_atomic(target, self.format())
        self.path = target
        return target


def _parse_line(raw: str, where: str) -> Tool | None:
    body, _, comment = raw.partition(";")
    body = body.strip()
    if not body:
        return None
    values: dict[str, float] = {}
    pos = 0
    for m in _WORD.finditer(body):
        if body[pos:m.start()].strip():
            break
        letter = m.group(1).upper()
        if letter in values:
            raise ToolTableError(f"{where}: word {letter} given twice")
        values[letter] = float(m.group(2))
        pos = m.end()
    rest = body[pos:].strip()
    if rest:
        raise ToolTableError(f"{where}: cannot read '{rest[:20]}'; a line is words such as "
                             f"T1 P1 Z12.5 D3 and a comment after ';'")
    unknown = sorted(set(values) - set("TPDIJQ" + OFFSET_AXES))
    if unknown:
        raise ToolTableError(f"{where}: unknown word {unknown[0]}; accepted: T P D I J Q and "
                             f"offsets {' '.join(OFFSET_AXES)}")
    if "T" not in values:
        raise ToolTableError(f"{where}: no T word; every line names its tool (T1 ...)")
    number = _whole(values["T"], "T", where, 0, 99999)
    pocket = _whole(values["P"], "P", where, 0, 99999) if "P" in values else None
    offsets = {a: _checked(values[a], a, where) for a in OFFSET_AXES if a in values}
    diameter = _checked(values.get("D", 0.0), "D", where)
    if diameter < 0:
        raise ToolTableError(f"{where}: D{_num(diameter)}: a diameter must be >= 0")
    orientation = _whole(values["Q"], "Q", where, 0, 9) if "Q" in values else None
    return Tool(number, pocket, offsets, diameter,
                _checked(values["I"], "I", where) if "I" in values else None,
                _checked(values["J"], "J", where) if "J" in values else None,
                orientation, comment.strip())


def _whole(value: float, letter: str, where: str, low: int, high: int) -> int:
    if not value.is_integer() or not low <= value <= high:
        raise ToolTableError(f"{where}: {letter}{_num(value)}: must be a whole number "
                             f"from {low} to {high}")
    return int(value)


def _checked(value: float, letter: str, where: str) -> float:
    if not math.isfinite(value) or abs(value) > LIMIT_MM:
        raise ToolTableError(f"{where}: {letter}{value!r}: must be a finite number within "
                             f"±{LIMIT_MM:g}")
    return value


def _finite(value: float, letter: str) -> float:
    return _checked(float(value), letter, "tool table")


def _num(value: float) -> str:
    value = float(value)
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)
