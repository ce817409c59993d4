"""Lab 03: Bresenham (002) against digital integration (004) — where the short axis steps."""

from __future__ import annotations

import random
from pathlib import Path

from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.bresenham import bresenham_cycles, prepare_line
from retrofit.motion.dda import dda_positions

#: the lines of the lab: 2:1 and 3:2 as in the engraver paper's Figure 4, and a random one
_DRAW = random.Random(4)
LINES = {"2:1": (8, 4), "3:2": (9, 6), "random": (_DRAW.randint(12, 30), _DRAW.randint(3, 11))}


def bresenham_trace(dx: int, dy: int) -> list[tuple[int, int, int, int]]:
    """Execute phase of 002's Bresenham for a move of (dx, dy) steps: each axis's step and error term per cycle.

    The base axis (the longer one) steps every cycle; the other steps when the ideal line is
    more than half a step ahead of it. Each entry is (x step, y step, x error term, y error term)
    after the cycle: the steps -1, 0 or +1, the error terms as the handout counts them (starting
    at 0, growing by 2|d| each cycle, dropping by 2n when the axis steps).
    """
    n = max(abs(dx), abs(dy))
    sx, sy = (dx > 0) - (dx < 0), (dy > 0) - (dy < 0)
    error_x = error_y = 0                    # how far the ideal line is ahead, in 1/(2n) of a step
    steps = []
    for _ in range(n):
        error_x += 2 * abs(dx)
        error_y += 2 * abs(dy)
        step_x = step_y = 0
        if error_x > n:                      # more than half a step behind: step
            error_x -= 2 * n
            step_x = sx
        if error_y > n:
            error_y -= 2 * n
            step_y = sy
        steps.append((step_x, step_y, error_x, error_y))
    return steps


def bresenham_steps(dx: int, dy: int) -> list[tuple[int, int]]:
    """The step of each axis per cycle, (x step, y step), from :func:`bresenham_trace`."""
    return [(step_x, step_y) for step_x, step_y, *_ in bresenham_trace(dx, dy)]


class DigitalIntegrator:
    """004's counters for a line of ``n`` base pulses and ``d`` short-axis pulses.

    ``count`` is COUNT = n / d (base pulses per short pulse), ``long`` is LONG (base pulses sent),
    ``short`` is SHORT (where the next short pulse is due, in base intervals from the start; it
    starts at COUNT) and ``sent`` the short pulses sent so far.
    """

    def __init__(self, n: int, d: int):
        self.n, self.d = n, d
        self.count = n / d if d else float(n + 1)     # COUNT (no short pulse at all when d == 0)
        self.long = 0                                  # LONG
        self.short = self.count                        # SHORT
        self.sent = 0

    def base_pulse(self) -> float | None:
        """One base pulse: count it, and decide whether a short pulse follows it.

        Returns the delay of the short pulse after this base pulse, in base intervals (the
        engraver times it with its clock), or None when no short pulse is due in this interval.
        """
        self.long += 1                                 # LONG: this base pulse is sent
        if self.sent < self.d and int(self.short) == self.long:
            delay = self.short - self.long             # 004: the short pulse comes (SHORT - LONG) / f later
            self.short += self.count                   # SHORT: where the next one is due
            self.sent += 1
            return delay
        return None


def dda_short_pulses(n: int, d: int) -> list[float]:
    """Where the ``d`` short-axis pulses of a line of ``n`` base pulses fall, in base intervals.

    Base pulse k is at k; a short pulse decided after base pulse LONG with delay t is at LONG + t.
    """
    integrator = DigitalIntegrator(n, d)
    pulses = []
    for _ in range(n):
        delay = integrator.base_pulse()
        if delay is not None:
            pulses.append(integrator.long + delay)
    return pulses


def lattice_path(steps) -> list[tuple[int, int]]:
    """The lattice points visited: (0, 0) and the point after every cycle."""
    x = y = 0
    points = [(0, 0)]
    for step_x, step_y in steps:
        x, y = x + step_x, y + step_y
        points.append((x, y))
    return points


def _bresenham(dx, dy):
    """The student's Bresenham if written, else the library's (and which one it was)."""
    try:
        return bresenham_steps(dx, dy), "your bresenham_steps"
    except NotImplementedError:
        cycles = bresenham_cycles(prepare_line((0, 0), (dx, dy)))
        n = max(abs(dx), abs(dy))
        sx, sy = (dx > 0) - (dx < 0), (dy > 0) - (dy < 0)
        sets = [set(c.tolist()) for c in cycles]
        return [(sx if k in sets[0] else 0, sy if k in sets[1] else 0) for k in range(1, n + 1)], "library"


def _dda(n, d):
    try:
        return dda_short_pulses(n, d), "your dda_short_pulses"
    except NotImplementedError:
        return dda_positions(prepare_line((0, 0), (n, d)))[1].tolist(), "library"


def plot_lines(out_dir) -> Path:
    """Per line: the lattice path against the ideal line, and the two methods' pulse trains."""
    plt = pyplot()
    fig, rows = plt.subplots(len(LINES), 2, figsize=(13, 3.4 * len(LINES)),
                             gridspec_kw={"width_ratios": [1, 1.6], "hspace": 0.5, "wspace": 0.4})
    for (label, (dx, dy)), (path_ax, pulse_ax) in zip(LINES.items(), rows):
        steps, who_b = _bresenham(dx, dy)
        short, who_d = _dda(dx, dy)
        points = lattice_path(steps)
        path_ax.plot([0, dx], [0, dy], "k--", lw=0.8, label="ideal line")
        path_ax.plot(*zip(*points), "o-", ms=3, lw=1.0, label=f"Bresenham ({who_b})")
        path_ax.set_aspect("equal")
        path_ax.set_title(f"{label}: lattice path to ({dx}, {dy})", fontsize=9)
        path_ax.set_xlabel("x [steps]", fontsize=8)
        path_ax.set_ylabel("y [steps]", fontsize=8)
        path_ax.grid(True, lw=0.3)
        path_ax.legend(fontsize=7, loc="lower right")
        base = list(range(1, dx + 1))
        bres_short = [k for k, (_, sy) in enumerate(steps, 1) if sy]
        pulse_ax.vlines(base, 2.1, 2.9, color="black", lw=1.2)
        pulse_ax.vlines(bres_short, 1.1, 1.9, color="tab:blue", lw=1.2)
        pulse_ax.vlines(short, 0.1, 0.9, color="tab:red", lw=1.2)
        pulse_ax.set_yticks([2.5, 1.5, 0.5])
        pulse_ax.set_yticklabels(["base axis", f"short: Bresenham\n({who_b})", f"short: digital integr.\n({who_d})"],
                                 fontsize=7)
        pulse_ax.set_xlim(0, dx + 0.5)
        pulse_ax.set_title(f"{label}: pulse trains, {dx} base pulses and {dy} short-axis pulses", fontsize=9)
        pulse_ax.set_xlabel("time [base intervals from the start of the move]", fontsize=8)
        pulse_ax.grid(True, axis="x", lw=0.3)
    fig.suptitle("Where the short axis steps: on base cycles (Bresenham) or evenly spaced (digital integration)")
    return save_figure(fig, out_dir, "step_patterns.png")


def plot_spacing(out_dir) -> Path:
    """The time between successive short-axis pulses, both methods, for the random line."""
    plt = pyplot()
    dx, dy = LINES["random"]
    steps, who_b = _bresenham(dx, dy)
    short, who_d = _dda(dx, dy)
    bres = [k for k, (_, sy) in enumerate(steps, 1) if sy]
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot([b - a for a, b in zip(bres, bres[1:])], "o-", label=f"Bresenham ({who_b})")
    ax.plot([b - a for a, b in zip(short, short[1:])], "s-", label=f"digital integration ({who_d})")
    ax.axhline(dx / dy, color="gray", ls="--", lw=0.8, label=f"ideal: {dx}/{dy} = {dx / dy:.3f}")
    ax.set_xlabel("short-axis pulse number")
    ax.set_ylabel("gap to the next pulse [base intervals]")
    ax.set_title(f"random line ({dx}, {dy}): spacing of the short-axis pulses")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3)
    ax.grid(True, lw=0.3)
    return save_figure(fig, out_dir, "short_axis_spacing.png")


def main(out_dir="out") -> list[Path]:
    """Draw the step patterns of the three lines and the spacing of the random line's short pulses."""
    return [plot_lines(out_dir), plot_spacing(out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
