"""The canonical machining calls: what an interpreter asks of the machine, one record per call.

Positions are tuples over the machine's axes in its order (``Machine.axis_names``), machine
coordinates, mm (degrees on a rotary axis), already rounded by the interpreter; every offset,
unit and mode has been applied before a call is made. The names follow LinuxCNC's canon
interface where it has one (``STRAIGHT_TRAVERSE``, ``ARC_FEED``, ``DWELL``...).
"""

from __future__ import annotations

from dataclasses import dataclass

#: a point in machine coordinates: one float per machine axis, in the machine's order
Position = tuple[float, ...]


@dataclass(frozen=True, slots=True)
class StraightTraverse:
    """A rapid move (G0) to ``end``."""

    end: Position


@dataclass(frozen=True, slots=True)
class StraightFeed:
    """A move at the feed rate in force (G1, and the pieces of a spline or a cycle) to ``end``."""

    end: Position


@dataclass(frozen=True, slots=True)
class ArcFeed:
    """A helix or arc (G2/G3) at the feed rate in force, from ``start`` to ``end`` around
    ``centre`` in the plane of axes ``plane`` (first, second index; counter-clockwise is from the
    first towards the second), ``extra_turns`` whole turns beyond the first.

    ``centre`` holds the plane's two coordinates; its other entries are 0. Axes off the plane
    move in proportion (a helix).
    """

    start: Position
    end: Position
    centre: Position
    plane: tuple[int, int]
    clockwise: bool
    extra_turns: int = 0


@dataclass(frozen=True, slots=True)
class StraightProbe:
    """A probing move (G38.x) as the machine ran it: a feed to ``end``, where it stopped."""

    end: Position


@dataclass(frozen=True, slots=True)
class SetFeedRate:
    """The feed of the moves that follow: mm/min, or mm per spindle turn while synchronised."""

    mm_min: float


@dataclass(frozen=True, slots=True)
class StartFeedSync:
    """The moves that follow are driven by the spindle's encoder (G33, G76, G33.1)."""


@dataclass(frozen=True, slots=True)
class StopFeedSync:
    """Back to the clock after a synchronised chain."""


@dataclass(frozen=True, slots=True)
class Dwell:
    """Stand still for ``seconds`` (G4; 0 under G61: an exact stop between blocks)."""

    seconds: float


@dataclass(frozen=True, slots=True)
class Spindle:
    """The spindle at ``rpm``, ``direction`` +1 (M3), -1 (M4) or 0 (stopped)."""

    rpm: float
    direction: int


@dataclass(frozen=True, slots=True)
class Coolant:
    """Coolant mist (7), flood (8) or off (0)."""

    code: int


@dataclass(frozen=True, slots=True)
class ChangeTool:
    """Put tool ``tool`` in the spindle (M6)."""

    tool: int


@dataclass(frozen=True, slots=True)
class DigitalOut:
    """Spare output ``number`` on (M62, M64) or off (M63, M65) by ``code``."""

    code: int
    number: int


@dataclass(frozen=True, slots=True)
class WaitInput:
    """Wait on spare input ``number`` (M66): ``mode`` 0..4 as L, at most ``timeout_s``."""

    number: int
    mode: int
    timeout_s: float


@dataclass(frozen=True, slots=True)
class Pause:
    """The program stops until the operator goes on: M0 (0), M1 (1), M60 (60), or a canned
    cycle's hand retract (19)."""

    code: int


@dataclass(frozen=True, slots=True)
class ZeroAxes:
    """Home ``axes`` (every axis when empty): G28 with no stored position, grbl's ``$H``."""

    axes: tuple[str, ...] = ()


#: any canonical call
Call = (StraightTraverse | StraightFeed | ArcFeed | StraightProbe | SetFeedRate | StartFeedSync
        | StopFeedSync | Dwell | Spindle | Coolant | ChangeTool | DigitalOut | WaitInput | Pause
        | ZeroAxes)
#: the calls that move the tool along a path
MOVES = (StraightTraverse, StraightFeed, ArcFeed, StraightProbe)
