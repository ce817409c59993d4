"""Plain CAM lines read by a compiled scanner: the bytes of a run of lines to a table of words.

:func:`scan_plain` reads what :mod:`retrofit.gcode.plainrun`'s pattern reads (an optional ``G0`` /
``G1``, then X, Y, Z, F in that order, each at most once, upper case, at most one space after
each word but F) straight from the text's bytes, a whole run of lines in one call, and gives each
number the float Python's ``float()`` gives it: a number of at most 15 digits is its digits as an
integer divided by a power of ten, both exact in a double, so the one division rounds correctly
(as ``float()`` does). A line of another shape, or a number of more digits, ends the run there;
the lines from it on are read the usual way, so nothing is read differently.

It is a compiled kernel (:mod:`retrofit.motion._jit`, built ahead of time by ``retrofit kernels``);
where kernels do not run compiled the pattern reads the run instead (:func:`plain_table`).
"""

from __future__ import annotations

import math

import numpy as np

from ..motion._jit import compiled, kernel

#: G, X, Y, Z, F: the columns of the table, in the order a plain line gives them
_LETTERS = (71, 88, 89, 90, 70)
#: the most digits of a number read exactly by one division
_DIGITS = 15
#: lines scanned in the first piece of a run (then four times as many each time)
FIRST_PIECE = 64


@kernel
def _number(buf, p, end):
    """(value, position after it); position -1 when no number of at most 15 digits starts at p."""
    negative = False
    if p < end and (buf[p] == 45 or buf[p] == 43):      # - +
        negative = buf[p] == 45
        p += 1
    mantissa, digits, decimals, dot = 0, 0, 0, False
    while p < end:
        c = int(buf[p])
        if 48 <= c <= 57:
            mantissa = mantissa * 10 + c - 48
            digits += 1
            if dot:
                decimals += 1
        elif c == 46 and not dot:
            dot = True
        else:
            break
        p += 1
    if digits == 0 or digits > _DIGITS:
        return 0.0, -1
    scale = 1.0
    for _ in range(decimals):
        scale *= 10.0                                   # exact up to 1e22
    value = float(mantissa) / scale
    return (-value if negative else value), p


@kernel
def scan_plain(buf, starts, stops, table):
    """Rows of ``table`` (G, X, Y, Z, F; NaN where a word is absent) filled from the lines
    ``buf[starts[i]:stops[i]]``; the number of lines read, up to the first that is not plain."""
    for i in range(len(starts)):
        p, end, last = int(starts[i]), int(stops[i]), -1
        for j in range(5):
            table[i, j] = math.nan
        if p >= end:
            return i
        while p < end:
            c, slot = int(buf[p]), -1
            for j in range(5):
                if c == _LETTERS[j]:
                    slot = j
            if slot <= last:                            # another letter, or out of order
                return i
            last = slot
            p += 1
            if slot == 0:                               # G0 G1 G00 G01
                if p + 1 < end and buf[p] == 48 and (buf[p + 1] == 48 or buf[p + 1] == 49):
                    p += 1
                if p < end and (buf[p] == 48 or buf[p] == 49):
                    table[i, 0] = float(int(buf[p]) - 48)
                    p += 1
                else:
                    return i
            else:
                value, p = _number(buf, p, end)
                if p < 0:
                    return i
                table[i, slot] = value
            if slot < 4 and p < end and buf[p] == 32:
                p += 1
    return len(starts)


def plain_table(text: str, starts, stops, first: int, last: int, read_by_pattern):
    """The (G, X, Y, Z, F) table of the plain lines ``first..last-1`` (indexes into ``starts`` /
    ``stops``, offsets into the ASCII ``text``), up to the first other line; ``read_by_pattern()``
    where kernels do not run compiled. The lines are scanned in pieces growing from
    :data:`FIRST_PIECE` lines, so a short run copies little of the text."""
    if last - first < 2 or not _scanner_ready(len(starts)):
        return read_by_pattern()
    kind = np.int32 if starts.typecode == "i" else np.int64
    table = np.empty((last - first, 5))
    done, size = first, FIRST_PIECE
    while done < last:
        end = min(done + size, last)
        begin = starts[done]
        buf = np.frombuffer(text[begin:stops[end - 1]].encode("ascii"), np.uint8)
        lo = np.frombuffer(starts, kind, end - done, done * starts.itemsize) - begin
        hi = np.frombuffer(stops, kind, end - done, done * stops.itemsize) - begin
        rows = scan_plain(buf, lo, hi, table[done - first:end - first])
        done += rows
        if done < end:
            break
        size *= 4
    return table[:done - first]


def _scanner_ready(work: int) -> bool:
    """Whether the scanner runs compiled without loading Numba for it: an ahead-of-time module
    built before the scanner was (``retrofit kernels`` not run again) leaves the pattern to it."""
    if not compiled(work):
        return False
    current = scan_plain                    # the compiled stand-in, once kernels run compiled
    return hasattr(current, "signatures") or bool(getattr(current, "exports", True))
