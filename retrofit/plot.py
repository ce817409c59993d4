"""Plots of a run: commanded path against the carriage path, in mm, saved as PNG (headless-safe)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .config import Machine
from .runlog import RunLog
from .sim import SimMachine


def plane_axes(machine: Machine) -> tuple[int, int]:
    """Indices of the (horizontal, vertical) axes: Z along, X across on a lathe; else the first two."""
    names = machine.axis_names
    if set(names) == {"X", "Z"}:
        return names.index("Z"), names.index("X")
    return 0, min(1, len(names) - 1)


def carriage_path(sim: SimMachine) -> np.ndarray:
    """Carriage positions (mm) of every axis at every tick where any axis stepped."""
    names = sim.machine.axis_names
    ticks = np.unique(np.concatenate([np.asarray(sim.traces[n].ticks, np.int64) for n in names] + [[0]]))
    cols = []
    for i, name in enumerate(names):
        trace = sim.traces[name]
        t = np.asarray(trace.ticks, np.int64)
        values = np.concatenate(([sim._initial[i][1]], np.asarray(trace.carriage_mm, float)))
        cols.append(values[np.searchsorted(t, ticks, side="right")])
    return np.column_stack(cols)


def plot_path(log: RunLog, sim: SimMachine, path: str | Path, title: str = "") -> Path:
    """Commanded path and carriage path in the machine's main plane; returns the PNG path."""
    import matplotlib
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg") and not _has_display():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    machine = log.machine
    h, v = plane_axes(machine)
    ah, av = machine.axes[h], machine.axes[v]
    commanded = np.array([log.start_steps] + [w.steps for w in log.waypoints], float)
    carriage = carriage_path(sim)
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(commanded[:, h] / ah.steps_per_mm, commanded[:, v] / av.steps_per_mm, "o-", ms=2.5,
            lw=0.8, color="tab:blue", label="commanded")
    ax.plot(carriage[:, h], carriage[:, v], "-", lw=0.8, color="tab:red", alpha=0.8, label="carriage (simulated)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{ah.name} ({ah.label}) [mm]")
    ax.set_ylabel(f"{av.name} ({av.label}) [mm]")
    ax.set_title(title or f"{machine.name}: commanded vs carriage path")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best")
    path = Path(path)
    from .atomic import staged
    try:
        with staged(path) as tmp:          # complete or absent, even on Ctrl-C
            fig.savefig(tmp, dpi=120, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def _has_display() -> bool:
    import os
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
