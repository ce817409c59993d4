"""G40, G41, G42, G41.1, G42.1 in the interpreter: cutter radius compensation as LinuxCNC runs it.

``G41``/``G42`` put the tool left/right of the programmed path, seen along the travel, in the XY
plane (G17) or the ZX plane of a lathe (G18). ``D`` names the tool whose table diameter is used
(no ``D``: the tool in the spindle; ``D0`` or a tool without diameter: radius 0, the path as
programmed). ``G41.1``/``G42.1 D<diameter>`` give the diameter itself, and under G18 ``L<0-9>``
the orientation of a lathe insert (as a tool table ``Q``): the point the machine positions is then
the insert's reference corner, not the centre of its nose radius. A negative diameter swaps the
side. ``G40`` turns compensation off: the move held back goes out where it ends, and the tool goes
straight from there to the next programmed point (an arc is refused as that move).

The geometry is :mod:`retrofit.gcode.cutter`; here the moves of blocks go in and retrofit's
commands come out. While a move is held back, every other command (feed, spindle, coolant,
dwell) waits behind it, so the machine does them in program order. The program position (G91,
``#5420``) stays the programmed point, as in LinuxCNC.

While compensation is on, LinuxCNC refuses what would move the path under the tool: a plane
change, G19, tool changes, G43/G49, G54-G59.3, G10 L2/L20 on the system in use, G28/G30 and
their .1, G92 and its family, G53 moves, canned cycles, G33/G76, G61/G64, G98/G99, M48-M53 and
reading the current position #5420-#5428; so does this module, naming the code.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..canon import StraightFeed, StraightTraverse
from . import arcmove, cycles
from .cutter import Compensator, CutterError, find_turn
from .errors import RuleError
from .params import CS_SELECT
from .state import clean_mm
from .validate import AXIS_NONMODAL, check_soft_limits

if TYPE_CHECKING:
    from .translate import Translator

#: plane -> its (first, second) axes, the (u, v) of the geometry
PLANE_AXES = {17: ("X", "Y"), 18: ("Z", "X")}
#: lathe insert orientation -> shift (along u = Z, v = X) of the reference corner from the nose
#: centre, in tool radii
_LATHE_SHIFT = {1: (1, -1), 2: (-1, -1), 3: (-1, 1), 4: (1, 1), 5: (1, 0), 6: (0, -1),
                7: (-1, 0), 8: (0, 1)}
#: codes refused once the other codes of the block have run, by modal group -> what they change
_REFUSED_GROUPS = {"tool length": "change tool offsets", "coordinate system": "change coordinate "
                   "systems", "path control": "change the path control mode", "return mode":
                   "change the canned cycle return mode"}


class RadiusComp:
    """Compensation state of one run: off, or on with a side, a radius and the geometry."""

    def __init__(self):
        self.on = False                       # G41/G42 in force (even with radius 0)
        self.code = 40.0
        self.geometry: Compensator | None = None   # on with a radius > 0
        self.axes = ("X", "Y")
        self.orientation = 0
        self.straight_next = False            # the move after G40 must be straight
        self.out: dict[str, float] = {}       # the last position sent to the machine

    @property
    def watching(self) -> bool:
        """A motion block needs this module: compensation is on or has just ended."""
        return self.on or self.straight_next


def before(tr: Translator, block) -> None:
    """Codes LinuxCNC runs before G40 in a block, refused while compensation is on."""
    g, s = block.g, tr.state
    plane = g.get("plane")
    if plane is not None and (plane == 19 or plane != s.plane):
        raise RuleError(f"G{plane:g}: cannot change planes with cutter radius compensation on "
                        f"(G{tr.comp.code:g}); give G40 first")
    if "tool change" in block.m or (tr.change_on_t and "T" in block.values):
        raise RuleError(f"{'M6' if 'tool change' in block.m else block.texts['T']}: cannot change "
                        f"tools with cutter radius compensation on; give G40 first")
    code = block.m.get("override")
    if code is not None:
        raise RuleError(f"M{code:g}: cannot enable or disable overrides with cutter radius "
                        f"compensation on; give G40 first")


def modes(tr: Translator, block) -> None:
    """G40/G41/G42 of ``block``, then the refusals of the codes LinuxCNC runs after them."""
    if "cutter radius" in block.g:
        switch(tr, block)
    if tr.comp.on:
        after(tr, block)


def switch(tr: Translator, block) -> None:
    """G40, G41, G42, G41.1 or G42.1 of ``block``."""
    code = block.g["cutter radius"]
    comp = tr.comp
    if code == 40:
        if comp.geometry is not None:
            _flush(tr, comp.geometry.off, "G40")
            comp.straight_next = not comp.geometry.first
        comp.on, comp.code, comp.geometry = False, 40.0, None
        return
    name = f"G{code:g}"
    if tr.state.plane not in PLANE_AXES:
        raise RuleError(f"{name}: cutter radius compensation works in G17 (XY) or G18 (ZX) only, "
                        f"not G{tr.state.plane}")
    if comp.on:
        raise RuleError(f"{name}: cutter radius compensation is already on (G{comp.code:g}); "
                        f"give G40 before turning it on again")
    radius, orientation = _tool(tr, block, name)
    left = code in (41, 41.1)
    if radius < 0:
        radius, left = -radius, not left
    comp.on, comp.code, comp.orientation = True, code, orientation
    comp.axes = PLANE_AXES[tr.state.plane]
    if radius > 0:
        u, v = comp.axes
        pos = tr.state.position
        comp.geometry = Compensator(radius, left, (pos[u], pos[v]), tr.state.inch,
                                    orientation not in (0, 9))
        comp.out = dict(pos)


def _tool(tr: Translator, block, name: str) -> tuple[float, int]:
    """(radius mm, lathe orientation) from D (and L) or the tool table."""
    s, v = tr.state, block.values
    if name in ("G41.1", "G42.1"):
        if "D" not in v:
            raise RuleError(f"{name} with no D word (D is the tool diameter, e.g. {name} D6)")
        orientation = 0
        if "L" in v:
            if s.plane != 18:
                raise RuleError(f"{name} {block.texts['L']}: L (lathe tool orientation) needs "
                                f"plane G18")
            orientation = int(v["L"])
            if orientation != v["L"] or not 0 <= orientation <= 9:
                raise RuleError(f"{block.texts['L']}: the orientation is a whole number 0 to 9")
        return s.to_mm(v["D"]) / 2.0, orientation
    number = s.tool
    if "D" in v:
        number = int(v["D"] + 0.5)
        if abs(number - v["D"]) >= 1e-4:
            raise RuleError(f"{name} {block.texts['D']}: D is a tool number, a whole number >= 0")
    table = tr.tool_table
    tool = table.get(number) if table is not None else None
    if tool is None:
        if "D" in v and number != 0:
            raise RuleError(f"{name} D{number}: requested tool {number} not found in the tool "
                            f"table")
        return 0.0, 0
    orientation = tool.orientation or 0
    if s.plane != 18 and orientation not in (0, 9):
        raise RuleError(f"{name} D{number}: tool {number} is a lathe tool (orientation "
                        f"{orientation}), but the plane is not G18")
    return tool.diameter_mm / 2.0, orientation


def after(tr: Translator, block) -> None:
    """Codes LinuxCNC runs after G41/G42 in a block, refused while compensation is on."""
    g = block.g
    for group, what in _REFUSED_GROUPS.items():
        if group in g:
            raise RuleError(f"G{g[group]:g}: cannot {what} with cutter radius compensation on; "
                            f"give G40 first")
    nonmodal = g.get("non-modal")
    if nonmodal in (28, 28.1, 30, 30.1, 92, 92.1, 92.2, 92.3, 76):
        raise RuleError(f"G{nonmodal:g}: not allowed with cutter radius compensation on; give "
                        f"G40 first")
    if nonmodal == 10 and block.values.get("L") in (2, 20):
        active = int(tr.state.params.numbered.get(CS_SELECT, 1.0))
        if int(block.values.get("P", 0) + 1e-4) in (0, active):
            raise RuleError(f"G10 {block.texts['L']}: cannot change the coordinate system in use "
                            f"with cutter radius compensation on; give G40 first")
    mode = block.motion if block.motion is not None else tr.state.motion
    if block.axes and nonmodal not in AXIS_NONMODAL and mode in cycles.CYCLES:
        raise RuleError(f"G{mode:g}: cannot use canned cycles with cutter radius compensation "
                        f"on; give G40 first")
    if tr.comp.geometry is not None and block.axes and mode == 33:
        raise RuleError("G33: cannot cut threads with cutter radius compensation on; give G40 "
                        "first")


def motion(tr: Translator, block, mode) -> bool:
    """A motion block while compensation is on (True: done here) or just after G40."""
    comp = tr.comp
    if comp.straight_next:
        if mode in (2, 3) and (block.axes or any(c in block.values for c in "IJKR")):
            raise RuleError(f"G{mode}: the move just after G40 must be straight (G0 or G1), not "
                            f"an arc: the tool leaves the compensated path there")
        if mode in (0, 1) and block.axes:
            comp.straight_next = False
        return False
    geometry = comp.geometry
    if geometry is None or mode not in (0, 1, 2, 3):
        return False
    if not block.axes and not (block.motion in (2, 3) and any(c in block.values for c in "IJK")):
        return False                       # no move (an arc without axis words is a full circle)
    if block.g.get("non-modal") == 53:
        raise RuleError(f"G53: cannot move in machine coordinates with cutter radius "
                        f"compensation on (G{comp.code:g}); give G40 first")
    s = tr.state
    start = s.position
    end = s.target(block.axes)
    s.pending = {}
    u, v = comp.axes
    p = (end[u], end[v])
    payload = (*tr.where, end)
    try:
        if mode in (0, 1):
            if mode == 1:
                tr.send_feed(math.dist(start.values(), end.values()), mode)
            _send(tr, geometry.straight("feed" if mode == 1 else "rapid", p, payload))
        else:
            centre, extra_turns = arcmove.arc_centre(tr, block, mode, end)
            turn = (extra_turns + 1) * (1 if mode == 3 else -1)
            tr.send_feed(_arc_length(start, end, centre, turn, comp.axes), mode)
            _send(tr, geometry.arc(p, centre, turn, payload))
    except CutterError as exc:
        raise RuleError(f"G{comp.code:g}: {exc}") from None
    s.position = end
    return True


def stop(tr: Translator, code) -> None:
    """M0, M1, M2, M30, M60 (``code``): the held moves go out where they end now."""
    if tr.comp.geometry is not None:
        _flush(tr, tr.comp.geometry.flush, f"M{code:g}")


def reset(tr: Translator, code) -> None:
    """M2, M30: as :func:`stop`, and compensation is off, as LinuxCNC resets it."""
    stop(tr, code)
    tr.comp = RadiusComp()


def finish(tr: Translator) -> None:
    """The program's text ends (no M2): a move still held back is refused, not dropped."""
    if tr.comp.geometry is not None and tr.comp.geometry.holding:
        raise RuleError(f"the program ends with cutter radius compensation on (G{tr.comp.code:g}) "
                        f"and its last move held back; end it with G40 and M2")


def _flush(tr: Translator, flush, word: str) -> None:
    try:
        _send(tr, flush())
    except CutterError as exc:
        raise RuleError(f"{word}: {exc}") from None


# -- output ------------------------------------------------------------------------------------
def _send(tr: Translator, items) -> None:
    """The final items of the geometry as canonical calls, each with its source line."""
    comp = tr.comp
    line, file = tr.where
    for item in items:
        if item.kind == "other":
            call, held_line, held_file = item.payload
            tr.at(held_line, held_file)
            tr.put(call)
            continue
        held_line, held_file, end = item.payload
        tr.at(held_line, held_file)
        point = dict(comp.out) if item.corner else dict(end)
        u, v = comp.axes
        point[u], point[v] = _machine(tr, item.end)
        point = {n: clean_mm(x) for n, x in point.items()}
        if item.kind == "arc":
            mode = 2 if item.turn < 0 else 3
            arcmove.arc_move(tr, comp.out, point, _machine(tr, item.centre), mode, abs(item.turn) - 1,
                             emit=tr.put)
        else:
            check_soft_limits(tr.machine, point)
            tr.put((StraightFeed if item.kind == "feed" else StraightTraverse)(tr.position_of(point)))
        comp.out = point
    tr.at(line, file)


def _arc_length(start, end, centre, turn, axes) -> float:
    """Length (mm) of the programmed arc, for the feed under G93."""
    u, v = axes
    sweep = abs(find_turn((start[u], start[v]), centre, turn, (end[u], end[v])))
    off = math.sqrt(sum((end[n] - start[n]) ** 2 for n in start if n not in axes))
    return math.hypot(math.dist((start[u], start[v]), centre) * sweep, off)


def _machine(tr: Translator, uv) -> tuple[float, float]:
    """A plane point of the geometry as the machine positions it (a lathe insert's corner)."""
    comp = tr.comp
    shift = _LATHE_SHIFT.get(comp.orientation) if tr.state.plane == 18 else None
    if shift is None or comp.geometry is None:
        return uv
    r = comp.geometry.r
    return (uv[0] + shift[0] * r, uv[1] + shift[1] * r)

