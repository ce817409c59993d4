"""G-code parser: the words of one block sorted into modal groups, axis words and values.

Checks what one block can be judged on alone: every letter is known, every G and M code is
supported, no modal group is named twice, no word is given twice, every axis word names an axis
of the machine, and feed, spindle speed and dwell are not negative.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..config import Machine
from .lexer import Word
from .validate import RuleError

#: G codes by modal group (RS274NGC's groups; G4, G28 and G92 act in their block only)
G_GROUPS: dict[int, str] = {
    0: "motion", 1: "motion", 2: "motion", 3: "motion",
    4: "non-modal", 28: "non-modal", 92: "non-modal",
    17: "plane", 18: "plane", 19: "plane",
    20: "units", 21: "units",
    90: "distance", 91: "distance",
}
#: M codes by group
M_GROUPS: dict[int, str] = {
    2: "program end", 30: "program end",
    3: "spindle", 4: "spindle", 5: "spindle",
    7: "coolant", 8: "coolant", 9: "coolant",
    0: "stop", 1: "stop", 60: "stop",      # PAUS: the run pauses
    6: "tool change",                      # TOOL: the changer, or a manual change
}
#: codes of a machine with a tool changer ([atc]: M6) or a tool table ([tools]: G43, G49)
TOOL_G_GROUPS: dict[int, str] = {43: "tool length", 49: "tool length"}
TOOL_M_GROUPS: dict[int, str] = {}
#: spindle-synchronised motion, on a machine with a spindle encoder ([spindle]): G33 threads
#: (modal, like G1), G76 the threading cycle (in its block only)
THREAD_G_GROUPS: dict[int, str] = {33: "motion", 76: "non-modal"}
#: words only a G76 block takes: Q compound angle, H spring passes, E taper length, L taper ends
CYCLE_LETTERS = "QHEL"
#: letters that name an axis in G-code (only the machine's own are accepted)
AXIS_LETTERS = "XYZABCUVW"
#: other letters with a value: feed, spindle speed, dwell, arc radius, arc centre offsets
VALUE_LETTERS = "FSPRIJK"
#: tool words: T (tool number) needs a tool changer, H (G43's tool) a tool table
TOOL_LETTERS = {"T": (None, ""), "H": ("tools", "tool table ([tools] section)")}

SUPPORTED_G = " ".join(f"G{c}" for c in sorted(G_GROUPS))
SUPPORTED_M = " ".join(f"M{c}" for c in sorted(M_GROUPS))


@dataclass
class ParsedBlock:
    """One block: its G and M codes by group, axis words and other values (as written)."""

    line: int
    g: dict[str, int] = field(default_factory=dict)        # group -> G code
    m: dict[str, int] = field(default_factory=dict)        # group -> M code
    axes: dict[str, float] = field(default_factory=dict)   # machine axis -> value, program units
    values: dict[str, float] = field(default_factory=dict)  # F S P R I J K -> value
    texts: dict[str, str] = field(default_factory=dict)    # letter -> word as written

    @property
    def motion(self) -> int | None:
        """The motion G code written in this block (0..3), if any."""
        return self.g.get("motion")


def parse_block(line: int, words: tuple[Word, ...], machine: Machine) -> ParsedBlock:
    """Sort one block's words; raise RuleError on the first word that breaks a rule."""
    block = ParsedBlock(line)
    cycle = any(w.letter == "G" and w.value == 76 for w in words)
    for index, word in enumerate(words):
        letter = word.letter
        if letter == "N":
            if index:
                raise RuleError(f"line number {word.text} must be the first word of the block")
        elif letter in "GM":
            _add_code(block, word, machine)
        elif letter in AXIS_LETTERS:
            if letter not in machine.axis_names:
                raise RuleError(f"axis {letter} is not on machine {machine.name} "
                                f"(axes: {', '.join(machine.axis_names)})")
            _add_value(block, block.axes, word)
        elif letter in VALUE_LETTERS or (cycle and letter in CYCLE_LETTERS):
            _add_value(block, block.values, word)
        elif letter in TOOL_LETTERS:
            part, what = TOOL_LETTERS[letter]
            if part is not None and part not in machine.parts:
                raise RuleError(f"{word.text}: machine {machine.name} has no {what}")
            _add_value(block, block.values, word)
        else:
            raise RuleError(f"unknown word {word.text!r}")
    return block


def _add_code(block: ParsedBlock, word: Word, machine: Machine) -> None:
    groups, codes = (G_GROUPS, block.g) if word.letter == "G" else (M_GROUPS, block.m)
    tool_groups, part = (TOOL_G_GROUPS, "tools") if word.letter == "G" else (TOOL_M_GROUPS, "atc")
    if part in machine.parts:
        groups = {**groups, **tool_groups}
    if word.letter == "G" and "spindle" in machine.parts:
        groups = {**groups, **THREAD_G_GROUPS}
    name = f"{word.letter}{word.value:g}"
    number = int(word.value) if word.value.is_integer() else None
    if word.letter == "G" and number in THREAD_G_GROUPS and number not in groups:
        raise RuleError(f"{name} needs a spindle encoder with an index pulse ([spindle] in the machine "
                        f"file); machine {machine.name} has none")
    if number not in groups:
        supported = " ".join(f"{word.letter}{c}" for c in sorted(groups))
        raise RuleError(f"{name} is not supported; supported: {supported}")
    group = groups[number]
    if group in codes:
        raise RuleError(f"{word.letter}{codes[group]} and {name} in one block: "
                        f"both are {group} codes (one per block)")
    codes[group] = number


def _add_value(block: ParsedBlock, into: dict[str, float], word: Word) -> None:
    letter = word.letter
    if letter in block.texts:
        raise RuleError(f"{letter} given twice in one block ({block.texts[letter]}, {word.text})")
    if word.value < 0 and letter in _NOT_NEGATIVE:
        raise RuleError(f"{word.text}: {_NOT_NEGATIVE[letter]}")
    block.texts[letter] = word.text
    into[letter] = word.value


_NOT_NEGATIVE = {
    "F": "a feed cannot be negative (set F > 0)",
    "S": "a spindle speed cannot be negative (set S >= 0; M3/M4 choose the direction)",
    "P": "a dwell cannot be negative (G4 P<seconds>, P >= 0; G76 P is the pitch, > 0)",
    "Q": "G76's compound angle cannot be negative (Q0 feeds straight in, Q29.5 along a 60 deg flank)",
    "E": "G76's taper length cannot be negative (E0: no taper)",
    "L": "G76's taper ends cannot be negative (L0 none, L1 entry, L2 exit, L3 both)",
    "T": "a tool number cannot be negative (T0 leaves the spindle empty)",
    "H": "a tool number cannot be negative (G43 H<n>)",
}
