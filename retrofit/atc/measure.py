"""Measuring tools on the setter: the reference run, then length and diameter of any tool.

:class:`ToolSetter` drives a prober — anything with ``run(commands)`` and ``probe(commands)``
returning where the probing move stopped (:class:`~retrofit.atc.cell.ProbeHit`) or None — and
writes the results into the :class:`~retrofit.atc.tooltable.ToolTable`. The tool to measure
must be in the spindle (the tool changer puts it there).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from ..commands import Command
from ..errors import ProbeError, ToolChangeError
from ..machine.config import Machine
from . import setter as st
from .tooltable import Reference, ToolEntry, ToolTable


class Prober(Protocol):
    """What runs the setter's moves and its probing moves (the simulated cell, the controller)."""

    def run(self, commands: Sequence[Command]) -> object:
        """Execute ``commands`` (approach and retract moves)."""

    def probe(self, commands: Sequence[Command]):
        """Execute a probing move; where it stopped on the beam (``position_mm``, ``step_mm``),
        or None when the beam never broke."""


@dataclass(frozen=True)
class Measurement:
    """One tool's results and the edges they came from (mm)."""

    tool: int
    length_mm: float
    diameter_mm: float
    z_edge_mm: float        # Z where the tip met the beam top
    y1_edge_mm: float       # Y where the tool met the beam from the -Y side
    y2_edge_mm: float       # ... from the +Y side


class ToolSetter:
    """The setter's procedures on one machine, recording into one tool table."""

    def __init__(self, machine: Machine, table: ToolTable):
        if "setter" not in machine.parts:
            raise ToolChangeError(f"machine {machine.name} has no tool setter (no [setter] section "
                                  f"in {machine.source})")
        self.machine = machine
        self.settings: st.SetterSettings = machine.parts["setter"]
        self.table = table

    def calibrate(self, prober: Prober, spindle_tool: int) -> Reference:
        """Measure where the reference tool (in the spindle) breaks the beam; store it."""
        s = self.settings
        if spindle_tool != s.reference_tool:
            raise ToolChangeError(f"the reference run needs the reference tool T{s.reference_tool} "
                                  f"in the spindle, not T{spindle_tool}")
        reference = Reference(s.reference_tool, s.reference_length_mm, self._length_edge(prober))
        self.table.reference = reference
        return reference

    def reference(self) -> Reference:
        """The table's reference, or a ToolChangeError saying how to make one."""
        if self.table.reference is None:
            raise ToolChangeError(f"no reference in the tool table of {self.machine.name}: run the "
                                  f"reference tool first (retrofit setter reference --machine "
                                  f"{self.machine.name})")
        return self.table.reference

    def measure(self, prober: Prober, spindle_tool: int) -> Measurement:
        """Length, then diameter, of the tool in the spindle; stored in the table."""
        ref = self.reference()
        if not spindle_tool:
            raise ToolChangeError("no tool in the spindle to measure (change to it first, e.g. T3)")
        z_edge = self._length_edge(prober)
        length = st.tool_length(self.settings, z_edge, ref.z_break_mm, ref.length_mm)
        y1, y2 = self._diameter_edges(prober, length)
        result = Measurement(spindle_tool, round(length, 6),
                             round(st.tool_diameter(self.settings, y1, y2), 6), z_edge, y1, y2)
        self.table.tools[spindle_tool] = ToolEntry(result.length_mm, result.diameter_mm)
        return result

    def _length_edge(self, prober: Prober) -> float:
        s = self.settings
        prober.run(st.length_approach(s))
        hit = prober.probe(st.length_probe(s))
        if hit is None:
            raise ProbeError(f"the beam did not break while Z went from {s.approach_z_mm:g} to "
                             f"{s.lowest_z_mm:g} mm: no tool in the spindle, or one shorter than "
                             f"the setter can reach")
        prober.run(st.retract(s))
        moving = 1 if s.lowest_z_mm > s.approach_z_mm else -1
        return st.edge_estimate(hit.position_mm["Z"], hit.step_mm["Z"], moving)

    def _diameter_edges(self, prober: Prober, length_mm: float) -> tuple[float, float]:
        s = self.settings
        z = st.diameter_z(s, length_mm)
        edges = []
        for side in (-1, 1):
            prober.run(st.side_approach(s, side, z))
            hit = prober.probe(st.side_probe(s))
            if hit is None:
                raise ProbeError(f"the beam did not break while Y went from {st.side_start_y(s, side):g} "
                                 f"to the beam's centre line {s.beam_y_mm:g} mm at Z {z:g}")
            edges.append(st.edge_estimate(hit.position_mm["Y"], hit.step_mm["Y"], -side))
        prober.run(st.retract(s))
        return edges[0], edges[1]
