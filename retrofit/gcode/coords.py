"""Coordinate systems and offsets: G54-G59.3, G10, G92 and friends, G28/G30, G43/G49.

Nothing here is sent to the machine as a command of its own: an offset only changes where the
next moves go (:meth:`~retrofit.gcode.state.ModalState.target`). LinuxCNC's semantics:

* ``G28`` / ``G30`` with axis words rapid to that intermediate point first, then move **only
  the named axes** (every axis when none is named) to the stored G28 / G30 position, in machine
  coordinates. The G28 position is the machine's home until ``G28.1`` stores another one, so
  ``G28`` becomes ``ZMOV`` (homing those axes); a stored position is an ``FMOV``. Afterwards the
  program position is the machine position minus the offsets -- not program zero.
* ``G92`` makes the current position read the given values (always absolute); ``G92.1`` clears
  the offset and its parameters, ``G92.2`` suspends it, ``G92.3`` brings it back.
* ``G10 L2 P<n>`` sets coordinate system n (``P0``: the one in use), ``G10 L20`` so that the
  current position reads the given values; ``G10 L1 P<tool>`` sets a tool's offsets in the table,
  ``G10 L10`` / ``L11`` so that the current position reads the given values with that tool.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..canon import ZeroAxes
from ..machine.tooltable import ToolTable, ToolTableError
from .errors import RuleError
from .params import CS_CODES, CS_SELECT, CS_STEP, G28_BASE, G30_BASE, G54_BASE, G92_BASE, TOOL_Z
from .state import clean_mm
from .threading import leave

if TYPE_CHECKING:
    from .translate import Translator


def _home_mm(tr: Translator) -> dict[str, float]:
    homing = tr.machine.parts.get("homing")
    return {n: (homing.home_mm(n) if homing else 0.0) for n in tr.machine.axis_names}


def go_home(tr: Translator, block, base: int) -> None:
    """G28 (``base`` #5161) or G30 (#5181)."""
    leave(tr)
    s = tr.state
    if block.axes:
        tr.rapid(s.target(block.axes), " (G28/G30 intermediate point)")
    names = [n for n in tr.machine.axis_names if n in block.axes] or list(tr.machine.axis_names)
    stored = any(base + i in s.params.numbered for i in range(9))
    home = _home_mm(tr)
    if base == G28_BASE and not stored:
        tr.emit(ZeroAxes(() if len(names) == len(tr.machine.axis_names) else tuple(names)))
        s.position = {**s.position, **{n: home[n] for n in names}}
        return
    end = dict(s.position)
    for n in names:
        end[n] = s.params.axis(base, n) if n in "XYZABCUVW" and stored else home[n]
    tr.rapid(end, " (the stored G28/G30 position)")


def store_home(tr: Translator, block, base: int) -> None:
    """G28.1 / G30.1: the current machine position becomes the G28 / G30 position."""
    for n in tr.machine.axis_names:
        if n in "XYZABCUVW":
            tr.state.params.set_axis(base, n, tr.state.position[n])


def set_g92(tr: Translator, block) -> None:
    """G92: the named axes now read the given values."""
    s = tr.state
    p = s.params
    if not p.numbered.get(G92_BASE - 1, 0.0):
        for n in "XYZABCUVW":
            p.set_axis(G92_BASE, n, 0.0)
    p.write(G92_BASE - 1, 1.0)
    for n, value in block.axes.items():
        rest = s.offset(n) - p.axis(G92_BASE, n)
        p.set_axis(G92_BASE, n, clean_mm(s.position[n] - rest - s.word_mm(n, value)))


def g92_family(tr: Translator, block) -> None:
    """G92.1 (clear), G92.2 (suspend), G92.3 (restore)."""
    p = tr.state.params
    code = block.g["non-modal"]
    if code == 92.1:
        for n in "XYZABCUVW":
            p.set_axis(G92_BASE, n, 0.0)
    p.write(G92_BASE - 1, 1.0 if code == 92.3 else 0.0)


def select_system(tr: Translator, code: float) -> None:
    """G54 .. G59.3."""
    tr.state.params.write(CS_SELECT, float(CS_CODES.index(code) + 1))


def g10(tr: Translator, block) -> None:
    """G10 L1/L10/L11 (tool table) and L2/L20 (coordinate systems)."""
    s, v = tr.state, block.values
    if "L" not in v or "P" not in v:
        raise RuleError("G10 needs L (1, 2, 10, 11 or 20) and P (the tool or coordinate system)")
    kind, number = v["L"], v["P"]
    if number != int(number) or number < 0:
        raise RuleError(f"{block.texts['P']}: G10's P is a whole number")
    if kind in (2, 20):
        if number > 9:
            raise RuleError(f"{block.texts['P']}: G10 L{kind:g} P is 0 (the system in use) to 9 "
                            f"(G59.3)")
        if v.get("R", 0.0):
            raise RuleError("G10 L2 R: rotated coordinate systems are not supported")
        system = int(number) or int(s.params.numbered.get(CS_SELECT, 1.0))
        base = G54_BASE + CS_STEP * (system - 1)
        for n, value in block.axes.items():
            mm = s.word_mm(n, value)
            if kind == 20:
                mm = s.position[n] - (s.offset(n) - s.params.axis(
                    G54_BASE + CS_STEP * (int(s.params.numbered.get(CS_SELECT, 1.0)) - 1), n)) - mm
            s.params.set_axis(base, n, clean_mm(mm))
    elif kind in (1, 10, 11):
        _g10_tool(tr, block, int(number), kind)
    else:
        raise RuleError(f"{block.texts['L']}: G10 takes L1, L2, L10, L11 or L20")


def _g10_tool(tr: Translator, block, number: int, kind: float) -> None:
    s = tr.state
    table = tr.tool_table if tr.tool_table is not None else ToolTable()
    if number not in table:
        raise RuleError(f"G10 L{kind:g} P{number}: requested tool {number} not found in the tool "
                        f"table")
    try:
        for n, value in block.axes.items():
            mm = s.word_mm(n, value)
            if kind != 1:
                here = s.position[n] - s.offset(n) + s.tool_offset.get(n, 0.0)
                mm = here - mm
            table = table.set_offset(number, n, clean_mm(mm))
    except ToolTableError as exc:
        raise RuleError(f"G10 L{kind:g}: {exc}") from None
    tr.tool_table = table


def table_name(table) -> str:
    """The tool table as a message names it: its file, or that the run was given none."""
    path = getattr(table, "path", None)
    return str(path) if path is not None else "(none given: --tool-table FILE names one)"


def tool_length(tr: Translator, block) -> None:
    """G43 [H], G43.1 (offsets in the block), G49 (cancel)."""
    s = tr.state
    before = dict(s.tool_offset)
    code = block.g["tool length"]
    if code == 49:
        s.tool_offset = {}
    elif code == 43.1:
        s.tool_offset = {n: s.word_mm(n, v) for n, v in block.axes.items()}
        block.axes.clear()
    else:
        number = block.values.get("H", float(s.tool))
        if number != int(number) or number < 0:
            raise RuleError(f"{block.texts.get('H', 'G43')}: H is a tool number")
        tool = tr.tool_table.get(int(number)) if tr.tool_table is not None else None
        if tool is None and number != 0:
            raise RuleError(f"G43 H{number:g}: tool {number:g} is not in the tool table "
                            f"{table_name(tr.tool_table)}; add it there, or measure it: "
                            f"retrofit setter measure T{number:g}")
        offsets = dict(tool.offsets_mm) if tool else {}
        s.tool_offset = {n: offsets[n] for n in tr.machine.axis_names if n in offsets}
    s.params.write(TOOL_Z, s.tool_offset.get("Z", 0.0))
    if "tool change" not in block.m:
        return              # the machine stays where it is; the program position changes
    for axis in set(before) | set(s.tool_offset):      # in the block of M6, LinuxCNC keeps the
        delta = s.tool_offset.get(axis, 0.0) - before.get(axis, 0.0)   # program position:
        if delta:                                      # the next move takes the offset up
            s.pending[axis] = s.pending.get(axis, 0.0) + delta


def absolute_centre_words(tr: Translator, words: dict) -> dict:
    """G90.1: I, J, K are the centre in program coordinates; made relative to the start."""
    s = tr.state
    out = dict(words)
    for letter, axis in (("I", "X"), ("J", "Y"), ("K", "Z")):
        if letter in out and axis in s.position:
            out[letter] = out[letter] + s.offset(axis) - s.position[axis]
    return out


NONMODAL = {
    10: g10, 28: lambda tr, b: go_home(tr, b, G28_BASE), 30: lambda tr, b: go_home(tr, b, G30_BASE),
    28.1: lambda tr, b: store_home(tr, b, G28_BASE), 30.1: lambda tr, b: store_home(tr, b, G30_BASE),
    92: set_g92, 92.1: g92_family, 92.2: g92_family, 92.3: g92_family,
}
