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


def polar() -> dict[str, str]:
    """@ radius and ^ angle in place of X Y, absolute and incremental, in moves and cycles."""
    p = {}
    p["polar-g90-moves"] = PRE + "G0 @10 ^30\nG1 ^90 F100\nG1 @5\nG1 @7 ^-135 Z-1\nG0 ^200\nM2\n"
    p["polar-g91-moves"] = PRE + ("G0 X10 Y0\nG91 G1 ^45 F100\nG1 @2\nG1 @-1 ^-30 Z-1\n"
                                  "G0 ^-90\nG90 G0 @3\nM2\n")
    p["polar-offsets-g20"] = PRE + ("G10 L2 P1 X5 Y5\nG92 X1\nG20 G0 @1 ^45\nG91 G1 ^45 F10\n"
                                    "G1 @0.5\nG21 G90 G0 ^0\nG92.1\nM2\n")
    p["polar-arc-end"] = PRE + "G0 X10 Y0\nG3 @10 ^90 I-10 J0 F100\nG2 ^0 R10\nM2\n"
    p["polar-cycle-g91"] = PRE + ("G0 X10 Y0 Z5\nF100\nG98 G91 G81 ^45 R-3 Z-2 L8\nG81 @2 R-3 Z-2 L3\n"
                                  "G90 G80\nG0 Z5\nM2\n")
    p["polar-cycle-g90"] = PRE + "G0 X0 Y0 Z5\nF100\nG98 G81 @10 ^0 R2 Z-1\n^120\n^240\n@5\nG80\nM2\n"
    p["err-polar-g18"] = PRE + "G18\nG0 @1 ^30\nM2\n"
    p["err-polar-with-x"] = PRE + "G0 X1 @1 ^30\nM2\n"
    p["err-polar-g91-origin"] = PRE + "G91 G0 ^30\nM2\n"
    p["err-polar-no-angle-at-origin"] = PRE + "G0 @5\nM2\n"
    p["err-polar-g53"] = PRE + "G0 X1\nG53 G0 @1 ^10\nM2\n"
    p["err-polar-g92"] = PRE + "G0 X1\nG92 @1 ^10\nM2\n"
    return p


def saved_state() -> dict[str, str]:
    """M70 save, M71 forget, M72 restore, M73 save and restore on return; moves show the modes."""
    p = {}
    p["m7x-m70-m72-modes"] = PRE + ("G0 X1 Y1\nM70\nG20 G91 G1 X1 F10\nG55 G0 Y0.1\nM72\n"
                                    "G1 X5 F100\nG0 Y2\nM72\nG0 X7\nM2\n")
    p["m7x-m73-endsub"] = PRE + ("G10 L2 P2 X10 Y10\no<s> sub\n  M73\n  G55 G20 G91\n  G0 X1 Y1\n"
                                 "o<s> endsub\nG0 X1 Y1\no<s> call\nG0 X3 Y3\nG91 G0 X1\n"
                                 "o<s> call\nG0 X1\nM2\n")
    p["m7x-m73-return"] = PRE + ("o<s> sub\n  M73\n  G91 G18\n  o1 if [#1 GT 0]\n    o<s> return\n"
                                 "  o1 endif\n  G0 X1\no<s> endsub\nG0 X2 Y2\no<s> call [1]\n"
                                 "G0 X5\no<s> call [0]\nG0 Y5\nM2\n")
    p["m7x-m71-forgets-m73"] = PRE + ("o<s> sub\n  M73\n  G91\n  M71\no<s> endsub\nG0 X2\n"
                                      "o<s> call\nG0 X1\nG90 M70\nG91\nM72\nG0 X4\nM2\n")
    p["m7x-sub-keeps-caller"] = PRE + ("o<s> sub\n  M70\n  G91\n  M72\n  G0 X1\no<s> endsub\n"
                                       "M70\nG91 G0 X1\no<s> call\nM72\nG0 X1\nM2\n")
    p["err-m7x-m72-first"] = PRE + "G0 X1\nM72\nM2\n"
    p["err-m7x-m72-after-m71"] = PRE + "M70\nG91\nM71\nM72\nG0 X1\nM2\n"
    p["err-m7x-m72-caller-level"] = PRE + "o<s> sub\n  M72\no<s> endsub\nM70\no<s> call\nM2\n"
    p["err-m7x-with-m3"] = PRE + "S100 M3 M70\nM2\n"
    return p
