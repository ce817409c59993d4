"""The fast path of the commonest CAM line: axis words, F and G0/G1, in a plain state.

Most lines of a CAM program are ``G1 X.. Y.. Z..`` or ``X.. Y.. Z..`` (the lexer marks them
``plain``: letters and numbers only). :func:`run_plain` translates such a line straight to its
FMOV / PFDR / PMOV, the very steps of ``Translator.run`` for a plain block (``_plain``,
``_motion``, ``ModalState.target``, ``rapid`` / ``feed_line``, ``put``), without building a
``Block``. It answers None, having changed nothing, for any line or state it does not cover
(another letter, a rotary axis, a word twice, a value out of range, cutter compensation,
G91 offsets pending,
G96, G93, G95, G61, a thread chain, no motion mode yet): the full translator then runs the line
and words any refusal. The golden tests against rs274 hold both to one meaning.
"""

from __future__ import annotations

import math

from ..commands import FMov, PMov
from .blocks import MAX_VALUE
from .state import DECIMALS, MM_PER_INCH
from .validate import check_soft_limits

_G = {0.0: 0, 1.0: 1}


def run_plain(tr, words: list, line: int, file: str):
    """Translate the plain ``words`` of one line (see the module doc); False when done, None
    when the full translator must run it."""
    s = tr.state
    if (tr.comp.on or tr.comp.straight_next or tr.indexing or s.pending or s.exact_stop
            or s.css is not None or s.inverse_time or s.per_rev or (tr.comp.geometry is not None
                                                                   and tr.comp.geometry.queue)):
        return None
    names = tr.names
    axes, feed, motion = {}, None, None
    for letter, value in words:
        if not -MAX_VALUE <= value <= MAX_VALUE:
            return None
        if letter in names and letter not in axes and letter not in s.rotary:
            axes[letter] = value
        elif letter == "F" and feed is None and value >= 0.0:
            feed = value
        elif letter == "G" and motion is None and value in _G:
            motion = _G[value]
        else:
            return None
    mode = s.motion if motion is None else motion
    if mode not in (0, 1):
        return None
    tr._line, tr._file = line, file
    scale = MM_PER_INCH if s.inch else 1.0
    if feed is not None:
        tr._feed_word(feed)                      # capped at the machine's fastest, as the full way
    if motion is not None:
        s.motion, s.motion_given, s.cycle_start, s.nurbs = motion, True, None, None
    if not axes:
        return False
    end = dict(s.position)
    for name, value in axes.items():
        mm = value * scale
        if s.diameter and name == "X":
            mm /= 2.0
        if s.incremental:
            end[name] = round(end[name] + mm, DECIMALS) + 0.0
        else:
            end[name] = round(mm + s.offset(name), DECIMALS) + 0.0
    check_soft_limits(tr.machine, end)
    command: FMov | PMov
    if mode == 0:
        command = FMov(tuple([(n, end[n]) for n in names]))
    else:
        if s.feed_sent != s.feed_mm_min:
            tr._send_feed(math.dist(s.position.values(), end.values()), 1)
        command = PMov(tuple([(n, end[n]) for n in names]))
    tr.commands.append(command)
    tr.lines.append(line)
    tr.files.append(file)
    s.position = end
    return False
