"""The Fanuc/Haas lathe dialect (G-code system A): a program's blocks run through the translator.

Chosen with ``--dialect fanuc`` or ``dialect = "fanuc"`` in the machine file's ``[machine]``;
never guessed. What differs from RS274 (LinuxCNC):

* X and U are diameters (G7 from the start), U and W are incremental X and Z; there is no G90/G91
  distance mode (G90 is a turning cycle);
* ``T0101`` is tool 01 with offset 01 (a TOOL command, then the offset from the tool table);
  ``T0100`` cancels the offset;
* G50 ``S`` caps the spindle under G96; G50 ``X Z`` sets the coordinates (RS274's G92); G96 S is
  a surface speed, G97 S rpm; G98 feeds per minute, G99 (the default) per revolution;
* G04 ``P`` is milliseconds without a decimal point, ``X``/``U``/``P.`` seconds; G32 a thread move
  (F the lead); G70-G76 and G90/G92/G94 are the lathe cycles (:mod:`retrofit.gcode.fanuc_cycle_run`);
* O-numbers and ``:`` numbers head programs; ``M98 P L`` calls one, ``M97 P`` (Haas) a local
  N-labelled part, ``M99`` returns; M31, M41-M44 and other machine-side M codes run with a note.

The machine-dependent choices (:mod:`retrofit.gcode.fanuc_settings`) come from ``[fanuc]``.
"""

from __future__ import annotations

import math

from . import fanuc_calls, fanuc_cycle_run
from .blocks import make_block
from .errors import RuleError
from .fanuc_read import FBlock, read_program
from .fanuc_settings import FanucSettings

#: G codes read in a Fanuc block (system A), and what is refused
ACCEPTED_G = "G0 G1 G2 G3 G4 G18 G20 G21 G28 G32 G40 G41 G42 G50 G53 G54-G59 G70-G76 G80 G90 " \
             "G92 G94 G96 G97 G98 G99"
#: M codes that act on things this machine does not have: run, with a note saying so
NOTED_M: dict[float, str] = {10: "chuck clamp", 11: "chuck unclamp", 12: "air blast on", 13: "air blast off",
           14: "spindle clamp", 15: "spindle unclamp", 21: "tailstock forward",
           22: "tailstock back", 23: "thread chamfer on (threads end square here)",
           24: "thread chamfer off", 31: "chip conveyor forward", 32: "chip conveyor reverse",
           33: "chip conveyor stop", 36: "parts catcher on", 37: "parts catcher off",
           41: "gear range 1", 42: "gear range 2", 43: "gear range 3", 44: "gear range 4",
           88: "through-spindle coolant on", 89: "through-spindle coolant off",
           6: "tool change: the T word changes the tool"}
PASSED_M = {0, 1, 2, 30, 3, 4, 5, 7, 8, 9}
MOTION = {0, 1, 2, 3, 32}
CYCLES = {70, 71, 72, 73, 74, 75, 76}
MODAL_CYCLES = {90, 92, 94}
PLAIN_G = {18, 20, 21, 40, 41, 42, 53, 54, 55, 56, 57, 58, 59}


class FanucRunner:
    """Runs a Fanuc program's blocks, keeping the dialect's modes beside the translator's."""

    def __init__(self, program, tr, settings: FanucSettings, messages: list):
        self.prog, self.tr, self.machine = program, tr, tr.machine
        self.settings, self.messages = settings, messages
        self.motion: float = 0.0              # group 01 (G00 at power-on)
        self.per_rev = settings.feed_at_start == "per_rev"
        self.cap_rpm: float | None = None       # G50 S
        self.first: dict[int, FBlock] = {}      # first blocks of G71-G76: cycle -> block
        self.modal: dict = {}                   # G90/G92/G94: the last Z, R, F
        self.line, self.pc = 0, 0
        self.xf = 2.0 if settings.x_diameter else 1.0

    # -- the run ---------------------------------------------------------------------------------
    def run(self) -> None:
        setup = [("G", 18.0), ("G", 7.0 if self.settings.x_diameter else 8.0), ("G", 90.0),
                 ("G", 20.0 if self.settings.inch_at_start else 21.0), ("G", 94.0)]
        self.emit(setup)
        calls: list[tuple[int, int, int]] = []
        steps = 0
        from .program import MAX_CALL_DEPTH, MAX_STEPS
        while self.pc < len(self.prog.blocks):
            steps += 1
            block = self.prog.blocks[self.pc]
            self.line = block.line
            if steps > len(self.prog.blocks) + MAX_STEPS:
                raise RuleError(f"the program runs more than {MAX_STEPS} blocks beyond its own "
                                f"(a loop that never ends?)")
            if block.error:
                raise RuleError(block.error)
            m = block.codes("M")
            if 98.0 in m or 97.0 in m or 99.0 in m:
                if 99.0 not in m and len(calls) >= MAX_CALL_DEPTH:
                    raise RuleError(f"subprogram calls nest deeper than {MAX_CALL_DEPTH}")
                if self.call(block, calls):
                    return
                continue
            if self.block(block):
                return
            self.pc += 1

    def call(self, block: FBlock, calls: list) -> bool:
        """M98/M97/M99 (:mod:`retrofit.gcode.fanuc_calls`); True when the program ends."""
        return fanuc_calls.call(self, block, calls)

    def index_of(self, n: int, what: str, after: int | None = None) -> int:
        """The block carrying N``n`` (the first after ``after`` when there are several)."""
        found = self.prog.numbers.get(n)
        if not found:
            raise RuleError(f"{what}{n}: no block N{n} in {self.prog.file}")
        later = [i for i in found if after is not None and i > after]
        return (later or found)[0]

    # -- one block -------------------------------------------------------------------------------
    def block(self, block: FBlock) -> bool:
        """One block; True when it ends the program."""
        gs = [round(g, 4) for g in block.codes("G")]
        for g in gs:
            if g not in MOTION | CYCLES | MODAL_CYCLES | PLAIN_G | {4, 28, 50, 80, 96, 97, 98, 99}:
                raise RuleError(f"G{g:g}: not read under the Fanuc dialect (read: {ACCEPTED_G})")
        for m in block.codes("M"):
            if m not in PASSED_M and m not in NOTED_M:
                raise RuleError(f"M{m:g}: not read under the Fanuc dialect (read: M0 M1 M2 M3 M4 "
                                f"M5 M7 M8 M9 M30 M97 M98 M99, and with a note "
                                f"M{' M'.join(str(k) for k in NOTED_M)})")
            if m in NOTED_M:
                self.messages.append((self.prog.file, block.line, "NOTE",
                                      f"M{m:g} ({NOTED_M[m]}) run as a no-op"))
        self.check_words(block, gs)
        if 92 in gs and not self.has_axes(block):          # G92 S: the spindle cap (systems B, C)
            gs = [g for g in gs if g != 92]
            if block.has("S"):
                self.g50(block)
                self.messages.append((self.prog.file, block.line, "NOTE", (f"G92 S{block.get('S'):g} "
                                      f"read as the spindle speed cap (G50 S in G-code system A)")))
        cycle = [g for g in gs if g in CYCLES]
        for g in gs:
            if g in MOTION or g in MODAL_CYCLES:           # G80 cancels drilling cycles (group
                self.motion = g                             # 10), none here: G0/G1 stay
        self.modes(block, gs)
        if cycle:
            fanuc_cycle_run.run_cycle(self, block, int(cycle[0]))
        elif 50 in gs:
            self.g50(block)
        elif 4 in gs:
            self.dwell(block)
        elif 28 in gs:
            self.emit([("G", 28.0)] + self.axis_words(block, only_given=True))
        elif self.motion in MODAL_CYCLES and self.has_axes(block):
            fanuc_cycle_run.run_modal(self, block, int(self.motion))
        elif self.has_axes(block):
            self.move(block, gs)
        stops = [m for m in block.codes("M") if m in (0, 1, 2, 30)]
        return bool(stops) and self.emit([("M", stops[0])])

    def check_words(self, block: FBlock, gs: list) -> None:
        """Every letter of the block means something for its codes (no word silently dropped:
        a G1 with R or C is a Haas/Fanuc corner, not read here)."""
        motion = next((g for g in reversed(gs) if g in MOTION | MODAL_CYCLES), self.motion)
        allowed = set("GMNTSFXZUW")
        if set(gs) & CYCLES:
            allowed |= set("PQRD") | (set("KAI") if 76 in gs else set("IK") if 73 in gs else set())
        if 4 in gs:
            allowed |= set("P")
        if motion in (2, 3):
            allowed |= set("RIK")
        if motion in MODAL_CYCLES:
            allowed |= set("R")
        for w in block.words:
            if w.letter not in allowed:
                raise RuleError(f"{w.letter}{w.value:g}: not read in this block under the Fanuc "
                                f"dialect (a corner or chamfer word on G1, an axis this lathe has "
                                f"not, a word of a code not given); the block may hold "
                                f"{' '.join(sorted(allowed))}")

    def modes(self, block: FBlock, gs: list) -> None:
        """Everything but the motion: modes, feed, spindle, coolant, tool; before the motion."""
        words = [("G", g) for g in gs if g in PLAIN_G and g != 53]
        if (41 in gs or 42 in gs) and self.tr.tool_table is None:
            self.messages.append((self.prog.file, block.line, "NOTE", ("G41/G42 without a tool "
                                  "table: the nose radius is taken as 0 (--tool-table)")))
        if 98 in gs or 99 in gs:
            self.per_rev = 99 in gs
            if self.per_rev:
                self.needs_encoder("G99")
            words.append(("G", 95.0 if self.per_rev else 94.0))
        thread = {32, 92, 76} & set(gs) or (self.motion in (32, 92) and self.has_axes(block))
        if block.has("F") and not thread:
            words.append(("F", block.get("F")))
        if block.has("S") and 50 not in gs and not (92 in block.codes("G") and not self.has_axes(block)):
            words += self.spindle_words(block, gs)
        elif 97 in gs:
            words.append(("G", 97.0))
        elif 96 in gs:
            raise RuleError("G96 needs S on its block (the surface speed, m/min or ft/min)")
        words += [("M", m) for m in block.codes("M") if m in (3, 4, 5, 7, 8, 9)]
        if words:
            self.emit(words)
        if block.has("T"):
            self.tool(block.get("T"))

    def spindle_words(self, block: FBlock, gs: list) -> list:
        s = block.get("S")
        if 96 in gs:
            top = self.machine.parts["spindle"].max_rpm if "spindle" in self.machine.parts else None
            cap = min(c for c in (self.cap_rpm, top) if c is not None) if top or self.cap_rpm else 0
            return [("G", 96.0), ("S", s)] + ([("D", cap)] if cap else [])
        return ([("G", 97.0)] if 97 in gs else []) + [("S", s)]

    def needs_encoder(self, code: str) -> None:
        if "spindle" not in self.machine.parts:
            raise RuleError(f"{code} (feed per revolution, the Fanuc default) needs a spindle "
                            f"encoder ([spindle] in the machine file); machine {self.machine.name} "
                            f"has none: give G98 (feed per minute), or set feed_at_start = "
                            f"\"per_min\" in [fanuc]")

    def tool(self, value: float) -> None:
        t = int(value)
        if t != value or t < 0:
            raise RuleError(f"T{value:g}: a Fanuc tool word is T<tool><offset>, e.g. T0101")
        base = 10 if self.settings.tool_digits == 2 else 100
        if 0 < t < base:
            raise RuleError(f"T{t}: which tool and which offset? A T word is tool then offset, "
                            f"{'T11 (tool 1, offset 1)' if base == 10 else 'T0101 or T101 (tool 1, offset 01)'}"
                            f" (tool_digits = {self.settings.tool_digits} in [fanuc])")
        number, offset = t // base, t % base
        if number and number != self.tr.state.tool:
            self.emit([("T", float(number)), ("M", 6.0)])
        table = self.tr.tool_table
        if offset and table is not None and table.get(offset) is not None:
            self.emit([("G", 43.0), ("H", float(offset))])
            return
        self.emit([("G", 49.0)])
        if offset:
            where = "no tool table given" if table is None else "not in the tool table"
            self.messages.append((self.prog.file, self.line, "NOTE", (
                f"T{t:04d}: offset {offset:02d} taken as 0: {where} (--tool-table; a Fanuc "
                f"control's empty offset is 0 too)")))

    def g50(self, block: FBlock) -> None:
        if block.has("S"):
            cap = block.get("S")
            if not cap > 0.0:
                raise RuleError(f"G50 S{cap:g}: the spindle speed cap must be > 0 rpm")
            self.cap_rpm = cap
            css = self.tr.state.css
            if css is not None:
                self.emit([("G", 96.0), ("S", self.surface()), ("D", self.capped(cap))])
        axes = self.axis_words(block, only_given=True)
        if axes:
            self.emit([("G", 92.0)] + axes)

    def capped(self, cap: float) -> float:
        top = self.machine.parts["spindle"].max_rpm
        return min(cap, top)

    def surface(self) -> float:
        surface, _ = self.tr.state.css
        return surface * (1.0 / 0.3048 if self.tr.state.inch else 1.0)

    def dwell(self, block: FBlock) -> None:
        w = block.word("P") or block.word("X") or block.word("U")
        if w is None:
            raise RuleError("G4 needs the dwell: P (ms, or s with a decimal point), X or U (s)")
        seconds = w.value / 1000.0 if w.letter == "P" and not w.point else w.value
        self.emit([("G", 4.0), ("P", seconds)])

    # -- positions and moves ---------------------------------------------------------------------
    def unit(self) -> float:
        return 25.4 if self.tr.state.inch else 1.0

    def here(self) -> tuple[float, float]:
        """Where the tool is: (X radius, Z) in program units."""
        s = self.tr.state
        return s.program_position("X") / self.unit(), s.program_position("Z") / self.unit()

    def number(self, block: FBlock, letter: str):
        """A length word's value, None if absent; whole numbers read by ``whole_numbers``."""
        w = block.word(letter)
        if w is None:
            return None
        if self.settings.whole_numbers == "increments" and not w.point:
            return w.value * (0.0001 if self.tr.state.inch else 0.001)
        return w.value

    def has_axes(self, block: FBlock) -> bool:
        return any(block.has(c) for c in "XZUW")

    def target(self, block: FBlock, start=None) -> tuple[float, float]:
        """The end (X radius, Z) of a block's X/U and Z/W words from ``start`` (default: here)."""
        x, z = start or self.here()
        for absolute, rel in (("X", "U"), ("Z", "W")):
            if block.has(absolute) and block.has(rel):
                raise RuleError(f"{absolute} and {rel} in one block: give the end either "
                                f"absolutely ({absolute}) or incrementally ({rel})")
        if block.has("X"):
            x = self.number(block, "X") / self.xf
        elif block.has("U"):
            x += self.number(block, "U") / self.xf
        if block.has("Z"):
            z = self.number(block, "Z")
        elif block.has("W"):
            z += self.number(block, "W")
        for letter in "YBCV":
            if block.has(letter):
                raise RuleError(f"{letter}: not an axis of a two-axis lathe under the Fanuc dialect")
        return x, z

    def axis_words(self, block: FBlock, only_given: bool = False) -> list:
        x, z = self.target(block)
        words = []
        if not only_given or block.has("X") or block.has("U"):
            words.append(("X", x * self.xf))
        if not only_given or block.has("Z") or block.has("W"):
            words.append(("Z", z))
        return words

    def move(self, block: FBlock, gs: list) -> None:
        kind = int(self.motion)
        if 53 in gs:
            self.machine_move(block, kind)
            return
        start = self.here()
        end = self.target(block)
        if kind == 32:
            lead = block.get("F") if block.has("F") else self.modal.get("lead")
            if lead is None:
                raise RuleError("G32 needs F, the lead of the thread (mm or inch per revolution)")
            self.modal["lead"] = lead
            self.path([(33, end, lead)], start)
            return
        centre = None
        if kind in (2, 3):
            centre = fanuc_cycle_run.arc_centre(self, block, start, end, kind)
        self.path([(kind, end, centre)], start)

    def machine_move(self, block: FBlock, kind: int) -> None:
        """G53: machine coordinates, which on a Fanuc or Haas control are 0 at the reference
        position (home, ``[homing]``; the machine's 0 when it has none)."""
        if kind not in (0, 1) or block.has("U") or block.has("W"):
            raise RuleError("G53 takes G0 or G1 with X and Z (machine coordinates from home)")
        homing = self.machine.parts.get("homing")
        words = [("G", 53.0), ("G", float(kind))]
        for axis in "XZ":
            if block.has(axis):
                home = homing.home_mm(axis) if homing else 0.0
                value = self.number(block, axis) * self.unit()
                scale = self.xf if axis == "X" else 1.0
                words.append((axis, (home * scale + value) / self.unit()))
        if kind == 1:
            self.feed_mode(True)
        self.emit(words)

    def path(self, moves, start) -> None:
        """Moves ``(kind, (x radius, z), extra)`` in program units through the translator."""
        here = start
        for kind, p, extra in moves:
            if kind in (0, 1) and abs(p[0] - here[0]) < 1e-12 and abs(p[1] - here[1]) < 1e-12:
                continue
            words = [("G", float(kind if kind != 33 else 33)), ("X", p[0] * self.xf), ("Z", p[1])]
            if kind in (1, 2, 3):
                self.feed_mode(True)
            if kind in (2, 3):
                words += [("I", extra[0] - here[0]), ("K", extra[1] - here[1])]
            if kind == 33:
                if self.tr.state.css is not None:
                    raise RuleError("a thread (G32, G92, G76) under G96: a thread needs a steady "
                                    "spindle speed; give G97 S<rpm> before it")
                self.feed_mode(False)
                dz = abs(p[1] - here[1])
                if dz == 0.0:
                    raise RuleError("a thread move must move along Z (the lead is per turn along Z)")
                length = math.hypot(p[1] - here[1], p[0] - here[0])   # exact along Z alone
                words.append(("K", extra * (length / dz)))
            self.emit(words)
            here = p

    def feed_mode(self, cutting: bool) -> None:
        """Put the translator in the feed mode a move needs (threads: per minute, their K)."""
        want = self.per_rev and cutting
        if want and not self.tr.state.per_rev:
            self.needs_encoder("G99")
            self.emit([("G", 95.0)])
        elif not want and self.tr.state.per_rev:
            self.emit([("G", 94.0)])

    def emit(self, words: list) -> bool:
        """One block of RS274 words through the translator; True when it ends the program."""
        return self.tr.run(make_block(self.line, words, self.machine), self.prog.file)


def run_fanuc(text: str, translator, file: str, messages: list) -> None:
    """Run the Fanuc program ``text`` through ``translator``; RuleErrors carry file and line."""
    settings = translator.machine.parts.get("fanuc") or FanucSettings()
    runner = FanucRunner(read_program(text, file), translator, settings, messages)
    try:
        runner.run()
    except RuleError as exc:
        if not hasattr(exc, "file"):
            exc.file, exc.line = file, runner.line
        raise
