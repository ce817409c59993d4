"""Feeds above the machine's fastest: run at the fastest, with one warning, as LinuxCNC does.

LinuxCNC plans every move within the machine's velocity limits, so ``F2.25e6`` on a mill whose
axes reach 6 m/min cuts at 6 m/min. retrofit does the same: an F (mm/min, after G20) above the
fastest linear axis's ``max_velocity_mm_s`` is taken as that speed, and the program's messages
get one ``WARNING`` line, at the first F that was lowered, saying so (later ones are lowered
silently). Rotary axes (degrees) do not count towards the ceiling.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .translate import Translator


def ceiling_mm_min(machine) -> float:
    """The fastest feed of ``machine`` (mm/min): its fastest linear axis."""
    linear = [a.max_velocity_mm_s for a in machine.axes if not a.rotary] or \
             [a.max_velocity_mm_s for a in machine.axes]
    return max(linear) * 60.0


def capped(tr: Translator, feed_mm_min: float, written: float) -> float:
    """``feed_mm_min`` within the machine's ceiling; warns once per program."""
    top = tr.feed_ceiling
    if top is None:
        top = tr.feed_ceiling = ceiling_mm_min(tr.machine)
    if feed_mm_min <= top:
        return feed_mm_min
    if not tr.feed_warned:
        tr.feed_warned = True
        line, file = tr.where
        tr.messages.append((file or "", line, "WARNING",
                            f"F{written:g} is above machine {tr.machine.name}'s fastest feed "
                            f"{top:g} mm/min: feeds run at {top:g} mm/min (said once)"))
    return top
