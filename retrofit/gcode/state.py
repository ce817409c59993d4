"""The modal state of a G-code program: what one block leaves behind for the next.

Positions are kept in **machine coordinates** (mm), the coordinates of every command retrofit
emits. A program writes **program coordinates**; the two differ by the offsets in force, as in
LinuxCNC::

    machine = program + G5x offset + G92 offset + tool offset

The offsets live in the numbered parameters (:mod:`retrofit.gcode.params`), so ``#5221=10`` moves
G54 as G10 L2 P1 X10 does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from ..canon.rounding import DECIMALS, clean_mm, clean_mm_list
from ..machine.config import Machine
from ..machine.rotary import shorter_way
from .params import CS_SELECT, CS_STEP, G54_BASE, G92_BASE, Parameters

MM_PER_INCH = 25.4
__all__ = ["DECIMALS", "MM_PER_INCH", "ModalState", "clean_mm", "clean_mm_list", "default_plane"]
def default_plane(machine: Machine) -> int:
    """G18 (ZX) on a machine without a Y axis (a lathe), G17 (XY) otherwise."""
    return 17 if "Y" in machine.axis_names else 18


@dataclass
class ModalState:
    """Everything a block may leave behind for the next one."""

    position: dict[str, float]          # mm, machine coordinates, every machine axis in order
    plane: int                          # 17, 18 or 19
    feed_mm_min: float                  # programmed feed (F), or the machine's default
    params: Parameters = field(default_factory=Parameters)
    motion: float | None = None         # the motion mode (0, 1, 2, 3, 33, 73, 81...); None: G80
    motion_given: bool = False          # a motion code (or G80) has been programmed
    inch: bool = False                  # G20 (True) or G21
    incremental: bool = False           # G91 (True) or G90
    arc_incremental: bool = True        # G91.1 (True, the default) or G90.1
    diameter: bool = False              # G7 (lathe diameter mode) or G8
    inverse_time: bool = False          # G93 (True) or G94
    retract_r: bool = False             # G99 (True: retract to R) or G98 (to the start height)
    feed_sent: float | None = None      # the feed of the last PFDR emitted
    rpm: float = 0.0                    # S
    spindle: int = 0                    # +1 (M3), -1 (M4), 0 (M5)
    coolant: int = 0                    # 7, 8 or 0
    tool: int = 0                       # in the spindle
    selected: int | None = None         # T given, not yet changed
    tool_offset: dict[str, float] = field(default_factory=dict)   # G43: axis -> mm
    pending: dict[str, float] = field(default_factory=dict)  # tool offset change the next move makes
    _offsets: tuple = (None, None, {})  # (parameter version, tool offsets, axis -> offset) cache
    cycle_r: float | None = None        # the last R of a canned cycle (program units)
    cycle_z: float | None = None        # the last Z of a canned cycle
    cycle_q: float | None = None        # the last Q (peck) of a canned cycle
    cycle_p: float | None = None        # the last P (dwell) of a canned cycle
    cycle_ijk: dict[str, float] = field(default_factory=dict)   # G87's last I J K (program units)
    cycle_start: float | None = None    # machine Z where the current run of cycles began
    spline_ij: tuple = (0.0, 0.0)       # G5's first control point when I J are left out (mm)
    nurbs: dict | None = None           # G5.2 control points collected until G5.3
    exact_stop: bool = False            # G61/G61.1 (True) or G64
    per_rev: bool = False               # G95: F in mm per spindle revolution
    css: tuple | None = None            # G96: (surface speed m/min, rpm ceiling); None: G97
    rotary: frozenset = frozenset()     # axes in degrees (A, B, C): no inch, no diameter
    wrapped: frozenset = frozenset()    # rotary axes whose G90 moves take the shorter way

    @classmethod
    def start(cls, machine: Machine, start_mm: Mapping[str, float] | None = None) -> ModalState:
        """The state at the top of a program: G21 G90 G91.1 G94 G54, the default plane, at
        ``start_mm`` (axes not named there at 0 mm)."""
        position = {name: 0.0 for name in machine.axis_names}
        for name, value in (start_mm or {}).items():
            key = name.upper()
            if key not in position:
                raise ValueError(f"start_mm names axis {name!r}, which is not on machine "
                                 f"{machine.name} (axes: {', '.join(machine.axis_names)})")
            position[key] = clean_mm(float(value))
        return cls(position=position, plane=default_plane(machine),
                   feed_mm_min=machine.motion.default_feed_mm_min,
                   rotary=frozenset(a.name for a in machine.axes if a.rotary),
                   wrapped=frozenset(a.name for a in machine.axes if a.wrap))

    def to_mm(self, value: float) -> float:
        """A length in program units (inch under G20) in mm."""
        return value * MM_PER_INCH if self.inch else value

    def offset(self, axis: str) -> float:
        """Machine minus program coordinate of ``axis`` (mm): G5x + G92 + tool offsets."""
        version, tool, cache = self._offsets
        if version != self.params.version or tool is not self.tool_offset:
            cache = {}
            self._offsets = (self.params.version, self.tool_offset, cache)
        value = cache.get(axis)
        if value is None:
            value = cache[axis] = self._offset(axis)
        return value

    def _offset(self, axis: str) -> float:
        p = self.params
        total = p.axis(G54_BASE + CS_STEP * (int(p.numbered.get(CS_SELECT, 1.0)) - 1), axis)
        if p.numbered.get(G92_BASE - 1, 0.0):
            total += p.axis(G92_BASE, axis)
        return total + self.tool_offset.get(axis, 0.0)

    def program_position(self, axis: str) -> float:
        """Where ``axis`` is in program coordinates (mm)."""
        return self.position[axis] - self.offset(axis) if axis in self.position else 0.0

    def word_mm(self, axis: str, value: float) -> float:
        """An axis word in mm: inches under G20, a diameter halved under G7 (X only); a rotary
        axis's word is degrees."""
        if axis in self.rotary:
            return value
        mm = value * MM_PER_INCH if self.inch else value
        return mm / 2.0 if self.diameter and axis == "X" else mm

    def target(self, axes: Mapping[str, float], machine_coords: bool = False) -> dict[str, float]:
        """The end point (machine mm, every axis) of axis words in program units, under G90/G91
        (``machine_coords``: G53, absolute machine coordinates)."""
        end = dict(self.position)
        for name, delta in self.pending.items():    # a new tool offset: the program position stays
            end[name] = clean_mm(end[name] + delta)
        scale = MM_PER_INCH if self.inch else 1.0
        for name, value in axes.items():
            mm = value if name in self.rotary else value * scale
            if self.diameter and name == "X":
                mm /= 2.0
            if name in self.wrapped and not (self.incremental or machine_coords):
                mm = shorter_way(end[name], mm + self.offset(name)) - self.offset(name)
            if machine_coords:
                end[name] = round(mm, DECIMALS) + 0.0
            elif self.incremental:
                end[name] = round(end[name] + mm, DECIMALS) + 0.0   # end holds the pending change
            else:
                end[name] = round(mm + self.offset(name), DECIMALS) + 0.0
        return end
