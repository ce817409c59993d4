"""G38.2-G38.5: straight probing moves, as LinuxCNC runs them.

A probing move goes in a straight line at the programmed feed toward its end point and stops
when the probe input changes: G38.2 and G38.3 stop when it trips (toward the workpiece), G38.4
and G38.5 when it clears (away from it). G38.2 and G38.4 are an error when the move ends
without that change; G38.3 and G38.5 are not. Where it stopped is stored, in the program's
coordinates and units, in ``#5061``-``#5069`` (X Y Z A B C U V W), and ``#5070`` is 1 when the
input changed, 0 when not -- so a program can go on from there::

    G38.2 Z-45 F60       (down until the tool meets the setter's beam)
    G10 L20 P1 Z0        (the point it met is Z0 of G54)

The interpreter cannot know where a probing move stops: the machine must make it. The
translator hands every probing move to a *prober* (``compile_program(..., probe=)``), which
executes the program so far and the move on the machine and returns a :class:`ProbeResult`;
the move is then compiled as a feed move to where it stopped. ``retrofit run`` probes on the
simulated machine (:class:`retrofit.atc.prober.SimProber`, the tool setter's beam), or on the
controller at the far end of the serial link when it drives one
(:class:`retrofit.atc.linkcell.LinkProber`). Without a prober, or on a machine without a probe
input, a probing move is refused with its line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .errors import RuleError
from .params import AXIS_ORDER
from .state import MM_PER_INCH
from .validate import check_soft_limits

if TYPE_CHECKING:
    from .translate import Translator

#: the probing codes: True for toward the workpiece (stop when the input trips)
PROBE_CODES = {38.2: True, 38.3: True, 38.4: False, 38.5: False}
#: the codes for which a move that ends without the input changing is an error
MUST_CHANGE = (38.2, 38.4)
#: where the stop point and the success flag are stored
RESULT_BASE, SUCCESS = 5061, 5070


@dataclass(frozen=True)
class ProbeRequest:
    """One probing move for the prober: the program's commands so far, then the move."""

    commands: list               # every command compiled before the move (and its lines)
    lines: list
    start_mm: dict[str, float]   # machine mm, every axis
    end_mm: dict[str, float]
    feed_mm_min: float
    toward: bool                 # stop when the input trips (G38.2/3); else when it clears


@dataclass(frozen=True)
class ProbeResult:
    """What the machine did: whether the input changed, and where every axis stopped (mm)."""

    changed: bool
    stop_mm: dict[str, float]
    already: bool = False        # the input was already in the stopping state at the start


Prober = Callable[[ProbeRequest], ProbeResult]


def probe_move(tr: Translator, block, mode: float, end: dict[str, float]) -> None:
    """Run one G38.x move of ``block`` to ``end`` (machine mm) through the translator ``tr``."""
    s, name = tr.state, f"G{mode:g}"
    if tr.probe is None:
        raise RuleError(_no_prober(tr.machine, name))
    if s.inverse_time:
        raise RuleError(f"{name}: cannot probe in inverse time feed mode (G93); use G94")
    if not s.feed_mm_min > 0.0:
        raise RuleError(f"{name}: cannot probe with zero feed rate (set F > 0)")
    if all(abs(end[a] - s.position[a]) < 1e-9 for a in end):
        raise RuleError(f"{name}: start point too close to probe point (the move goes nowhere)")
    rotary = [a for a in block.axes if a in "ABC" and abs(end[a] - s.position[a]) > 1e-9]
    if rotary:
        raise RuleError(f"{name}: cannot move rotary axis {rotary[0]} during probing")
    check_soft_limits(tr.machine, end)
    toward = PROBE_CODES[mode]
    result = tr.probe(ProbeRequest(list(tr.commands), tr.lines, dict(s.position), end, s.feed_mm_min,
                                   toward))
    if result.already:
        raise RuleError(f"{name}: the probe is {'already tripped' if toward else 'not tripped'} "
                        f"at the start of the move ({'G38.2/G38.3' if toward else 'G38.4/G38.5'} "
                        f"{'move toward' if toward else 'move away from'} the workpiece)")
    if not result.changed and mode in MUST_CHANGE:
        where = " ".join(f"{a}{end[a]:g}" for a in block.axes)
        raise RuleError(f"{name}: the move to {where} finished without making contact "
                        f"(G38.{3 if toward else 5} accepts that and sets #{SUCCESS}=0)")
    stop = {a: result.stop_mm.get(a, end[a]) for a in end}
    tr.feed_line(stop, mode, probing=True)
    _store(s, stop, result.changed)


def _store(s, stop: dict[str, float], changed: bool) -> None:
    """#5061.. the stop point in program coordinates and units; #5070 the success flag."""
    unit = MM_PER_INCH if s.inch else 1.0
    for i, axis in enumerate(AXIS_ORDER):
        value = (stop[axis] - s.offset(axis)) / unit if axis in stop else 0.0
        s.params.write(RESULT_BASE + i, round(value, 9) + 0.0)
    s.params.write(SUCCESS, 1.0 if changed else 0.0)


def _no_prober(machine, name: str) -> str:
    if "setter" not in machine.parts:
        return (f"{name}: machine {machine.name} has no probe input (probing needs one: the tool "
                f"setter's beam, [setter] in the machine file)")
    return (f"{name}: probing needs the machine to make the move while the program is read; "
            f"this compile has no prober (retrofit run probes on the simulated {machine.name})")
