"""A run tick by tick: commanded target, motor and carriage of every axis, for tables and plots."""

from __future__ import annotations

import numpy as np

from ..runlog import RunLog
from ..sim import SimMachine


def tick_trace(log: RunLog, sim: SimMachine, start: int = 0, stop: int | None = None) -> dict[str, np.ndarray]:
    """Per tick from ``start`` to ``stop`` (default: the whole run): ``tick``, and per axis
    ``<A>.commanded`` (the target being driven to, steps), ``<A>.motor`` (steps) and
    ``<A>.carriage`` (mm), as the controller commanded and the simulated machine did.

    >>> from retrofit.machine.config import load_machine
    >>> from retrofit.motion.errorloop import PositionErrorLoop
    >>> machine = load_machine("chivu-lathe")
    >>> log = PositionErrorLoop(machine).run([(3, 0)])
    >>> sim = SimMachine(machine); sim.feed(log.frames)
    >>> trace = tick_trace(log, sim)
    >>> int(trace["X.commanded"][-1]), int(trace["X.motor"][-1]), len(trace["tick"]) == log.ticks
    (3, 7, True)
    """
    stop = log.ticks if stop is None else stop
    ticks = np.arange(start, stop, dtype=np.int64)
    out: dict[str, np.ndarray] = {"tick": ticks}
    loaded = np.array([w.loaded_tick for w in log.waypoints], dtype=np.int64)
    targets = np.array([w.steps for w in log.waypoints] or [log.start_steps], dtype=np.int64)
    index = np.searchsorted(loaded, ticks, side="right") - 1
    for i, axis in enumerate(log.machine.axes):
        first = np.full(len(ticks), log.start_steps[i], dtype=np.int64)
        out[f"{axis.name}.commanded"] = np.where(index >= 0, targets[np.maximum(index, 0), i], first)
        trace_ticks, trace_motor, trace_carriage = sim.traces[axis.name].arrays()
        at = np.searchsorted(trace_ticks, ticks, side="right") - 1
        motor0, carriage0 = sim._initial[i]
        motor = np.concatenate(([motor0], trace_motor))
        carriage = np.concatenate(([carriage0], trace_carriage))
        out[f"{axis.name}.motor"] = motor[at + 1]
        out[f"{axis.name}.carriage"] = carriage[at + 1]
    return out
