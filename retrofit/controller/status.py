"""RDST and RDPS: the controller's status word and position, as the serial link sends them."""

from __future__ import annotations

from ..link.codec import AXIS_LETTERS
from ..link.replies import Position, Status, StatusFlags
from ..machine.config import Machine

#: 002's five switches (Table II) and their bits in the status word
SWITCH_FLAGS = {
    "nlsx": StatusFlags.X_NEG_LIMIT,
    "plsx": StatusFlags.X_POS_LIMIT,
    "plsz": StatusFlags.Z_POS_LIMIT,
    "ppsx": StatusFlags.X_PRECISE,
    "ppsz": StatusFlags.Z_PRECISE,
}


def switch_flags(closed: set[str]) -> StatusFlags:
    """The status bits of the closed switches that have one (002's five)."""
    flags = StatusFlags(0)
    for name in closed:
        flags |= SWITCH_FLAGS.get(name, StatusFlags(0))
    return flags


def status_reply(state: dict, queued: int) -> Status:
    """A STAT reply from the controller's state (``state``: flag name -> bool, plus 'switches')."""
    flags = switch_flags(state.pop("switches", set()))
    for name, on in state.items():
        if on:
            flags |= StatusFlags[name]
    return Status(flags, queued)


def position_reply(machine: Machine, steps) -> Position:
    """A POS reply: steps per axis, in the link's axis order (X, Y, Z, ...)."""
    pairs = list(zip(machine.axis_names, (int(s) for s in steps)))
    pairs.sort(key=lambda p: AXIS_LETTERS.index(p[0]) if p[0] in AXIS_LETTERS else len(AXIS_LETTERS))
    return Position(tuple(pairs))
