"""A program's lines read as the interpreter reaches them: the text, where each line starts, a lexer.

A file of two million lines lexed whole holds a ``Line`` object per line (several hundred bytes
each) before the first one runs. :class:`LazyLines` keeps the text (as bytes when it is not
ASCII) and where every line that is not empty starts and ends (found by NumPy in one pass,
milliseconds for a long file; 24 bytes a line), and
lexes a line when it is read (:func:`retrofit.gcode.lexer.lex_text_line`); the last lines read
are kept, so a loop does not lex its body again each time round. It is a sequence of the same
lines :func:`~retrofit.gcode.lexer.lex_lines` gives, except that a line holding only a comment
or spaces reads as None (nothing to run) where ``lex_lines`` leaves it out.

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


class LazyLines:
    """The non-empty lines of a program's text, lexed on reading (see the module doc)."""

    def __init__(self, text: str):
        data = text.encode("utf-8")
        ascii_only = len(data) == len(text)
        self.text = text if ascii_only else None       # offsets in bytes are offsets in the text
        self.data = None if ascii_only else data
        raw = np.frombuffer(data, np.uint8)
        lf = raw == 10
        cr = raw == 13
        ends = np.flatnonzero(lf | (cr & ~np.concatenate((lf[1:], [False]))))
        starts = np.concatenate(([0], ends + 1))
        stops = np.concatenate((ends, [len(raw)]))
        crlf = np.flatnonzero(lf)
        crlf = crlf[(crlf > 0) & cr[np.maximum(crlf - 1, 0)]]      # '\r\n': the '\r' is no text
        stops[np.searchsorted(stops, crlf)] -= 1
        numbers = np.arange(1, len(starts) + 1, dtype=np.int64)
        keep = stops > starts
        self.starts, self.stops = array("q", starts[keep].tobytes()), array("q", stops[keep].tobytes())
        self.numbers = array("q", numbers[keep].tobytes())
        hits = np.flatnonzero(((raw | 0x20) == ord("o")) | ((raw | 0x20) == ord("m")))
        self._candidates = np.unique(np.searchsorted(stops[keep], hits, side="left")).tolist()
        self._lex = lru_cache(maxsize=KEEP_LEXED)(self._lex_one)

    def __len__(self) -> int:
        return len(self.starts)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [line for line in (self._lex(i) for i in range(*index.indices(len(self))))
                    if line is not None]
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
            text = self.data[self.starts[index]:self.stops[index]].decode("utf-8")
        return lex_text_line(self.numbers[index], text)

    def first(self) -> Line | None:
        """The first line that holds something (None for a program of comments only)."""
        return next((line for line in self if line is not None), None)

    def candidates(self):
        """(index, line) of the lines that may hold an O-word, M98 or M99, in order."""
        for i in self._candidates:
            if i < len(self):
                line = self._lex(i)
                if line is not None:
                    yield i, line
