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

import numpy as np

from ..commands import FMov, PFdr, PMov
from .blocks import MAX_VALUE
from .feedcap import ceiling_mm_min
from .state import MM_PER_INCH, clean_mm_list
from .validate import _limits

#: the most lines taken in one run
RUN_LINES = 512
_NUM = r"([-+]?(?:\d+\.?\d*|\.\d+))"
_LINE = re.compile(rf"(?:G0?([01]) ?)?(?:X{_NUM} ?)?(?:Y{_NUM} ?)?(?:Z{_NUM} ?)?(?:F{_NUM})?")
_AXES = "XYZ"


def take_run(tr, lines, pc: int, file: str) -> int:
    """Translate the plain lines of ``lines`` (a ``LazyLines``) from index ``pc``; the number of
    lines taken (0: none, run them one by one)."""
    s = tr.state
    if (tr.comp.on or tr.comp.straight_next or tr.indexing or s.pending or s.exact_stop or s.incremental
            or s.css is not None or s.inverse_time or s.per_rev or (tr.comp.geometry is not None
                                                                   and tr.comp.geometry.queue)):
        return 0
    words = _read(lines, pc)
    if len(words) < 2:
        return 0
    names = tr.names
    k = len(words)
    table = np.full((k, 5), np.nan)              # G, X, Y, Z, F
    for i, row in enumerate(words):
        for j, text in enumerate(row):
            if text:
                table[i, j] = float(text)
    axes = [_AXES[j] for j in range(3) if not np.isnan(table[:, 1 + j]).all()]
    if any(a not in names or a in s.rotary for a in axes) or not (np.abs(np.nan_to_num(table)) <= MAX_VALUE).all():
        return 0
    feeds = table[:, 4]
    if (feeds < 0.0).any():
        return 0
    modes = _filled(table[:, 0], -1.0 if s.motion is None else float(s.motion))
    if not np.isin(modes, (0.0, 1.0)).all():
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


def _read(lines, pc: int) -> list[tuple]:
    """The word texts (G, X, Y, Z, F) of the plain lines from ``pc``, up to the first other line."""
    text = lines.text
    if text is None:
        return []
    last = min(pc + RUN_LINES, len(lines))
    starts, stops = lines.starts, lines.stops
    out = []
    match = _LINE.fullmatch
    for i in range(pc, last):
        m = match(text, starts[i], stops[i])
        if m is None or m.end() == m.start():
            break
        out.append(m.groups())
    return out


def _filled(values: np.ndarray, before: float) -> np.ndarray:
    """``values`` with each NaN replaced by the last value before it (``before`` at the start)."""
    given = ~np.isnan(values)
    index = np.where(given, np.arange(len(values)), -1)
    np.maximum.accumulate(index, out=index)
    return np.where(index >= 0, values[np.maximum(index, 0)], before)


def _emit(tr, lines, pc: int, file: str, modes, feed_mm, ends, moving) -> None:
    """The run's commands, in order, with their lines; the state's position and feed sent."""
    s, names = tr.state, tr.names
    rows = list(zip(*(ends[n].tolist() for n in names)))
    numbers = lines.numbers
    commands, out_lines = tr.commands, tr.lines
    sent = s.feed_sent
    count = 0
    for i, (mode, feed, move) in enumerate(zip(modes.tolist(), feed_mm.tolist(), moving.tolist())):
        if not move:
            continue
        line = numbers[pc + i]
        if mode == 1.0 and sent != feed:
            commands.append(PFdr(feed))
            out_lines.append(line)
            count += 1
            sent = feed
        commands.append((PMov if mode == 1.0 else FMov)(tuple(zip(names, rows[i]))))
        out_lines.append(line)
        count += 1
    tr.files.extend([file] * count)
    s.feed_sent = sent
    last = rows[-1]
    end = dict(s.position)
    end.update(zip(names, last))
    s.position = end
    tr._line, tr._file = numbers[pc + len(rows) - 1], file
