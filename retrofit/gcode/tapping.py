"""G33.1 rigid tapping: the tap in and out along one helix, the carriage following the encoder.

``G33.1 X- Y- Z- K- <I->`` taps from the current position to the end point, ``K`` mm along the
move per spindle revolution, and comes back: the spindle reverses at the bottom and the tap runs
out along the same helix to where it started (LinuxCNC's ``RIGID_TAP``; the position after the
block is its start). ``I`` multiplies the spindle speed of the way out (LinuxCNC 2.9), 1 when not
given. The commands: ``ISTP``, ``PFDR F<K>``, ``PMOV`` to the bottom, ``SPIN`` reversed, ``PMOV``
back to the start, ``SPIN`` as before, ``CSTP``. The controller turns the spindle round in time
for each end (see :mod:`retrofit.controller.turnaround`), so the tap stops at the programmed depth
and at its start.

Only a spindle that reverses on command, with an encoder that counts both ways, can do this
(``reverse_rpm_s`` in ``[spindle]``); on any other machine G33.1 is refused with the reason.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..canon import SetFeedRate, Spindle, StartFeedSync, StopFeedSync, StraightFeed
from ..motion.indexer import PLAN_SHARE, lead_in_mm, stopping_revs
from .errors import RuleError
from .threading import _path, check_synchronised, leave, spindle_turning
from .validate import check_soft_limits

if TYPE_CHECKING:
    from .translate import Translator

WHY = ("a rigid tap follows the spindle in, through its reversal and out, so it needs a spindle that "
       "reverses on command with an encoder counting both ways ([spindle] reverse_rpm_s in the "
       "machine file); tap with G84/G74 and a floating holder")


def reversible(tr: Translator):
    """The machine's SpindleSettings when it can tap rigidly; RuleError with the reason if not."""
    spindle = tr.machine.parts.get("spindle")
    if spindle is None:
        raise RuleError(f"G33.1: machine {tr.machine.name} has no spindle encoder; {WHY}")
    if spindle.reverse_rpm_s is None:
        raise RuleError(f"G33.1: the spindle of machine {tr.machine.name} does not reverse on command "
                        f"with a two-way encoder; {WHY}")
    if tr.state.css is not None or tr.state.per_rev:
        raise RuleError("G33.1 under G96/G95: a tap needs a steady spindle speed and its own pitch; "
                        "G97 S<rpm> and G94 first")
    return spindle


def _check_room(tr: Translator, spindle, start: dict, end: dict, pitch: float, scale: float) -> None:
    """Each way within the axes' speed; going in, room for the lead-in and the spindle's stop at
    the bottom; coming out, room for its stop at the top (at up to ``speed_tolerance`` fast)."""
    s = tr.state
    check_synchronised(tr, "G33.1", start, end, pitch, first=True)
    rpm = s.rpm
    try:
        s.rpm = rpm * scale
        check_synchronised(tr, "G33.1 (out)", end, start, pitch, first=False)
    finally:
        s.rpm = rpm
    length, _, a_max, _ = _path(tr.machine, start, end)
    fast = 1.0 + spindle.speed_tolerance
    lead = lead_in_mm(pitch, rpm * fast, a_max * spindle.sync_accel_share)
    for what, top, room in (("in", rpm * fast, length - lead), ("out", rpm * scale * fast, length)):
        stop = pitch * stopping_revs(top, spindle.reverse_rpm_s)
        if stop > room:
            raise RuleError(f"G33.1: at up to {top:.0f} rpm the spindle turns {stop:.2f} mm of the tap "
                            f"while it stops ({what}, planned at {PLAN_SHARE:.0%} of reverse_rpm_s "
                            f"{spindle.reverse_rpm_s:g}), more than the {room:.2f} mm left of the "
                            f"{length:.2f} mm tap; lower S (or I)")


def g33_1(tr: Translator, block, end: dict) -> None:
    """One rigid tap from the current position to ``end`` (mm) and back."""
    spindle = reversible(tr)
    if "K" not in block.values:
        raise RuleError("G33.1 needs K, the distance along the tap per spindle revolution "
                        "(e.g. G33.1 Z-10 K1.5)")
    pitch = tr.state.to_mm(block.values["K"])
    if not pitch > 0.0:
        raise RuleError(f"{block.texts['K']}: G33.1's K must be > 0 (mm per revolution)")
    scale = block.values.get("I", 1.0)
    if not 0.0 < scale <= 10.0:
        raise RuleError(f"{block.texts['I']}: G33.1's I scales the spindle speed of the way out: "
                        f"above 0 and at most 10")
    spindle_turning(tr, "G33.1")
    if tr.comp.geometry is not None:
        raise RuleError(f"G33.1 with cutter radius compensation on (G{tr.comp.code:g}): a tap goes "
                        f"where the program puts it, not beside it; G40 first")
    s = tr.state
    start = dict(s.position)
    check_soft_limits(tr.machine, end)
    _check_room(tr, spindle, start, end, pitch, scale)
    leave(tr)
    rpm, direction = s.rpm, s.spindle
    tr.emit(StartFeedSync())
    tr.emit(SetFeedRate(pitch))
    tr.emit(StraightFeed(tr.position_of(end)))
    tr.emit(Spindle(rpm * scale, -direction))
    tr.emit(StraightFeed(tr.position_of(start)))
    tr.emit(Spindle(rpm, direction))
    tr.emit(StopFeedSync())
    s.feed_sent = None
