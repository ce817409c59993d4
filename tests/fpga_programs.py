"""Random short engraver programs for the gateware's equality tests: lines, arcs, rapids,
dwells, feed changes (accelerations) and reversals, on an engraver with a coarse tick and
random driver timing, pin inversions, interpolator, profile and look-ahead."""

from dataclasses import replace

import numpy as np

from retrofit.machine.config import load_machine

COARSE = replace(load_machine("engraver"), tick_us=20.0)


def random_machine(rng: np.random.Generator):
    axes = tuple(replace(a, pulse_high_ticks=int(rng.integers(1, 6)), pulse_low_ticks=int(rng.integers(1, 6)),
                         dir_setup_ticks=int(rng.integers(0, 12)), dir_hold_ticks=int(rng.integers(0, 12)),
                         invert_step=bool(rng.integers(2)), invert_dir=bool(rng.integers(2)))
                 for a in COARSE.axes)
    motion = replace(COARSE.motion, interpolator=str(rng.choice(["dda", "bresenham"])),
                     profile=str(rng.choice(["trapezoid", "exponential"])), lookahead=int(rng.choice([1, 3, 16])))
    return replace(COARSE, axes=axes, motion=motion)


def random_program(rng: np.random.Generator) -> str:
    """Two to four moves between 0.2 and 0.4 mm (X, Y; an arc's bulge stays above 0), now and
    then a Z move within 0.01 mm of 0, each kind at random."""
    lines, at = ["G21 G90"], None
    for _ in range(int(rng.integers(2, 5))):
        kind = str(rng.choice(["G0", "G1", "G1", "arc", "G4"]))
        nx, ny = round(float(rng.uniform(0.2, 0.4)), 4), round(float(rng.uniform(0.2, 0.4)), 4)
        z = f" Z{round(float(rng.uniform(-0.01, 0.01)), 4)}" if rng.integers(3) == 0 else ""
        feed = int(rng.choice([600, 1500, 3000]))
        if kind == "G4":
            lines.append(f"G4 P{float(rng.choice([0.001, 0.002])):g}")
            continue
        if kind == "arc":
            chord = float(np.hypot(nx - at[0], ny - at[1])) if at else 0.0
            if chord < 0.03:
                continue
            radius = round(chord / 2 * float(rng.uniform(1.05, 2.0)), 4)
            lines.append(f"{rng.choice(['G2', 'G3'])} X{nx} Y{ny} R{radius} F{feed}")
        else:
            lines.append(f"{kind} X{nx} Y{ny}{z}" + (f" F{feed}" if kind == "G1" else ""))
        at = (nx, ny)
    return "\n".join(lines) + "\n"
