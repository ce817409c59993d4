"""What the controller did during a run: the port frames, the targets and when each was reached."""

from __future__ import annotations

from dataclasses import dataclass, field

from .config import Machine
from .frames import PortFrames


@dataclass
class Waypoint:
    """A commanded position (steps per axis) and the ticks it was loaded and reached.

    ``reached_tick`` is the frame carrying the last rising step edge towards it (or the tick the
    loop found it reached, when no step was needed), so the machine has taken every step by then.
    """

    steps: tuple[int, ...]
    loaded_tick: int
    reached_tick: int | None = None


@dataclass
class RunLog:
    """The controller's side of a run; outputs and the report read it."""

    machine: Machine
    frames: PortFrames
    waypoints: list[Waypoint] = field(default_factory=list)
    steps_emitted: dict[str, int] = field(default_factory=dict)
    max_following_error_steps: int = 0
    start_steps: tuple[int, ...] = ()

    @property
    def ticks(self) -> int:
        return self.frames.end_tick

    @property
    def final_target(self) -> tuple[int, ...]:
        return self.waypoints[-1].steps if self.waypoints else self.start_steps
