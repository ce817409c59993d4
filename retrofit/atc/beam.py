"""The simulated tool-setter beam: broken when the real tool in the spindle covers it.

The tool is a cylinder of its true diameter hanging its true length below the spindle's gauge
line (``[tools.sim]``; Z+ is up, so its tip is at Z - length); the beam is a band
``beam_width_mm`` thick whose top edge is at ``beam_top_z_mm``, running along X between emitter
and receiver ``beam_span_mm`` apart.
"""

from __future__ import annotations

from ..config import Machine
from .settings import tools_of
from .setter import SetterSettings

#: float noise allowed on every comparison, so an edge exactly on a step breaks the beam there
_SLACK_MM = 1e-9


class SimBeam:
    """The beam's state for given carriage positions and the tool the spindle really holds."""

    def __init__(self, machine: Machine):
        self.setter: SetterSettings = machine.parts["setter"]
        self.tools = tools_of(machine).sim

    def broken(self, at_mm: dict[str, float], spindle_tool: int | None) -> bool:
        """True when the tool in the spindle at carriage position ``at_mm`` interrupts the beam."""
        tool = self.tools.get(spindle_tool) if spindle_tool else None
        if tool is None:
            return False
        s = self.setter
        between = abs(at_mm["X"] - s.beam_x_mm) <= s.beam_span_mm / 2 + _SLACK_MM
        across = abs(at_mm["Y"] - s.beam_y_mm) <= tool.diameter_mm / 2 + s.beam_width_mm / 2 + _SLACK_MM
        tip = at_mm["Z"] - tool.length_mm
        reaches = tip - s.beam_top_z_mm <= _SLACK_MM                            # tip down past the top edge
        spans = s.beam_top_z_mm - at_mm["Z"] <= s.beam_width_mm + _SLACK_MM     # spindle above the bottom edge
        return between and across and reaches and spans
