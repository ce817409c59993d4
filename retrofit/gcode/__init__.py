"""The G-code front end: part programs (RS274NGC subset) compiled to retrofit's command set.

>>> from retrofit.config import load_machine
>>> from retrofit.gcode import compile_program
>>> [str(c) for c in compile_program("G0 X5 Z1", load_machine("chivu-lathe")).commands]
['FMOV X5 Z1']

See ``docs/gcode.md`` for the supported words and the rules every program is checked against.
"""

from .parser import SUPPORTED_G, SUPPORTED_M
from .program import Program, compile_program, load_program

__all__ = ["Program", "compile_program", "load_program", "SUPPORTED_G", "SUPPORTED_M"]
