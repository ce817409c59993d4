"""Tool changes as command sequences: the document's three conditions, step by step.

A tool change is a list of :class:`Step` — one box of the document's flow charts each, with
the commands that do it — and nothing here runs them: the same steps go to the simulator today
and to the controller later. Every step ends with ``DELY P0``, the document's M400 (wait until
every motion has finished), so no two steps blend into one another.

Geometry (``[atc]`` of the machine file; Z+ is up and Z = 0 is tul-mill's home at the top, so
Z_POINT_2 = -45 lies 4.5 mm below Z_POINT_1 = -40.5): the pockets are forks open towards
Y_POINT_A; a tool slides into or out of its fork along Y at the clamp height Z_POINT_2, and the
spindle lifts off a released tool, or comes down onto one, between Z_POINT_2 and Z_POINT_1.
Carousel position ATC_OFFSET + n brings pocket n to the spindle; the carousel is homed (ZMOV of
its axis: the planner takes it to 0, where its limit switch is) and then turned
counter-clockwise (towards +) to a pocket; homing turns it clockwise and closes the door.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..commands import Command, Dely, FMov, PFdr, PMov, ZMov
from ..errors import ToolChangeError
from .settings import AtcSettings


@dataclass(frozen=True)
class Step:
    """One box of a flow chart: what it does in words, and the commands that do it."""

    says: str
    commands: tuple[Command, ...]


@dataclass(frozen=True)
class ChangeSequence:
    """A whole tool change: from ``current`` to ``new`` (0 = empty spindle), the document's
    ``condition`` (1 pick, 2 put back then pick, 3 put back only, 0 nothing to do)."""

    current: int
    new: int
    condition: int
    steps: tuple[Step, ...]

    def commands(self) -> list[Command]:
        """Every step's commands, each step followed by ``DELY P0`` (M400)."""
        out: list[Command] = []
        for step in self.steps:
            out += list(step.commands) + [Dely(0.0)]
        return out

    def end_mm(self) -> dict[str, float]:
        """Where the axes the sequence moves stand at its end (mm, carousel units)."""
        return end_positions(self.commands())


def check_tool(atc: AtcSettings, tool, machine: str = "", what: str = "T") -> int:
    """``tool`` as a whole number in 0..pockets, or a ToolChangeError saying what is accepted."""
    on = f" on {machine}" if machine else ""
    number = tool
    if isinstance(tool, float) and tool.is_integer():
        number = int(tool)
    if isinstance(number, bool) or not isinstance(number, int):
        raise ToolChangeError(f"{what}{tool}: a tool number must be a whole number 0..{atc.pockets}")
    if not 0 <= number <= atc.pockets:
        raise ToolChangeError(f"{what}{number}: no such tool{on}; the carousel has pockets 1..{atc.pockets} "
                              f"(tool n lives in pocket n) and T0 puts the tool back, leaving the "
                              f"spindle empty")
    return number


def change_sequence(atc: AtcSettings, current: int, new: int, machine: str = "") -> ChangeSequence:
    """The steps that take the spindle from tool ``current`` to tool ``new`` (0 = none).

    Both numbers are checked first (0..pockets); selecting the tool already in the spindle gives
    an empty sequence (condition 0).
    """
    current = check_tool(atc, current, machine, "the tool in the spindle, T")
    new = check_tool(atc, new, machine)
    if new == current:
        return ChangeSequence(current, new, 0, ())
    steps: list[Step] = []
    if current:
        steps += put_back_steps(atc, current)
    if new:
        steps += pick_steps(atc, new, inside=bool(current))
    else:
        steps += leave_steps(atc)
    condition = 2 if current and new else (1 if new else 3)
    return ChangeSequence(current, new, condition, tuple(steps))


def put_back_steps(atc: AtcSettings, tool: int) -> list[Step]:
    """Deselection: the tool in the spindle goes back into its own pocket (figures 24 and 25)."""
    return [
        Step("X to X1, Y to Y_POINT_A, Z to Z_POINT_2 (rapid): in front of the magazine at the "
             "clamp height", (FMov((("X", atc.x1), ("Y", atc.y_point_a), ("Z", atc.z_point_2))),)),
        turn_to_pocket(atc, tool),
        Step(f"Y to Y_POINT_B at {atc.feed_in_mm_min:g} mm/min: T{tool} slides into pocket {tool}",
             _feed_move(atc.feed_in_mm_min, "Y", atc.y_point_b)),
        Step(f"Z to Z_POINT_1 at {atc.feed_out_mm_min:g} mm/min: the spindle lifts off, T{tool} "
             "stays in its pocket (released)", _feed_move(atc.feed_out_mm_min, "Z", atc.z_point_1)),
    ]


def pick_steps(atc: AtcSettings, tool: int, inside: bool) -> list[Step]:
    """Selection: the empty spindle takes tool ``tool`` from its pocket (figures 23 and 24).

    ``inside``: the spindle already stands at Y_POINT_B above the tools (after a put-back).
    """
    steps = []
    if not inside:
        steps.append(Step("X to X1, Y to Y_POINT_A, Z to Z_POINT_1 (rapid): in front of the "
                          "magazine, above the tools",
                          (FMov((("X", atc.x1), ("Y", atc.y_point_a), ("Z", atc.z_point_1))),)))
    steps.append(turn_to_pocket(atc, tool))
    if not inside:
        steps.append(Step(f"Y to Y_POINT_B at {atc.feed_in_mm_min:g} mm/min: above T{tool}",
                          _feed_move(atc.feed_in_mm_min, "Y", atc.y_point_b)))
    steps += [
        Step(f"Z to Z_POINT_2 at {atc.feed_clamp_mm_min:g} mm/min: down onto T{tool}, which "
             "clamps", _feed_move(atc.feed_clamp_mm_min, "Z", atc.z_point_2)),
        Step(f"Y to Y_POINT_A at {atc.feed_out_mm_min:g} mm/min: out of the magazine with T{tool}",
             _feed_move(atc.feed_out_mm_min, "Y", atc.y_point_a)),
        close_door(atc),
    ]
    return steps


def leave_steps(atc: AtcSettings) -> list[Step]:
    """After a put-back with no new tool (T0): out of the magazine, door closed (figure 25)."""
    return [Step(f"Y to Y_POINT_A at {atc.feed_out_mm_min:g} mm/min: out of the magazine, "
                 "spindle empty", _feed_move(atc.feed_out_mm_min, "Y", atc.y_point_a)),
            close_door(atc)]


def turn_to_pocket(atc: AtcSettings, pocket: int) -> Step:
    """Home the carousel (G205 P0 S0), then turn it counter-clockwise to ``pocket`` (G201 P0 X..)."""
    return Step(f"home the carousel, turn it counter-clockwise to pocket {pocket}",
                (ZMov((atc.axis,)), FMov(((atc.axis, atc.pocket_position(pocket)),))))


def close_door(atc: AtcSettings) -> Step:
    """The magazine door closes: the carousel turns clockwise home (G205 P0 S0 E0), then parks."""
    commands: tuple[Command, ...] = (ZMov((atc.axis,)),)
    if atc.atc_home:
        commands += (FMov(((atc.axis, atc.atc_home),)),)
    return Step("close the magazine door: the carousel turns clockwise home", commands)


def homing_steps(atc: AtcSettings, order: tuple[str, ...] = ("Z", "Y", "X")) -> list[Step]:
    """Home the axes one by one in ``order`` (the machine's ``[homing]`` order: Z first on the
    mill, to keep the tool clear), then the carousel."""
    names = [name for name in order if name != atc.axis] + [atc.axis]
    return [Step(f"home {name}", (ZMov((name,)),)) for name in names]


def recovery_steps(atc: AtcSettings, tool: int, machine: str = "") -> list[Step]:
    """After a lost or corrupt record: home the carousel, then T0 with the tool the operator saw."""
    tool = check_tool(atc, tool, machine, "the tool seen in the spindle, T")
    return [Step("home the carousel", (ZMov((atc.axis,)),))] + list(
        change_sequence(atc, tool, 0, machine).steps)


def end_positions(commands: list[Command]) -> dict[str, float]:
    """Axis positions (machine frame) after ``commands``, for the axes they name; ZMOV gives 0."""
    at: dict[str, float] = {}
    for cmd in commands:
        if isinstance(cmd, (FMov, PMov)):
            at.update(cmd.axes)
        elif isinstance(cmd, ZMov):
            at.update({name: 0.0 for name in cmd.names})
    return at


def _feed_move(feed: float, axis: str, mm: float) -> tuple[Command, ...]:
    return (PFdr(feed), PMov(((axis, mm),)))
