"""After the seam: canonical calls as commands of the instruction set, an arc as its chords.

One call makes one command (a feed rate a PFDR, a dwell a DELY, a spindle call a SPIN...), except
an arc, which becomes one PMOV per chord: chords no longer than the machine's arc tolerance lets
them be (:func:`retrofit.motion.arcs.arc_columns`), each end point rounded to 1 pm, an axis off
the plane that does not move written as it stood.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
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
from ..motion.arcs import arc_columns
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

    def chords(self, arc: ArcFeed) -> list[Command]:
        """One PMOV per chord of ``arc``."""
        points = self.chord_points(arc)
        moving = [i for i in range(len(self.names))
                  if i in arc.plane or arc.start[i] != arc.end[i]]
        columns: list[Iterator[tuple[str, float]]] = [itertools.repeat((n, clean_mm(v))) for n, v in zip(self.names, arc.start)]
        for i in moving:
            columns[i] = zip(itertools.repeat(self.names[i]), clean_mm_list(points[:, i]))
        return list(map(PMov, zip(*columns)))
