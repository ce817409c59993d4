"""M70-M73: saving the modal state and restoring it, as LinuxCNC does.

M70 saves the modal state at the current call level (the main program or a subroutine call),
M71 forgets what was saved there, M72 restores it (and keeps it for another M72), M73 saves it
and restores it by itself when the subroutine returns (``return`` or ``endsub``; M73 in the main
program only saves). A call starts with nothing saved at its level.

What is saved is what LinuxCNC saves: units (G20/G21), plane, distance and arc distance modes,
feed mode, coordinate system, tool length offset on or off (G43 restores the current tool's),
retract mode, path control, spindle speed mode, lathe diameter mode, whether G92 offsets apply,
cutter compensation, F, S, the spindle's direction and the coolant. The motion mode is not
restored. Restoring runs the codes that differ from the present state as blocks on the
restoring line -- first G20/G21, then the rest -- so the moves and commands they make are those
of the codes. LinuxCNC writes F with one decimal and S with none when it restores; retrofit
restores them as they were.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .blocks import make_block
from .errors import RuleError
from .params import CS_SELECT, G92_BASE

if TYPE_CHECKING:
    from .translate import Translator

_SYSTEMS = (54, 55, 56, 57, 58, 59, 59.1, 59.2, 59.3)


def snapshot(tr: Translator) -> dict:
    """The modal state LinuxCNC saves, as the codes (and F, S) that would set it."""
    s = tr.state
    p = s.params.numbered
    feed = s.feed_mm_min / 25.4 if s.inch and not s.inverse_time else s.feed_mm_min
    return {
        "units": 20 if s.inch else 21, "plane": s.plane, "distance": 91 if s.incremental else 90,
        "feed mode": 93 if s.inverse_time else 95 if s.per_rev else 94,
        "coordinate system": _SYSTEMS[int(p.get(CS_SELECT, 1.0)) - 1],
        "tool length": 43 if s.tool_offset else 49, "return mode": 99 if s.retract_r else 98,
        "path control": 61 if s.exact_stop else 64,
        "spindle speed mode": 96 if s.css is not None else 97,
        "arc distance": 91.1 if s.arc_incremental else 90.1, "lathe diameter": 7 if s.diameter else 8,
        "g92": bool(p.get(G92_BASE - 1, 0.0)), "cutter radius": int(tr.comp.code) if tr.comp.on else 40,
        "F": feed, "S": s.css[0] if s.css is not None else s.rpm,
        "spindle": {1: 3, -1: 4}.get(s.spindle, 5), "coolant": s.coolant or 9,
    }


def run(tr: Translator, block) -> None:
    """M70, M71, M72 or M73 in ``block`` (at the step of LinuxCNC's spindle group)."""
    code = block.m.get("spindle")
    if code not in (70, 71, 72, 73):
        return
    level = _level(tr)
    if code in (70, 73):
        tr.saved_states[level] = (snapshot(tr), code == 73 and level > 0)
    elif code == 71:
        tr.saved_states.pop(level, None)
    else:
        if level not in tr.saved_states:
            raise RuleError("M72: no modal state saved at this call level (M70 or M73 first; "
                            "M71 forgets it)")
        restore(tr, tr.saved_states[level][0], block.line)


def entered(tr: Translator) -> None:
    """A subroutine call: nothing is saved at its level yet."""
    tr.saved_states.pop(_level(tr), None)


def leaving(tr: Translator, line: int) -> None:
    """A return or endsub, after the level is left: M73's state comes back."""
    saved = tr.saved_states.pop(_level(tr) + 1, None)
    if saved is not None and saved[1]:
        restore(tr, saved[0], line)


def _level(tr: Translator) -> int:
    return len(tr.state.params.frames)


def restore(tr: Translator, saved: dict, line: int) -> None:
    """Run the codes that bring the present modal state back to ``saved``."""
    now = snapshot(tr)
    if now["units"] != saved["units"]:
        tr.run(make_block(line, [("G", float(saved["units"]))], tr.machine), tr.where[1])
    words = [("F", saved["F"]), ("S", saved["S"])]
    for group in ("plane", "cutter radius", "distance", "feed mode", "coordinate system",
                  "tool length", "return mode", "path control", "spindle speed mode",
                  "arc distance", "lathe diameter"):
        if now[group] != saved[group]:
            words.append(("G", float(saved[group])))
    if saved["g92"] and not now["g92"]:
        words.append(("G", 92.3))
    for group in ("spindle", "coolant"):
        if now[group] != saved[group]:
            words.append(("M", float(saved[group])))
    tr.run(make_block(line, words, tr.machine), tr.where[1])
