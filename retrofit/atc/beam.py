"""The simulated tool-setter beam: broken when the real tool in the spindle covers it.

The tool is a cylinder of its true diameter hanging its true length below the spindle's gauge
line (``[tools.sim]``; Z+ is up, so its tip is at Z - length); the beam is a band
``beam_width_mm`` thick whose top edge is at ``beam_top_z_mm``, running along X between emitter
and receiver ``beam_span_mm`` apart.
"""

from __future__ import annotations

import math

from ..machine.config import Machine
from .setter import SetterSettings
from .settings import tools_of

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


def beam_box_steps(machine: Machine, length_mm: float, diameter_mm: float) -> dict[str, tuple[int, int]]:
    """The carriage positions, in whole steps of X, Y and Z (lowest, highest, both inside), at
    which a tool of ``length_mm`` and ``diameter_mm`` breaks the beam: :meth:`SimBeam.broken`'s
    conditions solved for each axis (the ones of a harness that counts steps, not mm)."""
    s: SetterSettings = machine.parts["setter"]
    half_x = s.beam_span_mm / 2
    half_y = diameter_mm / 2 + s.beam_width_mm / 2
    bounds = {"X": (s.beam_x_mm - half_x, s.beam_x_mm + half_x),
              "Y": (s.beam_y_mm - half_y, s.beam_y_mm + half_y),
              "Z": (s.beam_top_z_mm - s.beam_width_mm, s.beam_top_z_mm + length_mm)}
    out = {}
    for name, (lo, hi) in bounds.items():
        spm = machine.axis(name).steps_per_mm
        out[name] = (math.ceil(lo * spm - _SLACK_MM * spm), math.floor(hi * spm + _SLACK_MM * spm))
    return out
