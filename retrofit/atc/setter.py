"""The optical tool setter: its ``[setter]`` section, its probing sequences, and the arithmetic.

Length (the document's figure 28): up to the safe height A1, over the beam, then Z descends at
the slow probing feed until the tool tip breaks the beam; all axes stop and Z is recorded. The
reference tool (known length) calibrates the beam once; any other tool's length is the
reference length plus how much earlier it broke the beam.

Diameter (figure 30): 1 mm below the beam top (the tool's length is known by then), the tool
approaches the beam along +Y from one side until it breaks it (Y1), lifts to the safe height,
goes round, and approaches along -Y from the other side (Y2). The beam's width is the
reference: diameter = Y2 - Y1 - beam width.

Each break is recorded at the first step after which the beam is broken, so the true edge lies
within the last step; the estimate takes the middle of that step (half a step back), which
keeps every result within one step of the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..commands import Command, FMov, PFdr, PMov
from ..machine.config import Axis
from ..machine.tomlreader import Section


@dataclass(frozen=True)
class SetterSettings:
    """Where the beam is (table coordinates) and how the setter probes (``[setter]``)."""

    beam_x_mm: float            # middle of the beam between emitter and receiver
    beam_y_mm: float            # the beam's centre line
    beam_top_z_mm: float        # Z of the beam's top edge, where a tool tip breaks it
    beam_width_mm: float        # the beam's thickness: the reference of the diameter
    beam_span_mm: float         # emitter to receiver (the tool must pass between them)
    approach_z_mm: float        # A1: safe height above the beam for the longest tool
    lowest_z_mm: float          # the descent ends here if nothing broke the beam
    probe_feed_mm_min: float    # slow feed of every probing move
    below_top_mm: float         # diameter: the tip this far below the beam top
    max_diameter_mm: float      # diameter: the approach starts clear of a tool this thick
    side_clearance_mm: float    # ... plus this
    reference_tool: int         # the tool of known length that calibrates the beam
    reference_length_mm: float


def read_setter_section(sec: Section, axes: tuple[Axis, ...]) -> SetterSettings:
    """Read ``[setter]``; the beam and the probing positions must lie within the axes' travel."""
    by_name = {a.name: a for a in axes}
    for needed in ("X", "Y", "Z"):
        if needed not in by_name:
            raise sec.error("beam_x_mm", "a tool setter needs axes X, Y and Z")
    settings = SetterSettings(
        beam_x_mm=_within(sec, "beam_x_mm", by_name["X"]),
        beam_y_mm=_within(sec, "beam_y_mm", by_name["Y"]),
        beam_top_z_mm=sec.get_float("beam_top_z_mm"),
        beam_width_mm=sec.get_float("beam_width_mm", minval=0.0, maxval=10.0),
        beam_span_mm=sec.get_float("beam_span_mm", above=0.0),
        approach_z_mm=_within(sec, "approach_z_mm", by_name["Z"]),
        lowest_z_mm=_within(sec, "lowest_z_mm", by_name["Z"]),
        probe_feed_mm_min=sec.get_float("probe_feed_mm_min", above=0.0, maxval=6000.0),
        below_top_mm=sec.get_float("below_top_mm", 1.0, above=0.0, maxval=50.0),
        max_diameter_mm=sec.get_float("max_diameter_mm", above=0.0),
        side_clearance_mm=sec.get_float("side_clearance_mm", above=0.0),
        reference_tool=sec.get_int("reference_tool", minval=1),
        reference_length_mm=sec.get_float("reference_length_mm", above=0.0))
    y = by_name["Y"]
    for side in (-1, 1):
        start = side_start_y(settings, side)
        if not y.min_mm <= start <= y.max_mm:
            raise sec.error("max_diameter_mm", f"puts the diameter approach at Y {start:g}, outside "
                            f"{y.min_mm:g}..{y.max_mm:g}; move the beam or lower the clearances")
    sec.finish()
    return settings


def _within(sec: Section, key: str, axis: Axis) -> float:
    value = sec.get_float(key)
    if not axis.min_mm <= value <= axis.max_mm:
        raise sec.error(key, f"must lie within axis {axis.name} {axis.min_mm:g}..{axis.max_mm:g}")
    return value


def side_start_y(s: SetterSettings, side: int) -> float:
    """Y where a diameter approach starts: clear of the beam on ``side`` (-1 below, +1 above)."""
    return s.beam_y_mm + side * (s.beam_width_mm / 2 + s.max_diameter_mm / 2 + s.side_clearance_mm)


# -- sequences: (commands before the probe, the probing move) --------------------------------------
def length_approach(s: SetterSettings) -> list[Command]:
    """Up to A1's height first, then over the beam (A1)."""
    return [FMov((("Z", s.approach_z_mm),)), FMov((("X", s.beam_x_mm), ("Y", s.beam_y_mm)))]


def length_probe(s: SetterSettings) -> list[Command]:
    """The slow descent towards the beam (cut by the beam, or ending at ``lowest_z_mm``)."""
    return [PFdr(s.probe_feed_mm_min), PMov((("Z", s.lowest_z_mm),))]


def diameter_z(s: SetterSettings, length_mm: float) -> float:
    """Z that puts the tip ``below_top_mm`` under the beam top (Z+ up: the tip is at Z - length)."""
    return round(s.beam_top_z_mm - s.below_top_mm + length_mm, 9)


def side_approach(s: SetterSettings, side: int, z_mm: float) -> list[Command]:
    """Lift to the safe height, go round to ``side`` of the beam, down to the measuring height."""
    return [FMov((("Z", s.approach_z_mm),)), FMov((("X", s.beam_x_mm), ("Y", side_start_y(s, side)))),
            FMov((("Z", z_mm),))]


def side_probe(s: SetterSettings) -> list[Command]:
    """The slow approach towards the beam's centre line."""
    return [PFdr(s.probe_feed_mm_min), PMov((("Y", s.beam_y_mm),))]


def retract(s: SetterSettings) -> list[Command]:
    """Back up to the safe height (rapid)."""
    return [FMov((("Z", s.approach_z_mm),))]


# -- arithmetic --------------------------------------------------------------------------------------
def edge_estimate(hit_mm: float, step_mm: float, moving: int) -> float:
    """The edge crossed during the last step of a move in direction ``moving`` (+1 / -1): its middle."""
    return hit_mm - moving * step_mm / 2


def tool_length(s: SetterSettings, z_edge_mm: float, ref_z_edge_mm: float, ref_length_mm: float) -> float:
    """Length from the Z at which the tip met the beam, against the reference tool's: a longer
    tool meets it with the spindle higher (Z+ up)."""
    return ref_length_mm + (z_edge_mm - ref_z_edge_mm)


def tool_diameter(s: SetterSettings, y1_edge_mm: float, y2_edge_mm: float) -> float:
    """Diameter from the two sides' edges and the beam's width."""
    return y2_edge_mm - y1_edge_mm - s.beam_width_mm
