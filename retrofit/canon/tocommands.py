"""After the seam: canonical calls as commands of the instruction set, an arc as its chords.

One call makes one command (a feed rate a PFDR, a dwell a DELY, a spindle call a SPIN...), except
an arc, which becomes one PMOV per chord: chords no longer than the machine's arc tolerance lets
them be (:func:`retrofit.motion.arcs.arc_columns`), each end point rounded to 1 pm, an axis off
the plane that does not move written as it stood.
"""

from __future__ import annotations

import collections
import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from ..commands import (
    Command,
    Cool,
    CStp,
    Dely,
    Dout,
    FMov,
    IStp,
    Paus,
    PFdr,
    PMov,
    Spin,
    Tool,
    Wait,
    ZMov,
)
from ..motion.arcs import arc_columns, arcs_columns
from .calls import (
    ArcFeed,
    Call,
    ChangeTool,
    Coolant,
    DigitalOut,
    Dwell,
    Pause,
    Position,
    SetFeedRate,
    Spindle,
    StartFeedSync,
    StopFeedSync,
    StraightFeed,
    StraightProbe,
    StraightTraverse,
    WaitInput,
    ZeroAxes,
)
from .rounding import clean_mm, clean_mm_list


class CommandCanon:
    """Turns canonical calls into commands for a machine with axes ``names`` (in its order)
    and chords within ``tolerance_mm`` of an arc."""

    def __init__(self, names: tuple[str, ...], tolerance_mm: float):
        self.names = tuple(names)
        self.tolerance_mm = tolerance_mm
        self._one: dict[type, Callable[[Any], Command]] = {
            StraightTraverse: lambda c: FMov(self.words(c.end)),
            StraightFeed: lambda c: PMov(self.words(c.end)),
            StraightProbe: lambda c: PMov(self.words(c.end)),
            SetFeedRate: lambda c: PFdr(c.mm_min),
            StartFeedSync: lambda c: IStp(),
            StopFeedSync: lambda c: CStp(),
            Dwell: lambda c: Dely(c.seconds),
            Spindle: lambda c: Spin(c.rpm, c.direction),
            Coolant: lambda c: Cool(c.code),
            ChangeTool: lambda c: Tool(c.tool),
            DigitalOut: lambda c: Dout(c.code, c.number),
            WaitInput: lambda c: Wait(c.number, c.mode, c.timeout_s),
            Pause: lambda c: Paus(c.code),
            ZeroAxes: lambda c: ZMov(c.axes),
        }

    def commands(self, call: Call) -> list[Command]:
        """The commands of ``call``, in order (at least one)."""
        if type(call) is ArcFeed:
            return self.chords(call)
        return [self._one[type(call)](call)]

    def words(self, point: Position) -> tuple[tuple[str, float], ...]:
        """A position as a command's axis words."""
        return tuple(zip(self.names, point))

    def chord_points(self, arc: ArcFeed) -> np.ndarray[Any, np.dtype[np.float64]]:
        """The end points [chord, axis] (mm, not rounded) of the chords of ``arc``."""
        return arc_columns(arc.start, arc.end, arc.centre, arc.clockwise, arc.plane,
                           self.tolerance_mm, arc.extra_turns)

    def chord_ends(self, arc: ArcFeed) -> np.ndarray[Any, np.dtype[np.float64]]:
        """The end points [chord, axis] of the chords of ``arc`` as their PMOVs give them: rounded
        to 1 pm, an axis off the plane that does not move as it stood."""
        points = self.chord_points(arc)
        ends = np.empty_like(points)
        for i, value in enumerate(arc.start):
            if i in arc.plane or value != arc.end[i]:
                ends[:, i] = clean_mm_list(points[:, i])
            else:
                ends[:, i] = clean_mm(value)
        return ends

    def chord_ends_of(self, arcs: list[ArcFeed]) -> list[np.ndarray[Any, np.dtype[np.float64]]]:
        """:meth:`chord_ends` of every arc of ``arcs``, all at once (:func:`arcs_columns`): an axis
        that does not move is ``s + 0·f``, its start, whose rounding is the start's."""
        points, counts = arcs_columns([(a.start, a.end, a.centre, a.clockwise, a.plane, a.extra_turns)
                                       for a in arcs], self.tolerance_mm)
        for i in range(points.shape[1]):
            points[:, i] = clean_mm_list(points[:, i])
        return np.split(points, np.cumsum(counts)[:-1])

    def chords(self, arc: ArcFeed) -> list[Command]:
        """One PMOV per chord of ``arc``."""
        return made(PMov, self.names, self.chord_ends(arc))


def made(kind: type, names: tuple[str, ...], ends: np.ndarray[Any, np.dtype[np.float64]]) -> list[Any]:
    """``kind(axes)`` (an FMOV or a PMOV) for every row of ``ends`` [move, axis], the same objects
    the class makes one by one, without running its ``__init__`` for each (a frozen dataclass
    whose only field is ``axes``)."""
    if kind not in (FMov, PMov):
        raise TypeError(f"made() builds FMOV and PMOV only, not {kind.__name__}")
    axes = list(zip(*[zip(itertools.repeat(n), ends[:, i].tolist()) for i, n in enumerate(names)]))
    moves = list(map(object.__new__, itertools.repeat(kind, len(axes))))
    collections.deque(map(object.__setattr__, moves, itertools.repeat("axes"), axes), maxlen=0)
    return moves
