"""A run of plain CAM lines translated at once: the lines read by one pattern, the targets by arrays.

CAM output is mostly long runs of lines like ``G1 X12.345 Y6.789 Z-1.2 F900`` or
``X12.3 Y4.5``, an arc now and then. :func:`take_run` reads as many such lines as follow (up to
:data:`RUN_LINES`) with one pattern in its canonical form (upper case; an optional ``G0`` /
``G1``, then X, Y, Z, F in that order, each at most once, single spaces), passing over comment
lines and taking plain G2/G3 lines with them (:mod:`retrofit.gcode.plainarcs`), works out every
target as :mod:`retrofit.gcode.plainline` would line by line (the same roundings, by
``state.clean_mm_list``, float for float), checks them against the soft limits at once, and
appends the FMOV / PFDR / PMOV and each arc's chords, with each line's number, as one block of
arrays (:class:`retrofit.canon.moves.Moves`). It takes nothing (0 lines) when the state is not
plain (``plainline``'s conditions) or under G91; when a line of the run would need a word the
full translator says (a value out of range, a target outside the limits, a feed of 0, an arc's
centre or radius) the run stops before it, and the line runs the full way, which refuses it with
its line. A rotary axis or a feed above the machine's fastest (lowered, with a warning) is left
to the full way too.
"""

from __future__ import annotations

import re

import numpy as np

from ..canon.moves import FMOV, PFDR, PMOV, Moves
from .blocks import MAX_VALUE
from .errors import RuleError
from .feedcap import ceiling_mm_min
from .plainarcs import arc_call, arc_row, arc_words
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
           for letter, value in lines[pc].words) and arc_words(lines[pc]) is None:
        return 0                                  # (a tool change...: line by line)
    table, rows, arcs = _gathered(lines, pc)      # G, X, Y, Z, F; the line of each row
    if len(table) < 2:
        return 0
    names, k = tr.names, len(table)
    bad = np.zeros(k, np.bool_)                   # rows the full translator must run (and word)
    for j, a in enumerate(_AXES):
        if a not in names or a in s.rotary:
            bad |= ~np.isnan(table[:, 1 + j])
    bad |= (np.abs(table) > MAX_VALUE).any(axis=1)
    feeds = table[:, 4]
    bad |= feeds < 0.0
    modes = _filled(table[:, 0], -1.0 if s.motion is None else float(s.motion))
    is_arc = np.zeros(k, np.bool_)
    is_arc[list(arcs)] = True
    bad |= ~((modes == 0.0) | (modes == 1.0) | is_arc)
    scale = MM_PER_INCH if s.inch else 1.0
    given = ~np.isnan(feeds)
    feed_mm = feeds.copy()
    if given.any():
        feed_mm[given] = clean_mm_list(feeds[given] * scale)
        bad |= feed_mm > ceiling_mm_min(tr.machine)   # lowered, with a warning: line by line
    feed_mm = _filled(feed_mm, s.feed_mm_min)
    ends = np.empty((k, len(names)))
    moving = np.zeros(k, np.bool_)
    for i, n in enumerate(names):
        col = table[:, 1 + _AXES.index(n)] if n in _AXES and n not in s.rotary else np.full(k, np.nan)
        present = ~np.isnan(col)
        target = col.copy()
        if present.any():
            mm = col[present] * scale
            if s.diameter and n == "X":
                mm = mm / 2.0
            target[present] = clean_mm_list(mm + s.offset(n))
        ends[:, i] = _filled(target, s.position[n])
        moving |= present
    for name, low, high in _limits(tr.machine):
        if name in names:
            at = ends[:, names.index(name)]
            bad |= ~((low <= at) & (at <= high))
    bad |= (modes != 0.0) & moving & ~(feed_mm > 0.0)
    cut = int(np.argmax(bad)) if bad.any() else k
    chords = _arcs(tr, lines, rows, arcs, ends, cut)
    cut = min(cut, *[r for r, c in chords.items() if c is None], k)
    if cut == 0:
        return 0
    _emit(tr, lines, rows[:cut], file, modes[:cut], feed_mm[:cut], ends[:cut], moving[:cut], chords)
    if not np.isnan(table[:cut, 0]).all():
        s.motion_given, s.cycle_start, s.nurbs = True, None, None
    s.motion, s.feed_mm_min = int(modes[cut - 1]), float(feed_mm[cut - 1])
    return int(rows[cut - 1]) + 1 - pc


def _gathered(lines, pc: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """(table, row -> line index, row -> arc words) of the plain and arc lines from ``pc``, up to
    :data:`RUN_LINES` lines or the first other line; comment lines are passed over, as the
    interpreter passes over them."""
    text = lines.text
    if text is None:
        return np.empty((0, 5)), np.empty(0, np.int64), {}
    last = min(pc + RUN_LINES, len(lines))
    parts, rows, arcs, at, count, scan = [], [], {}, pc, 0, True
    while at < last:
        part = _table(lines, at, last) if scan else ()
        scan = True
        if len(part):
            parts.append(part)
            rows.append(np.arange(at, at + len(part)))
            at, count, scan = at + len(part), count + len(part), False    # the scanner stopped there
            continue
        line = lines[at]
        if line is None or (line.plain and not line.words):     # a comment or spaces only
            at += 1
            continue
        words = arc_words(line)
        if words is None:
            break
        arcs[count] = words
        parts.append(np.array([arc_row(words)]))
        rows.append(np.array([at]))
        at, count = at + 1, count + 1
    if not parts:
        return np.empty((0, 5)), np.empty(0, np.int64), {}
    return np.concatenate(parts), np.concatenate(rows), arcs


def _arcs(tr, lines, rows, arcs: dict, ends: np.ndarray, cut: int) -> dict:
    """row -> chord ends of each arc row before ``cut``, in order, up to the first the full
    translator refuses (None there)."""
    names, calls = tr.names, {}
    for r in sorted(arcs):
        if r >= cut:
            break
        start = dict(tr.state.position) if r == 0 else dict(zip(names, ends[r - 1].tolist()))
        end = dict(zip(names, ends[r].tolist()))
        try:
            calls[r] = arc_call(tr, lines.numbers[int(rows[r])], arcs[r], start, end)
        except (RuleError, ValueError):
            calls[r] = None
            break
    made = [r for r, call in calls.items() if call is not None]
    out: dict = dict(zip(made, tr.canon.chord_ends_of([calls[r] for r in made]))) if made else {}
    out.update((r, None) for r, call in calls.items() if call is None)
    return out


def _table(lines, pc: int, last: int | None = None) -> np.ndarray:
    """The words (G, X, Y, Z, F; NaN: absent) of the plain lines from ``pc``, up to the first
    other line (or ``last``): by the compiled scanner (:mod:`.plainscan`) or the pattern."""
    last = min(pc + RUN_LINES, len(lines)) if last is None else last
    return plain_table(lines.text, lines.starts, lines.stops, pc, last, lambda: _read(lines, pc, last))


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


def _emit(tr, lines, rows, file: str, modes, feed_mm, ends, moving, chords: dict) -> None:
    """The run's commands, in order, with their lines, as one block of arrays; the state's
    position and feed sent.

    One FMOV (G0) or PMOV (G1) per moving line, an arc's chords (one PMOV each) for an arc line;
    a PFDR goes before a feed move whose feed differs from the last one sent, as line by line."""
    s, names = tr.state, tr.names
    at = np.flatnonzero(moving)
    numbers = np.frombuffer(lines.numbers, np.int32 if lines.numbers.typecode == "i" else np.int64)[rows]
    feeding = modes[at] != 0.0
    fed = np.flatnonzero(feeding)
    feeds = feed_mm[at][fed]
    before = np.concatenate(([np.nan if s.feed_sent is None else s.feed_sent], feeds[:-1]))
    changed = np.zeros(len(at), np.bool_)
    changed[fed] = feeds != before
    sizes = np.ones(len(at), np.int64)             # commands of each move: 1, or its chords
    arc_at = [j for j, r in enumerate(at.tolist()) if r in chords]
    for j in arc_at:
        sizes[j] = len(chords[int(at[j])])
    firsts = np.cumsum(sizes + changed) - sizes    # where each move's first command goes
    total = int(firsts[-1] + sizes[-1]) if len(at) else 0
    values = np.empty((total, len(names)))
    kinds = np.full(total, PMOV, np.int8)
    straight = np.ones(len(at), np.bool_)
    straight[arc_at] = False
    values[firsts[straight]] = ends[at[straight]]
    kinds[firsts[straight & ~feeding]] = FMOV
    for j in arc_at:
        values[firsts[j]:firsts[j] + sizes[j]] = chords[int(at[j])]
    pfdr = firsts[changed] - 1
    kinds[pfdr] = PFDR
    values[pfdr] = 0.0
    values[pfdr, 0] = feed_mm[at[changed]]
    tr.commands.add_block(Moves(names, kinds, values))
    tr.lines.extend(np.repeat(numbers[at], sizes + changed).tolist())
    tr.files.extend([file] * total)
    if len(feeds):
        s.feed_sent = float(feeds[-1])
    s.position = dict(zip(names, ends[-1].tolist()))
    tr._line, tr._file = int(numbers[-1]), file
