"""grbl's ``$`` lines in G-code files: run what has a meaning on a CNC, skip settings with a note.

* ``$H`` homes every axis (``ZMOV``);
* ``$J=<G-code>`` is a jog: the words after ``=`` run as one G1 move (G91, G20/G21 and G53 in it
  apply to that move only), without changing the program's modes;
* ``$X`` (unlock), ``$$``, ``$#``, ``$G``, ``$I``, ``$N``, ``$C``, ``$RST=..``, ``$SLP`` and
  settings such as ``$110=500`` configure or query a grbl controller: they are skipped, each with a
  note in the program's messages.

3D-printer codes (M104, M140, ...) are refused in :mod:`retrofit.gcode.blocks`.
"""

from __future__ import annotations

import copy

from ..canon import ZeroAxes
from .blocks import make_block
from .errors import RuleError
from .lexer import lex_line


def run_dollar(interp, line) -> None:
    """One ``$`` line of a grbl-flavoured file."""
    text = "".join(line.dollar.split()).upper()
    tr = interp.tr
    if text == "$H":
        tr.at(line.number, tr.where[1])
        tr.emit(ZeroAxes())
        homing = tr.machine.parts.get("homing")
        tr.state.position = {n: (homing.home_mm(n) if homing else 0.0) for n in tr.machine.axis_names}
        return
    if text.startswith("$J="):
        _jog(interp, line, text[3:])
        return
    interp.messages.append((tr.where[1] or "", line.number, "NOTE",
                            f"grbl line {line.dollar!r} skipped: it configures or queries a grbl "
                            f"controller"))


def _jog(interp, line, code: str) -> None:
    lexed = lex_line(line.number, code)
    if lexed is None or lexed.oword is not None or lexed.assigns:
        raise RuleError("$J= needs G-code words after '=', e.g. $J=G91 X10 F500")
    words = [(letter, interp._value(tree)) for letter, tree in lexed.words]
    block = make_block(line.number, words, interp.machine)
    if block.motion is not None or not block.axes or "F" not in block.values:
        raise RuleError("$J= takes axis words, F, and optionally G20/G21, G90/G91, G53 -- no "
                        "motion code")
    allowed = {"units", "distance"}
    if set(block.g) - allowed - ({"non-modal"} if block.g.get("non-modal") == 53 else set()) \
            or block.m:
        raise RuleError("$J= takes axis words, F, and optionally G20/G21, G90/G91, G53")
    state = interp.tr.state
    saved = copy.copy(state)
    block.g["motion"] = 1
    interp.tr.run(block, interp.tr.where[1])
    position, sent = state.position, state.feed_sent
    interp.tr.state.__dict__.update(saved.__dict__)
    state.position, state.feed_sent = position, sent
