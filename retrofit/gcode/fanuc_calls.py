"""Fanuc/Haas subprogram calls: ``M98 P L`` (a program O-number), ``M97 P L`` (Haas: an N number
of the same program), ``M99`` (back to the caller).

``M98 P0031000`` (more than four digits and no L) is three calls of O1000. A call is ``(index to
go back to, index of its first block, runs left)`` on the runner's stack. ``M99`` in the main
program ends it, with a note (a Fanuc control would start it again: a bar feeder's endless loop).
"""

from __future__ import annotations

from .errors import RuleError


def call(run, block, calls: list) -> bool:
    """M98/M97/M99; True when the program ends (M99 in the main program)."""
    letters = {w.letter for w in block.words}
    if letters - {"M", "P", "L", "N"} or len(block.codes("M")) != 1:
        raise RuleError("M97, M98 and M99 stand on a block of their own with P and L only")
    code = block.get("M")
    if code == 99.0:
        if block.has("P"):
            raise RuleError("M99 P (return to a sequence number) is not read; return with M99")
        if not calls:
            run.messages.append((run.prog.file, block.line, "NOTE", ("M99 in the main program "
                                 "ends it here (a Fanuc control would start it again)")))
            run.emit([("M", 30.0)])
            return True
        back, start, left = calls[-1]
        if left > 1:
            calls[-1] = (back, start, left - 1)
            run.pc = start
        else:
            calls.pop()
            run.pc = back
        return False
    if not block.has("P"):
        raise RuleError(f"M{code:g} needs P (the {'program' if code == 98 else 'N'} number to "
                        f"call)")
    number, times = int(block.get("P")), block.get("L", 1.0)
    if code == 98.0 and number > 9999 and not block.has("L"):
        number, times = number % 10000, float(number // 10000)   # M98 P0031000: 3 x O1000
    if times != int(times) or not 0 <= times <= 9999:
        raise RuleError(f"L{times:g}: the number of repeats is a whole number from 0 to 9999")
    if code == 98.0:
        if number not in run.prog.programs:
            raise RuleError(f"M98 P{number}: no program O{number} in {run.prog.file} (a "
                            f"subprogram is O{number} ... M99, after the main program's M30)")
        start = run.prog.programs[number]
    else:
        start = run.index_of(number, "M97 P")
    if times == 0:
        run.pc += 1
        return False
    calls.append((run.pc + 1, start, int(times)))
    run.pc = start
    return False
