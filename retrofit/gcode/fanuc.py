"""Fanuc-style subprograms, as LinuxCNC's interpreter runs them: ``M98 P<n> [L<k>]`` and ``M99``.

A line ``O1000`` alone marks where the subprogram starts (the flow of the program runs through
it like any line); ``M98 P1000 L3`` runs the lines from there to ``M99`` three times, then goes
on after the M98. The subprogram shares the caller's parameters (unlike ``o<name> call``, it has
no numbered arguments and no local ones). ``M99`` outside an M98 call ends the program, as
LinuxCNC's ``rs274`` reads it (a Fanuc control would start the program again: a bar-feeder's
endless loop, which a simulation would never finish).

A call on the stack of :class:`~retrofit.gcode.program.Interpreter` is ``(source, return
index)`` for ``o<name> call`` and a :class:`Call` for M98.
"""

from __future__ import annotations

from dataclasses import dataclass

from .blocks import make_block
from .errors import RuleError


@dataclass
class Call:
    """An M98 call: where to go back to, where its subprogram starts, and how many runs are left."""

    source: object
    back: int
    start: int
    left: int


def run_line(interp, src, pc: int, line, calls: list):
    """Run the M98 or M99 of ``line``; the next (source, index), or None when the program ends."""
    words = [(letter, interp._value(tree)) for letter, tree in line.words]
    letters = [letter for letter, _ in words]
    said = " ".join(f"{letter}{value:g}" for letter, value in words)
    if letters.count("M") != 1:
        raise RuleError(f"{said}: M98 and M99 stand on a line of their own (no other M word)")
    if ("M", 99.0) in words:
        if len(words) != 1:
            raise RuleError(f"{said}: M99 stands alone on its line")
        return _return(interp, src, line, calls)
    extra = sorted(set(letters) - {"M", "P", "L"})
    if extra:
        raise RuleError(f"{said}: M98 takes only P (the O-number to call) and L (how many times); "
                        f"move {' '.join(f'{k}{v:g}' for k, v in words if k in extra)} to a line of its own")
    value = dict(words)
    if "P" not in value:
        raise RuleError(f"{said}: M98 needs P, the number of the O-line to call (M98 P1000)")
    number, times = value["P"], value.get("L", 1.0)
    for letter, v in (("P", number), ("L", times)):
        if v != int(v) or v < 0:
            raise RuleError(f"{said}: {letter} is a whole number from 0 (read {v:g})")
    name = str(int(number))
    if name not in src.labels:
        raise RuleError(f"M98 P{name}: no line O{name} in {src.file} (a Fanuc-style subprogram "
                        f"starts with O{name} alone on its line and ends with M99)")
    from .program import MAX_CALL_DEPTH, MAX_STEPS
    if times > MAX_STEPS:
        raise RuleError(f"M98 P{name} L{times:g}: more than {MAX_STEPS} times")
    if times == 0:
        return src, pc + 1
    if len(calls) >= MAX_CALL_DEPTH:
        raise RuleError(f"M98 P{name}: subprogram calls nest deeper than {MAX_CALL_DEPTH}")
    start = src.labels[name]
    calls.append(Call(src, pc + 1, start, int(times)))
    return src, start + 1


def _return(interp, src, line, calls: list):
    if not calls:                                    # M99 in the main program: its end
        ended = interp.tr.run(make_block(line.number, [("M", 2.0)], interp.machine), src.file)
        assert ended
        return None
    call = calls[-1]
    if not isinstance(call, Call):
        raise RuleError("M99 inside an o-word subroutine: it ends a subprogram called with M98; "
                        "an o<name> sub ends with o<name> endsub")
    call.left -= 1
    if call.left > 0:
        return call.source, call.start + 1
    calls.pop()
    return call.source, call.back
