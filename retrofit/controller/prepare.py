"""The *prepare* phase of 002: each command taken from the queue becomes an entry of the window.

The interpreter keeps the state a program builds up -- feeds, step source, position, the side of
each nut (for backlash), the coordinate offset of PSTN -- and turns each command into what the
processor will execute: a straight move with every constant computed (:class:`LineEntry`), a
dwell, an indexer move (ISTP), a homing (ZMOV against switches), or an action done in order
between moves (SPIN, COOL, PSTN). Straight moves are prepared exactly as
:func:`retrofit.motion.planner.plan_program` prepares them, so their steps are the same.

Positions here are in *walker* steps: machine steps plus the compensation clearance while the
nut rests on its positive face; the processor maps them to its motor counter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..commands import Command, Cool, CStp, Dely, FMov, IStp, PFdr, PMov, Prob, Pstn, Spin, ZMov
from ..errors import MotionError
from ..machine.config import Machine
from ..motion.bresenham import prepare_line
from ..motion.lookahead import Kinematics
from ..motion.planner import kinematics


def barrier() -> Kinematics:
    """Kinematics of an entry the planner must stop before and after (dwell, ISTP, homing)."""
    return Kinematics(0.0, np.zeros(1), 1.0, 1.0, stop_before=True)


@dataclass
class Entry:
    """Something the processor executes, in program order; ``serial`` numbers the commands."""

    cmd: Command
    serial: int

    @property
    def is_move(self) -> bool:
        """True when the look-ahead counts it as one of its moves."""
        return True


@dataclass
class LineEntry(Entry):
    """A straight move timed by the clock (FMOV, PMOV under CSTP, ZMOV without switches)."""

    start: tuple[int, ...] = ()          # walker steps
    end: tuple[int, ...] = ()
    target: tuple[int, ...] = ()         # commanded position at the end (machine steps)
    kin: Kinematics | None = None
    rapid: bool = False                  # fast feed (FFDR) or machining feed (PFDR / MFDR)
    group: int = 0                       # which PFDR its machining feed came from


@dataclass
class DwellEntry(Entry):
    seconds: float = 0.0
    target: tuple[int, ...] = ()
    kin: Kinematics = field(default_factory=barrier)


@dataclass
class IndexEntry(Entry):
    """A PMOV under ISTP: take up the backlash, wait for the index, then follow the encoder."""

    start: tuple[int, ...] = ()          # walker steps before the take-up
    line_start: tuple[int, ...] = ()     # after the take-up: where the synchronised line starts
    end: tuple[int, ...] = ()
    target: tuple[int, ...] = ()
    feed_mm_rev: float = 0.0             # along the path, per spindle revolution
    path: Kinematics | None = None       # the line's length, direction, speed and accel caps
    chained: bool = False                # continues the previous ISTP move's synchronisation
    kin: Kinematics = field(default_factory=barrier)


@dataclass
class HomeEntry(Entry):
    """ZMOV on a machine with switches: home ``axes`` in order."""

    axes: tuple[str, ...] = ()
    target: tuple[int, ...] = ()         # machine steps after homing (home_mm on the homed axes)
    end: tuple[int, ...] = ()            # walker steps after homing
    kin: Kinematics = field(default_factory=barrier)


@dataclass
class ActionEntry(Entry):
    """SPIN, COOL or PSTN, done when the processor reaches it (between two moves)."""

    offsets: tuple[int, ...] = ()        # PSTN: program coordinates -> machine steps, from now on

    @property
    def is_move(self) -> bool:
        return False


class Walker:
    """The interpreter's state while commands are prepared (002's first phase)."""

    def __init__(self, machine: Machine, backlash_comp: bool, homing=None):
        self.machine = machine
        self.homing = homing
        self.clearance = [a.backlash_steps if backlash_comp else 0 for a in machine.axes]
        self.reset([0] * len(machine.axes))

    def reset(self, position: list[int], last_dir: list[int] | None = None) -> None:
        """Defaults for feeds and source; the position (machine steps) and the nuts' sides."""
        settings = self.machine.motion
        self.rapid = settings.rapid_feed_mm_min
        self.feed = settings.default_feed_mm_min
        self.group = 0
        self.source = "clock"
        self.chain = False
        self.position = list(position)
        self.offset = [0] * len(position)
        self.last_dir = list(last_dir) if last_dir else [-1] * len(position)
        self.motor = [p + self._comp(i) for i, p in enumerate(self.position)]

    def resync(self, motor: list[int], last_dir: list[int], offset: list[int]) -> None:
        """After a halt: the motor is where it stopped, the nuts on the side it last moved to."""
        self.last_dir = list(last_dir)
        self.motor = list(motor)
        self.position = [m - self._comp(i) for i, m in enumerate(motor)]
        self.offset = list(offset)
        self.chain = False

    def _comp(self, i: int) -> int:
        return self.clearance[i] if self.last_dir[i] > 0 else 0

    def take(self, cmd: Command, serial: int) -> list[Entry]:
        """Prepare one command; the entries it gives (none for a set-up command)."""
        if isinstance(cmd, PFdr):
            self.feed = positive_feed(cmd)
            self.group += 1
        elif isinstance(cmd, (CStp, IStp)):
            self.source = "index" if isinstance(cmd, IStp) else "clock"
            self.chain = self.chain and self.source == "index"
        elif isinstance(cmd, Pstn):
            for name, mm in cmd.axes:
                i = self._axis(name)
                self.offset[i] = self.position[i] - self.machine.axes[i].to_steps(mm)
            return [ActionEntry(cmd, serial, offsets=tuple(self.offset))]
        elif isinstance(cmd, (Spin, Cool)):
            return [ActionEntry(cmd, serial)]
        elif isinstance(cmd, Dely):
            self.chain = False
            return [DwellEntry(cmd, serial, seconds=cmd.seconds, target=tuple(self.position))]
        elif isinstance(cmd, ZMov) and self.homing is not None:
            self.chain = False
            return [self._home(cmd, serial)]
        elif isinstance(cmd, PMov) and self.source == "index":
            entry = self._indexed(cmd, serial)
            self.chain = True
            return [entry]
        elif isinstance(cmd, (FMov, PMov, ZMov)):
            self.chain = False
            return [self._line(cmd, serial)]
        elif isinstance(cmd, Prob):
            raise MotionError(no_probe_input(cmd, self.machine))
        return []

    def _axis(self, name: str) -> int:
        names = self.machine.axis_names
        if name.upper() not in names:
            raise MotionError(f"axis {name} is not on machine {self.machine.name} (axes: {', '.join(names)})")
        return names.index(name.upper())

    def _advance(self, cmd: Command) -> tuple[list[int], list[int]]:
        """The commanded target and the new motor position (clearance added on the + face)."""
        target = self._target(cmd)
        for i, (old, new) in enumerate(zip(self.position, target)):
            if new != old:
                self.last_dir[i] = 1 if new > old else -1
        motor = [t + self._comp(i) for i, t in enumerate(target)]
        prepare_line(tuple(self.motor), tuple(motor), self.machine.axis_names)   # the 24-bit space
        return target, motor

    def _line(self, cmd: Command, serial: int) -> LineEntry:
        start = tuple(self.motor)
        target, motor = self._advance(cmd)
        rapid = isinstance(cmd, (FMov, ZMov))
        kin = kinematics(self.machine, start, motor, (self.rapid if rapid else self.feed) / 60.0)
        kin.stop_before = isinstance(cmd, ZMov)
        self.position, self.motor = target, motor
        return LineEntry(cmd, serial, start=start, end=tuple(motor), target=tuple(target), kin=kin,
                         rapid=rapid, group=self.group)

    def _indexed(self, cmd: PMov, serial: int) -> IndexEntry:
        start = tuple(self.motor)
        target, motor = self._advance(cmd)
        line_start = tuple(p + self._comp(i) for i, p in enumerate(self.position))
        path = kinematics(self.machine, line_start, motor, float("inf"))
        self.position, self.motor = target, motor
        return IndexEntry(cmd, serial, start=start, line_start=line_start, end=tuple(motor),
                          target=tuple(target), feed_mm_rev=self.feed, path=path,
                          chained=self.chain)

    def _home(self, cmd: ZMov, serial: int) -> HomeEntry:
        order = self.homing.order
        names = tuple(n.upper() for n in cmd.names) or order
        for name in names:
            self._axis(name)
            if name not in order:
                raise MotionError(f"{cmd}: axis {name} has no [homing.{name.lower()}] in "
                                  f"{self.machine.name}; homed axes: {', '.join(order)}")
        axes = tuple(n for n in order if n in names)
        switches = self.machine.parts["switches"]
        for name in axes:
            i = self.machine.axis_names.index(name)
            how = self.homing.axes[name]
            side = switches.named(how.precise or how.switch).side
            self.position[i] = self.machine.axes[i].to_steps(how.home_mm)
            self.offset[i] = 0
            self.last_dir[i] = side
            self.motor[i] = self.position[i] + self._comp(i)
        return HomeEntry(cmd, serial, axes=axes, target=tuple(self.position), end=tuple(self.motor))

    def _target(self, cmd: Command) -> list[int]:
        """The commanded end point in machine steps, checked against the soft limits."""
        machine = self.machine
        target = list(self.position)
        if isinstance(cmd, ZMov):             # machine zero, on a machine without switches
            for name in cmd.names or machine.axis_names:
                target[self._axis(name)] = 0
        elif isinstance(cmd, (FMov, PMov, Prob, Pstn)):
            for name, mm in cmd.axes:
                i = self._axis(name)
                target[i] = machine.axes[i].to_steps(mm) + self.offset[i]
        else:
            raise MotionError(f"{cmd}: not a move; no target to plan")
        for i, axis in enumerate(machine.axes):
            if not axis.min_steps <= target[i] <= axis.max_steps:
                raise MotionError(f"{cmd}: {axis.name} {axis.to_mm(target[i]):.3f} mm is outside the "
                                  f"soft limits {axis.min_mm:g}..{axis.max_mm:g} mm")
        return target

    def comp_offsets(self) -> tuple[int, ...]:
        """Motor minus commanded position per axis, as things stand after the last prepared entry."""
        return tuple(self._comp(i) for i in range(len(self.position)))


def no_probe_input(cmd: Prob, machine: Machine) -> str:
    """Why this controller refuses a probing move: it reads no probe input."""
    return (f"{cmd}: the controller of {machine.name} has no probe input (its simulated machine has "
            f"no beam to break), so it makes no probing move; a device with a probe input "
            f"(firmware/) does, and G38.2-G38.5 probe on sim:// for a machine with a tool setter")


def positive_feed(cmd) -> float:
    if not cmd.feed > 0:
        raise MotionError(f"{cmd}: feed must be > 0 (mm/min, or mm per revolution under ISTP)")
    return cmd.feed
