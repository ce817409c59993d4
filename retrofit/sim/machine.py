"""The simulated machine: drivers -> motors -> lead screws with a dead band -> carriages.

It reads only the port bytes, the way the real electronics do, and reports what really happened:
where each motor and carriage is, how often each reversed, and every timing or travel violation.
A machine with ``[switches]`` gets its limit, home and precise-position switches (read from the
carriages), one with ``[spindle]`` a spindle with an encoder and an index pulse; a controller
reads both through :meth:`SimMachine.switch_states` and ``SimMachine.spindle``.
"""

from __future__ import annotations

import numpy as np

from ..backlash import DeadBand
from ..frames import PortFrames
from ..machine.config import Machine
from .axistrace import AxisTrace
from .drivers import DriverInput, Violation
from .pullout import PullOutMotor, turn_screw
from .spindle import SimSpindle
from .switches import SwitchBank


class SimMachine:
    """A machine built from a machine file, moved only by port frames."""

    def __init__(self, machine: Machine, start_steps: tuple[int, ...] | None = None,
                 trace_limit: int | None = None, trace_windows: tuple[tuple[int, int], ...] = (),
                 trace_around: int = 0):
        """``trace_limit``: keep about that many trace points per axis (None: every step, 0: none);
        ``trace_windows``: tick windows ``(start, stop)`` kept in full; ``trace_around``: steps
        within that many ticks of a violation kept in full."""
        self.machine = machine
        self.trace_around = trace_around
        self._watch = np.zeros(0, np.int64)
        self._watched: list[tuple[np.ndarray, np.ndarray]] = []     # (ticks, [tick, axis, motor/carriage])
        self.keep_watched = True          # False: only the last chunk's watched states (nothing plots them)
        start = start_steps or (0,) * len(machine.axes)
        self.drivers = [DriverInput(a) for a in machine.axes]
        self.motor_steps = list(start)
        self.screws = [DeadBand(machine.sim.dead_band_mm[a.name] * a.steps_per_mm, s)
                       for a, s in zip(machine.axes, start)]
        self.traces = {a.name: AxisTrace(trace_limit, trace_windows) for a in machine.axes}
        self.reversals = [0] * len(machine.axes)
        self._last_dir = [0] * len(machine.axes)
        self._out_of_travel = [False] * len(machine.axes)
        self.extra_violations: list[Violation] = []
        # [sim.motor.<axis>]: a rotor that may fall out of step (None: it takes every step)
        self.motors = [PullOutMotor(machine.sim.motors[a.name], a.name, machine.tick_s)
                       if a.name in machine.sim.motors else None for a in machine.axes]
        self.end_tick = 0
        self._initial = [(s, s / a.steps_per_mm) for s, a in zip(start, machine.axes)]
        self.switches = SwitchBank(machine, machine.parts.get("switches"),
                                   {a.name: c for a, (_, c) in zip(machine.axes, self._initial)})
        self._travel = [self.switches.hard_travel(a) for a in machine.axes]
        spindle = machine.parts.get("spindle")
        self.spindle = SimSpindle(spindle, machine.tick_us) if spindle is not None else None
        self._masks = [((a.invert_step << a.step_bit) | (a.invert_dir << a.dir_bit), a.step_bit, a.dir_bit)
                       for a in machine.axes]

    def feed(self, frames: PortFrames) -> None:
        """Run the machine through a chunk of frames (the compiled decoder; an axis with a
        pull-out motor model, or a small chunk before anything loaded the compiler, goes step by
        step). Chunks continue one another."""
        from ..motion._jit import compiled
        from .decode import changing_bits, feed_axis
        if not compiled(len(frames)):          # a small chunk: not worth loading the compiler
            return self.feed_reference(frames)
        watch, out = self._take_watch(frames.end_tick)
        changing = changing_bits(frames)
        for i, (axis, driver) in enumerate(zip(self.machine.axes, self.drivers)):
            if self.motors[i] is None:
                feed_axis(self, i, frames, watch, out, changing)
            else:
                rises, dirs = driver.edges(frames.ticks, frames.values)
                self._move(i, axis, rises, dirs, (watch, out, frames.end_tick))
        self._keep_watch(watch, out)
        self.end_tick = max(self.end_tick, frames.end_tick)

    def feed_reference(self, frames: PortFrames) -> None:
        """The same as :meth:`feed`, step by step in Python: the readable reference."""
        watch, out = self._take_watch(frames.end_tick)
        for i, (axis, driver) in enumerate(zip(self.machine.axes, self.drivers)):
            rises, dirs = driver.edges(frames.ticks, frames.values)
            self._move(i, axis, rises, dirs, (watch, out, frames.end_tick))
        self._keep_watch(watch, out)
        self.end_tick = max(self.end_tick, frames.end_tick)

    def watch(self, ticks) -> None:
        """Ask for the motor and carriage of every axis at the end of each of ``ticks`` (ticks
        not yet fed); :meth:`state_at` answers them exactly even from a decimated trace."""
        ticks = np.asarray(ticks if isinstance(ticks, np.ndarray) else list(ticks), dtype=np.int64)
        merged = np.sort(np.concatenate((self._watch, ticks[ticks >= self.end_tick])))
        # each tick once (np.unique would load numpy.ma, 6 ms of every run's start)
        self._watch = merged[np.concatenate(([True], merged[1:] != merged[:-1]))] if len(merged) else merged

    def _take_watch(self, end_tick: int):
        cut = int(np.searchsorted(self._watch, end_tick))
        watch, self._watch = self._watch[:cut], self._watch[cut:]
        return watch, np.zeros((len(watch), len(self.machine.axes), 2))

    def _keep_watch(self, watch, out) -> None:
        self._last_watch = (watch, out)
        if len(watch) and self.keep_watched:
            self._watched.append((watch, out))

    def carriages_at(self, ticks: np.ndarray) -> np.ndarray:
        """Carriage mm [tick, axis] at ticks watched in the last chunk fed (others: :meth:`state_at`)."""
        watch, out = getattr(self, "_last_watch", (np.zeros(0, np.int64), None))
        j = np.minimum(np.searchsorted(watch, ticks), max(len(watch) - 1, 0))
        found = watch[j] == ticks if len(watch) else np.zeros(len(ticks), bool)
        carriage = np.empty((len(ticks), len(self.machine.axes)))
        carriage[found] = out[j[found], :, 1]
        for k in np.flatnonzero(~found).tolist():
            state = self.state_at(int(ticks[k]))
            carriage[k] = [state[a.name][1] for a in self.machine.axes]
        return carriage

    def _watched_columns(self) -> tuple[np.ndarray, np.ndarray]:
        """(ticks, states [tick, axis, motor / carriage]) of every watched tick fed, tick order."""
        if len(self._watched) != 1:
            n_axes = len(self.machine.axes)
            parts = self._watched or [(np.zeros(0, np.int64), np.zeros((0, n_axes, 2)))]
            self._watched = [(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))]
        return self._watched[0]

    @property
    def watched_ticks(self) -> np.ndarray:
        """The watched ticks fed so far (their state is exact, whatever the trace kept)."""
        return self._watched_columns()[0]

    def states_at(self, ticks: np.ndarray) -> np.ndarray:
        """:meth:`state_at` of many ticks at once: [tick, axis, (motor steps, carriage mm)]."""
        ticks = np.asarray(ticks, np.int64)
        watched, states = self._watched_columns()
        j = np.minimum(np.searchsorted(watched, ticks), max(len(watched) - 1, 0))
        found = (watched[j] == ticks) if len(watched) else np.zeros(len(ticks), bool)
        out = np.empty((len(ticks), len(self.machine.axes), 2))
        out[found] = states[j[found]]
        for k in np.flatnonzero(~found).tolist():
            state = self.state_at(int(ticks[k]))
            out[k] = [state[a.name] for a in self.machine.axes]
        return out

    def feed_frame(self, tick: int, value: int) -> None:
        """Run the machine through one port byte, holding from ``tick`` on (a controller's hook:
        the same driver rules as :meth:`feed`, for one frame, without array overhead)."""
        for i, (axis, driver) in enumerate(zip(self.machine.axes, self.drivers)):
            invert, step_bit, dir_bit = self._masks[i]
            logical = value ^ invert
            step = (logical >> step_bit) & 1
            direction = 1 if (logical >> dir_bit) & 1 else -1
            rise = step and not driver.step
            if rise or step != driver.step or direction != driver.direction:
                driver._check([tick] if rise else [], [tick] if driver.step and not step else [],
                              [tick] if direction != driver.direction else [])
                driver.step, driver.direction = step, direction
            if rise:
                self._move(i, axis, (tick,), (direction,))
        self.end_tick = max(self.end_tick, tick + 1)

    def switch_states(self) -> dict[str, bool]:
        """Switch name -> closed, after the frames fed so far."""
        return self.switches.states()

    def _move(self, i, axis, rises: np.ndarray, dirs: np.ndarray, watching=None) -> None:
        trace, screw, spm = self.traces[axis.name], self.screws[i], axis.steps_per_mm
        motor, last_dir = self.motor_steps[i], self._last_dir[i]
        watch, out, end_tick = watching if watching is not None else ((), None, 0)
        w = 0
        for tick, direction in zip(list(rises), list(dirs)):
            while w < len(watch) and watch[w] < tick:
                out[w, i] = (motor, screw.carriage / spm)
                w += 1
            if last_dir and direction != last_dir:
                self.reversals[i] += 1
            last_dir = direction
            moved = int(direction) if self.motors[i] is None else self.motors[i].follow(tick, direction)
            motor += moved
            carriage = turn_screw(screw, moved) / spm
            if trace.limit != 0:
                trace.append(int(tick), motor, carriage)
            self._check_travel(i, axis, tick, carriage)
            self.switches.on_carriage(axis.name, tick, carriage)
        self.motor_steps[i], self._last_dir[i] = motor, last_dir
        while w < len(watch) and watch[w] < end_tick:
            out[w, i] = (motor, screw.carriage / spm)
            w += 1

    def _check_travel(self, i, axis, tick: int, carriage: float) -> None:
        lo, hi = self._travel[i]
        outside = not (lo - 1e-9 <= carriage <= hi + 1e-9)
        if outside and not self._out_of_travel[i]:
            self.extra_violations.append(Violation(tick, axis.name, "travel",
                f"carriage at {carriage:.3f} mm, outside {lo:g}..{hi:g} mm"))
        self._out_of_travel[i] = outside

    @property
    def violations(self) -> list[Violation]:
        found = [v for d in self.drivers for v in d.violations] + self.extra_violations
        found += [v for m in self.motors if m is not None for v in m.violations]
        return sorted(found, key=lambda v: (v.tick, v.axis, v.kind))

    def carriage_mm(self, axis: str) -> float:
        i = self.machine.axis_names.index(axis)
        return self.screws[i].carriage / self.machine.axes[i].steps_per_mm

    def state_at(self, tick: int) -> dict[str, tuple[int, float]]:
        """(motor steps, carriage mm) of every axis at the end of frame ``tick`` (exact for a
        watched tick or a full trace; from the points kept of a decimated one)."""
        watched, states = self._watched_columns()
        j = int(np.searchsorted(watched, tick))
        if j < len(watched) and watched[j] == tick:
            return {a.name: (int(states[j, i, 0]), float(states[j, i, 1]))
                    for i, a in enumerate(self.machine.axes)}
        return {axis.name: self.traces[axis.name].at(tick, *self._initial[i])
                for i, axis in enumerate(self.machine.axes)}
