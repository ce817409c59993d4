"""The tool table: each tool's measured length and diameter, and the tool setter's reference.

Lengths run from the spindle's gauge line to the tool tip. A tool's length offset (G43) is its
length minus the reference tool's, so programs touched off with the reference tool cut at the
same depth with any measured tool. The setter's own record (reference and measured lengths) is a
JSON file beside the spindle record (``mill.setter.json``); every save also writes the machine's
LinuxCNC tool table (``mill.tbl``): Z = length - reference length, D = diameter, so G43 in any
program uses the measurements.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..atomic import write_json_atomic
from ..errors import ToolChangeError, ToolStateError
from .state import default_state_dir


@dataclass(frozen=True)
class Reference:
    """The setter's calibration: the reference tool, its known length, the Z at which it broke the beam."""

    tool: int
    length_mm: float
    z_break_mm: float


@dataclass(frozen=True)
class ToolEntry:
    """What the setter measured of one tool (None: not measured)."""

    length_mm: float | None = None
    diameter_mm: float | None = None


@dataclass
class ToolTable:
    """Measured tools by number, and the reference they were measured against."""

    machine: str
    reference: Reference | None = None
    tools: dict[int, ToolEntry] = field(default_factory=dict)

    def length_offset(self, tool: int) -> float:
        """Length of ``tool`` minus the reference tool's (mm); H0 / T0 is 0."""
        if tool == 0:
            return 0.0
        entry = self.tools.get(tool)
        if entry is None or entry.length_mm is None or self.reference is None:
            raise ToolChangeError(f"tool {tool} has no measured length in the tool table of "
                                  f"{self.machine} (measure it: retrofit setter measure T{tool} "
                                  f"--machine {self.machine})")
        return round(entry.length_mm - self.reference.length_mm, 9)

    def as_dict(self) -> dict:
        """The table as the JSON file holds it."""
        ref = self.reference
        return {"machine": self.machine,
                "reference": None if ref is None else {"tool": ref.tool, "length_mm": ref.length_mm,
                                                       "z_break_mm": ref.z_break_mm},
                "tools": {str(n): {"length_mm": e.length_mm, "diameter_mm": e.diameter_mm}
                          for n, e in sorted(self.tools.items())}}


class ToolTableStore:
    """Loads and saves one machine's tool table."""

    def __init__(self, machine: str, path: str | Path | None = None, tbl: str | Path | None = None):
        self.machine = machine
        self.path = Path(path) if path is not None else default_state_dir() / f"{machine}-tooltable.json"
        self.tbl = Path(tbl) if tbl is not None else None

    def load(self) -> ToolTable:
        """The saved table (empty when there is none yet); ToolStateError when it is unreadable."""
        if not self.path.exists():
            return ToolTable(self.machine)
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
            if data.get("machine", self.machine) != self.machine:
                raise ValueError(f"it belongs to machine {str(data.get('machine'))[:40]!r}")
            ref = data.get("reference")
            reference = None if ref is None else Reference(_tool(ref["tool"]), _opt(ref["length_mm"]),
                                                           _opt(ref["z_break_mm"]))
            tools = {_tool(k): ToolEntry(_opt(v.get("length_mm")), _opt(v.get("diameter_mm")))
                     for k, v in data.get("tools", {}).items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError) as exc:
            raise ToolStateError(f"{self.path}: the setter's record is unreadable ({type(exc).__name__}: "
                                 f"{str(exc)[:80]}); remove it and measure the tools again (retrofit setter "
                                 f"reference, then retrofit setter measure T1 T2 ...)") from None
        return ToolTable(self.machine, reference, tools)

    def save(self, table: ToolTable) -> None:
        """Replace the file with ``table`` and update the tool table (``tbl``), atomically."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.path, table.as_dict())
        if self.tbl is None or table.reference is None:
            return
        from ..machine.tooltable import ToolTable as Tbl
        tbl = Tbl.load(self.tbl)
        for number, entry in sorted(table.tools.items()):
            if entry.length_mm is not None:
                tbl = tbl.set_offset(number, "Z", table.length_offset(number))
            if entry.diameter_mm is not None:
                from dataclasses import replace
                tbl = tbl.with_tool(replace(tbl[number] if number in tbl else _new(number),
                                            diameter_mm=entry.diameter_mm))
        tbl.save(self.tbl)


def _new(number: int):
    from ..machine.tooltable import Tool
    return Tool(number, pocket=number)


def _tool(value) -> int:
    number = int(value)
    if str(value).strip() != str(number) or not 0 <= number <= 99999:
        raise ValueError(f"{str(value)[:20]!r} is not a tool number")
    return number


def _opt(value) -> float | None:
    if value is None:
        return None
    number = float(value)
    if not math.isfinite(number) or abs(number) > 1e4:
        raise ValueError(f"{value!r} is not a finite length in mm")
    return number
