"""What the console and the HTML report draw, computed from a run's port frames and its program.

Nothing here keeps a copy per tick: a window of a run (the ticks a view shows) is cut from the
run-length port frames with a binary search, so a 10 M-step run answers a zoom as fast as a
short one. Positions are integer steps until the last line, where they become mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frames import PortFrames
from ..machine.config import Machine
from ..run.plot import is_lathe, stock_and_part, toolpath

#: at most this many points per trace of a timeline window
TIMELINE_POINTS = 1500
#: at most this many port frames in a pulse window before it is drawn as activity bands
PULSE_FRAMES = 6000
#: the shortest window velocity and acceleration are averaged over (s); a wider view averages
#: over two of its sample spacings
AVERAGE_S = 0.05


@dataclass
class AxisSteps:
    """Every step one axis took: the tick of each rising edge and the position after it (steps)."""

    ticks: np.ndarray        # int64, increasing
    position: np.ndarray     # int64, position after each step
    start: int               # position before the first step

    def __post_init__(self):
        self._after = np.concatenate(([self.start], self.position))

    def at(self, ticks: np.ndarray) -> np.ndarray:
        """Positions (steps) at the end of each of ``ticks``."""
        return self._after[np.searchsorted(self.ticks, ticks, side="right")]


def axis_steps(frames: PortFrames, machine: Machine, start_steps=None) -> list[AxisSteps]:
    """Step edges of every axis, decoded from the port frames as a driver decodes them
    (a rising step edge, the direction line sampled at it)."""
    start_steps = start_steps or (0,) * len(machine.axes)
    invert = 0
    for a in machine.axes:
        invert |= (a.invert_step << a.step_bit) | (a.invert_dir << a.dir_bit)
    logical = frames.values ^ np.uint8(invert)
    out = []
    for a, start in zip(machine.axes, start_steps):
        step = (logical >> a.step_bit) & 1
        prev = np.concatenate(([0], step[:-1]))
        rise = np.flatnonzero((step == 1) & (prev == 0))
        sign = np.where((logical[rise] >> a.dir_bit) & 1, 1, -1).astype(np.int64)
        out.append(AxisSteps(frames.ticks[rise], start + np.cumsum(sign), int(start)))
    return out


def preview(program, machine: Machine, source_text: str = "") -> dict:
    """The preview of a program: its segments (rapid or cut, with their program line), the
    work envelope (soft limits) and, on a lathe, the stock and the part the cuts leave."""
    segs = toolpath(program.commands, machine)
    lines = program.lines
    out = {
        "lathe": is_lathe(machine),
        "axes": [{"name": a.name, "label": a.label, "min": a.min_mm, "max": a.max_mm} for a in machine.axes],
        "segments": [{"kind": s.kind, "start": s.start, "end": s.end, "line": lines[s.index]} for s in segs],
        "rapids": sum(1 for s in segs if s.kind == "rapid"),
        "cuts": sum(1 for s in segs if s.kind == "cut"),
        "cut_lines": len({lines[s.index] for s in segs if s.kind == "cut"}),
    }
    lathe = stock_and_part(segs, machine, source_text)
    if lathe is not None:
        out["stock"] = {"radius": lathe["radius_mm"], "z": list(lathe["z_mm"])}
        out["part"] = {"z": np.round(lathe["part_z"], 4).tolist(), "x": np.round(lathe["part_x"], 4).tolist()}
    return out


def timeline(steps: list[AxisSteps], machine: Machine, t0: int, t1: int, carriage=None,
             points: int = TIMELINE_POINTS) -> dict:
    """Per axis position, velocity, acceleration (and carriage error when ``carriage`` is given:
    a function (axis index, ticks) -> carriage mm) on ``points`` ticks evenly spread in [t0, t1).

    Velocity and acceleration are means over a window (``window_s``: :data:`AVERAGE_S`, or two
    sample spacings when wider): the velocity is the steps between the first and the last step
    edge in the window over the time between them (exact for an even step rate, where counting
    steps would jump by a step), the acceleration the change of that velocity across the window.
    """
    ticks, half = timeline_ticks(machine, t0, t1, points)
    out = {"t": (ticks * machine.tick_s).round(9).tolist(), "axes": {},
           "window_s": round(2 * half * machine.tick_s, 6)}
    for i, (a, s) in enumerate(zip(machine.axes, steps)):
        pos = s.at(ticks) / a.steps_per_mm
        scale = 60.0 / (a.steps_per_mm * machine.tick_s)            # steps a tick -> mm/min
        vel = mean_rate(s, ticks, half) * scale
        acc = (mean_rate(s, ticks + half, half) - mean_rate(s, ticks - half, half)) * scale / 60.0 \
            / (2 * half * machine.tick_s)
        axis = {"position_mm": pos.round(6).tolist(), "velocity_mm_min": vel.round(3).tolist(),
                "accel_mm_s2": acc.round(3).tolist()}
        if carriage is not None:
            axis["error_mm"] = (carriage(i, ticks) - pos).round(6).tolist()
        out["axes"][a.name] = axis
    return out


def timeline_ticks(machine: Machine, t0: int, t1: int, points: int = TIMELINE_POINTS) -> tuple[np.ndarray, int]:
    """The ticks a timeline of [t0, t1) is computed at, and the half width (ticks) of its window."""
    t0, t1 = int(max(t0, 0)), int(max(t1, t0 + 2))
    ticks = np.unique(np.linspace(t0, t1 - 1, points).round().astype(np.int64))
    spacing = int(ticks[1] - ticks[0]) if len(ticks) > 1 else 1
    return ticks, max(int(AVERAGE_S / machine.tick_s / 2), spacing, 1)


def mean_rate(s: AxisSteps, ticks: np.ndarray, half: int) -> np.ndarray:
    """Steps a tick around each of ``ticks`` (the window ``ticks +- half``): between the first and
    the last step edge in it, their distance over their time; one edge alone: one step over the
    window; none: 0."""
    first = np.searchsorted(s.ticks, ticks - half, side="left")
    last = np.searchsorted(s.ticks, ticks + half, side="right") - 1
    rate = np.zeros(len(ticks))
    if not len(s.ticks):
        return rate
    lo, hi = np.clip(first, 0, len(s.ticks) - 1), np.clip(last, 0, len(s.ticks) - 1)
    many = last > first
    rate[many] = (s.position[hi[many]] - s.position[lo[many]]) / (s.ticks[hi[many]] - s.ticks[lo[many]])
    one = last == first
    rate[one] = (s.position[lo[one]] - s._after[lo[one]]) / (2.0 * half)
    return rate


class PulseIndex:
    """The step and direction lines of a run, indexed once so that any window is cut at once.

    ``window(t0, t1)`` gives the port frames in [t0, t1) when at most ``limit`` fall there;
    otherwise, for each line, how often it toggles in each of ``limit // 2`` slots of the window
    (``bands``), counted by binary search in the line's own edge ticks.
    """

    def __init__(self, frames: PortFrames, machine: Machine):
        self.frames, self.machine = frames, machine
        self.lines = []
        for a in machine.axes:
            self.lines += [(f"{a.name} step", a.step_bit, a.invert_step), (f"{a.name} dir", a.dir_bit, a.invert_dir)]
        values = frames.values
        self.edges = [frames.ticks[np.flatnonzero(np.diff((values >> bit) & 1) != 0) + 1] for _, bit, _ in self.lines]

    def window(self, t0: int, t1: int, limit: int = PULSE_FRAMES) -> dict:
        frames = self.frames
        t0, t1 = int(max(t0, 0)), int(max(t1, t0 + 1))
        lo = max(int(np.searchsorted(frames.ticks, t0, side="right")) - 1, 0)
        hi = int(np.searchsorted(frames.ticks, t1, side="left"))
        out = {"t0": t0, "t1": t1, "tick_us": self.machine.tick_us, "lines": [n for n, _, _ in self.lines]}
        if hi - lo <= limit:
            values = frames.values[lo:hi]
            out["ticks"] = np.clip(frames.ticks[lo:hi], t0, None).tolist()
            out["levels"] = [(((values >> bit) & 1) ^ inv).tolist() for _, bit, inv in self.lines]
            return out
        edges = np.linspace(t0, t1, limit // 2 + 1).round().astype(np.int64)
        out["bands"] = {"edges": edges.tolist(),
                        "counts": [np.diff(np.searchsorted(e, edges)).tolist() for e in self.edges]}
        return out


def pulses(frames: PortFrames, machine: Machine, t0: int, t1: int, limit: int = PULSE_FRAMES) -> dict:
    """The step and direction lines of every axis in [t0, t1) (see :class:`PulseIndex`)."""
    return PulseIndex(frames, machine).window(t0, t1, limit)
