"""Lab 12 (reference solution): the lathe paper's position-error loop, axis by axis, with backlash
compensation, checked by the carriage on a simulated screw with a real dead band."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from retrofit.machine.config import load_machine
from retrofit.frames import PinMap, PortFrames
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.stepgen import StepGenerator, StepTiming
from retrofit.sim import SimMachine

MACHINE = "chivu-lathe"
#: the plots' path in mm (X, Z): every leg reverses at least one axis
ZIGZAG_MM = [(1.0, 0.5), (0.2, 1.2), (0.9, 0.3), (0.1, 0.9), (0.7, 0.0), (0.0, 0.6)]


def turn(position: int, direction: int, new_direction: int, clearance: int) -> tuple[int, int]:
    """'AvansTransversalDreapta' and friends: the direction turns to ``new_direction`` (+1 / -1).

    Returns (instantaneous position, direction). On a reversal the instantaneous position moves
    by the clearance against the new direction, so the loop issues that many extra steps.
    """
    if new_direction == direction:
        return position, direction
    return position - clearance * new_direction, new_direction


def evaluate_axis(desired: int, position: int, direction: int, clearance: int,
                  can_turn: bool) -> tuple[int, int, bool]:
    """One axis of 'EvaluateEroare': (instantaneous position, direction, whether to ask for a step).

    ``can_turn`` is False while the step generator may not change direction (the hold time after
    a step): then nothing happens this tick.
    """
    error = desired - position
    if error == 0:
        return position, direction, False
    wanted = 1 if error > 0 else -1
    if wanted != direction:
        if not can_turn:
            return position, direction, False
        position, direction = turn(position, direction, wanted, clearance)
    return position, direction, True


def run_loop(machine, targets, backlash_comp: bool = True, start_steps=None) -> dict:
    """The timer loop of 003 through every target: port bytes, reached ticks and the readout.

    Each tick: every step generator gives its bits ('PasAvans'), the port byte is written once
    ('CalculByte', 'WritePort'); then, while a target is loaded, every axis is evaluated; when all
    errors were zero the target is reached and the next one loaded ('CalcNextInput'). The run ends
    on the first tick after the last target with no pulse under way.

    Returns a dict of plain lists: ``ticks`` and ``values`` (the port byte where it changes),
    ``end_tick`` (one past the last frame), ``reached`` (the tick each target was reached) and
    ``readout``: ``[tick, axis name, instantaneous position]`` every time that position changes.
    """
    axes = machine.axes
    gens = [StepGenerator(StepTiming.of(a)) for a in axes]
    clearance = [a.backlash_steps if backlash_comp else 0 for a in axes]
    position = [int(s) for s in (start_steps or [0] * len(axes))]
    pins = PinMap(machine)
    waiting = [[int(s) for s in t] for t in targets]
    out = {"ticks": [], "values": [], "end_tick": 0, "reached": [], "readout": []}
    desired = waiting.pop(0) if waiting else None
    tick = 0
    while True:
        bits = [g.frame() for g in gens]
        byte = pins.byte([b[0] for b in bits], [b[1] for b in bits])
        if not out["values"] or byte != out["values"][-1]:
            out["ticks"].append(tick)
            out["values"].append(byte)
        if desired is None and not any(g.busy for g in gens):
            break
        if desired is not None:
            errors = [d - p for d, p in zip(desired, position)]
            for i, (axis, gen) in enumerate(zip(axes, gens)):
                pos, direction, step = evaluate_axis(desired[i], position[i], gen.direction, clearance[i],
                                                     gen.can_change_direction())
                if direction != gen.direction:
                    gen.set_direction(direction)
                if pos != position[i]:
                    out["readout"].append([tick, axis.name, pos])
                position[i] = pos
                if step and gen.start_step():
                    position[i] += direction
                    out["readout"].append([tick, axis.name, position[i]])
            if not any(errors):
                out["reached"].append(tick)
                desired = waiting.pop(0) if waiting else None
        tick += 1
    out["end_tick"] = tick + 1
    return out


def carriages(machine, run: dict, start_steps=None) -> list[list[float]]:
    """Feed a run's port bytes to a simulated machine (lead screws with their dead band): the
    carriage of every axis, mm, at each reached tick."""
    sim = SimMachine(machine, tuple(start_steps) if start_steps else None)
    sim.watch(run["reached"])
    sim.feed(PortFrames(run["ticks"], run["values"], run["end_tick"]))
    return [[sim.state_at(t)[a.name][1] for a in machine.axes] for t in run["reached"]]


def zigzag(machine) -> list[list[int]]:
    """The plots' targets in steps."""
    return [[machine.axis(name).to_steps(mm) for name, mm in zip(("X", "Z"), point)] for point in ZIGZAG_MM]


def plot_carriage(machine, targets, runs: dict, out_dir) -> Path:
    """Carriage minus target at every target, per axis, with and without compensation."""
    plt = pyplot()
    fig, panels = plt.subplots(1, len(machine.axes), figsize=(11, 4))
    for i, (ax, axis) in enumerate(zip(panels, machine.axes)):
        for label, (run, at) in runs.items():
            errors = [c[i] - axis.to_mm(t[i]) for c, t in zip(at, targets)]
            ax.plot(range(1, len(errors) + 1), errors, "o-", label=label)
        for sign in (1, -1):
            ax.axhline(sign * axis.step_mm, color="gray", ls="--", lw=0.8)
        ax.set_xlabel("target")
        ax.set_ylabel(f"{axis.name} carriage - target [mm]")
        ax.set_title(f"{axis.name}: dead band {machine.sim.dead_band_mm[axis.name]:.3f} mm, clearance "
                     f"{axis.backlash_steps} steps ({axis.backlash_steps * axis.step_mm:.3f} mm)", fontsize=9)
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("the zigzag: where the carriage stands when the loop says 'reached' (dashed: one step)")
    return save_figure(fig, out_dir, "carriage_error.png")


def plot_readout(machine, run: dict, axis_name: str, out_dir) -> Path:
    """The instantaneous position of one axis over the run: steps, and the jumps of each reversal."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(11, 4))
    points = [(t, p) for t, name, p in run["readout"] if name == axis_name]
    ax.step([t for t, _ in points], [p for _, p in points], where="post", label="instantaneous position (PozInst)")
    reached = run["reached"]
    ax.plot(reached, _at_ticks(points, reached), "o", label="target reached")
    ax.set_xlabel("tick")
    ax.set_ylabel(f"{axis_name} [steps]")
    ax.set_title(f"{axis_name}: each reversal shifts PozInst by the clearance "
                 f"({machine.axis(axis_name).backlash_steps} steps); the loop then steps it back", fontsize=10)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "readout.png")


def _at_ticks(points, ticks):
    """The last value of (tick, value) points at or before each tick."""
    out, k, value = [], 0, points[0][1] if points else 0
    for t in ticks:
        while k < len(points) and points[k][0] <= t:
            value = points[k][1]
            k += 1
        out.append(value)
    return out


def main(out_dir="out") -> list[Path]:
    """The zigzag on the lathe, compensated and not: the carriage at every target, and the readout."""
    machine = load_machine(MACHINE)
    machine = replace(machine, axes=tuple(replace(a, backlash_mm=machine.sim.dead_band_mm[a.name])
                                          for a in machine.axes))      # the clearance measured in lab 04
    targets = zigzag(machine)
    runs = {}
    for label, comp in (("compensated", True), ("not compensated", False)):
        run = run_loop(machine, targets, comp)
        runs[label] = (run, carriages(machine, run))
    for label, (run, at) in runs.items():
        worst = [max(abs(c[i] - a.to_mm(t[i])) for c, t in zip(at, targets)) for i, a in enumerate(machine.axes)]
        print(f"{label}: {run['end_tick']} ticks, worst carriage error "
              + ", ".join(f"{a.name} {w:.3f} mm" for a, w in zip(machine.axes, worst)))
    return [plot_carriage(machine, targets, runs, out_dir),
            plot_readout(machine, runs["compensated"][0], "X", out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
