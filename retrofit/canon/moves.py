"""Moves kept as arrays after the seam: a block of FMOV / PMOV / PFDR, and a command list holding blocks.

A run of plain CAM lines (:mod:`retrofit.gcode.plainrun`) makes thousands of moves and arc chords
whose numbers are final when the run is read: a Python object per command would cost more than
reading the line. :class:`Moves` keeps them as two arrays (a kind and the axis words, or the feed,
of each command) and makes the command objects only when they are read one by one.
:class:`CommandList` is the interpreter's list of commands: ``len`` without making anything, and
every other way of reading it (iteration, an index, a slice, ``==``) reads the same
:class:`~retrofit.commands.Command` objects, in the same order, as a list of them would hold.
:meth:`CommandList.parts` gives the commands and blocks as they were added, for a reader that
takes the arrays as they are (the planner's table, :func:`retrofit.motion.planarrays.encode`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, MutableSequence
from typing import Any

import numpy as np

from ..commands import Command, FMov, PFdr, PMov
from .tocommands import made

#: the kinds of a block's rows
FMOV, PMOV, PFDR = 0, 1, 2


class Moves:
    """``len(kinds)`` commands: row i is an FMOV or a PMOV to ``values[i]`` (mm over the axes
    ``names``, in the machine's order) or a PFDR of ``values[i, 0]`` mm/min, by ``kinds[i]``."""

    __slots__ = ("names", "kinds", "values")

    def __init__(self, names: tuple[str, ...], kinds: np.ndarray, values: np.ndarray):
        if kinds.shape != (len(values),) or values.shape[1:] != (len(names),):
            raise ValueError(f"a block of {len(kinds)} kinds and {values.shape} values over {names}")
        self.names, self.kinds, self.values = tuple(names), kinds, values

    def __len__(self) -> int:
        return len(self.kinds)

    def commands(self) -> list[Command]:
        """The block's commands, as objects."""
        out = np.empty(len(self), object)
        for kind, cls in ((FMOV, FMov), (PMOV, PMov)):
            rows = np.flatnonzero(self.kinds == kind)
            if len(rows):
                out[rows] = made(cls, self.names, self.values[rows])
        rows = np.flatnonzero(self.kinds == PFDR)
        if len(rows):
            out[rows] = [PFdr(feed) for feed in self.values[rows, 0].tolist()]
        listed: list[Command] = out.tolist()
        return listed


class CommandList(MutableSequence[Command]):
    """The commands of a program, some of them held in :class:`Moves` blocks (see the module doc).

    Reading it one command at a time makes the blocks' objects once, for good; appending never
    does."""

    def __init__(self, items: Iterable[Command] = ()):
        self._items: list[Any] = list(items)          # commands and Moves blocks
        self._count = len(self._items)
        self._blocks = False

    def add_block(self, block: Moves) -> None:
        """Append the commands of ``block``, kept as arrays."""
        if len(block):
            self._items.append(block)
            self._count += len(block)
            self._blocks = True

    def parts(self) -> list[Any]:
        """The commands and the blocks, in order, as they were added."""
        return list(self._items)

    def _listed(self) -> list[Command]:
        if self._blocks:
            flat: list[Command] = []
            for item in self._items:
                if type(item) is Moves:
                    flat.extend(item.commands())
                else:
                    flat.append(item)
            self._items, self._blocks = flat, False
        return self._items

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, index: Any) -> Any:
        return self._listed()[index]

    def __setitem__(self, index: Any, value: Any) -> None:
        self._listed()[index] = value
        self._count = len(self._items)

    def __delitem__(self, index: Any) -> None:
        del self._listed()[index]
        self._count = len(self._items)

    def insert(self, index: int, value: Command) -> None:
        self._listed().insert(index, value)
        self._count += 1

    def append(self, value: Command) -> None:
        self._items.append(value)
        self._count += 1

    def extend(self, values: Iterable[Command]) -> None:
        if isinstance(values, CommandList):
            for item in values.parts():
                self.add_block(item) if type(item) is Moves else self.append(item)
            return
        values = list(values)
        self._items.extend(values)
        self._count += len(values)

    def __iter__(self) -> Iterator[Command]:
        return iter(self._listed())

    def __eq__(self, other: object) -> bool:
        if isinstance(other, CommandList):
            other = other._listed()
        return isinstance(other, list) and self._listed() == other

    __hash__ = None  # type: ignore[assignment]  # mutable, as a list

    def __add__(self, other: Iterable[Command]) -> list[Command]:
        return self._listed() + list(other)

    def __radd__(self, other: Iterable[Command]) -> list[Command]:
        return list(other) + self._listed()

    def copy(self) -> CommandList:
        """A new list of the same commands (blocks shared: nothing changes a block)."""
        out = CommandList()
        out._items, out._count, out._blocks = list(self._items), self._count, self._blocks
        return out

    __copy__ = copy

    def __reduce__(self) -> tuple[Any, ...]:
        return (CommandList, (self._listed(),))

    def __repr__(self) -> str:
        return f"CommandList({self._listed()!r})"
