"""Lab 11 (your file): the command set of 002 — prepare, execute, and the pipeline of three."""

from __future__ import annotations

import pickle
from dataclasses import replace
from pathlib import Path

import numpy as np

# the command classes your functions tell apart (parse_command turns a text into one)
from retrofit.commands import CStp, Dely, FFdr, FMov, Init, MFdr, PFdr, PMov, Pstn, Rdps, Rdst, Stop, ZMov, \
    parse_command
from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure
from retrofit.motion.bresenham import bresenham_cycles, prepare_line

MACHINE = "mitic-lathe"
LOOKAHEAD = 1               # the plots' window: lookahead + 1 = two moves prepared, as the queue fills
QUEUE_DEPTH = 3             # 002: "a pipelined command queue, which could accept three commands in advance"
EXTRA_ACTIONS = 16          # PSTN entries the window may hold besides its moves
#: the program of the plots: a host sends it as fast as the controller takes it
PROGRAM = ["PFDR F600", "FMOV X5 Z-2", "PMOV X12.5 Z-8", "DELY P0.005", "PMOV X3 Z-8.25", "PSTN X0 Z0",
           "PFDR F900", "PMOV X-4 Z-3", "FMOV X0 Z0", "PMOV X2 Z2"]


def new_controller(machine) -> dict:
    """A controller just after INIT: default feeds, position 0, nothing queued, nothing prepared."""
    n = len(machine.axes)
    return {
        "window": machine.motion.lookahead + 1,       # moves prepared ahead of the one executing
        "queue": [], "prepared": [], "executing": None, "cycle": 0,
        "position": [0] * n, "offset": [0] * n, "stopped": False, "error": False,
        "interp": new_interpreter(machine),
    }


def new_interpreter(machine) -> dict:
    """The interpreter's state after INIT: where the prepared commands leave the tool, the feeds."""
    n = len(machine.axes)
    return {"position": [0] * n, "offset": [0] * n, "feed": machine.motion.default_feed_mm_min,
            "rapid": machine.motion.rapid_feed_mm_min, "group": 0}


def point_at(start, end, cycle: int) -> list[int]:
    """The lattice point of a straight move after ``cycle`` step cycles of 002's Bresenham (lab 03)."""
    line = prepare_line(tuple(start), tuple(end))
    return [s + d * int(np.searchsorted(c, cycle, side="right"))
            for s, d, c in zip(start, line.direction, bresenham_cycles(line))]


def prepare(interp: dict, machine, text: str) -> tuple[dict, dict | None]:
    """002's first phase for one command taken from the queue: (the new interpreter state, its entry).

    Set-up commands (PFDR, CSTP) change the state and give no entry; a target outside the soft
    limits, or a PFDR feed that is not above 0, gives an entry of kind "refused".
    """
    # TODO 1 (README, task 1): the hints there open one at a time.
    raise NotImplementedError("TODO 1: write prepare(interp, machine, text): one command's entry and the new state")


def halt(ctl: dict, error: bool) -> dict:
    """Stop at once: nothing queued, prepared or executing; the interpreter goes on from where the tool is."""
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write halt(ctl, error): stop at once, nothing queued, prepared or executing")


def has_room(ctl: dict) -> bool:
    """Fewer than ``window`` moves and dwells prepared (a PSTN rides along, up to 16 of them)."""
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write has_room(ctl): may the window take another entry?")


def interpret(ctl: dict, machine) -> dict:
    """Take commands from the queue and prepare them while the window has room."""
    # TODO 2 (README, task 2): the hints there open one at a time.
    raise NotImplementedError("TODO 2: write interpret(ctl, machine): prepare from the queue while the window has room")


def status(ctl: dict) -> dict:
    """What RDST answers."""
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write status(ctl): what RDST answers")


def override(ctl: dict, cmd) -> dict:
    """FFDR / MFDR: the feed changes now, for the move executing and the moves prepared behind it."""
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write override(ctl, cmd): FFDR and MFDR change the feed now")


def submit(ctl: dict, machine, text: str):
    """A command arrives: (the new state, the reply). The scan for immediate commands comes first.

    Replies: "OK", "BUSY" (three already wait), "ERR" (refused), RDPS: the position in program
    steps (a list), RDST: :func:`status`.
    """
    # TODO 3 (README, task 3): the hints there open one at a time.
    raise NotImplementedError("TODO 3: write submit(ctl, machine, text): immediate commands, the queue, BUSY, ERR")


def start_next(ctl: dict, machine) -> dict:
    """The executing entry is done: the next prepared one starts (a PSTN is done on the way)."""
    # TODO 4 (README, task 4): the hints there open one at a time.
    raise NotImplementedError("TODO 4: write start_next(ctl, machine): the next prepared entry starts")


def tick(ctl: dict, machine) -> dict:
    """002's processing for one tick: the executing entry runs one step cycle; when that was its
    last, the next entry starts (its first cycle comes next tick); then the queue refills."""
    # TODO 4 (README, task 4): the hints there open one at a time.
    raise NotImplementedError("TODO 4: write tick(ctl, machine): one step cycle of the entry executing")


def _copy(ctl: dict) -> dict:
    """A deep copy of a state (plain data), quickly."""
    return pickle.loads(pickle.dumps(ctl))


def run(machine, events) -> list:
    """Play ``events`` -- ("submit", text) or ("tick", count) -- and record (reply, state) after each
    command and after every tick (reply None for a tick; each state a copy, so a function that
    changes the state it was given in place still leaves a true record)."""
    ctl, records = new_controller(machine), []
    for kind, value in events:
        if kind == "submit":
            ctl, reply = submit(ctl, machine, value)
            records.append((reply, _copy(ctl)))
        else:
            for _ in range(value):
                ctl = tick(ctl, machine)
                records.append((None, _copy(ctl)))
    return records


def run_ticks(ctl: dict, machine, count: int) -> list:
    """``count`` ticks from the state ``ctl``: the state after each."""
    states = []
    for _ in range(count):
        ctl = tick(ctl, machine)
        states.append(_copy(ctl))
    return states


def stream(machine, program, max_ticks: int = 200_000) -> list:
    """A host that keeps the queue full: it sends the next command whenever the last was taken,
    after BUSY waits a tick and tries again. The states after every tick."""
    ctl, states, waiting = new_controller(machine), [], list(program)
    for _ in range(max_ticks):
        while waiting:
            ctl, reply = submit(ctl, machine, waiting[0])
            if reply == "BUSY":
                break
            waiting.pop(0)
        ctl = tick(ctl, machine)
        states.append(_copy(ctl))
        if not waiting and ctl["executing"] is None and not ctl["prepared"] and not ctl["queue"]:
            return states
    raise RuntimeError(f"the program did not end within {max_ticks} ticks")


def plot_pipeline(machine, states, out_dir) -> Path:
    """How full the queue and the window are, and which command executes, tick by tick."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    ticks = range(1, len(states) + 1)
    top.step(ticks, [len(s["queue"]) for s in states], where="post", label="queue (waiting)")
    top.step(ticks, [len(s["prepared"]) for s in states], where="post", label="window (prepared)")
    top.axhline(QUEUE_DEPTH, color="gray", ls="--", lw=0.8, label="queue depth 3")
    top.set_ylabel("commands")
    top.set_title(f"{machine.name}: the pipeline while a host streams {len(PROGRAM)} commands "
                  f"(window {states[0]['window']})", fontsize=10)
    top.legend(fontsize=8)
    names = sorted({s["executing"]["cmd"] for s in states if s["executing"]}, key=PROGRAM.index)
    row = [names.index(s["executing"]["cmd"]) if s["executing"] else -1 for s in states]
    bottom.plot(ticks, row, ".", ms=2)
    bottom.set_yticks(range(-1, len(names)), ["(nothing)"] + names, fontsize=7)
    bottom.set_xlabel("tick")
    bottom.set_title("the entry executing: no tick without one until the program ends", fontsize=10)
    return save_figure(fig, out_dir, "pipeline.png")


def plot_path(machine, states, out_dir) -> Path:
    """The position register, tick by tick, per axis."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(11, 4))
    for i, axis in enumerate(machine.axes):
        ax.plot([axis.to_mm(s["position"][i]) for s in states], label=f"{axis.name}")
    ax.set_xlabel("tick")
    ax.set_ylabel("position [mm] (machine)")
    ax.set_title("the actual position, one Bresenham cycle a tick", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.3)
    return save_figure(fig, out_dir, "position.png")


def main(out_dir="out") -> list[Path]:
    """Stream the program through your controller and plot its pipeline and its position."""
    machine = load_machine(MACHINE)
    machine = replace(machine, motion=replace(machine.motion, lookahead=LOOKAHEAD))
    states = stream(machine, PROGRAM)
    print(f"{len(PROGRAM)} commands in {len(states)} ticks; position at the end "
          f"{states[-1]['position']} steps")
    return [plot_pipeline(machine, states, out_dir), plot_path(machine, states, out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
