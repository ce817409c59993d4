"""A program's lines read as the interpreter reaches them: the text, where each line starts, a lexer.

A file of two million lines lexed whole holds a ``Line`` object per line (several hundred bytes
each) before the first one runs. :class:`LazyLines` keeps the text (as bytes when it is not
ASCII) and where every line that is not empty starts and ends (found by NumPy in one pass,
milliseconds for a long file; 12 bytes a line), and
lexes a line when it is read (:func:`retrofit.gcode.lexer.lex_text_line`); the last lines read
are kept, so a loop does not lex its body again each time round. It is a sequence of the same
lines :func:`~retrofit.gcode.lexer.lex_lines` gives, except that a line holding only a comment
or spaces reads as a line without words (nothing to run) where ``lex_lines`` leaves it out.

``candidates()`` gives the lines that may hold an O-word or an M98 / M99 (an ``O`` or an ``M``
somewhere on them): :func:`retrofit.gcode.ocode.scan` pairs O-words by reading only those.
"""

from __future__ import annotations

from array import array
from functools import lru_cache

import numpy as np

from .lexer import Line, lex_text_line

#: lines kept lexed (a loop's body up to this long is lexed once)
KEEP_LEXED = 4096
#: bytes of text scanned for line ends at a time
SCAN_BYTES = 1 << 22


class LazyLines:
    """The non-empty lines of a program's text, lexed on reading (see the module doc)."""

    def __init__(self, text: str):
        data = text.encode("utf-8")
        ascii_only = len(data) == len(text)
        self.text = text if ascii_only else None       # offsets in bytes are offsets in the text
        self.data = None if ascii_only else data
        kind = "i" if len(data) < 2 ** 31 - 1 else "q"
        self.starts, self.stops, self.numbers = array(kind), array(kind), array(kind)
        raw = np.frombuffer(data, np.uint8)
        first, number, has_cr = 0, 1, b"\r" in data
        for at in range(0, len(raw), SCAN_BYTES):          # a piece at a time: little memory
            first, number = self._scan(raw, at, min(at + SCAN_BYTES, len(raw)), first, number, has_cr)
        if first < len(raw):                               # the last line, without an end
            self._keep(np.array([first]), np.array([len(raw)]), np.array([number]))
        self._candidates = self._marked(data)
        self._lex = lru_cache(maxsize=KEEP_LEXED)(self._lex_one)

    def _scan(self, raw, lo: int, hi: int, first: int, number: int, has_cr: bool) -> tuple[int, int]:
        """Lines ending in ``raw[lo:hi]``; (start of the next line, its number)."""
        piece = raw[lo:hi]
        lf = piece == 10
        if has_cr:
            after = raw[hi] if hi < len(raw) else 0
            cr = piece == 13
            lf |= cr & ~np.concatenate((lf[1:], [after == 10]))
        ends = np.flatnonzero(lf) + lo
        if not len(ends):
            return first, number
        starts = np.concatenate(([first], ends[:-1] + 1))
        stops = ends
        if has_cr:
            stops = ends - ((raw[ends] == 10) & (raw[np.maximum(ends - 1, 0)] == 13) & (ends > starts))
        self._keep(starts, stops, np.arange(number, number + len(ends)))
        return int(ends[-1]) + 1, number + len(ends)

    def _keep(self, starts, stops, numbers) -> None:
        keep = stops > starts
        kind = self.starts.typecode
        self.starts.frombytes(starts[keep].astype(kind).tobytes())
        self.stops.frombytes(stops[keep].astype(kind).tobytes())
        self.numbers.frombytes(numbers[keep].astype(kind).tobytes())

    def _marked(self, data: bytes) -> list[int]:
        """Indexes of the lines holding an O or an M (either case): ``bytes.find`` runs through
        a long program in a few milliseconds when they are few, as in CAM output."""
        hits = []
        for letter in b"oOmM":
            at = data.find(letter)
            while at >= 0:
                hits.append(at)
                at = data.find(letter, at + 1)
        stops = np.frombuffer(self.stops, np.int32 if self.stops.typecode == "i" else np.int64)
        rows = np.unique(np.searchsorted(stops, np.array(hits, np.int64), side="left")).tolist()
        return [r for r in rows if r < len(self.starts)]

    def __len__(self) -> int:
        return len(self.starts)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [line for line in (self._lex(i) for i in range(*index.indices(len(self))))
                    if not blank(line)]
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError(index)
        return self._lex(index)

    def __iter__(self):
        return (self._lex(i) for i in range(len(self)))

    def _lex_one(self, index: int) -> Line | None:
        if self.text is not None:
            text = self.text[self.starts[index]:self.stops[index]]
        else:
            assert self.data is not None         # kept whenever the text is not
            text = self.data[self.starts[index]:self.stops[index]].decode("utf-8")
        line = lex_text_line(self.numbers[index], text)
        return Line(self.numbers[index], plain=True) if line is None else line

    def first(self) -> tuple[int, Line] | None:
        """(index, line) of the first line that holds something (None for a program of comments
        only)."""
        return next(((i, line) for i, line in enumerate(self) if not blank(line)), None)

    def candidates(self):
        """(index, line) of the lines that may hold an O-word, M98 or M99, in order."""
        for i in self._candidates:
            if i < len(self):
                yield i, self._lex(i)


def blank(line: Line) -> bool:
    """Whether ``line`` holds nothing to run (only a comment or spaces)."""
    return not (line.words or line.assigns or line.oword or line.messages or line.dollar
                or line.percent or line.error)
