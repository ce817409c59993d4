"""The machine-file sections of the tool changer and the tools: ``[atc]``, ``[atc.sim]``, ``[tools]``.

Each reader takes the strict :class:`~retrofit.machine.tomlreader.Section` and the machine's axes (see
``SECTION_PARSERS`` in :mod:`retrofit.machine.config`) and returns a frozen object that lands in
``Machine.parts``. Positions are mm on X, Y, Z and carousel units on the carousel axis (one
unit turns the disc by one pocket pitch, as the document's ATC_OFFSET and ATC_HOME are given).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ConfigError, ToolChangeError
from ..machine.config import Axis, Machine
from ..machine.tomlreader import Section

#: when tool changes happen in G-code: on M6 (RS274NGC), or on the T word itself (Repetier, 000)
CHANGE_ON = ("M6", "T")


@dataclass(frozen=True)
class MagazineGeometry:
    """What the simulator knows of the real carousel (``[atc.sim]``): angles and the magazine zone."""

    first_pocket_deg: float     # pocket 1 on the disc, from its 0° mark
    pocket_pitch_deg: float     # then one pocket every this many degrees
    degrees_per_unit: float     # the disc turns this much for one carousel-axis unit
    station_deg: float          # where the spindle meets the disc, from the 0° mark at home
    magazine_y_mm: float        # beyond this Y the spindle is inside the magazine's footprint
    tolerance_mm: float         # how far off the station or the clamp point still engages
    tolerance_deg: float        # how far off its angle a pocket still takes a tool

    def pocket_angle_deg(self, pocket: int) -> float:
        """Turn of the disc (degrees from home) that brings ``pocket`` to the spindle."""
        return self.first_pocket_deg + (pocket - 1) * self.pocket_pitch_deg + self.station_deg


@dataclass(frozen=True)
class AtcSettings:
    """The carousel tool changer (``[atc]``): the document's constants and feeds."""

    axis: str                   # the carousel's step channel (E0 on RAMPS)
    pockets: int                # pockets 1..pockets; tool n lives in pocket n
    change_on: str              # "M6" or "T"
    x1: float                   # X1: in front of the magazine
    y_point_a: float            # Y_POINT_A: outside the magazine
    y_point_b: float            # Y_POINT_B: in the pocket
    z_point_1: float            # Z_POINT_1: safe height above the tools in the magazine
    z_point_2: float            # Z_POINT_2: clamp / release height
    atc_offset: float           # ATC_OFFSET: pocket n is at carousel position ATC_OFFSET + n
    atc_home: float             # ATC_HOME: where the carousel parks after its door closes
    feed_in_mm_min: float       # Y into the magazine
    feed_out_mm_min: float      # lift off a released tool, Y out of the magazine
    feed_clamp_mm_min: float    # careful Z onto a tool
    sim: MagazineGeometry

    def pocket_position(self, pocket: int) -> float:
        """Carousel-axis position (units) that brings ``pocket`` to the spindle."""
        return round(self.atc_offset + pocket, 9)


def read_atc_section(sec: Section, axes: tuple[Axis, ...]) -> AtcSettings:
    """Read ``[atc]`` and its ``[atc.sim]`` table; every position is checked against the axis limits."""
    by_name = {a.name: a for a in axes}
    axis = sec.get_str("axis", "E").upper()
    if axis not in by_name or axis in ("X", "Y", "Z"):
        raise sec.error("axis", f"must name the carousel's own axis; axes are {', '.join(by_name)}")
    for needed in ("X", "Y", "Z"):
        if needed not in by_name:
            raise ConfigError(f"{sec.file} [{sec.name}]: a tool changer needs axes X, Y and Z "
                              f"(the machine has {', '.join(by_name)})")
    pockets = sec.get_int("pockets", minval=1, maxval=99)
    place = {key: _position(sec, key, by_name[name]) for key, name in (
        ("x1", "X"), ("y_point_a", "Y"), ("y_point_b", "Y"), ("z_point_1", "Z"), ("z_point_2", "Z"))}
    carousel = by_name[axis]
    offset = sec.get_float("atc_offset")
    for pocket in (1, pockets):
        if not carousel.min_mm <= offset + pocket <= carousel.max_mm:
            raise sec.error("atc_offset", f"puts pocket {pocket} at {offset + pocket:g}, outside axis "
                            f"{axis} {carousel.min_mm:g}..{carousel.max_mm:g}")
    settings = AtcSettings(
        axis=axis, pockets=pockets,
        change_on=sec.get_str("change_on", "M6", choices=CHANGE_ON), atc_offset=offset,
        atc_home=_position(sec, "atc_home", carousel),
        feed_in_mm_min=sec.get_float("feed_in_mm_min", above=0.0),
        feed_out_mm_min=sec.get_float("feed_out_mm_min", above=0.0),
        feed_clamp_mm_min=sec.get_float("feed_clamp_mm_min", above=0.0),
        sim=_read_geometry(sec.section("sim"), place), **place)
    if settings.y_point_a == settings.y_point_b or settings.z_point_1 == settings.z_point_2:
        raise ConfigError(f"{sec.file} [{sec.name}]: Y_POINT_A and Y_POINT_B, and Z_POINT_1 and "
                          "Z_POINT_2, must differ (outside / inside, safe / clamp)")
    sec.finish()
    return settings


def _position(sec: Section, key: str, axis: Axis) -> float:
    value = sec.get_float(key)
    if not axis.min_mm <= value <= axis.max_mm:
        raise sec.error(key, f"must lie within axis {axis.name} {axis.min_mm:g}..{axis.max_mm:g}")
    return value


def _read_geometry(sec: Section, place: dict[str, float]) -> MagazineGeometry:
    geometry = MagazineGeometry(
        first_pocket_deg=sec.get_float("first_pocket_deg", minval=0.0, maxval=360.0),
        pocket_pitch_deg=sec.get_float("pocket_pitch_deg", above=0.0, maxval=360.0),
        degrees_per_unit=sec.get_float("degrees_per_unit", above=0.0),
        station_deg=sec.get_float("station_deg", minval=-360.0, maxval=360.0),
        magazine_y_mm=sec.get_float("magazine_y_mm"),
        tolerance_mm=sec.get_float("tolerance_mm", 0.5, above=0.0),
        tolerance_deg=sec.get_float("tolerance_deg", 1.0, above=0.0),
    )
    low, high = sorted((place["y_point_a"], place["y_point_b"]))
    if not low < geometry.magazine_y_mm < high:
        raise sec.error("magazine_y_mm", f"must lie between Y_POINT_A and Y_POINT_B ({low:g}..{high:g})")
    sec.finish()
    return geometry


@dataclass(frozen=True)
class SimTool:
    """A real tool as the simulator sees it: length from the spindle's gauge line to the tip."""

    number: int
    length_mm: float
    diameter_mm: float


@dataclass(frozen=True)
class ToolsSettings:
    """``[tools]``: the simulated tools (``[tools.sim]``). Z+ is up on every machine, so a tool
    hangs towards -Z: its tip is at the spindle's Z minus its length."""

    sim: dict[int, SimTool]             # tool number -> real geometry (pocket n holds tool n)


#: why ``[tools] z_positive`` is refused: the one Z convention of every machine
Z_UP_RULE = ("Z+ is up on every machine (as in LinuxCNC and grbl): Z = 0 at the top of travel after "
             "homing, the work below it, a tool hanging towards -Z and its length offset positive "
             "for a longer tool; remove the key and give Z positions counted upward")


def read_tools_section(sec: Section, axes: tuple[Axis, ...]) -> ToolsSettings:
    """Read ``[tools]``: ``[tools.sim]`` entries ``tN = {length_mm, diameter_mm}``."""
    if sec.has("z_positive"):
        raise sec.error("z_positive", f"no such setting: {Z_UP_RULE}")
    tools: dict[int, SimTool] = {}
    table = sec.section("sim", required=False)
    if table is not None:
        for key, entry in table.subsections():
            number = _tool_key(table, key)
            tools[number] = SimTool(number, entry.get_float("length_mm", above=0.0, maxval=1000.0),
                                    entry.get_float("diameter_mm", above=0.0, maxval=1000.0))
            entry.finish()
        table.finish()
    sec.finish()
    return ToolsSettings(tools)


def _tool_key(sec: Section, key: str) -> int:
    digits = key[1:]
    if not (key.startswith("t") and digits.isdigit() and int(digits) > 0):
        raise sec.error(key, "must be a tool number such as t1, t12 (t followed by the number, >= 1)")
    return int(digits)


def atc_of(machine: Machine) -> AtcSettings:
    """The machine's ``[atc]`` settings, or a ToolChangeError saying it has no tool changer."""
    settings = machine.parts.get("atc")
    if settings is None:
        raise ToolChangeError(f"machine {machine.name} has no tool changer (no [atc] section in "
                              f"{machine.source})")
    return settings


def tools_of(machine: Machine) -> ToolsSettings:
    """The machine's ``[tools]`` settings (no simulated tools when it has none)."""
    return machine.parts.get("tools") or ToolsSettings({})
