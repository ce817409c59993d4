"""Programs of the differential corpus for M61 (``m61-*``), polar coordinates (``polar-*``) and
saving the modal state with M70-M73 (``m7x-*``); ``err-*`` ones break a rule of each.

Written by ``make_programs.py``. rs274 run alone takes the tool in the spindle back from its
canonical layer before every block (in LinuxCNC the tool M61 sets stays), so a program here uses
the tool M61 sets (G43 without H) on the line of the M61 itself, where both agree; #5400 after
M61 is checked in ``tests/test_gcode_modal.py``.
"""

from __future__ import annotations

PRE = "G21 G90 G94 G40 G49 G80 G54 G91.1 G17\n"


def tool_number() -> dict[str, str]:
    """M61 Q: the tool number changes, nothing moves."""
    p = {}
    p["m61-g43-same-line"] = PRE + "M61 Q2 G43\nG0 X1 Y1 Z1\nM61 Q1 G43\nG0 Z1\nG49 G0 Z1\nM2\n"
    p["m61-rounds-q"] = PRE + "M61 Q2.6 G43\nG0 X1 Z1\nM61 Q0.4 G43\nG0 Z1\nM2\n"
    p["m61-then-m6"] = PRE + "T1 M61 Q3 G43\nG0 X2 Z2\nM6\nG43 H1\nG0 Z2\nM2\n"
    p["err-m61-no-q"] = PRE + "M61\nG0 X1\nM2\n"
    p["err-m61-negative"] = PRE + "M61 Q-1\nG0 X1\nM2\n"
    p["err-m61-unknown-tool"] = PRE + "M61 Q5\nG0 X1\nM2\n"
    p["err-m61-with-m6"] = PRE + "T1 M6 M61 Q2\nG0 X1\nM2\n"
    return p
