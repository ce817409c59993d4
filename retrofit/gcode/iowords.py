"""M62-M66: the spare digital outputs and inputs named in the machine's ``[io]``, as LinuxCNC.

* ``M62 P<n>`` / ``M63 P<n>``: output n on / off as the next move starts (a DOUT M62 / M63);
* ``M64 P<n>`` / ``M65 P<n>``: output n on / off at once (DOUT M64 / M65);
* ``M66 P<n> L<mode> Q<s>``: wait on input n -- L0 reads it at once, L1/L2 wait for a rising /
  falling edge, L3/L4 for it to be high / low, for at most Q seconds. The moves before it end
  first. ``#5399`` is the input's level when the wait ends, -1 when Q seconds passed (a WAIT).

They act in LinuxCNC's place in a block: after T selects a tool, before M6 and M3/M4/M5.
As LinuxCNC's interpreter waits for its motion controller at an M66, retrofit's finds when the
wait starts (the program so far, planned) and reads the machine's simulated input
(:mod:`retrofit.machine.iopins`); the run waits the same way on the same input. P on M62-M65 is
rounded to a whole output as rs274 does. Analog inputs (M66 E) are refused: the boards have none.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..canon import DigitalOut, WaitInput
from ..commands import Wait
from ..errors import RetrofitError
from ..machine.iopins import WAIT_MODES, wait_outcome
from .errors import NeedsWholeProgram, RuleError

if TYPE_CHECKING:
    from .translate import Translator

#: where M66 leaves its result
RESULT = 5399
#: the longest wait accepted (s): a day
MAX_WAIT_S = 86400.0


def run(tr: Translator, block) -> None:
    """The M62-M66 of ``block``, if any, through the translator ``tr``."""
    code = block.m.get("io")
    if code is None:
        return
    if tr.streaming:          # read ahead: the commands so far are not kept
        raise NeedsWholeProgram(f"M{code}")
    io = tr.machine.parts.get("io")
    if code == 66:
        _wait(tr, block, io)
        return
    if "P" not in block.values:
        raise RuleError(f"M{code} needs P<output>, e.g. M{code} P0")
    number = round(block.values["P"])
    count = len(io.outputs) if io is not None else 0
    if not 0 <= number < count:
        raise RuleError(f"M{code} {block.texts['P']}: {_none_or_range(tr.machine, 'out', count)}")
    tr.emit(DigitalOut(code, number))


def _none_or_range(machine, kind: str, count: int) -> str:
    what = "output" if kind == "out" else "input"
    if count == 0:
        return (f"machine {machine.name} names no digital {what} pins ([io] {kind}0 = <pin> in "
                f"its machine file)")
    return f"machine {machine.name} has digital {what}s {kind}0..{kind}{count - 1} ([io])"


def _wait(tr: Translator, block, io) -> None:
    values, texts = block.values, block.texts
    if "P" in values and "E" in values:
        raise RuleError("M66: either P (a digital input) or E (an analog input), not both")
    if "E" in values:
        raise RuleError(f"M66 {texts['E']}: analog inputs are not supported (the boards have none);"
                        f" wait on a digital input with P")
    if "P" not in values or values["P"] < 0:
        raise RuleError("M66 needs P<input>, e.g. M66 P0 L3 Q5 (wait up to 5 s for input 0 high)")
    number = round(values["P"])
    count = len(io.inputs) if io is not None else 0
    if not 0 <= number < count:
        raise RuleError(f"M66 {texts['P']}: {_none_or_range(tr.machine, 'in', count)}")
    mode = values.get("L", 0.0)
    if mode not in WAIT_MODES:
        raise RuleError(f"M66 {texts['L']}: the wait mode L is 0 (read at once), 1 (rising edge), "
                        f"2 (falling edge), 3 (high) or 4 (low)")
    timeout = values.get("Q", 0.0)
    if mode and not timeout > 0.0:
        raise RuleError(f"M66 L{mode:g}: a wait needs a timeout Q above 0 (seconds)")
    if not timeout <= MAX_WAIT_S:
        raise RuleError(f"M66 {texts['Q']}: the timeout is at most {MAX_WAIT_S:g} s")
    wait = Wait(number, int(mode), timeout if mode else 0.0)
    outcome = wait_outcome(io, wait.input, wait.mode, wait.timeout, _start_seconds(tr))
    tr.emit(WaitInput(wait.input, wait.mode, wait.timeout))
    tr.state.params.write(RESULT, outcome.value)


def _start_seconds(tr: Translator) -> float:
    """When the moves compiled so far end: the program so far planned as the run plans it (tool
    changes by the machine's changer)."""
    from ..atc.front import expand_host_commands
    from ..motion.planner import plan_program
    from .program import Program
    if tr.comp.geometry is not None and tr.comp.geometry.queue:
        raise RuleError("M66 while cutter radius compensation holds a move back: turn it off "
                        "(G40) before waiting on an input")
    program = Program(list(tr.commands), list(tr.lines), tr.where[1])
    try:
        expanded = expand_host_commands(program, tr.machine, tr.spindle_tool)
        return plan_program(expanded.commands, tr.machine).end_s
    except RetrofitError as exc:
        raise RuleError(f"M66: the moves before it cannot be planned: {exc}") from None
