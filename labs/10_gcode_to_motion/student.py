"""Lab 10 (your file): from G-code to motion — modal state and the G81 drilling cycle,
worked by hand and checked against an interpreter."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from retrofit.lab.core import pyplot, save_figure

PROGRAMS = Path(__file__).resolve().parent / "programs"
_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


@dataclass(frozen=True)
class Move:
    """One straight move to (x, y, z) in mm: a rapid (G0) or a feed move (G1) at ``feed`` mm/min."""

    kind: str           # "rapid" or "feed"
    x: float
    y: float
    z: float
    feed: float = 0.0


@dataclass
class State:
    """The modal state the interpreter carries from block to block."""

    motion: str = "G0"          # G0, G1, G81 or "" after G80
    absolute: bool = True       # G90 / G91
    retract_to_start: bool = True    # G98 (back to the Z the cycle started from) / G99 (to R)
    feed: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    r: float = 0.0              # the cycle's R plane and depth, modal while G81 is
    depth: float = 0.0


def parse_words(line: str) -> list[tuple[str, float]]:
    """The words of a block: ``"G1 X10 F200"`` -> [("G", 1.0), ("X", 10.0), ("F", 200.0)].

    Any case; spaces and tabs anywhere, even inside a number (RS274NGC ignores them: ``x1 0.5`` is X10.5).
    """
    # TODO 1 (README, task 1): a letter, then a number (maybe signed, maybe with a point).
    raise NotImplementedError("TODO 1: write parse_words(line): the (letter, value) words of a block")

def target(state: State, words: dict[str, float]) -> tuple[float, float, float]:
    """Where a move of this block ends: X, Y, Z given are absolute (G90) or added (G91); others stay."""
    # TODO 2 (README, task 2): G90 or G91 decides what a number means; an axis not named stays.
    raise NotImplementedError("TODO 2: write target(state, words): where this block's move ends")

def g81_moves(state: State, x: float, y: float) -> list[Move]:
    """One G81 hole at (x, y), from where the tool stands, with the state's R, depth and retract mode."""
    # TODO 3 (README, task 3): the hole worked by hand first: which moves, rapid or feed, to where?
    raise NotImplementedError("TODO 3: write g81_moves(state, x, y): the moves of one drilled hole")

def interpret(text: str) -> list[Move]:
    """Every move of a program (G0, G1, G80, G81, G90, G91, G98, G99, F, X, Y, Z, R; cycles in G90).

    Axis words after G80 with no new G0 or G1 raise ValueError, as in LinuxCNC.
    """
    # TODO 4 (README, task 4): block by block, update the modal state, then emit the block's moves.
    raise NotImplementedError("TODO 4: write interpret(text): every move of the program")

def plot_program(name: str, out_dir) -> Path:
    """The moves of one program in X-Z (side view) and X-Y (top view): rapids dashed, feeds solid."""
    plt = pyplot()
    moves = interpret((PROGRAMS / f"{name}.ngc").read_text(encoding="utf-8"))
    fig, (side, top) = plt.subplots(1, 2, figsize=(11, 4.5))
    x = y = z = 0.0
    for m in moves:
        style = dict(color="tab:red", linestyle="--") if m.kind == "rapid" else dict(color="tab:blue")
        side.plot([x, m.x], [z, m.z], **style)
        top.plot([x, m.x], [y, m.y], **style)
        x, y, z = m.x, m.y, m.z
    side.plot([], [], color="tab:red", linestyle="--", label="rapid (G0)")
    side.plot([], [], color="tab:blue", label="feed (G1)")
    side.set(xlabel="X (mm)", ylabel="Z (mm)", title=f"{name}.ngc, side view")
    top.set(xlabel="X (mm)", ylabel="Y (mm)", title=f"{name}.ngc, top view")
    side.legend(loc="lower left")
    for ax in (side, top):
        ax.grid(alpha=0.3)
    return save_figure(fig, out_dir, f"{name}.png")


def main(out_dir="out") -> list[Path]:
    """Interpret the drilling programs and draw their moves."""
    for name in ("drill_g98", "drill_g99"):
        moves = interpret((PROGRAMS / f"{name}.ngc").read_text(encoding="utf-8"))
        print(f"{name}: {len(moves)} moves, {sum(m.kind == 'feed' for m in moves)} of them drilling feeds")
    return [plot_program("drill_g98", out_dir), plot_program("drill_g99", out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
