"""Plots of a run, and the drawing rules every view of a run shares (PNG, HTML report, console).

The rules: rapids are dashed, cuts solid; on a lathe the stock and the part the cuts leave are
drawn under the path; an inset magnifies the worst distance between the commanded and the
carriage path, so a backlash of 0.1 mm on a 30 mm circle is visible; an axis is named once
("X transversal [mm]", not "X (X) [mm]"); titles say what ran, on what, in the user's words.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..machine.config import Machine
from ..runlog import RunLog
from ..sim import SimMachine

#: the step (mm) along Z at which the lathe part outline is sampled
PART_STEP_MM = 0.05


@dataclass(frozen=True)
class Segment:
    """One straight piece of the commanded tool path, in mm, and the command it came from."""

    kind: str                      # "rapid" (FMOV) or "cut" (PMOV)
    start: tuple[float, ...]
    end: tuple[float, ...]
    index: int                     # index of the command in the program


def toolpath(commands, machine: Machine, start_mm: tuple[float, ...] | None = None) -> list[Segment]:
    """The commanded path of ``commands`` as segments: FMOV a rapid, PMOV a cut (arcs are chords).

    >>> from retrofit.machine.config import load_machine
    >>> from retrofit.commands import parse_command
    >>> segs = toolpath([parse_command("FMOV X5 Z1"), parse_command("PMOV Z-4")], load_machine("chivu-lathe"))
    >>> [(s.kind, s.end) for s in segs]
    [('rapid', (5.0, 1.0)), ('cut', (5.0, -4.0))]
    """
    from ..commands import FMov, PMov
    names = machine.axis_names
    here = tuple(start_mm) if start_mm is not None else (0.0,) * len(names)
    out = []
    for i, cmd in enumerate(commands):
        if not isinstance(cmd, (FMov, PMov)):
            continue
        target = list(here)
        for name, mm in cmd.axes:
            if name.upper() in names:
                target[names.index(name.upper())] = float(mm)
        target = tuple(target)
        if target != here:
            out.append(Segment("rapid" if isinstance(cmd, FMov) else "cut", here, target, i))
        here = target
    return out


def is_lathe(machine: Machine) -> bool:
    """A lathe: its axes are X (radius) and Z (along the bed)."""
    return set(machine.axis_names) == {"X", "Z"}


def plane_axes(machine: Machine) -> tuple[int, int]:
    """Indices of the (horizontal, vertical) axes: Z along, X across on a lathe; else the first two."""
    names = machine.axis_names
    if is_lathe(machine):
        return names.index("Z"), names.index("X")
    return 0, min(1, len(names) - 1)


def axis_label(axis) -> str:
    """``X transversal [mm]``; an axis whose label is its name is named once: ``X [mm]``."""
    if axis.label.strip().upper() in ("", axis.name.upper()):
        return f"{axis.name} [mm]"
    return f"{axis.name} {axis.label} [mm]"


_STOCK = re.compile(r"stock[^\n]*?(\d+(?:\.\d+)?)\s*mm\s+diameter", re.IGNORECASE)


def stock_and_part(segments: list[Segment], machine: Machine, source_text: str = "") -> dict | None:
    """On a lathe: the stock (a bar) and the radius the cuts leave along Z; None elsewhere, and
    None when the program does not name its stock.

    The stock's diameter is read from a program comment such as ``Stock: bar of 44 mm diameter``;
    it reaches from the facing cut (a radial cut to the centre; else the
    cuts' rightmost Z) to 5 mm past the cuts' leftmost Z. The part's radius at each Z is the smallest radius a cut reached there.
    """
    if not is_lathe(machine):
        return None
    x, z = machine.axis_names.index("X"), machine.axis_names.index("Z")
    cuts = [s for s in segments if s.kind == "cut"]
    if not cuts:
        return None
    found = _STOCK.search(source_text)
    if found is None:
        return None
    radius = float(found.group(1)) / 2
    facing = [s for s in cuts if abs(s.start[z] - s.end[z]) < 1e-9 and min(s.start[x], s.end[x]) <= 0.5]
    z_right = max(s.start[z] for s in facing) if facing else max(max(s.start[z], s.end[z]) for s in cuts)
    z_left = min(min(s.start[z], s.end[z]) for s in cuts) - 5.0
    grid = np.arange(z_left, z_right + PART_STEP_MM / 2, PART_STEP_MM)
    part = np.full(len(grid), radius)
    for s in cuts:
        z0, z1, x0, x1 = s.start[z], s.end[z], s.start[x], s.end[x]
        lo, hi = sorted((z0, z1))
        sel = (grid >= lo - PART_STEP_MM / 2) & (grid <= hi + PART_STEP_MM / 2)
        if not sel.any():
            continue
        if hi - lo < 1e-9:                   # a radial cut: it reaches its lowest radius there
            xs = np.full(int(sel.sum()), min(x0, x1))
        else:
            xs = np.interp(grid[sel], [z0, z1], [x0, x1]) if z0 < z1 else np.interp(grid[sel], [z1, z0], [x1, x0])
        part[sel] = np.minimum(part[sel], xs)
    return {"radius_mm": radius, "z_mm": (z_left, z_right), "part_z": grid, "part_x": np.clip(part, 0.0, radius)}


def worst_error_point(log: RunLog, sim: SimMachine, h: int, v: int) -> tuple[float, float, float, str] | None:
    """(h_mm, v_mm, error_mm, axis) at the reached point where an axis's carriage lies furthest
    from its target: the figure the run's summary gives per axis (its worst error), so the plot
    and the summary name one and the same number."""
    machine = log.machine
    ah, av = machine.axes[h], machine.axes[v]
    best = None
    for w in log.waypoints:
        if w.reached_tick is None:
            continue
        state = sim.state_at(w.reached_tick)
        for a, steps in zip(machine.axes, w.steps):
            err = abs(state[a.name][1] - a.to_mm(steps))
            if best is None or err > best[2]:
                best = (ah.to_mm(w.steps[h]), av.to_mm(w.steps[v]), float(err), a.name)
    return best


def has_backlash(machine: Machine) -> bool:
    """Whether any axis has a clearance: compensated (``backlash_mm``) or simulated (a dead band)."""
    return any(a.backlash_mm > 0 for a in machine.axes) or any(v > 0 for v in machine.sim.dead_band_mm.values())


def user_title(machine: Machine, what: str, backlash_comp: bool | None = None) -> str:
    """What ran, on which machine, in words: ``lathe-profile.ngc on the chivu-lathe, backlash
    compensation on``; the backlash compensation is named only on a machine with backlash."""
    title = f"{what} on the {machine.name}" if what else machine.name
    if backlash_comp is not None and has_backlash(machine):
        title += f", backlash compensation {'on' if backlash_comp else 'off'}"
    return title


def plot_run(args, log: RunLog, sim: SimMachine, commands=None, target: Path | None = None,
             program: tuple[str, str] | None = None) -> Path:
    """``--plot FILE.png`` of a ``retrofit run`` or ``retrofit demo``: its title in the user's words.

    ``program`` is the run's (name, G-code text) when the caller has read it already (stdin).
    """
    source = ""
    if program is not None:
        what, source = program
    elif getattr(args, "program", None):
        from .program import resolve_program
        path = resolve_program(args.program)
        what, source = path.name, path.read_text(errors="replace")
    elif getattr(args, "which", "") == "circle":
        what = f"circle (r = {args.radius:g} mm, {args.points} points)"
    else:
        what = getattr(args, "which", "")
    title = user_title(log.machine, what, not getattr(args, "no_backlash_comp", False))
    return plot_path(log, sim, target or args.plot, title, commands, source)


def plot_path(log: RunLog, sim: SimMachine, path: str | Path, title: str = "", commands=None,
              source_text: str = "") -> Path:
    """Commanded path and carriage path in the machine's main plane; returns the PNG path.

    ``commands`` (the program's) let rapids be told from cuts; without them the commanded path
    is the controller's waypoints, drawn solid. ``source_text`` (the G-code) may name the stock.
    """
    from .. import hold
    from ..atomic import staged
    plt = _pyplot()
    fig = run_figure(log, sim, title, commands, source_text)
    path = Path(path)
    hold.on_draw(fig, path.name)
    try:
        with staged(path) as tmp:          # complete or absent, even on Ctrl-C
            fig.savefig(tmp, dpi=120, bbox_inches="tight", format=path.suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    return path


def run_figure(log: RunLog, sim: SimMachine, title: str = "", commands=None, source_text: str = ""):
    """The matplotlib figure :func:`plot_path` saves: its first axes the path in the main plane
    (with the inset as a child axes); on a mill a second one, the side view (X and Z), where the
    plunges and drill points show."""
    plt = _pyplot()
    machine = log.machine
    h, v = plane_axes(machine)
    side = side_axes(machine)
    fig, axes = plt.subplots(2 if side else 1, 1, figsize=(8, 9.5 if side else 6), squeeze=False,
                             gridspec_kw={"height_ratios": [2, 1]} if side else None)
    ax = axes[0][0]
    segments = toolpath(commands, machine, tuple(a.to_mm(s) for a, s in zip(machine.axes, log.start_steps))) \
        if commands is not None else []
    lathe = stock_and_part(segments, machine, source_text)
    if lathe is not None:
        _draw_lathe(ax, lathe)
    carriage = carriage_path(sim)
    _draw_view(ax, log, segments, carriage, h, v)
    ax.set_title(title or user_title(machine, ""), fontsize=10)
    _mark_plunges(ax, segments, h, v, side)
    worst = worst_error_point(log, sim, h, v)
    if worst is not None and round(worst[2], 3) > 0:        # only an error a reader can see
        _inset(ax, segments, log, carriage, h, v, worst)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    if side:
        low = axes[1][0]
        _draw_view(low, log, segments, carriage, *side)
        _mark_plunges(low, segments, *side, side)
        low.set_title("side view: Z against X (plunges and drill points marked)", fontsize=9)
    return fig


def side_axes(machine: Machine) -> tuple[int, int] | None:
    """(X, Z) indices for a mill's side view; None on a lathe or a machine without both."""
    names = machine.axis_names
    if is_lathe(machine) or "X" not in names or "Z" not in names:
        return None
    return names.index("X"), names.index("Z")


def _draw_view(ax, log: RunLog, segments, carriage, h: int, v: int) -> None:
    """The commanded path and the carriage's in the plane of axes ``h`` and ``v``."""
    machine = log.machine
    ah, av = machine.axes[h], machine.axes[v]
    if segments:
        _draw_segments(ax, segments, h, v)
    else:
        commanded = np.array([log.start_steps] + [w.steps for w in log.waypoints], float)
        ax.plot(commanded[:, h] / ah.steps_per_mm, commanded[:, v] / av.steps_per_mm, "-", lw=1.0,
                color="tab:blue", label="commanded")
    ax.plot(carriage[:, h], carriage[:, v], "-", lw=2.5, color="tab:red", alpha=0.25, zorder=1,
            label="carriage (simulated)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(axis_label(ah))
    ax.set_ylabel(axis_label(av))
    ax.grid(True, lw=0.3)


def _mark_plunges(ax, segments, h: int, v: int, side) -> None:
    """On a mill, where a cut goes down along Z alone (a plunge, a drill point): a marker at its bottom."""
    if not side:
        return
    z = side[1]
    bottoms = [s.end for s in segments if s.kind == "cut" and s.end[z] < s.start[z]
               and all(a == b for i, (a, b) in enumerate(zip(s.start, s.end)) if i != z)]
    if bottoms:
        pts = np.array(bottoms)
        ax.plot(pts[:, h], pts[:, v], "v", ms=5, color="tab:green", ls="none",
                label=f"plunge / drill point ({len(bottoms)})", zorder=3)


def _pyplot():
    import matplotlib
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg") and not _has_display():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _draw_lathe(ax, lathe: dict) -> None:
    z_left, z_right = lathe["z_mm"]
    r = lathe["radius_mm"]
    ax.fill_between([z_left, z_right], 0, r, color="0.88", lw=0, label=f"stock (diameter {2 * r:g} mm)")
    ax.fill_between(lathe["part_z"], 0, lathe["part_x"], color="tab:olive", alpha=0.45, lw=0,
                    label="part left by the cuts")
    ax.axhline(0.0, color="0.3", lw=0.6, ls="-.")          # the spindle axis


def _draw_segments(ax, segments: list[Segment], h: int, v: int) -> None:
    for kind, style in (("rapid", dict(ls=(0, (4, 3)), color="tab:gray", lw=0.9, label="rapid (G0)")),
                        ("cut", dict(ls="-", color="tab:blue", lw=1.1, label="cut (G1/G2/G3)"))):
        xs, ys = [], []
        for s in segments:
            if s.kind == kind:
                xs += [s.start[h], s.end[h], np.nan]
                ys += [s.start[v], s.end[v], np.nan]
        if xs:
            ax.plot(xs, ys, **style)


def _inset(ax, segments, log: RunLog, carriage: np.ndarray, h: int, v: int, worst) -> None:
    """A magnifying inset around the worst commanded-vs-carriage distance."""
    ch, cv, err, axis = worst
    half = max(4 * err, 20 * log.machine.axes[h].step_mm)
    ins = ax.inset_axes([1.06, 0.25, 0.5, 0.5])
    if segments:
        _draw_segments(ins, segments, h, v)
    else:
        commanded = np.array([w.steps for w in log.waypoints], float)
        ins.plot(commanded[:, h] * log.machine.axes[h].step_mm, commanded[:, v] * log.machine.axes[v].step_mm,
                 "-", color="tab:blue", lw=1.1)
    ins.plot(carriage[:, h], carriage[:, v], "-", lw=1.0, color="tab:red")
    ins.plot([ch], [cv], "o", ms=3, color="black")
    ins.set_xlim(ch - half, ch + half)
    ins.set_ylim(cv - half, cv + half)
    ins.set_aspect("equal")
    ins.tick_params(labelsize=6)
    factor = (ax.get_xlim()[1] - ax.get_xlim()[0]) / (2 * half)
    ins.set_title(f"magnified x{factor:.0f}: worst error {err:.3f} mm ({axis})", fontsize=7)
    ins.set_xlabel("commanded (blue, grey) and carriage (red)", fontsize=7)
    ax.indicate_inset_zoom(ins, edgecolor="0.2")


def carriage_path(sim: SimMachine, points: int | None = None) -> np.ndarray:
    """Carriage positions (mm) of every axis at every tick where any axis stepped (with ``points``:
    at every n-th of those ticks, n chosen to give about that many)."""
    names = sim.machine.axis_names
    ticks = np.concatenate([np.asarray(sim.traces[n].ticks, np.int64) for n in names] + [[0]])
    ticks.sort()
    ticks = ticks[np.concatenate(([True], ticks[1:] != ticks[:-1]))]       # each tick once
    if points:
        ticks = ticks[::max(1, len(ticks) // points)]
    cols = []
    for i, name in enumerate(names):
        trace = sim.traces[name]
        t = np.asarray(trace.ticks, np.int64)
        values = np.concatenate(([sim._initial[i][1]], np.asarray(trace.carriage_mm, float)))
        cols.append(values[np.searchsorted(t, ticks, side="right")])
    return np.column_stack(cols)


def _has_display() -> bool:
    import os
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
