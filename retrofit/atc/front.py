"""The host's commands of a program (TOOL, PAUS) turned into what the run executes.

A compiled program may hold ``TOOL Tn`` (T n M6) and ``PAUS Mm`` (M0, M1, M60). They never reach
a device: before planning, :func:`expand_host_commands` replaces each one.

- On a machine with a tool changer (``[atc]``), ``TOOL Tn`` becomes the 000 carousel sequence
  from the tool in the spindle to Tn (the spindle stops first), followed through the program
  from the spindle record: the tool changer is a front end emitting its commands into the run.
  The sequence's positions are the machine's; when the program has shifted its coordinates
  (PSTN: G92, G43) they are expressed in the program's. After the change the axes go back
  (one rapid move) to where the program left them, so the program goes on from where it was.
- Elsewhere ``TOOL Tn`` becomes a manual change: a pause (``PAUS M6``) for the operator; none
  when Tn is already in the spindle (T1 -> T1 is no change).
- Every pause is a :class:`HostEvent` the run records (``sim://``) or waits on (a real output).
  A ``DELY P0`` goes before it: the axes come to rest there (the planner blends no move through
  a pause), as a machine stands at M0 and as the console's run stops.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..commands import PAUSE_REASONS, Command, Dely, FMov, Paus, PMov, Pstn, Spin, Tool
from ..errors import GcodeError, ToolChangeError
from ..machine.config import Machine


@dataclass(frozen=True)
class HostEvent:
    """A tool change or a pause, where it sits in the expanded program."""

    index: int          # the first command after it (the expanded program's numbering)
    line: int | None    # line of the program
    kind: str           # "tool change" (by the changer) or "pause"
    says: str           # in words, e.g. "manual tool change (M6): put T2 in the spindle"
    tool: int | None = None      # the tool in the spindle after it


@dataclass
class Expanded:
    """A program with its host commands replaced, and what the run must know of them."""

    commands: list[Command]
    lines: list[int | None]
    events: list[HostEvent]
    start_tool: int
    end_tool: int
    file: str = "<string>"

    @property
    def changes(self) -> list[HostEvent]:
        return [e for e in self.events if e.kind == "tool change"]

    @property
    def changes_the_tool(self) -> bool:
        """Whether the run changes the tool in the spindle (by the changer or by hand)."""
        return any(e.tool is not None for e in self.events)

    @property
    def pauses(self) -> list[HostEvent]:
        return [e for e in self.events if e.kind == "pause"]


def expand_host_commands(program, machine: Machine, spindle_tool: int = 0,
                         keep_pauses: bool = False) -> Expanded:
    """Replace every TOOL and PAUS of ``program`` (commands, lines, file); see the module doc.

    ``keep_pauses``: a pause (PAUS, and TOOL of a manual change) stays in the commands as well,
    at its event's index, for a front end that asks its operator itself (the console).
    A tool number the changer cannot hold is a GcodeError naming the program's line.
    """
    atc = None
    if "atc" in machine.parts:
        from .settings import atc_of
        atc = atc_of(machine)
    out = Expanded([], [], [], spindle_tool, spindle_tool, program.file)
    commands = program.commands
    if not any(isinstance(cmd, (Tool, Paus))          # nothing to replace (a block holds moves only)
               for cmd in (commands.parts() if hasattr(commands, "parts") else commands)):
        out.commands, out.lines = commands.copy() if hasattr(commands, "parts") else list(commands), \
            list(program.lines)
        return out
    spinning = False
    frame = _Frame()
    for cmd, line in zip(program.commands, program.lines):
        frame.follow(cmd)
        if isinstance(cmd, Spin):
            spinning = cmd.direction != 0 and cmd.rpm > 0
        if isinstance(cmd, Tool) and atc is not None:
            spinning = _auto_change(out, atc, machine, cmd.number, line, spinning, frame)
        elif isinstance(cmd, Tool) and cmd.number == out.end_tool:
            continue                                  # the tool asked for is in the spindle: no change
        elif isinstance(cmd, Tool):
            says = f"{PAUSE_REASONS[6]}: put T{cmd.number} in the spindle" if cmd.number else \
                f"{PAUSE_REASONS[6]}: take the tool out of the spindle"
            _come_to_rest(out, line)
            out.events.append(HostEvent(len(out.commands), line, "pause", says, cmd.number))
            out.end_tool = cmd.number
            if keep_pauses:
                out.commands.append(cmd)
                out.lines.append(line)
        elif isinstance(cmd, Paus):
            _come_to_rest(out, line)
            out.events.append(HostEvent(len(out.commands), line, "pause",
                                        PAUSE_REASONS.get(cmd.reason, f"pause M{cmd.reason}")))
            if keep_pauses:
                out.commands.append(cmd)
                out.lines.append(line)
        else:
            out.commands.append(cmd)
            out.lines.append(line)
    return out


def _come_to_rest(out: Expanded, line) -> None:
    """The axes at rest before a pause: DELY P0 (the planner stops for a dwell)."""
    out.commands.append(Dely(0.0))
    out.lines.append(line)


class _Frame:
    """Where the program has sent each axis (program coordinates) and its offsets (machine - program)."""

    def __init__(self):
        self.at: dict[str, float] = {}
        self.offset: dict[str, float] = {}

    def follow(self, cmd: Command) -> None:
        if isinstance(cmd, Pstn):
            for axis, value in cmd.axes:
                self.offset[axis] = self.offset.get(axis, 0.0) + self.at.get(axis, 0.0) - value
                self.at[axis] = value
        elif isinstance(cmd, (FMov, PMov)):
            self.at.update(cmd.axes)

    def program(self, cmd: Command) -> Command:
        """A machine-frame move in program coordinates."""
        if isinstance(cmd, (FMov, PMov)) and any(self.offset.get(a) for a, _ in cmd.axes):
            return type(cmd)(tuple((a, round(v - self.offset.get(a, 0.0), 9)) for a, v in cmd.axes))
        return cmd


def _auto_change(out: Expanded, atc, machine: Machine, number: int, line, spinning: bool,
                 frame: _Frame) -> bool:
    """Append the changer's sequence to T``number``; returns whether the spindle still turns."""
    from .sequences import change_sequence
    try:
        seq = change_sequence(atc, out.end_tool, number, machine.name)
    except ToolChangeError as exc:
        raise GcodeError(str(exc), out.file, line) from None
    if not seq.condition:
        return spinning
    if spinning:
        out.commands.append(Spin(0.0, 0))            # the spindle stops before the change
        out.lines.append(line)
        spinning = False
    start = len(out.commands)
    back = [FMov(tuple(frame.at.items()))] if frame.at else []
    for cmd in [frame.program(c) for c in seq.commands()] + back:
        out.commands.append(cmd)
        out.lines.append(line)
    out.events.append(HostEvent(start, line, "tool change",
                                f"tool change T{seq.current} -> T{seq.new} by the changer "
                                f"(condition {seq.condition})", seq.new))
    out.end_tool = seq.new
    return spinning
