"""G-code translation: blocks run through the modal state into retrofit's command set.

G0 is FMOV and G1 is PMOV, both naming every machine axis with its target in machine
coordinates (mm); a G2/G3 arc becomes one PMOV per chord (:mod:`retrofit.motion.arcs`); F
becomes a PFDR sent just before the next feed move when it changed; G4 is DELY; M3/M4/M5 with S
are SPIN, M7/M8/M9 COOL; M6 (and T on a machine that changes on T) is TOOL; M0/M1/M60 PAUS; M62-M66 DOUT and
WAIT (:mod:`retrofit.gcode.iowords`).
Offsets (G5x, G92, G43) are kept here, never sent: see :mod:`retrofit.gcode.coords`.

Within a block the words act in LinuxCNC's order: feed mode, F, S, T, M62-M66, M6, M3/M4/M5, M7/M8/M9,
G4, plane, units, G40/G41/G42 (:mod:`retrofit.gcode.radiuscomp`), G43/G49, G54.., G61/G64,
G90/G91, G98/G99, then G10/G28/G30/G92 or the motion, then M0/M1/M2/M30/M60.
"""

from __future__ import annotations

import math

from ..commands import Command, Cool, Dely, FMov, Paus, PFdr, PMov, Spin, ZMov
from ..machine.config import Machine
from ..motion.arcs import arc_columns, arc_extent
from . import (
    coords,
    cycles,
    feedcap,
    iowords,
    modalsave,
    pathcontrol,
    polar,
    probing,
    radiuscomp,
    spindle,
    splines,
    tapping,
    tools,
)
from .arcwords import arc_center, chord_moves, plane_axes
from .blocks import Block
from .errors import RuleError
from .state import DECIMALS, ModalState, clean_mm
from .threading import g33, g76, leave
from .validate import check_arc, check_feed, check_soft_limits, check_word_use

#: the longest dwell accepted (s): a day
MAX_DWELL_S = 86400.0
#: feed and spindle speed ceilings: values beyond them overflow what any machine represents
MAX_FEED_MM_MIN = 1.0e6
MAX_RPM = 1.0e6
#: the only non-axis letter of a plain block
_PLAIN_VALUES = frozenset("F")


class Translator:
    """Turns blocks, in program order, into commands and the source line of each."""

    def __init__(self, machine: Machine, state: ModalState, tool_table=None, probe=None):
        self.machine = machine
        self.probe = probe                # runs G38 moves on the machine (retrofit.gcode.probing)
        self.state = state
        self.tool_table = tool_table
        self.commands: list[Command] = []
        self.lines: list[int] = []
        self.files: list[str] = []
        self._line = 0
        self._file = ""
        self.indexing = False             # ISTP emitted and not yet ended by CSTP (a G33 chain)
        self.last_block = None            # (file, line) of the last move under G61
        self.names = machine.axis_names
        atc = machine.parts.get("atc")
        self.change_on_t = getattr(atc, "change_on", "M6") == "T"
        self.comp = radiuscomp.RadiusComp()     # G40/G41/G42
        self.spindle_tool = state.tool          # in the spindle at the start (M66 plans from it)
        self.saved_states: dict[int, tuple] = {}   # call level -> (M70/M73 state, restore on return)
        self.messages: list[tuple[str, int, str, str]] = []   # (file, line, kind, text)

    def run(self, block: Block, file: str = "") -> bool:
        """Translate one block; True when it ends the program (M2, M30)."""
        self._line, self._file = block.line, file
        s = self.state
        g = block.g
        if not block.m and (not g or (len(g) == 1 and g.get("motion") in (0, 1))) \
                and not block.values.keys() - _PLAIN_VALUES:
            return self._plain(block)
        if block.motion is not None:
            s.motion_given = True
        mode = block.motion if block.motion is not None else s.motion
        if "@" in block.values or "^" in block.values:
            polar.mark(self, block)
        check_word_use(block, mode)
        if self.comp.on:
            radiuscomp.before(self, block)
        if "feed mode" in g:
            spindle.set_feed_mode(self, g["feed mode"])
        if "F" in block.values:
            self._feed_word(block.values["F"])
        if "io" in block.m:
            iowords.run(self, block)          # M62-M66: after T selects, before M6
        tools.tool_words(self, block)
        self._spindle(block)
        if "spindle" in block.m:
            modalsave.run(self, block)        # M70-M73: LinuxCNC's spindle group
        self._coolant(block)
        if g.get("non-modal") == 4:
            self._dwell(block.values["P"])
        self._modes(block)
        if self.comp.on or "cutter radius" in g:
            radiuscomp.modes(self, block)
        if "tool length" in g:
            coords.tool_length(self, block)
        if "coordinate system" in g:
            coords.select_system(self, g["coordinate system"])
        if block.motion is not None and block.motion not in splines.KEEP_MODE:
            s.motion = None if block.motion == 80 else block.motion
            if s.motion not in cycles.CYCLES:
                s.cycle_start = None
            if s.motion != 5.2:
                s.nurbs = None
        nonmodal = g.get("non-modal")
        if nonmodal in coords.NONMODAL:
            coords.NONMODAL[nonmodal](self, block)
        elif nonmodal == 76:
            self._needs_encoder("G76")
            g76(self, block)
        elif nonmodal == 5.3:
            splines.finish(self, block)
        else:
            self._motion(block, mode)
        stop = block.m.get("stopping")
        if stop in (0, 1, 60):
            radiuscomp.stop(self, stop)
            self._emit(Paus(stop))
        if stop in (2, 30):
            radiuscomp.reset(self, stop)
            self._end()
            return True
        return False

    def finish(self) -> None:
        """The end of the program's text without M2/M30: nothing may be left held back."""
        radiuscomp.finish(self)

    def _plain(self, block: Block) -> bool:
        """A block of axis words and F only, the bulk of CAM output: the same steps as
        :meth:`run`, without the codes it does not have."""
        if "F" in block.values:
            self._feed_word(block.values["F"])
        if block.g:
            self.state.motion, self.state.motion_given = block.g["motion"], True
            self.state.cycle_start = None
            self.state.nurbs = None
        self._motion(block, self.state.motion)
        return False

    # -- words acting before the motion ------------------------------------------------------
    def _feed_word(self, value: float) -> None:
        if value < 0.0 or (value > MAX_FEED_MM_MIN and (self.state.inverse_time or self.state.per_rev)):
            raise RuleError(f"F{value:g}: a feed is from 0 to {MAX_FEED_MM_MIN:g}")
        if self.state.inverse_time:
            self.state.feed_mm_min = value
            return
        feed = clean_mm(self.state.to_mm(value))
        self.state.feed_mm_min = feed if self.state.per_rev else feedcap.capped(self, feed, value)

    def _spindle(self, block: Block) -> None:
        s = self.state
        if block.values.get("$", 0.0) not in (0.0, -1.0):
            raise RuleError(f"{block.texts['$']}: machine {self.machine.name} has one spindle, "
                            f"$0 ($-1: every spindle)")
        if "spindle speed mode" in block.g:
            spindle.set_speed_mode(self, block)
        if "S" in block.values and s.css is not None:
            spindle.surface_word(self, block)
        elif "S" in block.values:
            rpm = block.values["S"]
            if rpm < 0.0 or rpm > MAX_RPM:
                raise RuleError(f"{block.texts['S']}: a spindle speed is from 0 to {MAX_RPM:g} rpm "
                                f"(M3/M4 choose the direction)")
            s.rpm = rpm
        code = block.m.get("spindle")
        if code in (3, 4):
            s.spindle = 1 if code == 3 else -1
            self._emit(Spin(s.rpm, s.spindle))
        elif code == 5:
            s.spindle = 0
            self._emit(Spin(0.0, 0))
        elif "S" in block.values and s.spindle:
            self._emit(Spin(s.rpm, s.spindle))      # new speed while the spindle turns

    def _coolant(self, block: Block) -> None:
        code = block.m.get("coolant")
        if code is not None:
            self.state.coolant = 0 if code == 9 else code
            self._emit(Cool(self.state.coolant))

    def _dwell(self, seconds: float) -> None:
        if not 0.0 <= seconds <= MAX_DWELL_S:
            raise RuleError(f"G4 P{seconds:g}: a dwell is from 0 to {MAX_DWELL_S:g} s")
        leave(self)
        self._emit(Dely(seconds))

    def _modes(self, block: Block) -> None:
        s, g = self.state, block.g
        if "plane" in g:
            s.plane = g["plane"]
        if "units" in g:
            s.inch = g["units"] == 20
        if "distance" in g:
            s.incremental = g["distance"] == 91
        if "arc distance" in g:
            s.arc_incremental = g["arc distance"] == 91.1
        if "lathe diameter" in g:
            s.diameter = g["lathe diameter"] == 7
        if "return mode" in g:
            s.retract_r = g["return mode"] == 99
        if "path control" in g:
            pathcontrol.set_mode(self, block)

    def _end(self) -> None:
        """M2/M30: the spindle stops and the coolant goes off if they were on."""
        leave(self)
        if self.state.spindle:
            self.state.spindle = 0
            self._emit(Spin(0.0, 0))
        if self.state.coolant:
            self.state.coolant = 0
            self._emit(Cool(0))

    # -- motion ----------------------------------------------------------------------------
    def _motion(self, block: Block, mode) -> None:
        if mode is None and block.axes and not self.state.motion_given:
            mode = self.state.motion = 0      # grbl: G0 is the motion mode from power-up
        if block.polar is not None and not (mode in cycles.CYCLES and self.state.incremental):
            polar.resolve(self, block)
        if self.comp.watching and radiuscomp.motion(self, block, mode):
            return
        if mode in splines.MODES:
            splines.run(self, block, mode)
            return
        if not block.axes:
            if block.motion in (2, 3) and any(c in block.values for c in "IJK"):
                self._arc(block, mode, dict(self.state.position))   # a full circle where it is
            return
        if mode is None:
            raise RuleError("cannot use axis values without a G code that uses them (no motion "
                            "mode: G80 is in force; give G0, G1, G2 or G3)")
        if mode == 80:
            raise RuleError("cannot use axis values with G80 (it ends the motion mode; give G0, "
                            "G1, G2 or G3)")
        machine_coords = block.g.get("non-modal") == 53
        if machine_coords and mode not in (0, 1):
            raise RuleError(f"G53 works with G0 or G1 only, not G{mode:g}")
        if mode in cycles.CYCLES:
            cycles.run(self, block, mode)
            return
        end = self.state.target(block.axes, machine_coords)
        if mode == 33.1:
            tapping.g33_1(self, block, end)
            return
        if mode == 33:
            self._needs_encoder("G33")
            g33(self, block, end)
            self.state.position = end
            return
        leave(self)
        if mode in probing.PROBE_CODES:
            probing.probe_move(self, block, mode, end)
        elif mode == 0:
            self.rapid(end)
        elif mode == 1:
            self.feed_line(end, mode)
        else:
            self._arc(block, mode, end)

    def _needs_encoder(self, code: str) -> None:
        if "spindle" not in self.machine.parts:
            raise RuleError(f"{code} needs a spindle encoder with an index pulse ([spindle] in the "
                            f"machine file); machine {self.machine.name} has none")
        if self.state.css is not None or self.state.per_rev:
            raise RuleError(f"{code} under G96/G95: a thread needs a steady spindle speed and its "
                            f"own pitch; G97 S<rpm> and G94 first")

    def rapid(self, end: dict[str, float], where: str = "") -> None:
        """A G0 move to ``end`` (machine mm)."""
        check_soft_limits(self.machine, end, where)
        if self.state.css is not None:
            spindle.follow(self, end["X"])
        self._emit(FMov(self._axes(end)))
        self.state.position = end

    def feed_line(self, end: dict[str, float], mode=1) -> None:
        """A G1 move to ``end`` (machine mm) at the programmed feed."""
        check_soft_limits(self.machine, end)
        s = self.state
        if s.css is not None:
            spindle.css_line(self, end, mode)
            return
        if s.inverse_time or s.feed_sent != s.feed_mm_min:
            self._send_feed(math.dist(s.position.values(), end.values()), mode)
        self._emit(PMov(self._axes(end)))
        self.state.position = end

    def _arc(self, block: Block, mode: int, end: dict[str, float]) -> None:
        center, extra_turns = self.arc_centre(block, mode, end)
        self.arc_move(self.state.position, end, center, mode, extra_turns)
        self.state.position = end

    def arc_centre(self, block: Block, mode: int, end: dict[str, float]):
        """The centre (plane coordinates, mm) of a G2/G3 from the current position to ``end``
        and its whole turns beyond the first (P)."""
        s = self.state
        first, second = plane_axes(self.machine, s.plane, mode)
        start = s.position
        words = {c: s.to_mm(block.values[c]) for c in "IJKR" if c in block.values}
        if not s.arc_incremental:
            words = coords.absolute_centre_words(self, words)
        turns = block.values.get("P", 1.0)
        if turns < 1 or turns != int(turns) or turns > 1000:
            raise RuleError(f"{block.texts['P']}: the number of turns of an arc is a whole number "
                            f"from 1 to 1000")
        center = arc_center(mode, s.plane, (start[first], start[second]), (end[first], end[second]),
                            words, block.texts, s.inch)
        return center, int(turns) - 1

    def arc_move(self, start: dict[str, float], end: dict[str, float], center, mode: int,
                 extra_turns: int, emit=None) -> None:
        """The chords (PMOV) of a G2 (``mode`` 2) or G3 arc around ``center`` (plane
        coordinates), after its feed; ``emit`` takes the commands (default: in program order)."""
        first, second = plane_axes(self.machine, self.state.plane, mode)
        names = self.names
        plane = (names.index(first), names.index(second))
        center_all = [0.0] * len(names)
        center_all[plane[0]], center_all[plane[1]] = center
        args = (tuple(start[n] for n in names), tuple(end[n] for n in names), tuple(center_all),
                mode == 2, plane)
        tolerance = self.machine.motion.arc_tolerance_mm
        try:
            extent = arc_extent(*args, tolerance, extra_turns)
        except ValueError:
            raise RuleError(f"G{mode}: the arc's centre or radius is not a finite number") from None
        length = check_arc(self.machine, mode, *extent)
        chords = arc_columns(*args, tolerance, extra_turns)
        if emit is None:
            self._send_feed(length, mode)
            emit = self._emit
        s = self.state
        # an axis off the plane that does not move stays at its start on every chord
        words = [(n, clean_mm(start[n])) for n in names]
        moving = [(i, n) for i, n in enumerate(names) if i in plane or start[n] != end[n]]
        if s.css is None:
            moves = chord_moves(words, moving, chords)
            if emit == self._emit and not self._holding():
                self.put_all(moves)
            else:
                for move in moves:
                    emit(move)
            return
        x = names.index("X")
        for p in chords.tolist():        # G96: the spindle speed follows the tool chord by chord
            spindle.follow(self, p[x])
            if s.per_rev:
                self._send_feed(length, mode)
            for i, n in moving:
                words[i] = (n, round(p[i], DECIMALS) + 0.0)                  # clean_mm, inlined
            emit(PMov(tuple(words)))

    # -- output ----------------------------------------------------------------------------
    def _send_feed(self, length_mm: float = 0.0, mode=1) -> None:
        s = self.state
        feed = s.feed_mm_min
        if s.inverse_time:
            if not s.feed_mm_min > 0.0:
                raise RuleError(f"G{mode:g} under G93 needs F on its line (moves per minute)")
            feed = clean_mm(max(length_mm, 1e-9) * s.feed_mm_min)
            s.feed_mm_min = 0.0           # G93: every feed move gives its own F
        elif s.per_rev:
            feed = spindle.per_rev_feed(self, mode)
        check_feed(mode, feed)
        if s.feed_sent != feed:
            self._emit(PFdr(feed))
            s.feed_sent = feed

    def _axes(self, point: dict[str, float]) -> tuple[tuple[str, float], ...]:
        return tuple([(name, point[name]) for name in self.names])

    def _holding(self) -> bool:
        """True while cutter compensation holds a move back (other commands wait behind it)."""
        held = self.comp.geometry
        return held is not None and bool(held.queue)

    def _emit(self, command: Command) -> None:
        if self._holding():
            self.comp.geometry.hold((command, self._line, self._file))
            return
        self.put(command)

    def put_all(self, commands: list[Command]) -> None:
        """:meth:`put` each of ``commands``, moves of one block (after the first, a move of the
        same block changes nothing put checks: the tool offset is taken, the block is the last)."""
        if commands:
            self.put(commands[0])
            self.commands.extend(commands[1:])
            self.lines.extend([self._line] * (len(commands) - 1))
            self.files.extend([self._file] * (len(commands) - 1))

    def put(self, command: Command) -> None:
        """Append ``command`` now, with the source line of the block being translated."""
        if self.state.pending and isinstance(command, (FMov, PMov, ZMov)):
            self.state.pending = {}
        if self.state.exact_stop:
            pathcontrol.stop_between_blocks(self, command)
        self.commands.append(command)
        self.lines.append(self._line)
        self.files.append(self._file)

