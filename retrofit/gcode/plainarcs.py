"""The G2/G3 lines of a run of plain CAM lines: each arc checked and cut into chords inside the run.

CAM output puts an arc (``G2 X.. Y.. I.. J.. F..``) every few dozen lines; were each to end the run
of plain lines (:mod:`retrofit.gcode.plainrun`) the run would restart after it, and a run's set-up
costs as much as dozens of its lines. :func:`arc_words` says whether a line is such an arc: only
letters and numbers, one G2 or G3, axis words, I, J, K, R, P and F, each at most once, at least
one axis word. :func:`arc_chords` then does what the full translator does with it
(``Translator.run``'s checks of the words, ``arcmove.arc_centre`` and ``arcmove.arc_move``, the
canon's chords), by those very functions, and gives the canonical arc; a broken rule is a
RuleError, and the run stops before that line so that the full translator words it.
"""

from __future__ import annotations

from . import arcmove
from .blocks import MAX_VALUE, make_block
from .validate import check_word_use

#: the letters an arc line of a run may hold
_ARC_LETTERS = frozenset("GXYZIJKRPF")
_AXES = "XYZ"


def arc_words(line) -> list | None:
    """The words of ``line`` (a lexed line) when it is a plain G2/G3 line a run may take (see the
    module doc), else None."""
    if line is None or not line.plain or not line.words or line.assigns or line.oword \
            or line.messages or line.dollar or line.percent or line.error:
        return None
    seen = set()
    motion = None
    for letter, value in line.words:
        if letter not in _ARC_LETTERS or letter in seen or not -MAX_VALUE <= value <= MAX_VALUE:
            return None
        seen.add(letter)
        if letter == "G":
            if value not in (2.0, 3.0):
                return None
            motion = value
    if motion is None or seen.isdisjoint(_AXES) or ("F" in seen and line_feed(line.words) < 0.0):
        return None
    return line.words


def line_feed(words) -> float:
    """The F of an arc line's words (NaN: none)."""
    return next((value for letter, value in words if letter == "F"), float("nan"))


def arc_row(words) -> list[float]:
    """The run's table row (G, X, Y, Z, F; NaN: absent) of an arc line's words."""
    given = dict(words)
    return [given["G"]] + [given.get(letter, float("nan")) for letter in "XYZF"]


def arc_call(tr, number: int, words, start: dict, end: dict):
    """The canonical arc (``ArcFeed``) of line ``number`` with ``words`` from ``start`` to ``end``
    (every axis, machine mm); a RuleError (or ValueError) where the full translator refuses the
    line. Its chords: ``tr.canon.chord_ends_of``."""
    s = tr.state
    block = make_block(number, words, tr.machine)
    mode = int(block.motion or 0)                 # 2 or 3 (arc_words)
    check_word_use(block, mode)
    before = s.position
    s.position = start
    try:
        centre, extra_turns = arcmove.arc_centre(tr, block, mode, end)
        calls: list = []
        arcmove.arc_move(tr, start, end, centre, mode, extra_turns, emit=calls.append)
    finally:
        s.position = before
    arc, = calls
    return arc
