"""G2/G3 as one canonical arc: its centre from the words, its checks, its feed, then the call.

The arc goes through the seam whole (:class:`retrofit.canon.ArcFeed`) and is cut into chords
after it, except under G96, where the spindle speed follows the tool chord by chord: there the
chords are asked of the canon (:meth:`~retrofit.canon.CommandCanon.chord_points`) and each goes
out as a straight feed after its speed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..canon import ArcFeed, StraightFeed
from ..motion.arcs import arc_extent
from . import coords, spindle
from .arcwords import arc_center, plane_axes
from .errors import RuleError
from .state import DECIMALS, clean_mm
from .validate import check_arc

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..canon import Call
    from .blocks import Block
    from .translate import Translator


def arc(tr: Translator, block: Block, mode: int, end: dict[str, float]) -> None:
    """The G2/G3 of ``block`` from where the tool is to ``end`` (machine mm)."""
    center, extra_turns = arc_centre(tr, block, mode, end)
    arc_move(tr, tr.state.position, end, center, mode, extra_turns)
    tr.state.position = end


def arc_centre(tr: Translator, block: Block, mode: int,
               end: dict[str, float]) -> tuple[tuple[float, float], int]:
    """The centre (plane coordinates, mm) of a G2/G3 from the current position to ``end``
    and its whole turns beyond the first (P)."""
    s = tr.state
    first, second = plane_axes(tr.machine, s.plane, mode)
    start = s.position
    words = {c: s.to_mm(block.values[c]) for c in "IJKR" if c in block.values}
    if not s.arc_incremental:
        words = coords.absolute_centre_words(tr, words)
    turns = block.values.get("P", 1.0)
    if turns < 1 or turns != int(turns) or turns > 1000:
        raise RuleError(f"{block.texts['P']}: the number of turns of an arc is a whole number "
                        f"from 1 to 1000")
    center = arc_center(mode, s.plane, (start[first], start[second]), (end[first], end[second]),
                        words, block.texts, s.inch)
    return center, int(turns) - 1


def arc_move(tr: Translator, start: dict[str, float], end: dict[str, float], center,
             mode: int, extra_turns: int, emit: Callable[[Call], None] | None = None) -> None:
    """A G2 (``mode`` 2) or G3 arc around ``center`` (plane coordinates), after its feed;
    ``emit`` takes the calls (default: in program order, the feed first)."""
    first, second = plane_axes(tr.machine, tr.state.plane, mode)
    names = tr.names
    plane = (names.index(first), names.index(second))
    center_all = [0.0] * len(names)
    center_all[plane[0]], center_all[plane[1]] = center
    call = ArcFeed(tr.position_of(start), tr.position_of(end), tuple(center_all), plane,
                   mode == 2, extra_turns)
    try:
        extent = arc_extent(call.start, call.end, call.centre, call.clockwise, plane,
                            tr.machine.motion.arc_tolerance_mm, extra_turns)
    except ValueError:
        raise RuleError(f"G{mode}: the arc's centre or radius is not a finite number") from None
    length = check_arc(tr.machine, mode, *extent)
    if emit is None:
        tr.send_feed(length, mode)
        emit = tr.emit
    if tr.state.css is None:
        emit(call)
    else:
        _css_arc(tr, call, length, mode, emit)


def _css_arc(tr: Translator, call: ArcFeed, length: float, mode: int,
             emit: Callable[[Call], None]) -> None:
    """Under G96 the spindle speed follows the tool chord by chord: the arc's chords, each
    after its speed (and its feed under G95)."""
    s = tr.state
    x = tr.names.index("X")
    words = [clean_mm(v) for v in call.start]
    moving = [i for i in range(len(words)) if i in call.plane or call.start[i] != call.end[i]]
    for p in tr.canon.chord_points(call).tolist():
        spindle.follow(tr, p[x])
        if s.per_rev:
            tr.send_feed(length, mode)
        for i in moving:
            words[i] = round(p[i], DECIMALS) + 0.0                       # clean_mm, inlined
        emit(StraightFeed(tuple(words)))
