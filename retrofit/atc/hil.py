"""The mill's magazine and tool-setter beam as the simavr harness models them.

``firmware/harness/hil.c`` counts each axis's steps on the firmware's pins. With the options made
here it also moves the tools as :class:`~retrofit.atc.magazine.MagazineModel` does (an empty
spindle coming down into the seat over a pocket's tool clamps it; one lifting out of the seat,
still in the fork, leaves its tool in the empty pocket there) and drives the setter's beam from
the tool the spindle really holds, each tool's box from :func:`~retrofit.atc.beam.beam_box_steps`.
Everything is in whole steps of the axes the harness counts.
"""

from __future__ import annotations

import math

from ..machine.config import Machine
from .beam import beam_box_steps
from .magazine import MagazineState
from .settings import atc_of, tools_of

#: below any carriage: the seat has no lower edge
_FLOOR = -(1 << 31)


def _steps(machine: Machine, axis: str, lo_mm: float, hi_mm: float) -> tuple[int, int]:
    """The whole steps of ``axis`` from ``lo_mm`` to ``hi_mm``, both edges inside."""
    spm = machine.axis(axis).steps_per_mm
    return math.ceil(lo_mm * spm - 1e-9), math.floor(hi_mm * spm + 1e-9)


def magazine_args(machine: Machine, index: dict[str, int], spindle_tool: int) -> list[str]:
    """The harness's --seat, --pocket, --tool-box and --spindle-tool for ``machine``, the tools
    in their pockets and ``spindle_tool`` (0: none) in the spindle; ``index``: axis name -> the
    harness's axis number."""
    atc, tools = atc_of(machine), tools_of(machine).sim
    g, tol = atc.sim, atc.sim.tolerance_mm
    box = {"X": _steps(machine, "X", atc.x1 - tol, atc.x1 + tol),
           "Y": _steps(machine, "Y", atc.y_point_b - tol, atc.y_point_b + tol),
           "Z": (_FLOOR, _steps(machine, "Z", atc.z_point_2, atc.z_point_2 + tol)[1])}
    args = ["--seat", ",".join(f"{index[a]},{lo},{hi}" for a, (lo, hi) in box.items())
            + f",{index[atc.axis]}"]
    state = MagazineState.loaded(machine, spindle_tool)
    for pocket, tool in sorted(state.pockets.items()):
        angle = g.pocket_angle_deg(pocket)
        lo, hi = _steps(machine, atc.axis, (angle - g.tolerance_deg) / g.degrees_per_unit,
                        (angle + g.tolerance_deg) / g.degrees_per_unit)
        args += ["--pocket", f"{pocket},{lo},{hi},{tool or 0}"]
    for number, tool in sorted(tools.items()):
        where = beam_box_steps(machine, tool.length_mm, tool.diameter_mm)
        args += ["--tool-box", f"{number}," + ",".join(f"{index[a]},{lo},{hi}" for a, (lo, hi) in where.items())]
    return args + ["--spindle-tool", str(spindle_tool)]


def beam_args(machine: Machine, pin: str, index: dict[str, int],
              tool: tuple[float, float] | int | None) -> list[str]:
    """--beam: ``pin`` high (broken) while the carriages are inside the box where ``tool``
    (length, diameter in mm) breaks the beam; for a [tools.sim] number, the magazine's options
    too, that tool in the spindle at the start; None: the beam stays clear."""
    if isinstance(tool, int):
        return ["--beam", f"{pin},1"] + magazine_args(machine, index, tool)
    box = beam_box_steps(machine, *tool).items() if tool is not None else ()
    return ["--beam", ",".join([pin, "1"] + [f"{index[a]},{lo},{hi}" for a, (lo, hi) in box])]
