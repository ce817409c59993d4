"""Lab 02 (your file): step pulses — the pulse-width and period counters of the lathe paper, and a timing diagram."""

from __future__ import annotations

from pathlib import Path

from retrofit.machine.config import load_machine
from retrofit.frames import PinMap
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output

MACHINE = "chivu-lathe"
WRITE_VCD = True            # also write the lathe's pins as a VCD file (GTKWave, PulseView)


class PulseCounters:
    """The step signal of one axis, as the paper's PasAvans / SetPasAvans make it.

    ``dunu`` counts the ticks the step bit still stays at 1, ``perioada`` the ticks until the
    next step may start (the paper's dunuL / perioadaL). Both count timer ticks.
    """

    def __init__(self, pulse_high_ticks: int = 1, pulse_low_ticks: int = 1):
        self.pulse_high = pulse_high_ticks      # ticks at logic 1 of every pulse
        self.pulse_low = pulse_low_ticks        # ticks at logic 0 before the next pulse may start
        self.dunu = 0
        self.perioada = 0

    def pas_avans(self) -> int:
        """One timer tick: the step bit for this tick (PasAvans)."""
        # TODO 1 (README, task 1): the hints there open one at a time.
        raise NotImplementedError("TODO 1: write PulseCounters.pas_avans(): one tick of the counters")

    def set_pas_avans(self) -> bool:
        """Ask for a step (SetPasAvans): start a pulse if none is in progress; True if started."""
        # TODO 2 (README, task 2): the hints there open one at a time.
        raise NotImplementedError("TODO 2: write PulseCounters.set_pas_avans(): start a pulse if none is running")


def timer_ticks(counters: PulseCounters, requests: list[bool]) -> list[int]:
    """The step bit of every tick, as the paper's Timer1Timer runs them.

    ``requests[t]`` is True when one more step is wanted at tick ``t``. Each tick: PasAvans gives
    this tick's bit (it goes to the port), then, while steps are wanted, SetPasAvans is asked for
    one; a step refused because a pulse is in progress is asked for again next tick, as
    EvaluateEroare does while the position error is not zero. No wanted step is ever lost.
    """
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write timer_ticks(counters, requests): the step bit of every tick")


def lathe_signals(machine, targets) -> dict[str, list[int]]:
    """The lathe's step and direction pins tick by tick, for a short run of the error loop."""
    log = PositionErrorLoop(machine).run(targets)
    pins = PinMap(machine)
    signals: dict[str, list[int]] = {}
    per_tick = log.frames.per_tick()
    for i, axis in enumerate(machine.axes):
        decoded = [pins.decode(int(value)) for value in per_tick]
        signals[f"{axis.name}.step"] = [steps[i] for steps, _ in decoded]
        signals[f"{axis.name}.dir"] = [1 if dirs[i] > 0 else 0 for _, dirs in decoded]
    return signals, log


def plot_counters(out_dir) -> Path:
    """Step bits of the counters for three request patterns: every tick, every 3rd tick, in bursts."""
    plt = pyplot()
    patterns = {"a step wanted every tick: the counters set the pace, one pulse every 4 ticks": [True] * 24,
                "a step wanted every 6th tick: each pulse starts the tick after it is wanted":
                    [t % 6 == 0 for t in range(24)],
                "bursts: wanted steps wait their turn and none is lost": [t in (0, 1, 2, 13, 14, 20) for t in range(24)]}
    fig, axes = plt.subplots(len(patterns), 1, sharex=True, figsize=(10, 6.5))
    for ax, (label, requests) in zip(axes, patterns.items()):
        bits = timer_ticks(PulseCounters(2, 2), requests)
        ax.step(range(len(bits) + 1), bits + bits[-1:], where="post", lw=1.5, label="step bit")
        asks = [t for t, wanted in enumerate(requests) if wanted]
        ax.plot(asks, [1.25] * len(asks), "v", ms=5, color="tab:red", label="one more step wanted")
        ax.set_ylim(-0.2, 1.5)
        ax.set_yticks([0, 1])
        ax.set_title(label, fontsize=9)
        ax.set_ylabel("step bit")
        ax.grid(True, axis="x", lw=0.3)
    fig.suptitle("PulseCounters(pulse_high = 2, pulse_low = 2): the step bit for three patterns of wanted steps")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, bbox_to_anchor=(0.5, -0.04))
    axes[-1].set_xlabel("tick (one timer period each)")
    return save_figure(fig, out_dir, "counters.png")


def plot_lathe_timing(signals: dict, machine, out_dir) -> Path:
    """The timing diagram of the lathe's four pins while X and Z go out and back."""
    plt = pyplot()
    names = list(signals)
    fig, ax = plt.subplots(figsize=(12, 4))
    for row, name in enumerate(reversed(names)):
        levels = signals[name]
        ax.step(range(len(levels)), [row * 1.5 + v for v in levels], where="post", lw=1.0)
    ax.set_yticks([row * 1.5 + 0.5 for row in range(len(names))])
    ax.set_yticklabels(list(reversed(names)))
    ax.set_xlabel(f"tick ({machine.tick_us:g} µs)")
    ax.set_ylabel("pin (0 low, 1 high)")
    counts = []
    for axis in machine.axes:
        step, direction = signals[f"{axis.name}.step"], signals[f"{axis.name}.dir"]
        rises = [t for t in range(1, len(step)) if step[t] and not step[t - 1]]
        out = sum(direction[t] for t in rises)
        counts.append(f"{axis.name}: {out} pulses out, {len(rises) - out} back")
    take_up = ", ".join(f"{a.name} {a.backlash_steps} ({a.backlash_mm:g} mm)" for a in machine.axes)
    ax.set_title(f"{machine.name}: X commanded 3 steps out and back, Z 2 steps — {'; '.join(counts)}\n"
                 f"the extra pulses are backlash compensation: whenever an axis changes direction (its first "
                 f"move too) the controller first takes up the clearance, {take_up} steps", fontsize=10)
    ax.grid(True, axis="x", lw=0.3)
    return save_figure(fig, out_dir, "lathe_timing.png")


def main(out_dir="out") -> list[Path]:
    """Draw the counters' step bits and the lathe's timing diagram (and a VCD file)."""
    machine = load_machine(MACHINE)
    written = [plot_counters(out_dir)]
    signals, log = lathe_signals(machine, [(3, 2), (0, 0)])
    written.append(plot_lathe_timing(signals, machine, out_dir))
    if WRITE_VCD:
        path = Path(out_dir) / "lathe_steps.vcd"
        with open_output(f"vcd://{path}", machine) as out:
            out.write(log.frames)
        written.append(path)
    return written


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
