"""Lab 07: tuning the 1 ms position loop — step responses for several gains, model against simulation."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from retrofit.camlink.model import loop_model, step_comparison
from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure

MACHINE = "grenoble-mill"
AXIS = "X"
GAINS = [0.1, 0.2, 0.3, 0.5, 1.0, 2.0]
STEP_MM = 0.2            # small enough that the drive (feed 255) does not saturate
PERIODS = 300            # loop periods of 1 ms
BAND = 0.02              # settled: within 2 % of the step for good
MAX_OVERSHOOT = 5.0      # per cent, for the best gain


def with_gains(machine, kp: float, ki: float = 0.0):
    """The machine with the loop gains of its ``[servo]`` section replaced."""
    servo = replace(machine.parts["servo"], kp=kp, ki=ki)
    return replace(machine, parts={**machine.parts, "servo": servo})


def overshoot_percent(setpoint, position) -> float:
    """How far the response went past a step from 0, in per cent of the step (0 if never past)."""
    step = float(setpoint[-1])
    peak = max(position) if step > 0 else -min(position)
    return max(0.0, 100.0 * (peak - abs(step)) / abs(step))


def settling_time_ms(t_s, setpoint, position, band: float = BAND) -> float:
    """The time from which the response stays within ``band`` of the step for good, in ms.

    ``math.inf`` when it is still outside the band at the last sample.
    """
    step = float(setpoint[-1])
    outside = [i for i, (r, y) in enumerate(zip(setpoint, position)) if abs(r - y) > band * abs(step)]
    if not outside:
        return 0.0
    last = outside[-1]
    return math.inf if last == len(position) - 1 else float(t_s[last + 1]) * 1000.0


def best_gain(metrics: dict[float, tuple[float, float]], max_overshoot: float = MAX_OVERSHOOT) -> float:
    """The gain that settles soonest with no more overshoot than allowed (simulation's figures).

    ``metrics`` maps kp to (overshoot %, settling time ms).
    """
    allowed = {kp: settle for kp, (over, settle) in metrics.items() if over <= max_overshoot}
    return min(allowed, key=lambda kp: (allowed[kp], kp))


def responses(machine) -> dict:
    """The step response of model and simulation for every gain of GAINS."""
    return {kp: step_comparison(with_gains(machine, kp), AXIS, STEP_MM, PERIODS) for kp in GAINS}


def metrics_of(runs: dict, which: str) -> dict[float, tuple[float, float]]:
    """kp -> (overshoot %, settling time ms) of the model ("model") or the simulation ("sim")."""
    return {kp: (overshoot_percent(c.setpoint, getattr(c, which)),
                 settling_time_ms(c.t_s, c.setpoint, getattr(c, which))) for kp, c in runs.items()}


def plot_steps(runs: dict, out_dir) -> Path:
    """Step responses, model (lines) and simulation (dots), one colour per gain."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5))
    for kp, c in runs.items():
        line, = ax.plot(c.t_s * 1e3, c.model, lw=1.2, label=f"kp = {kp:g}")
        ax.plot(c.t_s[::4] * 1e3, c.sim[::4], ".", ms=3, color=line.get_color())
    first = next(iter(runs.values()))
    ax.plot(first.t_s * 1e3, first.setpoint, "k--", lw=0.8, label="set-point")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("encoder position [pulses]")
    ax.set_title(f"{MACHINE} {AXIS}: {STEP_MM:g} mm step; lines python-control model, dots simulated loop")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "step_responses.png")


def plot_metrics(model: dict, sim: dict, best: float, out_dir) -> Path:
    """Overshoot and settling time against the gain, model and simulation."""
    plt = pyplot()
    fig, (over_ax, settle_ax) = plt.subplots(1, 2, figsize=(11, 4))
    for label, values, style in (("model", model, "o-"), ("simulation", sim, "s--")):
        gains = list(values)
        line, = over_ax.plot(gains, [values[k][0] for k in gains], style, label=label)
        settled = [k for k in gains if math.isfinite(values[k][1])]
        settle_ax.plot(settled, [values[k][1] for k in settled], style, color=line.get_color(), label=label)
        never = [k for k in gains if not math.isfinite(values[k][1])]
        if never:                  # not a time: drawn as an arrow above the others, off the scale
            settle_ax.plot(never, [0.95] * len(never), "^", ms=9, color=line.get_color(), mfc="none",
                           transform=settle_ax.get_xaxis_transform(), clip_on=False,
                           label=f"{label}: not settled within {PERIODS} ms")
    over_ax.axhline(MAX_OVERSHOOT, color="gray", lw=0.8, ls=":", label=f"{MAX_OVERSHOOT:g} % allowed")
    over_ax.set_title("overshoot against the gain")
    settle_ax.set_title(f"settling time against the gain (run of {PERIODS} ms)")
    for ax, name in ((over_ax, "overshoot [%]"), (settle_ax, f"settling time to {100 * BAND:g} % [ms]")):
        ax.axvline(best, color="tab:green", lw=0.8, label=f"best kp = {best:g}")
        ax.set_xscale("log")
        ax.set_xlabel("kp [feed units per pulse of error]")
        ax.set_ylabel(name)
        ax.grid(True, which="both", lw=0.3)
    over_ax.legend(fontsize=8, loc="upper left")
    settle_ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{MACHINE} {AXIS}: tuning kp on a {STEP_MM:g} mm step, model and simulation", y=1.02)
    return save_figure(fig, out_dir, "tuning.png")


def plot_poles(machine, out_dir) -> Path:
    """Closed-loop poles in the z-plane for every gain (python-control)."""
    import control
    import numpy as np
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    circle = np.linspace(0, 2 * np.pi, 200)
    ax.plot(np.cos(circle), np.sin(circle), "k:", lw=0.6)
    every = []
    for kp in GAINS:
        poles = control.poles(loop_model(with_gains(machine, kp), AXIS).y_from_r)
        ax.plot(poles.real, poles.imag, "x", ms=7, label=f"kp = {kp:g}")
        every.extend(poles)
    reach = max(abs(p.imag) for p in every) + 0.02
    ax.set_xlim(min(p.real for p in every) - 0.02, 1.02)
    ax.set_ylim(-reach, reach)
    ax.set_xlabel("Re z (z-plane, 1 ms sampling)")
    ax.set_ylabel("Im z")
    ax.set_title("closed-loop poles near z = 1 (unit circle dotted)")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, out_dir, "poles.png")


def main(out_dir="out") -> list[Path]:
    """Step responses for every gain; overshoot and settling; the best gain; poles."""
    machine = load_machine(MACHINE)
    runs = responses(machine)
    model, sim = metrics_of(runs, "model"), metrics_of(runs, "sim")
    for kp in GAINS:
        print(f"kp {kp:g}: overshoot model {model[kp][0]:.1f} %, sim {sim[kp][0]:.1f} %; "
              f"settling model {model[kp][1]:.0f} ms, sim {sim[kp][1]:.0f} ms")
    best = best_gain(sim)
    print(f"best gain (simulation, overshoot <= {MAX_OVERSHOOT:g} %): kp = {best:g}")
    return [plot_steps(runs, out_dir), plot_metrics(model, sim, best, out_dir), plot_poles(machine, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
