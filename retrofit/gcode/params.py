"""Parameters: numbered ``#1``-``#5602``, named local ``#<name>`` and global ``#<_name>``.

The numbers LinuxCNC gives a meaning are kept here too, so that a program reads and sets them as
it would on LinuxCNC (9 values each, in the axis order X Y Z A B C U V W, lengths in mm):

====================  ===========================================================
``#5161``-``#5169``   the G28 position (G28.1 stores it), machine coordinates
``#5181``-``#5189``   the G30 position (G30.1)
``#5211``-``#5219``   the G92 offset; ``#5210`` is 1 while it is applied
``#5220``             the coordinate system in use: 1 (G54) .. 9 (G59.3)
``#5221``-``#5229``   the G54 offset; G55 from ``#5241``, ... G59.3 from ``#5381`` (every 20)
``#5400``             the tool in the spindle; ``#5403`` its length offset (Z)
``#5420``-``#5428``   the current position in program coordinates
====================  ===========================================================

Numbered ``#1``-``#30`` are the arguments of a subroutine call, local to the call. Reading a
numbered parameter never set gives 0; reading a named one never set is an error.
"""

from __future__ import annotations

import math

from .errors import RuleError

AXIS_ORDER = "XYZABCUVW"
MAX_NUMBER = 5602
G28_BASE, G30_BASE, G92_BASE, CS_SELECT, G54_BASE, CS_STEP = 5161, 5181, 5211, 5220, 5221, 20
TOOL, TOOL_Z, POSITION_BASE = 5400, 5403, 5420
#: the coordinate systems G54 .. G59.3 in the order of #5220
CS_CODES = (54.0, 55.0, 56.0, 57.0, 58.0, 59.0, 59.1, 59.2, 59.3)
ARGUMENTS = 30


class Parameters:
    """Every parameter of a running program."""

    def __init__(self):
        self.numbered: dict[int, float] = {CS_SELECT: 1.0}
        self.globals: dict[str, float] = {}
        self.frames: list[dict[str, float]] = [{}]
        self.saved: list[dict[int, float]] = []
        self.version = 0          # counts writes to numbered parameters (offsets are cached on it)

    @staticmethod
    def index(value: float) -> int:
        """A parameter number: a whole number from 1 to 5602."""
        if not math.isfinite(value) or value != int(value) or not 1 <= value <= MAX_NUMBER:
            raise RuleError(f"parameter number #{value:g} out of range (#1 to #{MAX_NUMBER}, "
                            f"whole numbers)")
        return int(value)

    def read(self, ref) -> float:
        """The value of parameter ``ref``: a number or a (lower-case) name."""
        if isinstance(ref, str):
            table = self.globals if ref.startswith("_") else self.frames[-1]
            if ref not in table and ref.startswith("_hal["):
                raise RuleError(f"#<{ref}>: HAL pins are LinuxCNC's; retrofit has no HAL (set "
                                f"the value in the program)")
            if ref not in table:
                raise RuleError(f"named parameter #<{ref}> is not defined (assign it first: "
                                f"#<{ref}>=0)")
            return table[ref]
        return self.numbered.get(self.index(ref), 0.0)

    def write(self, ref, value: float) -> None:
        """Set parameter ``ref``; only finite values are accepted."""
        if not math.isfinite(value):
            raise RuleError(f"parameter {_show(ref)} would be set to {value}, not a finite number")
        if isinstance(ref, str):
            (self.globals if ref.startswith("_") else self.frames[-1])[ref] = value
        else:
            self.numbered[self.index(ref)] = value
            self.version += 1

    def exists(self, name: str) -> bool:
        """EXISTS[#<name>]."""
        return name in (self.globals if name.startswith("_") else self.frames[-1])

    def axis(self, base: int, axis: str) -> float:
        """One of nine values stored from ``base`` on, by axis letter."""
        return self.numbered.get(base + AXIS_ORDER.index(axis), 0.0)

    def set_axis(self, base: int, axis: str, value: float) -> None:
        self.write(base + AXIS_ORDER.index(axis), value)

    def enter(self, arguments: list[float]) -> None:
        """A subroutine call: new local names, #1-#30 set from the arguments (the rest 0)."""
        self.saved.append({n: self.numbered.get(n, 0.0) for n in range(1, ARGUMENTS + 1)})
        for n in range(1, ARGUMENTS + 1):
            self.numbered[n] = arguments[n - 1] if n <= len(arguments) else 0.0
        self.frames.append({})

    def leave(self) -> None:
        """Return from a subroutine: the caller's locals and #1-#30 come back."""
        self.frames.pop()
        self.numbered.update(self.saved.pop())
        self.version += 1


def _show(ref) -> str:
    return f"#<{ref}>" if isinstance(ref, str) else f"#{ref:g}"
