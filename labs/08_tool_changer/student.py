"""Lab 08 (your file): the tool changer of the mill — X, Y, Z and the carousel over time during a T3 -> T7 change."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from retrofit.atc.cell import SimCell
from retrofit.atc.magazine import MagazineState
from retrofit.atc.sequences import change_sequence
from retrofit.atc.settings import atc_of
from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure

MACHINE = "tul-mill"
FROM_TOOL, TO_TOOL = 3, 7
START_MM = {"X": 5.0, "Y": 5.0, "Z": -5.0, "E": 0.0}   # where the mill stands before the change
AXES = ("X", "Y", "Z", "E")
#: how far below Z_POINT_1 (mm) still counts as at it: float noise, far under one step
EPS_MM = 1e-6


def run_change(machine, current: int = FROM_TOOL, new: int = TO_TOOL) -> SimCell:
    """Change from tool ``current`` to ``new`` on the simulated mill; return the simulated cell."""
    atc = atc_of(machine)
    cell = SimCell(machine, MagazineState.loaded(machine, current), start_mm=START_MM)
    cell.run(change_sequence(atc, current, new, machine.name).commands())
    return cell


def pocket_angle_deg(geometry, pocket: int) -> float:
    """Where ``pocket`` sits on the disc, degrees from its 0° mark (pocket 1 at 80°, then every 20°)."""
    # TODO 1 (README, task 1): the hints there open one at a time.
    raise NotImplementedError("TODO 1: write pocket_angle_deg(geometry, pocket): where the pocket sits on the disc")


def carousel_position(geometry, pocket: int) -> float:
    """The carousel-axis position (units) that brings ``pocket`` to the spindle.

    The disc must turn by the pocket's angle plus the station's (where the spindle meets the disc);
    one unit turns it ``degrees_per_unit``.
    """
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write carousel_position(geometry, pocket): the carousel units for a pocket")


def over_time(cell, axis: str, start: float) -> tuple[np.ndarray, np.ndarray]:
    """The carriage of ``axis`` over time: (seconds, mm), from (0, start) then after each step.

    The carousel (axis E) in degrees of the disc, not in its units.
    """
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write over_time(cell, axis, start): (seconds, position) of one axis")


def position_at(t_s, values, t):
    """The position at time ``t`` (a number or an array): the last value at or before it."""
    # TODO 4 (README, task 4): the hints there open one at a time.
    raise NotImplementedError("TODO 4: write position_at(t_s, values, t): the position at a time")


def unsafe_turns(traces: dict, atc) -> list[float]:
    """The times (s) of every carousel step taken while the spindle was inside the magazine zone
    (Y beyond ``atc.sim.magazine_y_mm``) below the safe height Z_POINT_1 (Z+ is up)."""
    # TODO 5 (README, task 5): the hints there open one at a time.
    raise NotImplementedError("TODO 5: write unsafe_turns(traces, atc): the carousel steps taken while unsafe")


def all_over_time(cell) -> dict:
    """X, Y, Z (mm) and the carousel (degrees) over time."""
    return {name: over_time(cell, name, START_MM[name]) for name in AXES}


def turning_spans(t_e, gap_s: float = 0.05) -> list[tuple[float, float]]:
    """The intervals during which the carousel turns: its steps, grouped where they follow closely."""
    steps = np.asarray(t_e)[1:]
    if not len(steps):
        return []
    breaks = np.flatnonzero(np.diff(steps) > gap_s)
    starts = np.concatenate([[steps[0]], steps[breaks + 1]])
    ends = np.concatenate([steps[breaks], [steps[-1]]])
    return list(zip(starts.tolist(), ends.tolist()))


def plot_timeline(cell, traces: dict, out_dir) -> Path:
    """Four stacked panels: X, Y, Z and the carousel against time, the carousel's turns shaded."""
    plt = pyplot()
    atc = atc_of(cell.machine)
    geometry = atc.sim
    fig, panels = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    spans = turning_spans(traces["E"][0])
    end = max(t[-1] for t, _ in traces.values()) + 0.2
    for ax, name in zip(panels, AXES):
        t, v = traces[name]
        ax.step(np.append(t, end), np.append(v, v[-1]), where="post", lw=1.3)
        for k, (a, b) in enumerate(spans):
            ax.axvspan(a, b, color="tab:orange", alpha=0.2, label="carousel turning" if k == 0 else None)
        for tick, what in cell.magazine.events:
            ax.axvline(tick * cell.machine.tick_s, color="tab:green", lw=0.8, ls="--")
        ax.grid(True, lw=0.3)
    x_ax, y_ax, z_ax, e_ax = panels
    x_ax.axhline(atc.x1, color="gray", lw=0.8, ls=":", label=f"X1 {atc.x1:g}")
    x_ax.set_ylabel("X [mm]")
    y_ax.axhspan(geometry.magazine_y_mm, atc.y_point_b + 2, color="0.85", label="magazine zone")
    y_ax.axhline(atc.y_point_a, color="gray", lw=0.8, ls=":", label=f"Y_POINT_A {atc.y_point_a:g}")
    y_ax.axhline(atc.y_point_b, color="gray", lw=0.8, ls="-.", label=f"Y_POINT_B {atc.y_point_b:g}")
    y_ax.set_ylabel("Y [mm]")
    z_ax.axhline(atc.z_point_1, color="tab:red", lw=0.8, ls=":", label=f"Z_POINT_1 {atc.z_point_1:g} (safe)")
    z_ax.axhline(atc.z_point_2, color="gray", lw=0.8, ls="-.", label=f"Z_POINT_2 {atc.z_point_2:g} (clamp)")
    z_ax.set_ylabel("Z [mm], up is +")
    for tool in (FROM_TOOL, TO_TOOL):
        angle = carousel_position(geometry, tool) * geometry.degrees_per_unit
        e_ax.axhline(angle, color="gray", lw=0.8, ls=":")
        e_ax.annotate(f"pocket {tool}: {angle:g}°", (0.0, angle), xytext=(2, 3), textcoords="offset points",
                      fontsize=8)
    e_ax.set_ylabel("carousel [deg]")
    e_ax.set_xlabel("time [s] (dashed: " + "; ".join(what for _, what in cell.magazine.events) + ")")
    for ax in panels:
        ax.legend(fontsize=7, loc="upper right")
    fig.suptitle(f"{MACHINE}: T{FROM_TOOL} -> T{TO_TOOL}, what the simulated axes did")
    return save_figure(fig, out_dir, "timeline.png")


def plot_carousel(cell, traces: dict, out_dir) -> Path:
    """The disc with its pockets, and the spindle's path in Y-Z with where the carousel turned."""
    plt = pyplot()
    atc = atc_of(cell.machine)
    geometry = atc.sim
    fig = plt.figure(figsize=(11, 5))
    disc = fig.add_subplot(1, 2, 1, projection="polar")
    disc.set_theta_zero_location("N")
    for pocket in range(1, atc.pockets + 1):
        angle = np.radians(pocket_angle_deg(geometry, pocket))
        colour = "tab:red" if pocket == FROM_TOOL else "tab:green" if pocket == TO_TOOL else "tab:blue"
        disc.plot([angle], [1.0], "o", ms=14, color=colour, alpha=0.7)
        disc.annotate(f"{pocket}", (angle, 1.0), ha="center", va="center", fontsize=8, color="white")
        disc.annotate(f"{pocket_angle_deg(geometry, pocket):g}°", (angle, 1.25), ha="center", fontsize=7)
    disc.plot([0, 0], [0, 1.4], "k-", lw=0.8)
    disc.set_rticks([])
    disc.set_ylim(0, 1.45)
    disc.set_title(f"the disc at home: pocket n at {geometry.first_pocket_deg:g} + "
                   f"{geometry.pocket_pitch_deg:g}(n-1) deg\n(red T{FROM_TOOL}, green T{TO_TOOL})", fontsize=9)
    side = fig.add_subplot(1, 2, 2)
    t_y, y = traces["Y"]
    t_z, z = traces["Z"]
    times = np.unique(np.concatenate([t_y, t_z]))
    side.plot(position_at(t_y, y, times), position_at(t_z, z, times), lw=1.0, label="spindle path")
    t_e = traces["E"][0][1:]
    side.plot(position_at(t_y, y, t_e), position_at(t_z, z, t_e), ".", ms=4, color="tab:orange",
              label="where the carousel turned")
    side.axvspan(geometry.magazine_y_mm, atc.y_point_b + 2, color="0.85", label="magazine zone")
    side.axhline(atc.z_point_1, color="tab:red", lw=0.8, ls=":", label="Z_POINT_1 (safe)")
    side.set_xlabel("Y [mm]")
    side.set_ylabel("Z [mm], up is +")
    side.set_title("side view: the spindle in Y-Z", fontsize=9)
    side.grid(True, lw=0.3)
    side.legend(fontsize=8)
    return save_figure(fig, out_dir, "carousel.png")


def main(out_dir="out") -> list[Path]:
    """Run the T3 -> T7 change, extract the axes over time, check the carousel's turns, plot."""
    machine = load_machine(MACHINE)
    atc = atc_of(machine)
    for pocket in (FROM_TOOL, TO_TOOL):
        print(f"pocket {pocket}: at {pocket_angle_deg(atc.sim, pocket):g} deg on the disc, "
              f"carousel position {carousel_position(atc.sim, pocket):g}")
    cell = run_change(machine)
    traces = all_over_time(cell)
    unsafe = unsafe_turns(traces, atc)
    print(f"{len(traces['E'][0]) - 1} carousel steps, {len(unsafe)} of them with the spindle down in the magazine")
    print("the simulated magazine:", "; ".join(what for _, what in cell.magazine.events),
          f"-> T{cell.magazine.state.spindle} in the spindle; violations: {cell.violations or 'none'}")
    return [plot_timeline(cell, traces, out_dir), plot_carousel(cell, traces, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
