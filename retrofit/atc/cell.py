"""The simulated mill with its magazine and tool setter beam, driven command list by command list.

:class:`SimCell` is one way to execute what the tool changer and the tool setter produce: each
list of commands is planned (``plan_program``), turned into port frames by the fast path
(``execute_fast``) and fed to one :class:`~retrofit.sim.SimMachine`, whose traces the
:class:`~retrofit.atc.magazine.MagazineModel` replays. Successive runs follow one another on
one tick axis. A probing move (:meth:`SimCell.probe`) is executed step by step against the
simulated beam and cut at the first step that breaks it: all axes stop there.
"""

from __future__ import annotations

import bisect
import copy
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..commands import Command
from ..errors import ProbeError
from ..frames import PinMap, PortFrames
from ..machine.config import Machine
from ..motion.fast import execute_fast
from ..motion.planner import plan_program
from ..runlog import RunLog
from ..sim import SimMachine, Violation
from ..sim.machine import AxisTrace
from .beam import SimBeam
from .magazine import MagazineModel, MagazineState

#: ticks of quiet line between two runs (the step lines settle, directions may turn)
GAP_TICKS = 2


@dataclass(frozen=True)
class ProbeHit:
    """Where a probing move stopped: the controller's count of steps at the breaking step."""

    tick: int                       # the tick of the step that broke the beam
    position_mm: dict[str, float]   # commanded position (steps emitted so far), mm per axis
    step_mm: dict[str, float]       # one step of each axis, mm


@dataclass(frozen=True)
class ExecutedMove:
    """One planned move as the simulated machine made it."""

    target_mm: dict[str, float]     # where the controller sent each axis
    reached_mm: dict[str, float]    # where each carriage was when the move's last step rose
    peak_mm_s: dict[str, float]     # each axis's fastest step-to-step speed during the move


def _peak_speed(trace: AxisTrace, first: int, last: int, step_mm: float, tick_s: float) -> float:
    lo, hi = bisect.bisect_right(trace.ticks, first), bisect.bisect_right(trace.ticks, last)
    gaps = np.diff(np.asarray(trace.ticks[max(lo - 1, 0):hi], dtype=np.int64))
    return float(step_mm / (gaps.min() * tick_s)) if len(gaps) else 0.0


class SimCell:
    """A simulated machine fed run after run, with the magazine model watching its traces."""

    def __init__(self, machine: Machine, magazine: MagazineState | None = None,
                 start_mm: dict[str, float] | None = None):
        self.machine = machine
        start = start_mm or {}
        self.steps = tuple(a.to_steps(start.get(a.name, 0.0)) for a in machine.axes)   # commanded
        self.sim = SimMachine(machine, self.steps)
        self.magazine = MagazineModel(machine, magazine or MagazineState.loaded(machine),
                                      {a.name: a.to_mm(s) for a, s in zip(machine.axes, self.steps)})
        self._start_mm = {a.name: a.to_mm(s) for a, s in zip(machine.axes, self.steps)}
        self.beam = SimBeam(machine) if "setter" in machine.parts else None
        self.tick = 0
        self.runs: list[tuple[int, RunLog]] = []     # (first tick, the controller's log) of each run

    # -- what the machine did --------------------------------------------------------------------
    @property
    def violations(self) -> list[Violation]:
        """The simulator's own violations (timing, travel) and the magazine's, in tick order."""
        found = self.sim.violations + self.magazine.violations
        return sorted(found, key=lambda v: (v.tick, v.axis, v.kind))

    def carriage_mm(self) -> dict[str, float]:
        """Where every carriage really is (mm; carousel units)."""
        return {a.name: self.sim.carriage_mm(a.name) for a in self.machine.axes}

    def commanded_mm(self) -> dict[str, float]:
        """Where the controller has sent every axis (mm; carousel units)."""
        return {a.name: a.to_mm(s) for a, s in zip(self.machine.axes, self.steps)}

    def moves(self) -> list[ExecutedMove]:
        """Every move of every run as the machine made it: where it ended, how fast each axis went."""
        out = []
        for offset, log in self.runs:
            for waypoint in log.waypoints:
                first, last = offset + waypoint.loaded_tick, offset + (waypoint.reached_tick or 0)
                out.append(ExecutedMove(
                    {a.name: a.to_mm(s) for a, s in zip(self.machine.axes, waypoint.steps)},
                    {a.name: self.sim.traces[a.name].at(last, 0, self._start_mm[a.name])[1]
                     for a in self.machine.axes},
                    {a.name: _peak_speed(self.sim.traces[a.name], first, last, a.step_mm,
                                         self.machine.tick_s) for a in self.machine.axes}))
        return out

    # -- running ---------------------------------------------------------------------------------
    def run(self, commands: Iterable[Command]) -> RunLog:
        """Plan and execute ``commands`` from where the last run ended; the machine follows."""
        plan = plan_program(list(commands), self.machine, start_steps=self.steps)
        log = execute_fast(plan)
        self.runs.append((self.tick, log))
        self._feed(log.frames)
        self.steps = tuple(log.final_target)
        return log

    def beam_broken(self) -> bool:
        """Whether the beam is broken now, by the tool really in the spindle."""
        return self.beam is not None and self.beam.broken(self.carriage_mm(), self.magazine.state.spindle)

    def probe(self, commands: Iterable[Command], until_broken: bool = True) -> ProbeHit | None:
        """Execute a probing move, checking the simulated beam after every step.

        The planned move's step times come from a trial run on a copy of the machine; the run is
        cut at the first step after which the beam is broken (``until_broken``; else at the first
        after which it is clear again), so every axis stops there. None when the whole move
        passes without that change (the machine then stands at its end).
        """
        if self.beam is None:
            raise ProbeError(f"machine {self.machine.name} has no tool setter ([setter] section)")
        plan = plan_program(list(commands), self.machine, start_steps=self.steps)
        frames = _shifted(execute_fast(plan).frames, self.tick)
        trial = self._trial()
        trial.feed(frames)
        tick = self._first_break(trial, until_broken)
        if tick is None:
            self._feed_shifted(frames)
            self.steps = tuple(plan.moves[-1].target) if plan.moves else self.steps
            return None
        cut = cut_frames(frames, tick, self.machine)
        counted = count_steps(cut, self.machine)
        self._feed_shifted(cut)
        self.steps = tuple(s + c for s, c in zip(self.steps, counted))
        axes = self.machine.axes
        return ProbeHit(tick, {a.name: a.to_mm(s) for a, s in zip(axes, self.steps)},
                        {a.name: a.step_mm for a in axes})

    def _trial(self) -> SimMachine:
        """A copy of the simulated machine as it stands now, with empty traces."""
        kept = self.sim.traces
        self.sim.traces = {name: AxisTrace() for name in kept}
        try:
            return copy.deepcopy(self.sim)
        finally:
            self.sim.traces = kept

    def _first_break(self, trial: SimMachine, broken: bool = True) -> int | None:
        """The first tick of the trial run after which the beam is ``broken`` (or clear)."""
        names = self.machine.axis_names
        now = self.carriage_mm()
        tool = self.magazine.state.spindle
        for tick in sorted({t for n in names for t in trial.traces[n].ticks}):
            at = {n: trial.traces[n].at(tick, 0, now[n])[1] for n in names}
            if self.beam.broken(at, tool) == broken:
                return tick
        return None

    def _feed(self, frames: PortFrames) -> None:
        self._feed_shifted(_shifted(frames, self.tick))

    def _feed_shifted(self, frames: PortFrames) -> None:
        start = self.tick
        self.sim.feed(frames)
        self.magazine.replay(self.sim, start)
        self.tick = frames.end_tick + GAP_TICKS


def _shifted(frames: PortFrames, offset: int) -> PortFrames:
    return PortFrames(frames.ticks + offset, frames.values, frames.end_tick + offset)


def cut_frames(frames: PortFrames, tick: int, machine: Machine) -> PortFrames:
    """``frames`` stopped after ``tick``: no step rises later, pulses high then end normally.

    Directions stay as they were at ``tick``; a step line high at ``tick`` falls after the
    axis's pulse width, as the step generator would end it.
    """
    pins = PinMap(machine)
    keep = frames.ticks <= tick
    ticks, values = list(frames.ticks[keep].tolist()), list(frames.values[keep].tolist())
    logical = (values[-1] if values else pins.invert) ^ pins.invert
    step_mask = sum(pins.step_masks)
    high = max(a.pulse_high_ticks for a in machine.axes)
    low = max(a.pulse_low_ticks for a in machine.axes)
    if logical & step_mask:
        ticks.append(tick + high)
        values.append((logical & ~step_mask) ^ pins.invert)
    end = tick + high + low + 1
    return PortFrames(np.array(ticks, np.int64), np.array(values, np.uint8), end)


def count_steps(frames: PortFrames, machine: Machine) -> list[int]:
    """Signed steps each axis's step line carries in ``frames`` (rising edges, direction at the edge).

    A run's frames start with every step line low, so no edge is lost at the start.
    """
    pins = PinMap(machine)
    previous = 0
    counts = [0] * len(machine.axes)
    for value in frames.values.tolist():
        logical = value ^ pins.invert
        for i, (sm, dm) in enumerate(zip(pins.step_masks, pins.dir_masks)):
            if logical & sm and not previous & sm:
                counts[i] += 1 if logical & dm else -1
        previous = logical
    return counts
