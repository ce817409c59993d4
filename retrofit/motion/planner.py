"""From commands to planned moves: targets in steps, backlash, limits, look-ahead and profiles.

This is the *prepare* phase of 002 for a whole program: every motion command becomes a
``PlannedMove`` holding all the constants the execute phase needs (start and end in motor
steps, its velocity profile and its start time), so executing it is pure arithmetic.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..commands import Command, Dely, FFdr, FMov, MFdr, PFdr, PMov, Prob, Pstn, Wait, ZMov
from ..errors import MotionError
from ..machine.config import Machine
from . import profile as prof
from .bresenham import STEP_SPACE_LIMIT, prepare_line
from .lookahead import Kinematics, plan_speeds

#: the exponential profile starts from this speed (a stepper's start frequency), mm/s
EXP_START_MM_S = 1.0
#: the look-ahead's passes assume this share of the acceleration under the exponential profile
EXP_ACCEL_SCALE = 0.25


@dataclass
class PlannedMove:
    """One prepared move (or dwell, when ``start == end`` and ``dwell_s > 0``)."""

    start: tuple[int, ...]          # motor steps
    end: tuple[int, ...]            # motor steps (backlash clearance included)
    target: tuple[int, ...]         # commanded position at the end, in steps
    t0_s: float                     # program time at which it starts
    profile: np.ndarray | None      # profile row (see motion.profile), None for a dwell
    dwell_s: float = 0.0
    index: int = 0                  # position of the command in the program

    @property
    def duration_s(self) -> float:
        return self.dwell_s if self.profile is None else prof.duration(self.profile)


class Plan:
    """The prepared moves of a program: ``moves`` (objects, made on first use) and the same
    moves as columns (:meth:`arrays`, what the compiled paths read)."""

    def __init__(self, machine: Machine, start_steps: tuple[int, ...], moves: list[PlannedMove] | None = None,
                 end_s: float = 0.0, arrays=None):
        self.machine, self.start_steps, self.end_s = machine, start_steps, end_s
        self._moves = moves if moves is not None or arrays is not None else []
        self._arrays = arrays

    @property
    def moves(self) -> list[PlannedMove]:
        if self._moves is None:
            a = self._arrays
            self._moves = [PlannedMove(tuple(s), tuple(e), tuple(t), t0, p if has else None, d, i)
                           for s, e, t, t0, p, has, d, i in zip(
                               a.starts.tolist(), a.ends.tolist(), a.targets.tolist(), a.t0s.tolist(),
                               a.profiles, a.has_profile.tolist(), a.dwells.tolist(), a.index.tolist())]
        return self._moves

    def arrays(self):
        """The moves as :class:`~retrofit.motion.planarrays.PlanArrays` (columns)."""
        if self._arrays is None:
            from .planarrays import PlanArrays
            self._arrays = PlanArrays.of_moves(self.moves, len(self.machine.axes))
        return self._arrays


@dataclass
class _Segment:
    start: tuple[int, ...]
    end: tuple[int, ...]
    target: tuple[int, ...]
    kin: Kinematics
    dwell_s: float
    index: int
    wait: Wait | None = None        # M66: a dwell as long as the input makes it


def plan_program(commands: Iterable[Command], machine: Machine, backlash_comp: bool = True,
                 start_steps: Sequence[int] | None = None) -> Plan:
    """Prepare every motion command of a program (see module doc); by compiled passes over
    arrays (``motion.planarrays``, the same plan) unless the program needs this walker's words."""
    from .planarrays import plan_arrays
    start = tuple(start_steps or (0,) * len(machine.axes))
    commands = list(commands)
    fast = plan_arrays(commands, machine, backlash_comp, start)
    if fast is not None:
        return Plan(machine, start, end_s=fast[1], arrays=fast[0])
    return plan_walked(commands, machine, backlash_comp, start)


def plan_walked(commands: list[Command], machine: Machine, backlash_comp: bool, start: tuple[int, ...]) -> Plan:
    """:func:`plan_program` by the readable walker, one object per move (the reference)."""
    segments = list(_segments(commands, machine, backlash_comp, start))   # may raise MotionError
    settings = machine.motion
    exponential = settings.profile == "exponential"
    speeds = plan_speeds([s.kin for s in segments], settings.lookahead, settings.junction_deviation_mm,
                         accel_scale=EXP_ACCEL_SCALE if exponential else 1.0,
                         axis_accel=np.array([a.max_accel_mm_s2 for a in machine.axes]),
                         axis_step=np.array([a.step_mm for a in machine.axes]))
    plan = Plan(machine, start)
    t = 0.0
    for seg, (entry, exit_) in zip(segments, speeds):
        row = None
        if seg.kin.length_mm > 0.0:
            row = profile_row(seg.kin, entry, exit_, seg.kin.a_max_mm_s2, exponential)
        dwell = seg.dwell_s if seg.wait is None else wait_seconds(machine, seg.wait, t)
        move = PlannedMove(seg.start, seg.end, seg.target, t, row, dwell, seg.index)
        plan.moves.append(move)
        t = t + move.duration_s
    plan.end_s = t
    return plan


def profile_row(kin: Kinematics, entry: float, exit_: float, accel: float, exponential: bool) -> np.ndarray:
    """The velocity profile row of a move of ``kin`` from ``entry`` to ``exit_`` mm/s at ``accel``:
    an exponential ramp (from a stepper's start speed) or a trapezoid."""
    if exponential:
        return prof.exponential(kin.length_mm, entry, kin.v_max_mm_s, exit_, accel,
                                min(EXP_START_MM_S, kin.v_max_mm_s))
    return prof.trapezoid(kin.length_mm, entry, kin.v_max_mm_s, exit_, accel)


def wait_seconds(machine: Machine, wait: Wait, start_s: float) -> float:
    """How long a WAIT started ``start_s`` into the run lasts on the machine's simulated input."""
    from ..machine.iopins import wait_outcome
    io = machine.parts.get("io")
    if io is None or wait.input >= len(io.inputs):
        raise MotionError(f"{wait}: machine {machine.name} has no digital input {wait.input} "
                          f"([io] in{wait.input} in its machine file)")
    return wait_outcome(io, wait.input, wait.mode, wait.timeout, start_s).seconds


def kinematics(machine: Machine, start: Sequence[int], end: Sequence[int], feed_mm_s: float) -> Kinematics:
    """Length, direction and speed / acceleration caps of a straight move in motor steps."""
    axes = machine.axes
    mm = [(e - s) / a.steps_per_mm for s, e, a in zip(start, end, axes)]
    total = 0.0
    for d in mm:                      # summed in order, as NumPy sums a few elements
        total += d * d
    length = math.sqrt(total)
    if length == 0.0:
        return Kinematics(0.0, np.zeros(len(mm)), feed_mm_s, 1.0)
    unit = [d / length for d in mm]
    v_max, a_max = feed_mm_s, math.inf
    for u, axis in zip(unit, axes):
        u = abs(u)
        if u > 0:
            v_max = min(v_max, axis.max_velocity_mm_s / u)
            a_max = min(a_max, axis.max_accel_mm_s2 / u)
    return Kinematics(length, np.array(unit), v_max, a_max)


def _segments(commands: list[Command], machine: Machine, backlash_comp: bool, start: tuple[int, ...]):
    """Walk the program as an interpreter would, yielding straight segments and dwells."""
    walker = _Walker(machine, backlash_comp, start)
    index = -1
    try:
        for index, cmd in enumerate(commands):
            yield from walker.take(cmd, index)
    except MotionError as exc:
        exc.command_index = index             # lets a front end name the source line
        raise


class _Walker:
    """The interpreter's state while a program is prepared: feeds, position, backlash side."""

    def __init__(self, machine: Machine, backlash_comp: bool, start: tuple[int, ...]):
        self.machine = machine
        self.rapid = machine.motion.rapid_feed_mm_min
        self.feed = machine.motion.default_feed_mm_min
        self.position = list(start)                          # commanded, in steps
        self.offset = [0] * len(machine.axes)                # PSTN: program coordinates -> machine steps
        self.clearance = [a.backlash_steps if backlash_comp else 0 for a in machine.axes]
        self.last_dir = [-1] * len(machine.axes)             # the nut starts on its negative face
        self.motor = list(start)

    def take(self, cmd: Command, index: int):
        machine = self.machine
        if isinstance(cmd, FFdr):
            self.rapid = _positive_feed(cmd)
        elif isinstance(cmd, (PFdr, MFdr)):
            self.feed = _positive_feed(cmd)
        elif isinstance(cmd, Pstn):
            for name, mm in cmd.axes:
                i = machine.axis_names.index(_axis_name(machine, name))
                self.offset[i] = self.position[i] - machine.axes[i].to_steps(mm)
        elif isinstance(cmd, Dely):
            kin = Kinematics(0.0, np.zeros(len(machine.axes)), 1.0, 1.0, stop_before=True)
            yield _Segment(tuple(self.motor), tuple(self.motor), tuple(self.position), kin, cmd.seconds, index)
        elif isinstance(cmd, Wait):
            kin = Kinematics(0.0, np.zeros(len(machine.axes)), 1.0, 1.0, stop_before=True)
            yield _Segment(tuple(self.motor), tuple(self.motor), tuple(self.position), kin, 0.0,
                           index, cmd)
        elif isinstance(cmd, (FMov, PMov, ZMov)):
            yield self._move(cmd, index)
        elif isinstance(cmd, Prob):
            raise MotionError(f"{cmd}: a planned run has no probe input to stop a probing move; "
                              f"send PROB to a device with one (firmware/), or probe with "
                              f"G38.2-G38.5 in G-code on a machine with a tool setter")

    def _move(self, cmd: FMov | PMov | ZMov, index: int) -> _Segment:
        """A straight move in motor steps: the clearance is added while the nut is on its + face."""
        machine = self.machine
        target = _target(machine, cmd, self.position, self.offset)
        for i, (old, new) in enumerate(zip(self.position, target)):
            if new != old:
                self.last_dir[i] = 1 if new > old else -1
        motor = tuple(t + (self.clearance[i] if self.last_dir[i] > 0 else 0) for i, t in enumerate(target))
        if not all(-STEP_SPACE_LIMIT <= m <= STEP_SPACE_LIMIT for m in motor):
            prepare_line(tuple(self.motor), motor, machine.axis_names)   # words the refusal
        speed = (self.rapid if isinstance(cmd, (FMov, ZMov)) else self.feed) / 60.0
        kin = kinematics(machine, self.motor, motor, speed)
        kin.stop_before = isinstance(cmd, ZMov)
        segment = _Segment(tuple(self.motor), motor, tuple(target), kin, 0.0, index)
        self.position, self.motor = list(target), list(motor)
        return segment


def _positive_feed(cmd) -> float:
    if not cmd.feed > 0:
        raise MotionError(f"{cmd}: feed must be > 0 mm/min")
    return cmd.feed


def _axis_name(machine: Machine, name: str, names: tuple[str, ...] | None = None) -> str:
    names = machine.axis_names if names is None else names
    if name.upper() not in names:
        raise MotionError(f"axis {name} is not on machine {machine.name} (axes: {', '.join(names)})")
    return name.upper()


def _target(machine: Machine, cmd: FMov | PMov | ZMov, position: list[int], offset: list[int]) -> list[int]:
    """The commanded end point in machine steps, checked against the soft limits."""
    target = list(position)
    names = machine.axis_names
    if isinstance(cmd, ZMov):          # machine zero (homing against switches is the controller's)
        for name in cmd.names or names:
            target[names.index(_axis_name(machine, name, names))] = 0
    else:
        for name, mm in cmd.axes:
            i = names.index(_axis_name(machine, name, names))
            target[i] = machine.axes[i].to_steps(mm) + offset[i]
    for i, axis in enumerate(machine.axes):
        if not axis.min_steps <= target[i] <= axis.max_steps:
            raise MotionError(f"{cmd}: {axis.name} {axis.to_mm(target[i]):.3f} mm is outside the soft "
                              f"limits {axis.min_mm:g}..{axis.max_mm:g} mm")
    return target
