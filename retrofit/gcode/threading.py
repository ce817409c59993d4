"""G33 and G76: threads, as moves timed by the spindle's indexer (ISTP) instead of the clock.

``G33 X- Z- K-`` is one spindle-synchronised move: ``K`` mm along its path per revolution. Moves
of consecutive G33 blocks form one synchronised chain (a tapered thread, a fusee); the chain
becomes ``ISTP``, ``PFDR F<K>``, ``PMOV ...`` and ends with ``CSTP`` at the next other motion.

``G76 P- Z- I- J- K- <R- Q- H- E- L->`` is LinuxCNC's threading cycle, started from the *drive
line* (the current X) at the start of the thread (the current Z), cut pass by pass as LinuxCNC's
``rs274`` cuts it (tests/test_gcode_g76.py compares every move):

* ``P`` pitch (mm/rev), ``Z`` the end of the thread;
* ``I`` the thread's peak from the drive line (negative: an external thread, positive: internal);
* ``J`` the first cut's depth beyond the peak, ``K`` the full depth (``K > J``); under G7
  (diameter mode) ``I``, ``J`` and ``K`` are diameters, halved like X;
* ``R`` depth degression (pass ``n`` cuts to ``J n^(1/R)``; 1 constant depth, 2 constant area);
* ``Q`` compound angle (deg): the infeed follows the flank, each pass starts ``(depth - |I|)
  tan Q`` further along Z and ends ``(K - depth + |I|) tan Q`` short of ``Z``;
* ``H`` spring passes at full depth after the full-depth pass;
* ``E`` taper length along Z and ``L`` which ends taper (0 none, 1 entry, 2 exit, 3 both).

Each pass: rapid to its start, out at the drive line plus the depth still to cut; rapid in to
its depth (or, with an entry taper, a synchronised move in by ``|I|`` and one down the taper over
``E``), the synchronised cut, a synchronised exit taper if asked, and a rapid out to the drive
line plus the depth still to cut. Every pass synchronises on the spindle's index, so all passes
cut one helix. A synchronised move needs a *lead-in* to reach thread speed from rest (``v^2 / 2a``); the
tool is on the helix from the end of the lead-in on, so the cycle must start at least that far
from the work. Programs whose thread speed or lead-in the machine cannot give are refused here,
before any motion, with the figures.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..canon import SetFeedRate, StartFeedSync, StopFeedSync, StraightFeed, StraightTraverse
from ..motion.indexer import lead_in_mm, thread_speed_mm_s
from .state import clean_mm
from .validate import RuleError, check_soft_limits

if TYPE_CHECKING:
    from .translate import Translator

#: most passes a G76 may make (a J far below K with a high R would otherwise run for ever)
MAX_PASSES = 1000


def pass_depths(first: float, full: float, degression: float, spring: int,
                peak: float = 0.0) -> list[float]:
    """Depth of every pass of a G76 beyond the peak: ``J n^(1/R)`` while below ``K``, then ``K``,
    then springs. The comparison is made from the drive line (``peak`` + depth), as LinuxCNC
    makes it, so a pass that lands on ``K`` counts the same way.

    >>> [round(d, 3) for d in pass_depths(0.2, 0.6, 2.0, 1)]
    [0.2, 0.283, 0.346, 0.4, 0.447, 0.49, 0.529, 0.566, 0.6, 0.6]
    """
    depths, n, depth = [], 1, first
    while peak + depth < peak + full:
        depths.append(depth)
        n += 1
        depth = first * n ** (1.0 / degression)
        if n > MAX_PASSES:
            raise RuleError(f"G76 would cut more than {MAX_PASSES} passes to reach K{full:g} from "
                            f"J{first:g} with R{degression:g}; raise J or lower R")
    return depths + [full] * (1 + spring)


def _path(machine, start: dict, end: dict) -> tuple[float, float, float, float]:
    """(length mm, speed cap mm/s, acceleration cap mm/s^2, base steps per mm) of a straight move."""
    deltas = {a.name: end[a.name] - start[a.name] for a in machine.axes}
    length = math.sqrt(sum(d * d for d in deltas.values()))
    v_max = a_max = math.inf
    for axis in machine.axes:
        u = abs(deltas[axis.name]) / length if length else 0.0
        if u > 0.0:
            v_max = min(v_max, axis.max_velocity_mm_s / u)
            a_max = min(a_max, axis.max_accel_mm_s2 / u)
    base = max(abs(deltas[a.name]) * a.steps_per_mm for a in machine.axes)
    return length, v_max, a_max, (base / length if length else 0.0)


def check_synchronised(tr: Translator, what: str, start: dict, end: dict, feed_mm_rev: float, first: bool) -> None:
    """A synchronised move the machine can make at the program's spindle speed: its speed within
    the axes', one step at most per encoder count, and (``first`` of a chain) room for the lead-in."""
    machine, rpm = tr.machine, tr.state.rpm
    spindle = machine.parts["spindle"]
    length, v_max, a_max, per_mm = _path(machine, start, end)
    if length == 0.0:
        raise RuleError(f"{what}: a synchronised move must go somewhere (start = end)")
    plan_rpm = rpm * (1.0 + spindle.speed_tolerance)
    speed = thread_speed_mm_s(feed_mm_rev, plan_rpm)
    if speed > v_max:
        raise RuleError(f"{what}: {feed_mm_rev:g} mm/rev at up to {plan_rpm:.0f} rpm (S{rpm:g} and "
                        f"{spindle.speed_tolerance:.0%} margin) is {speed:.2f} mm/s; the axes allow "
                        f"{v_max:.2f} mm/s; lower S")
    steps_rev = feed_mm_rev * per_mm
    if steps_rev > spindle.encoder_counts_per_rev:
        raise RuleError(f"{what}: {steps_rev:.0f} steps a revolution exceed the encoder's "
                        f"{spindle.encoder_counts_per_rev} counts; the indexer makes at most one step "
                        f"a count")
    lead = lead_in_mm(feed_mm_rev, plan_rpm, a_max * spindle.sync_accel_share)
    if first and lead > length:
        raise RuleError(f"{what}: at S{rpm:g} the lead-in to thread speed takes {lead:.2f} mm, more "
                        f"than the {length:.2f} mm of the synchronised move; start further from the "
                        f"work or lower S")


def spindle_turning(tr: Translator, code: str) -> None:
    if not (tr.state.spindle and tr.state.rpm > 0.0):
        raise RuleError(f"{code} with the spindle stopped: a thread follows the spindle (M3 or M4 "
                        f"with S > 0 first)")


def leave(tr: Translator) -> None:
    """End a synchronised chain: back to the clock, and the next feed move re-sends its feed."""
    if tr.indexing:
        tr.emit(StopFeedSync())
        tr.indexing = False
        tr.state.feed_sent = None


def _synchronised(tr: Translator, start: dict, end: dict, feed_mm_rev: float) -> None:
    if not tr.indexing:
        tr.emit(StartFeedSync())
        tr.indexing = True
        tr.state.feed_sent = None
    if tr.state.feed_sent != feed_mm_rev:
        tr.emit(SetFeedRate(feed_mm_rev))
        tr.state.feed_sent = feed_mm_rev
    tr.emit(StraightFeed(tr.position_of(end)))


def g33(tr: Translator, block, end: dict) -> None:
    """One G33 move from the current position to ``end`` (mm), K mm per revolution."""
    if "K" not in block.values:
        raise RuleError("G33 needs K, the distance along the move per spindle revolution "
                        "(e.g. G33 Z-20 K1.5)")
    pitch = tr.state.to_mm(block.values["K"])
    if not pitch > 0.0:
        raise RuleError(f"{block.texts['K']}: G33's K must be > 0 (mm per revolution)")
    spindle_turning(tr, "G33")
    check_soft_limits(tr.machine, end)
    check_synchronised(tr, "G33", tr.state.position, end, pitch, first=not tr.indexing)
    _synchronised(tr, tr.state.position, end, pitch)


def _words(tr: Translator, block) -> dict:
    """G76's words in mm, I J K as radii (halved under G7, as LinuxCNC reads them), and R, Q, H,
    L as numbers, checked one by one."""
    if tr.state.plane != 18:
        raise RuleError(f"G76 needs the ZX plane (G18), not G{tr.state.plane}")
    if block.motion is not None:
        raise RuleError(f"G76 is a cycle of its own: no G{block.motion} in its block")
    others = [block.texts[n] for n in block.axes if n != "Z"]
    if others or "X" not in tr.machine.axis_names:
        raise RuleError(f"G76 takes Z as its only axis word (the cycle starts at the current X); "
                        f"{others[0] if others else 'the machine has no X'}")
    missing = [c for c in "PZIJK" if c not in block.values and c not in block.axes]
    if missing:
        raise RuleError(f"G76 needs P (pitch), Z (end), I (peak offset), J (first depth) and K "
                        f"(full depth); missing: {' '.join(missing)}")
    v, mm = block.values, tr.state.to_mm
    across = 0.5 if tr.state.diameter else 1.0          # G7: I, J and K are diameters
    w = {"P": mm(v["P"]), "I": mm(v["I"]) * across, "J": mm(v["J"]) * across,
         "K": mm(v["K"]) * across, "E": mm(v.get("E", 0.0)),
         "R": v.get("R", 1.0), "Q": v.get("Q", 0.0), "H": v.get("H", 0.0), "L": v.get("L", 0.0),
         "Z": tr.state.target({"Z": block.axes["Z"]})["Z"]}
    for letter, rule in (("P", "the pitch must be > 0"), ("J", "the first depth must be > 0"),
                         ("K", "the full depth must be > 0")):
        if not w[letter] > 0.0:
            raise RuleError(f"{block.texts[letter]}: {rule}")
    if not v["K"] > v["J"]:
        raise RuleError(f"{block.texts['K']}: the full depth K must be greater than the first "
                        f"depth J ({block.texts['J']})")
    if w["R"] < 1.0:
        raise RuleError(f"{block.texts['R']}: the depth degression must be >= 1.0 (R1 constant depth)")
    if w["I"] == 0.0:
        raise RuleError(f"{block.texts['I']}: the peak must be off the drive line (I < 0 external, "
                        f"I > 0 internal thread)")
    if not (w["H"].is_integer() and w["H"] >= 0 and w["L"].is_integer() and 0 <= w["L"] <= 3):
        raise RuleError("G76 H (spring passes) must be a whole number >= 0 and L one of 0, 1, 2, 3")
    if not -90.0 < w["Q"] < 90.0:
        raise RuleError(f"{block.texts['Q']}: the compound angle must be within -90..90 deg")
    if w["Q"] == -1.0:
        raise RuleError(f"{block.texts['Q']}: LinuxCNC reads Q-1 as no compound angle (Q0); write "
                        f"Q0, or the angle you mean")
    length = abs(w["Z"] - tr.state.position["Z"])
    if length == 0.0:
        raise RuleError("G76: Z is where the cycle starts; the thread needs a length")
    if not 0.0 <= w["E"] <= length / 2.0:
        raise RuleError(f"{block.texts['E']}: the taper must be >= 0 and at most half the drive "
                        f"line ({length:.3f} mm)")
    # depths from the drive line counted in the program's units, as LinuxCNC counts the passes
    peak = abs(v["I"]) * across
    w["depths"] = [mm(peak + d) for d in pass_depths(v["J"] * across, v["K"] * across, w["R"],
                                                     int(w["H"]), peak)]
    return w


def _pass_moves(w: dict, x_drive: float, z_start: float, depth: float, lean: float) -> list:
    """One pass ``depth`` from the drive line (peak offset included), as LinuxCNC cuts it:
    [(kind, x, z, lead)] with kind "rapid" or "sync". The pass starts ``lean (depth - |I|)`` along
    Z (the compound infeed along the flank), ends ``lean (K - depth + |I|)`` short of Z, and goes
    out to the drive line plus the depth still to cut."""
    sign = 1.0 if w["I"] > 0.0 else -1.0                 # internal threads cut outward
    peak, full = abs(w["I"]), w["K"]
    toward = 1.0 if w["Z"] > z_start else -1.0
    shift = (depth - peak) * lean * toward
    zs, ze = z_start + shift, w["Z"] - (full - (depth - peak)) * lean * toward
    back, cut, flank = (x_drive + sign * (depth - peak - full), x_drive + sign * depth,
                        x_drive + sign * (depth - full))
    taper = w["E"] if int(w["L"]) else 0.0
    steep = w["P"] * math.hypot(taper, full) / taper if taper else w["P"]
    moves = [("rapid", back, zs, None)]
    if taper and int(w["L"]) & 1:
        moves += [("sync", flank, zs, steep), ("sync", cut, zs + taper * toward, steep)]
    else:
        moves.append(("rapid", cut, zs, None))
    if taper and int(w["L"]) & 2:
        moves += [("sync", cut, ze - taper * toward, w["P"]), ("sync", flank, ze, steep)]
    else:
        moves.append(("sync", cut, ze, w["P"]))
    return moves + [("rapid", back, ze, None)]


def g76(tr: Translator, block) -> None:
    """The threading cycle, from the current position (the drive line at the thread's start)."""
    w = _words(tr, block)
    spindle_turning(tr, "G76")
    leave(tr)
    here = dict(tr.state.position)
    point = lambda x, z: {**here, "X": clean_mm(x), "Z": clean_mm(z)}  # noqa: E731
    lean = math.tan(math.radians(w["Q"]))
    passes = [_pass_moves(w, here["X"], here["Z"], depth, lean) for depth in w["depths"]]
    for moves in passes:
        for _kind, x, z, _lead in moves:
            check_soft_limits(tr.machine, point(x, z), " (G76 pass)")
    at = here
    for moves in passes:
        first = True
        for kind, x, z, lead in moves:
            end = point(x, z)
            if kind == "rapid":
                leave(tr)
                tr.emit(StraightTraverse(tr.position_of(end)))
            else:
                check_synchronised(tr, "G76", at, end, lead, first=first)
                _synchronised(tr, at, end, lead)
                first = False
            at = end
        leave(tr)
    final = point(here["X"], w["Z"])
    if final != at:
        tr.emit(StraightTraverse(tr.position_of(final)))
    tr.state.position = final
