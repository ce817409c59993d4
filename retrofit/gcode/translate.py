"""G-code translation: parsed blocks run through the modal state into retrofit's command set.

G0 is FMOV and G1 is PMOV, both naming every machine axis with its absolute target in mm; a
G2/G3 arc becomes one PMOV per chord (:mod:`retrofit.motion.arcs`); F becomes a PFDR sent just
before the next feed move when it changed; G4 is DELY, G28 ZMOV, G92 PSTN, M3/M4/M5 with S are
SPIN and M7/M8/M9 are COOL; T, M6, G43 and G49 become TOOL, M0/M1/M60 PAUS, G43/G49 PSTN (:mod:`retrofit.gcode.tools`);
G33 and the G76 cycle become moves under the spindle's indexer (:mod:`retrofit.gcode.threading`).
Within a block the words act in this order: plane, units and distance mode; feed; T and M6;
spindle; coolant; dwell; G43/G49; G28/G92 or the motion; program end.
"""

from __future__ import annotations

from ..commands import Command, Cool, Dely, FMov, PFdr, PMov, Pstn, Spin, ZMov
from ..config import Machine
from ..controller.settings import home_positions_mm
from ..motion.arcs import arc_points
from .arcwords import allowed_radius_mismatch, arc_center, plane_axes
from .parser import ParsedBlock
from .state import ModalState, clean_mm
from .threading import g33, g76, leave
from .tools import change_tool, pause, tool_length
from .validate import RuleError, check_feed, check_soft_limits, check_word_use


class Translator:
    """Turns parsed blocks, in program order, into commands and the source line of each."""

    def __init__(self, machine: Machine, state: ModalState):
        self.machine = machine
        self.state = state
        self.commands: list[Command] = []
        self.lines: list[int] = []
        self._line = 0
        self.offset_mm = {name: 0.0 for name in machine.axis_names}   # machine - program (G92, G43)
        self.tool_table = None            # retrofit.tooltable.ToolTable, for G43
        self.spindle_tool = 0             # the tool in the spindle, followed through T / M6
        self.selected_tool: int | None = None
        self.length_offset_mm = 0.0       # the G43 offset in force
        self.indexing = False             # ISTP emitted and not yet ended by CSTP (a G33 chain)

    def run(self, block: ParsedBlock) -> bool:
        """Translate one block; True when it ends the program (M2, M30)."""
        self._line = block.line
        mode = block.motion if block.motion is not None else self.state.motion
        check_word_use(block, mode)
        self._modes(block)
        if "F" in block.values:
            self.state.feed_mm_min = clean_mm(self.state.to_mm(block.values["F"]))
        if "T" in block.values or "tool change" in block.m:
            change_tool(self, block)
        self._spindle(block)
        self._coolant(block)
        nonmodal = block.g.get("non-modal")
        if nonmodal == 4:
            self._emit(Dely(block.values["P"]))
        if "tool length" in block.g:
            tool_length(self, block)
        if block.motion is not None:
            self.state.motion = block.motion
        if nonmodal == 28:
            self._home(block)
        elif nonmodal == 92:
            self._set_position(block)
        elif nonmodal == 76:
            g76(self, block)
        else:
            self._motion(block, mode)
        if "stop" in block.m:
            pause(self, block)
        if "program end" in block.m:
            self._end()
            return True
        return False

    # -- modes, spindle, coolant ----------------------------------------------------------------
    def _modes(self, block: ParsedBlock) -> None:
        g = block.g
        if "plane" in g:
            self.state.plane = g["plane"]
        if "units" in g:
            self.state.inch = g["units"] == 20
        if "distance" in g:
            self.state.incremental = g["distance"] == 91

    def _spindle(self, block: ParsedBlock) -> None:
        s = self.state
        if "S" in block.values:
            s.rpm = block.values["S"]
        code = block.m.get("spindle")
        if code in (3, 4):
            if not s.rpm > 0.0:
                raise RuleError(f"M{code} with spindle speed 0 (set S > 0, e.g. M{code} S800)")
            s.spindle = 1 if code == 3 else -1
            self._emit(Spin(s.rpm, s.spindle))
        elif code == 5:
            s.spindle = 0
            self._emit(Spin(0.0, 0))
        elif "S" in block.values and s.spindle:
            self._emit(Spin(s.rpm, s.spindle))      # new speed while the spindle turns

    def _coolant(self, block: ParsedBlock) -> None:
        code = block.m.get("coolant")
        if code is not None:
            self.state.coolant = 0 if code == 9 else code
            self._emit(Cool(self.state.coolant))

    def _end(self) -> None:
        """M2/M30: the spindle stops and the coolant goes off if they were on."""
        leave(self)
        if self.state.spindle:
            self.state.spindle = 0
            self._emit(Spin(0.0, 0))
        if self.state.coolant:
            self.state.coolant = 0
            self._emit(Cool(0))

    # -- G28, G92 ----------------------------------------------------------------------------
    def _home(self, block: ParsedBlock) -> None:
        """G28: rapid to the intermediate point if axis words are given, then home every axis;
        machine zero is 0 mm on every axis (each axis's ``home_mm`` when it homes on switches)."""
        leave(self)
        if block.axes:
            via = self.state.target(block.axes)
            check_soft_limits(self.machine, via, " (G28 intermediate point)")
            self._emit(FMov(self._axes(via)))
        self._emit(ZMov())
        self.state.position = home_positions_mm(self.machine)

    def _set_position(self, block: ParsedBlock) -> None:
        """G92: the named axes are now at the given values (absolute, whatever G90/G91 says)."""
        named = {n: clean_mm(self.state.to_mm(v)) for n, v in block.axes.items()}
        self._emit(Pstn(tuple((n, named[n]) for n in self.machine.axis_names if n in named)))
        for n, value in named.items():
            self.offset_mm[n] = clean_mm(self.offset_mm[n] + self.state.position[n] - value)
        self.state.position.update(named)

    # -- motion ----------------------------------------------------------------------------
    def _motion(self, block: ParsedBlock, mode: int | None) -> None:
        if not block.axes:
            if block.motion is not None:
                raise RuleError(f"G{block.motion} without an axis word")
            return
        if mode is None:
            raise RuleError("axis words without a motion mode (put G0, G1, G2 or G3 before them)")
        end = self.state.target(block.axes)
        if mode == 33:
            g33(self, block, end)
            self.state.position = end
            return
        leave(self)
        if mode == 0:
            check_soft_limits(self.machine, end)
            self._emit(FMov(self._axes(end)))
        elif mode == 1:
            check_feed(mode, self.state.feed_mm_min)
            check_soft_limits(self.machine, end)
            self._send_feed()
            self._emit(PMov(self._axes(end)))
        else:
            self._arc(block, mode, end)
        self.state.position = end

    def _arc(self, block: ParsedBlock, mode: int, end: dict[str, float]) -> None:
        s = self.state
        first, second = plane_axes(self.machine, s.plane, mode)
        check_feed(mode, s.feed_mm_min)
        start = s.position
        words_mm = {c: s.to_mm(block.values[c]) for c in "IJKR" if c in block.values}
        center = arc_center(mode, s.plane, (start[first], start[second]), (end[first], end[second]),
                            words_mm, block.texts, allowed_radius_mismatch(self.machine))
        names = self.machine.axis_names
        plane = (names.index(first), names.index(second))
        center_all = [0.0] * len(names)
        center_all[plane[0]], center_all[plane[1]] = center
        chords = arc_points(tuple(start[n] for n in names), tuple(end[n] for n in names),
                            tuple(center_all), mode == 2, plane, self.machine.motion.arc_tolerance_mm)
        points = [{n: clean_mm(v) for n, v in zip(names, p)} for p in chords]
        for point in points:
            check_soft_limits(self.machine, point, f" on the G{mode} arc")
        self._send_feed()
        for point in points:
            self._emit(PMov(self._axes(point)))

    # -- output ----------------------------------------------------------------------------
    def _send_feed(self) -> None:
        feed = self.state.feed_mm_min
        if self.state.feed_sent != feed:
            self._emit(PFdr(feed))
            self.state.feed_sent = feed

    def _axes(self, point: dict[str, float]) -> tuple[tuple[str, float], ...]:
        return tuple((name, point[name]) for name in self.machine.axis_names)

    def _emit(self, command: Command) -> None:
        self.commands.append(command)
        self.lines.append(self._line)
