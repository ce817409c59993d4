"""The ``[fanuc]`` section of a machine file: where Fanuc/Haas lathe controls differ by parameter.

Each key has the default most Fanuc 0i-T and Haas lathes ship with; a school sets the others to
match its control. The dialect itself is chosen with ``dialect = "fanuc"`` in ``[machine]`` or
``--dialect fanuc`` on the command line, never guessed from the program.

* ``x_diameter`` (true): X and U are diameters (Fanuc parameter 1006 DIAx).
* ``whole_numbers`` ("units"): a coordinate without a decimal point (``X20``) is 20 mm or inch,
  as on Haas and on Fanuc with DPI = 1 (parameter 3401); "increments" reads it as 20 least input
  increments (0.020 mm, 0.0020 inch), as a Fanuc with DPI = 0 does.
* ``feed_at_start`` ("per_rev"): G99 (feed per revolution) at the top of a program; "per_min": G98.
* ``inch_at_start`` (false): G21 (mm) at the top of a program; true: G20.
* ``g71_type2`` (true): a G71/G72 profile whose first block moves both axes is a type II profile
  (pockets allowed, :mod:`retrofit.gcode.fanuc_pockets`); false: controls without type II, where
  such a profile is refused.
* ``cycle_pq`` ("increments"): P and Q of G74, G75 and G76 (peck, shift, thread height, first and
  minimum depth) written without a decimal point are least input increments (P1000 = 1 mm), as a
  Fanuc 0i reads them; "units": they are mm (inch). With a decimal point they are always mm (inch).
* ``g71_retract_mm`` (0.5): the retract of the one-block G71/G72 form ``G71 P Q U W D F`` (Haas,
  Fanuc 0-T), where it is a machine setting (Haas setting 73, Fanuc parameter 5133).
* ``tool_digits`` (4): a T word is ``T<tool><offset>`` with two digits each (T0101, Haas T101);
  2: one digit each (T11), as on older controls.
* ``retract_45`` ("rapid"): how G71/G72 leave each roughing cut by R at 45 degrees: "rapid" or "feed".
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FanucSettings:
    """The machine-dependent choices of the Fanuc dialect (see the module doc)."""

    x_diameter: bool = True
    whole_numbers: str = "units"
    feed_at_start: str = "per_rev"
    inch_at_start: bool = False
    g71_type2: bool = True
    cycle_pq: str = "increments"
    g71_retract_mm: float = 0.5
    tool_digits: int = 4
    retract_45: str = "rapid"


def read_fanuc_section(sec, axes) -> FanucSettings:
    """``[fanuc]``: every key optional; an unknown key is refused as a typo."""
    d = FanucSettings()
    settings = FanucSettings(
        x_diameter=sec.get_bool("x_diameter", d.x_diameter),
        whole_numbers=sec.get_str("whole_numbers", d.whole_numbers, choices=("units", "increments")),
        feed_at_start=sec.get_str("feed_at_start", d.feed_at_start, choices=("per_rev", "per_min")),
        inch_at_start=sec.get_bool("inch_at_start", d.inch_at_start),
        g71_type2=sec.get_bool("g71_type2", d.g71_type2),
        cycle_pq=sec.get_str("cycle_pq", d.cycle_pq, choices=("increments", "units")),
        g71_retract_mm=sec.get_float("g71_retract_mm", d.g71_retract_mm, minval=0.0, maxval=100.0),
        tool_digits=sec.get_int("tool_digits", d.tool_digits, minval=2, maxval=4),
        retract_45=sec.get_str("retract_45", d.retract_45, choices=("rapid", "feed")))
    if settings.tool_digits not in (2, 4):
        raise sec.error("tool_digits", "must be 4 (T0101) or 2 (T11)")
    sec.finish()
    return settings
