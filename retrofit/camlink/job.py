"""The CAM side's job: a tool path or a compiled part program as the messages of one machining.

A job follows the paper's sequence (section 6): ``A`` auto mode, ``M1`` machining starts, ``H``
home (so the CAM side knows where the axes are), then per operation ``P1``/``P0`` (coolant),
``S`` spindle, the rows, ``#`` (coolant off); finally ``M0`` (spindle stopped).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

from ..commands import Command, Cool, Dely, FFdr, FMov, MFdr, PFdr, PMov, Spin, ZMov
from ..errors import LinkError
from ..machine.config import Machine
from .protocol import FEED_LIMIT, Auto, EndOperation, Home, Machining, Message, Operation, Spindle, ToolChange
from .servo import servo_of
from .trajectory import hold_rows, plan_rows, xyz_axes

#: commands that change nothing on the CAM link's machine
_IGNORED = ("INIT", "CSTP", "RDPS", "RDST")


def spindle_value(machine: Machine, rpm: float) -> int:
    """The link's spindle speed 0..255 for ``rpm`` (255 = ``[servo] spindle_max_rpm``)."""
    value = round(rpm / servo_of(machine).spindle_max_rpm * FEED_LIMIT)
    if not 0 <= value <= FEED_LIMIT:
        raise LinkError(f"spindle {rpm:g} rpm: the link's spindle runs 0.."
                        f"{servo_of(machine).spindle_max_rpm:g} rpm (S0..S255), clockwise")
    return value


def path_job(machine: Machine, moves: Sequence[tuple[Sequence[float], float]], *, coolant: bool = False,
             spindle: int = 0, tool: tuple[int, int] | None = None) -> Iterator[Message]:
    """One machining of one operation along ``moves`` [(point_mm, feed_mm_min), ...] from home."""
    yield from (Auto(), Machining(True), Home())
    if tool is not None:
        yield ToolChange(*tool)
    yield Operation(coolant)
    if spindle:
        yield Spindle(spindle)
    yield from plan_rows(machine, (0.0, 0.0, 0.0), moves)
    yield from (EndOperation(), Machining(False))


class ProgramJob:
    """Turns the commands of a compiled part program into the messages of a job."""

    def __init__(self, machine: Machine):
        self.machine = machine
        self.names = tuple(a.name for a in xyz_axes(machine))
        self.position = (0.0, 0.0, 0.0)          # the job starts with H: at machine zero
        self.path_start = self.position
        self.moves: list[tuple[tuple[float, ...], float]] = []
        self.rapid = machine.motion.rapid_feed_mm_min
        self.feed = machine.motion.default_feed_mm_min
        self.coolant = False
        self.open = False                        # an operation (P ... #) is open

    def messages(self, commands: Iterable[Command]) -> Iterator[Message]:
        """The whole job: A, M1, H, the program's operations, M0."""
        yield from (Auto(), Machining(True), Home())
        for command in commands:
            yield from self._command(command)
        yield from self._flush()
        if self.open:
            yield EndOperation()
        yield Machining(False)

    def _command(self, cmd: Command) -> Iterator[Message]:
        if isinstance(cmd, (FMov, PMov)):
            target = dict(zip(self.names, self.position))
            target.update(cmd.position())
            point = tuple(target[n] for n in self.names)
            self.moves.append((point, self.rapid if isinstance(cmd, FMov) else self.feed))
            self.position = point
        elif isinstance(cmd, FFdr):
            self.rapid = cmd.feed
        elif isinstance(cmd, (PFdr, MFdr)):
            self.feed = cmd.feed
        elif isinstance(cmd, Dely):
            yield from self._flush()
            yield from self._open()
            yield from hold_rows(self._pulses(), round(cmd.seconds / self.machine.tick_s))
        elif isinstance(cmd, Spin):
            yield from self._spin(cmd)
        elif isinstance(cmd, Cool):
            yield from self._cool(cmd)
        elif isinstance(cmd, ZMov):
            yield from self._home()
        elif cmd.mnemonic not in _IGNORED:
            raise LinkError(f"{cmd}: not available over the CAM link (it carries moves, dwells, "
                            "spindle, coolant and homing)")

    def _spin(self, cmd: Spin) -> Iterator[Message]:
        if cmd.direction < 0:
            raise LinkError(f"{cmd}: the CAM link's spindle turns clockwise only (M3, not M4)")
        yield from self._flush()
        yield Spindle(spindle_value(self.machine, cmd.rpm) if cmd.direction else 0)

    def _cool(self, cmd: Cool) -> Iterator[Message]:
        yield from self._flush()
        if self.open:
            yield EndOperation()
            self.open = False
        self.coolant = cmd.mode != 0

    def _home(self) -> Iterator[Message]:
        yield from self._flush()
        if self.open:
            yield EndOperation()
            self.open = False
        yield Home()
        self.position = self.path_start = (0.0, 0.0, 0.0)

    def _open(self) -> Iterator[Message]:
        if not self.open:
            self.open = True
            yield Operation(self.coolant)

    def _flush(self) -> Iterator[Message]:
        """The rows of the moves gathered since the last stop (one planned path)."""
        if self.moves:
            yield from self._open()
            yield from plan_rows(self.machine, self.path_start, self.moves)
            self.moves = []
        self.path_start = self.position

    def _pulses(self) -> tuple[int, ...]:
        return tuple(a.to_steps(v) for a, v in zip(self.machine.axes, self.position))


def program_job(machine: Machine, commands: Iterable[Command]) -> Iterator[Message]:
    """The messages of a job running ``commands`` (from ``retrofit.gcode.compile_program``)."""
    return ProgramJob(machine).messages(commands)
