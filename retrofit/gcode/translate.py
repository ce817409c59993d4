"""G-code translation: blocks run through the modal state into retrofit's command set.

The translator emits canonical calls (:mod:`retrofit.canon`), which its :attr:`Translator.canon`
turns into commands: G0 is a straight traverse (FMOV) and G1 a straight feed (PMOV), both
naming every machine axis with its target in machine coordinates (mm); a G2/G3 is one arc with
its centre, cut into chords (one PMOV each) after the seam; F becomes a feed rate (PFDR) sent
just before the next feed move when it changed; G4 is a dwell (DELY); M3/M4/M5 with S the
spindle (SPIN), M7/M8/M9 the coolant (COOL); M6 (and T on a machine that changes on T) a tool
change (TOOL); M0/M1/M60 a pause (PAUS); M62-M66 a digital output or a wait (DOUT, WAIT:
:mod:`retrofit.gcode.iowords`).
Offsets (G5x, G92, G43) are kept here, never sent: see :mod:`retrofit.gcode.coords`.

Within a block the words act in LinuxCNC's order: feed mode, F, S, T, M62-M66, M6, M3/M4/M5, M7/M8/M9,
G4, plane, units, G40/G41/G42 (:mod:`retrofit.gcode.radiuscomp`), G43/G49, G54.., G61/G64,
G90/G91, G98/G99, then G10/G28/G30/G92 or the motion, then M0/M1/M2/M30/M60.
"""

from __future__ import annotations

import math

from ..canon import (
    Call,
    CommandCanon,
    Coolant,
    Dwell,
    Pause,
    SetFeedRate,
    Spindle,
    StraightFeed,
    StraightProbe,
    StraightTraverse,
    ZeroAxes,
)
from ..canon.calls import MOVES, Position
from ..canon.moves import CommandList
from ..machine.config import Machine
from ..machine.tooltable import ToolTable
from . import (
    arcmove,
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
from .blocks import Block
from .errors import RuleError
from .probing import Prober
from .state import ModalState, clean_mm
from .threading import g33, g76, leave
from .validate import check_feed, check_soft_limits, check_word_use

#: the longest dwell accepted (s): a day
MAX_DWELL_S = 86400.0
#: feed and spindle speed ceilings: values beyond them overflow what any machine represents
MAX_FEED_MM_MIN = 1.0e6
MAX_RPM = 1.0e6
#: the only non-axis letter of a plain block
_PLAIN_VALUES = frozenset("F")


class Translator:
    """Turns blocks, in program order, into canonical calls, and through :attr:`canon` into
    commands and the source line of each."""

    def __init__(self, machine: Machine, state: ModalState, tool_table: ToolTable | None = None,
                 probe: Prober | None = None):
        self.machine = machine
        self.probe = probe                # runs G38 moves on the machine (retrofit.gcode.probing)
        self.state = state
        self.tool_table = tool_table
        self.canon = CommandCanon(machine.axis_names, machine.motion.arc_tolerance_mm)
        self.commands: CommandList = CommandList()   # moves of plain runs kept as arrays
        self.lines: list[int] = []
        self.files: list[str] = []
        self._line = 0
        self._file = ""
        self.indexing = False             # ISTP emitted and not yet ended by CSTP (a G33 chain)
        self.last_block: tuple[str, int] | None = None   # (file, line) of the last move under G61
        self.names = machine.axis_names
        atc = machine.parts.get("atc")
        self.change_on_t = getattr(atc, "change_on", "M6") == "T"
        self.comp = radiuscomp.RadiusComp()     # G40/G41/G42
        self.spindle_tool = state.tool          # in the spindle at the start (M66 plans from it)
        self.saved_states: dict[int, tuple] = {}   # call level -> (M70/M73 state, restore on return)
        self.messages: list[tuple[str, int, str, str]] = []   # (file, line, kind, text)
        self.feed_ceiling: float | None = None  # the machine's fastest feed, once asked (feedcap)
        self.feed_warned = False                # a feed above it has been said once
        self.streaming = False                  # read ahead: the commands so far are not all kept
        #: plain G0/G1 lines make their commands directly (:mod:`.plainline`, :mod:`.plainrun`),
        #: the ones their straight traverses and feeds would make; False: through the canon too
        self.plain_path = True

    @property
    def where(self) -> tuple[int, str]:
        """(line, file) of the block being translated."""
        return self._line, self._file

    def at(self, line: int, file: str) -> None:
        """The block being translated is ``line`` of ``file`` (for the calls made now)."""
        self._line, self._file = line, file

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
            self.feed_word(block.values["F"])
        if "io" in block.m:
            iowords.run(self, block)          # M62-M66: after T selects, before M6
        tools.tool_words(self, block)
        self._spindle(block)
        if "spindle" in block.m:
            modalsave.run(self, block)        # M70-M73: LinuxCNC's spindle group
        self._coolant(block)
        if g.get("non-modal") == 4:
            self.dwell(block.values["P"])
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
            self.emit(Pause(int(stop)))
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
            self.feed_word(block.values["F"])
        if block.g:
            self.state.motion, self.state.motion_given = block.g["motion"], True
            self.state.cycle_start = None
            self.state.nurbs = None
        self._motion(block, self.state.motion)
        return False

    # -- words acting before the motion ------------------------------------------------------
    def feed_word(self, value: float) -> None:
        """F ``value`` (program units): the feed of the moves that follow."""
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
            self.emit(Spindle(s.rpm, s.spindle))
        elif code == 5:
            s.spindle = 0
            self.emit(Spindle(0.0, 0))
        elif "S" in block.values and s.spindle:
            self.emit(Spindle(s.rpm, s.spindle))    # new speed while the spindle turns

    def _coolant(self, block: Block) -> None:
        code = block.m.get("coolant")
        if code is not None:
            self.state.coolant = 0 if code == 9 else int(code)
            self.emit(Coolant(self.state.coolant))

    def dwell(self, seconds: float) -> None:
        """G4 P ``seconds``."""
        if not 0.0 <= seconds <= MAX_DWELL_S:
            raise RuleError(f"G4 P{seconds:g}: a dwell is from 0 to {MAX_DWELL_S:g} s")
        leave(self)
        self.emit(Dwell(seconds))

    def _modes(self, block: Block) -> None:
        s, g = self.state, block.g
        if "plane" in g:
            s.plane = int(g["plane"])
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
            self.emit(Spindle(0.0, 0))
        if self.state.coolant:
            self.state.coolant = 0
            self.emit(Coolant(0))

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
                arcmove.arc(self, block, mode, dict(self.state.position))   # a full circle where it is
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
            arcmove.arc(self, block, mode, end)

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
        self.emit(StraightTraverse(self.position_of(end)))
        self.state.position = end

    def feed_line(self, end: dict[str, float], mode=1, probing: bool = False) -> None:
        """A G1 move to ``end`` (machine mm) at the programmed feed (``probing``: a G38 move
        that stopped there)."""
        check_soft_limits(self.machine, end)
        s = self.state
        if s.css is not None:
            spindle.css_line(self, end, mode)
            return
        if s.inverse_time or s.feed_sent != s.feed_mm_min:
            self.send_feed(math.dist(s.position.values(), end.values()), mode)
        self.emit((StraightProbe if probing else StraightFeed)(self.position_of(end)))
        self.state.position = end

    # -- output ----------------------------------------------------------------------------
    def send_feed(self, length_mm: float = 0.0, mode=1) -> None:
        """The feed rate of the next feed move of ``length_mm``, when it is not the one sent."""
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
            self.emit(SetFeedRate(feed))
            s.feed_sent = feed

    #: the plain-line fast path's names (:mod:`.plainline`)
    _feed_word = feed_word
    _send_feed = send_feed

    def position_of(self, point: dict[str, float]) -> Position:
        """``point`` (axis -> machine mm) as a canonical position: every axis in order."""
        return tuple([point[name] for name in self.names])

    def emit(self, call: Call) -> None:
        """Make ``call`` now, or hold it behind a move cutter compensation holds back."""
        held = self.comp.geometry
        if held is not None and held.queue:
            held.hold((call, self._line, self._file))
            return
        self.put(call)

    def put(self, call: Call) -> None:
        """Make ``call`` now: its commands, with the source line of the block being translated."""
        commands = self.canon.commands(call)
        if self.state.pending and isinstance(call, (*MOVES, ZeroAxes)):
            self.state.pending = {}
        if self.state.exact_stop and pathcontrol.stop_between_blocks(self, isinstance(call, MOVES)):
            commands = self.canon.commands(Dwell(0.0)) + commands
        self.commands.extend(commands)
        self.lines.extend([self._line] * len(commands))
        self.files.extend([self._file] * len(commands))
