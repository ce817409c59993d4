"""A run of plain CAM lines translated at once: the lines read by one pattern, the targets by arrays.

CAM output is mostly long runs of lines like ``G1 X12.345 Y6.789 Z-1.2 F900`` or
``X12.3 Y4.5``. :func:`take_run` reads as many such lines as follow (up to :data:`RUN_LINES`) with
one pattern in its canonical form (upper case; an optional ``G0`` / ``G1``, then X, Y, Z, F in
that order, each at most once, single spaces), works out every target as
:mod:`retrofit.gcode.plainline` would line by line (the same roundings, by
``state.clean_mm_list``, float for float), checks them against the soft limits at once, and
appends the FMOV / PFDR / PMOV with each line's number. It takes nothing (0 lines) when the state
is not plain (``plainline``'s conditions), under G91, or when any line of the run would need a
word the full translator says (a value out of range, a target outside the limits, a feed of 0):
the lines then run one by one and the refusal comes from there, with its line. A rotary axis
or a feed above the machine's fastest (lowered, with a warning) is left to them too.
"""

from __future__ import annotations

import re
from itertools import repeat

import numpy as np

from ..commands import FMov, PFdr, PMov
from .blocks import MAX_VALUE
from .feedcap import ceiling_mm_min
from .plainscan import plain_table
from .state import MM_PER_INCH, clean_mm_list
from .validate import _limits

#: the most lines taken in one run
RUN_LINES = 512
_NUM = r"([-+]?(?:\d+\.?\d*|\.\d+))"
_LINE = re.compile(rf"(?:G0?([01]) ?)?(?:X{_NUM} ?)?(?:Y{_NUM} ?)?(?:Z{_NUM} ?)?(?:F{_NUM})?")
_AXES = "XYZ"
_RUN_WORDS = "GXYZF"


def take_run(tr, lines, pc: int, file: str) -> int:
    """Translate the plain lines of ``lines`` (a ``LazyLines``) from index ``pc``; the number of
    lines taken (0: none, run them one by one)."""
    s = tr.state
    if (tr.comp.on or tr.comp.straight_next or tr.indexing or s.pending or s.exact_stop or s.incremental
            or s.css is not None or s.inverse_time or s.per_rev or (tr.comp.geometry is not None
                                                                   and tr.comp.geometry.queue)):
        return 0
    if any(letter not in _RUN_WORDS or (letter == "G" and value not in (0.0, 1.0))
           for letter, value in lines[pc].words):
        return 0                                  # (an arc, a tool change...: line by line)
    table = _table(lines, pc)                     # G, X, Y, Z, F
    if len(table) < 2:
        return 0
    names = tr.names
    k = len(table)
    axes = [_AXES[j] for j in range(3) if not np.isnan(table[:, 1 + j]).all()]
    if any(a not in names or a in s.rotary for a in axes) or (np.abs(table) > MAX_VALUE).any():
        return 0
    feeds = table[:, 4]
    if (feeds < 0.0).any():
        return 0
    modes = _filled(table[:, 0], -1.0 if s.motion is None else float(s.motion))
    if not ((modes == 0.0) | (modes == 1.0)).all():
        return 0
    scale = MM_PER_INCH if s.inch else 1.0
    given = ~np.isnan(feeds)
    feed_mm = feeds.copy()
    if given.any():
        feed_mm[given] = clean_mm_list(feeds[given] * scale)
        if (feed_mm[given] > ceiling_mm_min(tr.machine)).any():
            return 0                                  # lowered, with a warning: line by line
    feed_mm = _filled(feed_mm, s.feed_mm_min)
    ends = {n: np.full(k, s.position[n]) for n in names}
    moving = np.zeros(k, np.bool_)
    for a in axes:
        col = table[:, 1 + _AXES.index(a)]
        present = ~np.isnan(col)
        mm = col[present] * scale
        if s.diameter and a == "X":
            mm = mm / 2.0
        ends[a] = col.copy()
        ends[a][present] = clean_mm_list(mm + s.offset(a))
        ends[a] = _filled(ends[a], s.position[a])
        moving |= present
    for name, low, high in _limits(tr.machine):
        if name in ends and not ((low <= ends[name]) & (ends[name] <= high)).all():
            return 0
    if ((modes == 1.0) & moving & ~(feed_mm > 0.0)).any():
        return 0
    _emit(tr, lines, pc, file, modes, feed_mm, ends, moving)
    if not np.isnan(table[:, 0]).all():
        s.motion_given, s.cycle_start, s.nurbs = True, None, None
    s.motion, s.feed_mm_min = int(modes[-1]), float(feed_mm[-1])
    return k


def _table(lines, pc: int) -> np.ndarray:
    """The words (G, X, Y, Z, F; NaN: absent) of the plain lines from ``pc``, up to the first
    other line: by the compiled scanner (:mod:`.plainscan`) or the pattern, one table."""
    text = lines.text
    if text is None:
        return np.empty((0, 5))
    last = min(pc + RUN_LINES, len(lines))
    return plain_table(text, lines.starts, lines.stops, pc, last, lambda: _read(lines, pc, last))


def _read(lines, pc: int, last: int) -> np.ndarray:
    """:func:`_table` by the pattern, line by line."""
    text, starts, stops = lines.text, lines.starts, lines.stops
    out = []
    match = _LINE.fullmatch
    for i in range(pc, last):
        m = match(text, starts[i], stops[i])
        if m is None or m.end() == m.start():
            break
        out.append([np.nan if word is None else float(word) for word in m.groups()])
    return np.array(out, np.float64).reshape(len(out), 5)


def _filled(values: np.ndarray, before: float) -> np.ndarray:
    """``values`` with each NaN replaced by the last value before it (``before`` at the start)."""
    given = ~np.isnan(values)
    index = np.where(given, np.arange(len(values)), -1)
    np.maximum.accumulate(index, out=index)
    return np.where(index >= 0, values[np.maximum(index, 0)], before)


def _emit(tr, lines, pc: int, file: str, modes, feed_mm, ends, moving) -> None:
    """The run's commands, in order, with their lines; the state's position and feed sent.

    The moves are made a column at a time (one PMOV per moving line, FMOV under G0); a PFDR goes
    before a feed move whose feed differs from the last one sent, as line by line."""
    s, names, k = tr.state, tr.names, len(modes)
    at = np.flatnonzero(moving)
    kind = np.int32 if lines.numbers.typecode == "i" else np.int64
    numbers = np.frombuffer(lines.numbers, kind, k, pc * lines.numbers.itemsize)
    at_lines = numbers[at].tolist()
    axes = list(zip(*[zip(repeat(n), ends[n][at].tolist()) for n in names]))
    moves: list[FMov | PMov] = list(map(PMov, axes))
    feeding = modes[at] == 1.0
    for j in np.flatnonzero(~feeding).tolist():
        moves[j] = FMov(axes[j])
    fed = np.flatnonzero(feeding)
    feeds = feed_mm[at][fed]
    before = np.concatenate(([np.nan if s.feed_sent is None else s.feed_sent], feeds[:-1]))
    changed = feeds != before
    done = 0
    for j, feed in zip(fed[changed].tolist(), feeds[changed].tolist()):
        tr.commands.extend(moves[done:j])
        tr.lines.extend(at_lines[done:j])
        tr.commands.append(PFdr(feed))
        tr.lines.append(at_lines[j])
        done = j
    tr.commands.extend(moves[done:])
    tr.lines.extend(at_lines[done:])
    tr.files.extend([file] * (len(moves) + int(changed.sum())))
    if len(feeds):
        s.feed_sent = float(feeds[-1])
    end = dict(s.position)
    end.update((n, float(ends[n][-1])) for n in names)
    s.position = end
    tr._line, tr._file = int(numbers[-1]), file
