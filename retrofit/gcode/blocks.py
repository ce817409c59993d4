"""Blocks: the evaluated words of one line sorted into modal groups, axis words and values.

Checks what one block can be judged on alone, in LinuxCNC's terms: every G and M code is known
(and supported here), no modal group is named twice, no letter is given twice, every axis word
names an axis of the machine, every value is a finite number.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..machine.config import Machine
from .errors import RuleError

#: G codes by modal group, as LinuxCNC groups them
G_GROUPS: dict[float, str] = {
    **dict.fromkeys((4, 10, 28, 28.1, 30, 30.1, 53, 92, 92.1, 92.2, 92.3), "non-modal"),
    **dict.fromkeys((0, 1, 2, 3, 5, 5.1, 5.2, 33, 33.1, 38.2, 38.3, 38.4, 38.5, 73, 74, 80, 81, 82, 83,
                     84, 85, 86, 87, 88, 89), "motion"),
    76: "non-modal", 5.3: "non-modal",
    **dict.fromkeys((17, 18, 19), "plane"), **dict.fromkeys((20, 21), "units"),
    **dict.fromkeys((90, 91), "distance"), **dict.fromkeys((90.1, 91.1), "arc distance"),
    **dict.fromkeys((93, 94, 95), "feed mode"), **dict.fromkeys((96, 97), "spindle speed mode"),
    **dict.fromkeys((40, 41, 41.1, 42, 42.1), "cutter radius"),
    **dict.fromkeys((43, 43.1, 49), "tool length"), **dict.fromkeys((98, 99), "return mode"),
    **dict.fromkeys((54, 55, 56, 57, 58, 59, 59.1, 59.2, 59.3), "coordinate system"),
    **dict.fromkeys((61, 61.1, 64), "path control"), **dict.fromkeys((7, 8), "lathe diameter"),
}
#: M codes by group
M_GROUPS: dict[float, str] = {
    **dict.fromkeys((0, 1, 2, 30, 60), "stopping"), **dict.fromkeys((6, 61), "tool change"),
    **dict.fromkeys((3, 4, 5, 70, 71, 72, 73), "spindle"), **dict.fromkeys((7, 8, 9), "coolant"),
    **dict.fromkeys((48, 49, 50, 51, 52, 53), "override"),
    **dict.fromkeys((62, 63, 64, 65, 66), "io"),
}
#: codes LinuxCNC knows that retrofit refuses, and why
REFUSED: dict[str, str] = {
    "G43.2": "G43.2 is not supported (use G43 H or G43.1)", "G52": "G52 is not supported (use G92)",
    **dict.fromkeys(("M67", "M68"), "analog outputs are not supported (the boards have none)"),
    "M19": "spindle orientation is not supported",
}
#: 3D-printer codes seen in grbl-flavoured files: a CNC has no hot end, bed or extruder
PRINTER: dict[str, str] = {
    "M104": "hot-end temperature", "M109": "hot-end temperature wait", "M140": "bed temperature",
    "M190": "bed temperature wait", "M106": "part fan", "M107": "part fan off",
    "M82": "extruder absolute mode", "M83": "extruder relative mode", "M84": "motors off",
    "G29": "bed levelling",
}
AXIS_LETTERS = "XYZABCUVW"
#: the largest magnitude any word may have; larger values overflow what a machine can represent
MAX_VALUE = 1.0e9


@dataclass
class Block:
    """One block: its G and M codes by group, axis words and other values (as written)."""

    line: int
    g: dict[str, float] = field(default_factory=dict)        # group -> G code
    m: dict[str, float] = field(default_factory=dict)        # group -> M code
    axes: dict[str, float] = field(default_factory=dict)     # machine axis -> value, program units
    values: dict[str, float] = field(default_factory=dict)   # other letters -> value
    polar: tuple | None = None      # (@ radius, ^ angle), either None (retrofit.gcode.polar)

    @property
    def texts(self) -> dict[str, str]:
        """Letter -> the word as evaluated (``'X12.5'``), for messages."""
        return {letter: f"{letter}{value:g}" for letter, value in (*self.axes.items(), *self.values.items())}

    @property
    def motion(self) -> float | None:
        """The motion G code written in this block, if any."""
        return self.g.get("motion")


def code_name(letter: str, value: float) -> str:
    """``G1``, ``G59.1``: a code as LinuxCNC writes it."""
    return f"{letter}{value:g}"


def make_block(line: int, words: list[tuple[str, float]], machine: Machine) -> Block:
    """Sort one block's evaluated words; raise RuleError on the first word that breaks a rule."""
    block = Block(line)
    axes, values = block.axes, block.values
    names = _axis_names(machine)
    for letter, value in words:
        if not -MAX_VALUE <= value <= MAX_VALUE:          # also refuses NaN
            raise RuleError(f"{letter}{value:g}: the value is not a finite number within "
                            f"+-{MAX_VALUE:g}")
        if letter == "G" or letter == "M":
            _add_code(block, letter, value)
        elif letter == "N":
            raise RuleError("line number N must be the first word of the block")
        elif letter in axes or letter in values:
            raise RuleError(f"{letter} given twice in one block ({block.texts[letter]}, "
                            f"{letter}{value:g})")
        elif letter in AXIS_LETTERS:
            if letter not in names:
                raise RuleError(f"axis {letter} is not on machine {machine.name} "
                                f"(axes: {', '.join(machine.axis_names)})")
            axes[letter] = value
        else:
            values[letter] = value
    return block


_NAMES: dict[int, tuple] = {}


def _axis_names(machine: Machine) -> frozenset:
    names = _NAMES.get(id(machine))
    if names is None or names[0] is not machine:      # an id can be reused by a new machine
        names = _NAMES[id(machine)] = (machine, frozenset(machine.axis_names))
    return names[1]


def _add_code(block: Block, letter: str, value: float) -> None:
    code = round(value, 4)
    if code == int(code):
        code = int(code)
    name = code_name(letter, code)
    groups = G_GROUPS if letter == "G" else M_GROUPS
    if code not in groups:
        if name in PRINTER:
            raise RuleError(f"{name} ({PRINTER[name]}) is a 3D-printer code; a CNC machine "
                            f"cannot do it")
        if name in REFUSED:
            raise RuleError(f"{name}: {REFUSED[name]}")
        raise RuleError(f"unknown {'G' if letter == 'G' else 'M'} code used: {name}")
    group = groups[code]
    codes = block.g if letter == "G" else block.m
    if group == "motion" and 80 in (code, codes.get(group)) and group in codes:
        codes[group] = code if code != 80 else codes[group]   # as rs274: the other code wins
        return
    if group in codes:
        raise RuleError(f"two {letter} codes used from the same modal group ({group}): "
                        f"{code_name(letter, codes[group])} and {name}")
    codes[group] = code
