"""The G-code front end: RS274NGC as LinuxCNC reads it, compiled to retrofit's command set.

A student can follow a program through the package in this order: :mod:`.lexer` (lines into
words), :mod:`.expressions` (``#`` parameters and ``[...]``), :mod:`.ocode` (subroutines and
loops), :mod:`.blocks` (words into modal groups), :mod:`.state` (what a block leaves behind),
:mod:`.translate`, :mod:`.coords`, :mod:`.cycles`, :mod:`.threading`, :mod:`.radiuscomp` with
:mod:`.cutter` (blocks into commands) and :mod:`.program` (the interpreter that runs them all)::

    >>> from retrofit.machine.config import load_machine
    >>> from retrofit.gcode import compile_program
    >>> [str(c) for c in compile_program("G0 X5 Z1", load_machine("chivu-lathe")).commands]
    ['FMOV X5 Z1']

See ``docs/gcode.md`` for every code and word, beside LinuxCNC's and grbl's.
"""

from .blocks import G_GROUPS, M_GROUPS
from .program import Program, compile_program, load_program

SUPPORTED_G = " ".join(f"G{c:g}" for c in sorted(G_GROUPS))
SUPPORTED_M = " ".join(f"M{c:g}" for c in sorted(M_GROUPS))

__all__ = ["Program", "compile_program", "load_program", "SUPPORTED_G", "SUPPORTED_M"]
