"""Write the feature programs of the differential corpus into ``programs/``.

Usage: ``python3 tests/gcode/make_programs.py`` then ``python3 tests/gcode/regenerate.py``.
Each program exercises one feature of RS274NGC as LinuxCNC reads it; the ones named ``err-*``
break a rule of the language and must be refused by both interpreters. Hand-written programs
(``hand-*.ngc``) live beside the generated ones and are not touched by this script.
"""

from __future__ import annotations

import itertools
from pathlib import Path

try:
    from comp_programs import compensation, refusals
    from lathe_programs import lathe_cycles
    from modal_programs import polar, saved_state, tool_number
except ImportError:               # imported as tests.gcode.make_programs
    from .comp_programs import compensation, refusals
    from .lathe_programs import lathe_cycles
    from .modal_programs import polar, saved_state, tool_number

OUT = Path(__file__).resolve().parent / "programs"
PRE = "G21 G90 G94 G40 G49 G80 G54 G91.1 G17\n"


def arcs() -> dict[str, str]:
    progs = {}
    planes = {17: ("X", "Y", "I", "J", "Z"), 18: ("Z", "X", "K", "I", "Y"), 19: ("Y", "Z", "J", "K", "X")}
    for plane, (a, b, ia, ib, n) in planes.items():
        for mode, form, units, dist in itertools.product((2, 3), ("ijk", "r", "rneg", "full"),
                                                         (21, 20), (90, 91)):
            k = 0.04 if units == 20 else 1.0
            lines = [f"G{units} G{dist} G{plane} F{100 * k:g}", f"G0 {a}{2 * k:g} {b}{3 * k:g} {n}0"]
            ea, eb = (12 * k, 3 * k)
            if dist == 91:
                ea, eb = 10 * k, 0.0
            if form == "ijk":
                lines.append(f"G{mode} {a}{ea:g} {b}{eb:g} {ia}{5 * k:g} {ib}0 {n}{k:g}")
            elif form in ("r", "rneg"):
                r = 7 * k * (-1 if form == "rneg" else 1)
                lines.append(f"G{mode} {a}{ea:g} {b}{eb:g} R{r:g}")
            else:
                end = (0.0, 0.0) if dist == 91 else (2 * k, 3 * k)
                lines.append(f"G{mode} {a}{end[0]:g} {b}{end[1]:g} {ia}{4 * k:g} {ib}{-3 * k:g} P2")
            lines += [f"G1 {a}{k:g}", "M2"]
            progs[f"arc-g{plane}-g{mode}-{form}-g{units}-g{dist}"] = "\n".join(lines) + "\n"
    progs["arc-helix"] = PRE + "G0 X10 Y0 Z5\nG1 F200\nG3 X10 Y0 Z-5 I-10 J0 P3\nG2 X0 Y10 Z-7 I-10 J0\nM2\n"
    progs["arc-g901-absolute-centre"] = PRE + "G90.1\nG0 X10 Y0\nG3 X0 Y10 I0 J0 F100\nG91.1\nG2 X10 Y0 I0 J-10\nM2\n"
    progs["arc-tolerance-accepted"] = PRE + "G0 X0 Y0\nG2 X10 Y0.5 I5 J0 F100\nM2\n"
    progs["arc-spiral-large"] = PRE + "G0 X0 Y0\nG2 X100 Y1.5 I50 J0 F100\nM2\n"
    progs["err-arc-radius-differs"] = PRE + "G0 X0 Y0\nG2 X10 Y0.7 I5 J0 F100\nM2\n"
    progs["err-arc-r-too-small"] = PRE + "G0 X0 Y0\nG2 X10.003 Y0 R5 F100\nM2\n"
    progs["err-arc-no-centre"] = PRE + "G0 X0 Y0\nG2 X10 Y0 F100\nM2\n"
    progs["err-arc-r-full-circle"] = PRE + "G0 X0 Y0\nG2 X0 Y0 R5 F100\nM2\n"
    progs["err-arc-wrong-plane-word"] = PRE + "G0 X0 Y0\nG2 X10 Y0 I5 K1 F100\nM2\n"
    return progs


def offsets() -> dict[str, str]:
    progs = {}
    for n, code in enumerate(("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"), 1):
        progs[f"cs-{code.lower().replace('.', '_')}"] = (
            PRE + f"G10 L2 P{n} X{n * 3} Y{-n} Z{n / 2:g}\n{code}\nG0 X1 Y1 Z1\nG1 X5 F100\n"
            f"G10 L20 P0 X0 Y0\nG0 X2 Y2\nG53 G0 X0 Y0\nG0 X3\nM2\n")
    progs["g92-family"] = PRE + ("G0 X20 Y5\nG92 X10 Y0\nG0 X12 Y1\nG92.2\nG0 X12 Y1\nG92.3\n"
                                 "G0 X12 Y1\nG92.1\nG0 X12 Y1\nM2\n")
    progs["g92-with-g54"] = PRE + "G10 L2 P1 X5 Y5\nG0 X1 Y1\nG92 X0 Y0\nG0 X1 Y1\nG91 G0 X1\nG90 G0 X0 Y0\nM2\n"
    progs["g28-named-axis-bug1"] = PRE + "G0 X10 Y20 Z5\nG28 Z2\nG0 X1\nM2\n"
    progs["g28-cam-retract"] = PRE + "G0 X10 Y20 Z5\nG91 G28 Z0\nG90 G0 X3 Y3\nM2\n"
    progs["g28-after-g92-bug2"] = PRE + "G0 X20\nG92 X10\nG28\nG91 G1 X5 F100\nM2\n"
    progs["g28-all-axes"] = PRE + "G0 X5 Y6 Z7\nG28\nG0 X1\nM2\n"
    progs["g28-stored"] = PRE + "G0 X5 Y6 Z7\nG28.1\nG0 X0 Y0 Z0\nG28 X1\nG0 Y2\nG28\nM2\n"
    progs["g30-stored"] = PRE + "G0 X3 Y4 Z5\nG30.1\nG0 X0 Y0 Z0\nG30 Z1\nG30\nM2\n"
    progs["g53-moves"] = PRE + "G10 L2 P1 X10\nG0 X1\nG53 G1 X2 F100\nG53 G0 Y3\nG0 X0\nM2\n"
    progs["units-mixed"] = PRE + "G0 X1 Y1\nG20 G0 X1 Y1\nG21 G0 X2\nG20 G91 G1 X0.5 F4\nG21 G90 G1 X0 F100\nM2\n"
    progs["incremental"] = PRE + "G91\nG0 X1 Y1\nG1 X0.1 F100\nX0.1\nX0.1\nY-0.3\nG90 X0\nM2\n"
    progs["tool-length"] = PRE + "T1 M6\nG43 H1\nG0 X0 Y0 Z5\nG43 H2\nG0 Z5\nG49\nG0 Z5\nM2\n"
    progs["tool-length-g43-alone"] = PRE + "T2 M6\nG43\nG0 Z1\nG43.1 Z3\nG0 Z1\nG49 G0 Z1\nM2\n"
    progs["tool-g10-l1"] = PRE + "G10 L1 P5 Z7\nT5 M6\nG43 H5\nG0 Z0\nM2\n"
    progs["tool-g10-l10"] = PRE + "T1 M6 G43\nG0 Z20\nG10 L10 P1 Z5\nG43 H1\nG0 Z5\nM2\n"
    progs["err-g10-missing-l"] = PRE + "G10 P1 X3\nM2\n"
    progs["err-g92-no-axis"] = PRE + "G92\nM2\n"
    return progs


def cycles() -> dict[str, str]:
    progs = {}
    for code, ret, extra in itertools.product((81, 82, 83, 73, 85, 89), (98, 99), ("", "L3")):
        words = {82: " P0.5", 83: " Q1.2", 73: " Q0.4", 89: " P0.25"}.get(code, "")
        inc = "G91 " if extra else ""
        xy = "X4 Y0" if extra else "X5 Y5"
        r = "R-2" if extra else "R2"
        z = "Z-3" if extra else "Z-3"
        progs[f"cycle-g{code}-g{ret}{'-l3' if extra else ''}"] = (
            PRE + f"G0 X0 Y0 Z10\nF100\nG{ret} {inc}G{code} {xy} {z} {r}{words} {extra}\n"
            f"G90 X8 Y8\nG80\nG0 Z12\nM2\n") if not extra else (
            PRE + f"G0 X0 Y0 Z10\nF100\nG{ret} G{code} X1 Y1 Z-3 R2{words}\n"
            f"G91 {xy} Z-2 R-3 {extra}\nG90 G80\nG0 Z12\nM2\n")
    for code, turn in ((84, "M3"), (74, "M4"), (86, "M3"), (86, "M4")):
        words = " P0.2" if code != 86 else " P0.5"
        name = f"cycle-g{code}" + ("-m4" if code == 86 and turn == "M4" else "")
        progs[name] = PRE + (f"{turn} S300\nG0 X0 Y0 Z10\nF150\nG98 G{code} X1 Y1 Z-3 R2{words}\n"
                             f"G99 X4 Y1\nG91 X2 Y0 Z-2 R-3{' L2' if code != 74 else ''}\nG90 G80\n"
                             f"G0 Z12\nM2\n")        # rs274 takes no L with G74
    progs["cycle-g84-no-p"] = PRE + "M3 S300\nG0 X0 Y0 Z10\nG98 G84 X1 Y1 Z-3 R2 F150\nG80\nM2\n"
    progs["cycle-g88"] = PRE + "M3 S300\nG0 X0 Y0 Z10\nF150\nG88 X1 Y1 Z-3 R2 P0.5\nG80\nG0 Z12\nM2\n"
    progs["cycle-g87"] = PRE + "M3 S300\nG0 X0 Y0 Z10\nF150\nG99 G87 X1 Y1 Z-3 R2 I0.5 J0 K-1\nG80\nM2\n"
    progs["cycle-g87-g98-g99"] = PRE + ("M3 S300\nG0 X0 Y0 Z10\nF150\nG98 G87 X1 Y1 Z-3 R2 I0.5 J-0.25 K-1\n"
                                        "G99 X4 Y1\nX6 K0 I-0.3\nG90 G80\nG0 Z12\nM2\n")
    progs["cycle-g87-g91-l2"] = PRE + ("M4 S300\nG0 X0 Y0 Z10\nF150\nG99 G87 X1 Y1 Z-3 R2 I0 J0.4 K-1\n"
                                       "G91 X2 Y0 Z-2 R-3 K1 L2\nG90 G80\nG0 Z12\nM2\n")
    progs["cycle-g87-g98-l3"] = PRE + ("M3 S500\nG0 X0 Y0 Z10\nF150\nG98 G91 G87 X3 Y-1 Z-4 R-3 I0.5 J0 "
                                       "K1.5 L3\nG90 G80\nM2\n")
    progs["cycle-g87-g20-g55"] = ("G20 G90 G94 G40 G49 G80 G54 G91.1 G17\nG10 L2 P2 X1 Y-0.5 Z-0.2\nM3 S300\n"
                                  "G0 X0 Y0 Z1\nF6\nG55 G98 G87 X0.1 Y0.1 Z-0.3 R0.2 I0.05 J0 K-0.1\n"
                                  "G80\nM2\n")
    progs["err-cycle-g87-no-j"] = PRE + "M3 S300\nG0 Z10\nG87 X1 Y1 Z-3 R2 I0.5 K-1 F100\nM2\n"
    progs["err-cycle-g87-no-spindle"] = PRE + "G0 Z10\nG87 X1 Y1 Z-3 R2 I0.5 J0 K-1 F100\nM2\n"
    progs["err-cycle-g84-m4"] = PRE + "M4 S300\nG0 Z10\nG84 X1 Y1 Z-2 R1 F100\nM2\n"
    progs["err-cycle-g74-m3"] = PRE + "M3 S300\nG0 Z10\nG74 X1 Y1 Z-2 R1 F100\nM2\n"
    progs["err-cycle-g86-no-spindle"] = PRE + "G0 Z10\nG86 X1 Y1 Z-2 R1 P1 F100\nM2\n"
    progs["err-cycle-g86-no-p"] = PRE + "M3 S300\nG0 Z10\nG86 X1 Y1 Z-2 R1 F100\nM2\n"
    progs["err-cycle-g82-no-p"] = PRE + "G0 Z10\nG82 X1 Y1 Z-2 R1 F100\nM2\n"
    progs["err-cycle-g88-no-p"] = PRE + "M3 S300\nG0 Z10\nG88 X1 Y1 Z-2 R1 F100\nM2\n"
    progs["err-cycle-r-below-z"] = PRE + "G0 Z10\nG81 X1 Y1 Z2 R1 F100\nM2\n"
    progs["err-cycle-g83-no-q"] = PRE + "G0 Z10\nG83 X1 Y1 Z-2 R1 F100\nM2\n"
    return progs


def splines() -> dict[str, str]:
    """G5, G5.1, G5.2/G5.3: rs274 prints a spline as NURBS_FEED without points, so each program
    follows its spline with a G91 move whose absolute end shows where the spline ended."""
    p = {}
    p["spline-g5-chain"] = PRE + ("G0 X0 Y0\nG1 F100\nG5 I0 J3 P4 Q-1 X1 Y1\nG5 P0 Q-1 X2 Y2\n"
                                  "G91 G1 X0.5\nG90 G0 X0\nM2\n")
    p["spline-g5-keeps-mode"] = PRE + "G0 X1\nG5 I1 J0 P1 Q0 X2 Y0 F100\nX3\nG1 X4\nG5 I1 J1 P1 Q1 X6 Y0\nX7\nM2\n"
    p["spline-g5-no-ij"] = PRE + "G0 X0 Y0\nG1 F100\nG5 P-2 Q1 X5 Y5\nG91 G1 Y1\nM2\n"
    p["spline-g51"] = PRE + "G0 X0 Y0\nG1 F100\nG5.1 X5 Y0 I2 J2\nG5.1 X0 Y0 I-2 J-4\nG91 G1 X1\nM2\n"
    p["spline-g5-g20-g91"] = PRE + ("G0 X1 Y1\nG20 G91 G1 F4\nG5 I0.04 J0.1 P0.1 Q-0.04 X0.2 Y0.1\n"
                                    "G1 X0.04\nG21 G90 G0 X0 Y0\nM2\n")
    p["spline-g5-offsets"] = PRE + ("G10 L2 P1 X3 Y-2\nG92 X1\nG0 X0 Y0\nG1 F100\n"
                                    "G5 I1 J2 P-1 Q2 X4 Y1\nG91 G1 X1\nM2\n")
    p["spline-nurbs-quarter"] = PRE + ("G0 X10 Y0\nG1 F100\nG5.2 X10 Y10 P0.7071067812\nX0 Y10 P1\n"
                                       "G5.3\nG91 G1 X1\nM2\n")
    p["spline-nurbs-order4"] = PRE + ("G0 X0 Y0\nG1 F200\nG5.2 P1 L4\nX5 Y10 P1\nX10 Y-5 P2\n"
                                      "X15 Y5 P1\nX20 Y0 P0.5\nG5.3\nG91 G1 Y1\nM2\n")
    p["spline-nurbs-g91"] = PRE + ("G0 X2 Y2\nG1 F100\nG91\nG5.2 X4 Y0 P1\nX4 Y4 P1\nX0 Y4 P1\n"
                                   "G5.3\nG1 X1\nM2\n")
    p["err-spline-g5-no-pq"] = PRE + "G0 X0 Y0\nG5 I1 J1 X2 Y2 F100\nM2\n"
    p["err-spline-g5-only-i"] = PRE + "G0 X0 Y0\nG5 I1 P1 Q1 X2 Y2 F100\nM2\n"
    p["err-spline-g51-no-j"] = PRE + "G0 X0 Y0\nG5.1 I1 X2 Y2 F100\nM2\n"
    p["err-spline-g51-p"] = PRE + "G0 X0 Y0\nG5.1 I1 J1 P1 X2 Y2 F100\nM2\n"
    p["err-spline-z"] = PRE + "G0 X0 Y0\nG5 I1 J0 P1 Q0 X2 Y0 Z-1 F100\nM2\n"
    p["err-spline-g18"] = PRE + "G18\nG0 X0 Z0\nG5 I1 J1 P1 Q1 X2 Z1 F100\nM2\n"
    p["err-spline-no-axes"] = PRE + "G0 X0 Y0\nG5 I1 J0 P1 Q0 F100\nM2\n"
    p["err-nurbs-too-few"] = PRE + "G0 X0 Y0 F100\nG5.2 X1 Y1 P1 L4\nX2 Y0 P1\nG5.3\nM2\n"
    p["err-nurbs-g53-alone"] = PRE + "G0 X0 Y0 F100\nG5.3\nM2\n"
    p["err-nurbs-broken"] = PRE + "G0 X0 Y0 F100\nG5.2 X1 Y1 P1\nX2 Y0 P1\nG0 X3\nG5.3\nM2\n"
    p["err-nurbs-no-weight"] = PRE + "G0 X0 Y0 F100\nG5.2 X1 Y1 P1\nX2 Y0\nX3 Y1 P1\nG5.3\nM2\n"
    p["err-nurbs-one-axis"] = PRE + "G0 X0 Y0 F100\nG5.2 X1 Y1 P1\nX2 P1\nG5.3\nM2\n"
    p["err-nurbs-after-end"] = PRE + "G0 X0 Y0 F100\nG5.2 X1 Y1 P1\nX2 Y0 P1\nG5.3\nX4 Y4\nM2\n"
    return p


def language() -> dict[str, str]:
    p = {}
    p["expr-operators"] = PRE + ("G0 X[1+2*3] Y[2**3] Z[7 MOD 3]\nG0 X[10/4] Y[-7 MOD 3] Z[[1 EQ 1] + [2 NE 2]]\n"
                                 "G0 X[[3 GT 2] + [3 GE 3] + [2 LT 1] + [2 LE 2]] Y[[1 AND 0] + [1 OR 0] + [1 XOR 1]]\n"
                                 "G0 X[2 ** 3 ** 2 / 64] Y[1 - 2 - 3] Z[8 / 2 / 2]\nM2\n")
    p["expr-functions"] = PRE + ("G0 X[ABS[-3]] Y[ACOS[0.5]/10] Z[ASIN[1]/10]\nG0 X[ATAN[1]/[1]] Y[COS[60]*10] Z[EXP[1]]\n"
                                 "G0 X[FIX[2.7]] Y[FUP[2.1]] Z[LN[10]]\nG0 X[ROUND[2.5]] Y[ROUND[-2.5]] Z[SIN[30]*10]\n"
                                 "G0 X[SQRT[2]] Y[TAN[45]] Z[ATAN[-1]/[-1]/10]\nM2\n")
    p["expr-exists"] = PRE + "#<a>=1\nG0 X[EXISTS[#<a>]] Y[EXISTS[#<b>]]\nM2\n"
    p["params-same-line"] = PRE + "#1=5\n#1=7 #2=#1\nG0 X#1 Y#2\n#3=2 G0 X#3\nG0 Y#3\nM2\n"
    p["params-indirect"] = PRE + "#1=2\n#2=9\nG0 X##1\n#[#1+1]=4\nG0 Y#3\nM2\n"
    p["params-named"] = PRE + "#<depth>=-2\n#<_safe>=5\nG0 Z#<_safe>\nG1 Z#<depth> F100\n#<depth>=[#<depth>*2]\nG1 Z#<depth>\nM2\n"
    p["params-position"] = PRE + "G10 L2 P1 X1\nG0 X4 Y5 Z6\n#1=#5420\n#2=#5421\nG0 X[#1+1] Y[#2+1] Z#<_z>\nM2\n"
    p["oword-sub-call"] = PRE + ("o100 sub\n  G0 X#1 Y#2\n  G1 Z#3 F100\no100 endsub\n"
                                 "o100 call [1] [2] [-1]\no100 call [3] [4] [-2]\nM2\n")
    p["oword-named-sub"] = PRE + ("o<hole> sub\n  G0 X#1 Y#2\n  G1 Z-1 F50\n  G0 Z1\no<hole> endsub\n"
                                  "o<hole> call [10] [10]\no<hole> call [20] [10]\nM2\n")
    p["oword-return-value"] = PRE + ("o<sq> sub\n  o<sq> return [#1*#1]\no<sq> endsub\n"
                                     "o<sq> call [3]\nG0 X#<_value>\nM2\n")
    p["oword-locals"] = PRE + ("#<x>=1\n#1=5\no<f> sub\n  #<x>=9\n  G0 X#<x> Y#1\no<f> endsub\n"
                               "o<f> call [2]\nG0 X#<x> Y#1\nM2\n")
    p["oword-if-else"] = PRE + ("#1=2\no1 if [#1 EQ 1]\n  G0 X1\no1 elseif [#1 EQ 2]\n  G0 X2\no1 else\n"
                                "  G0 X3\no1 endif\no2 if [#1 GT 5]\n  G0 Y1\no2 else\n  G0 Y2\no2 endif\nM2\n")
    p["oword-while"] = PRE + "#1=0\no10 while [#1 LT 5]\n  G0 X#1\n  #1=[#1+1]\no10 endwhile\nG0 Y#1\nM2\n"
    p["oword-do-while"] = PRE + "#1=0\no10 do\n  G0 X#1\n  #1=[#1+2]\no10 while [#1 LT 7]\nM2\n"
    p["oword-repeat"] = PRE + "G91\no5 repeat [4]\n  G1 X1 F100\n  G1 Y1\no5 endrepeat\nG90 G0 X0 Y0\nM2\n"
    p["oword-break-continue"] = PRE + ("#1=0\no7 while [1]\n  #1=[#1+1]\n  o8 if [#1 EQ 2]\n    o7 continue\n"
                                       "  o8 endif\n  G0 X#1\n  o9 if [#1 GE 4]\n    o7 break\n  o9 endif\n"
                                       "o7 endwhile\nG0 Y#1\nM2\n")
    p["oword-nested-calls"] = PRE + ("o<a> sub\n  G0 X#1\n  o<b> call [#1+1]\no<a> endsub\n"
                                     "o<b> sub\n  G0 Y#1\no<b> endsub\no<a> call [3]\nM2\n")
    p["oword-recursion"] = PRE + ("o<fact> sub\n  o1 if [#1 LE 1]\n    o<fact> return [1]\n  o1 endif\n"
                                  "  o<fact> call [#1-1]\n  o<fact> return [#1*#<_value>]\no<fact> endsub\n"
                                  "o<fact> call [4]\nG0 X#<_value>\nM2\n")
    p["messages"] = PRE + "(MSG, starting)\n#1=3\n(DEBUG, one is #1)\nG0 X1\n(PRINT, done)\nM2\n"
    p["comments-and-case"] = PRE + "n10 g0 x1 (rough) y2 ; trailing\nN20 G 1 X - 1.5 F 100\n  g1y2\nM2\n"
    p["percent-delimited"] = "%\n" + PRE + "G0 X1\nG0 X2\n%\nG0 X3 (never)\n"
    p["block-delete-off"] = PRE + "/G0 X5\nG0 X1\nM2\n"
    p["bare-g0-g1"] = PRE + "G0\nG1 F100\nX5\nG0\nY5\nM2\n"
    p["spindle-s0"] = PRE + "M3 S0\nG1 X1 F100\nS1000\nM4\nM5\nM2\n"
    p["coolant"] = PRE + "M7\nM8\nG0 X1\nM9\nM7 M8\nM9\nM2\n"
    p["pauses"] = PRE + "G0 X1\nM0\nG0 X2\nM1\nG0 X3\nM60\nM2\n"
    p["dwell"] = PRE + "G0 X1\nG4 P0.5\nG1 X2 F100\nM2\n"
    p["inverse-time"] = PRE + "G93\nG1 X10 F2\nG1 Y10 F4\nG94\nG1 X0 F100\nM2\n"
    p["path-control"] = PRE + "G64 P0.01\nG0 X1\nG61\nG0 X2\nG61.1\nG64\nG0 X3\nM2\n"
    p["feed-units"] = PRE + "G20\nG1 X1 F10\nG21\nG1 X10\nM2\n"
    g70 = "G18 G21 G90 G8\nF100\nO100 SUB\nG0 X5 Z2\nG1 Z-5\n{arc}\nG0 X10\nG1 Z-15\nO100 ENDSUB\n"
    p["lathe-g70-turn"] = g70.format(arc="G3 X8 Z-8 K-3 I0") + "G0 X12 Z5\nG70 Q100\nG0 X14\nM2\n"
    p["lathe-g70-r-p2"] = g70.format(arc="G3 X8 Z-8 R3") + "G0 X12 Z5\nG70 Q100 X13 Z4 P2\nM2\n"
    p["lathe-g70-g7"] = g70.format(arc="G3 X16 Z-8 K-3 I0").replace("G8", "G7").replace(
        "X5 ", "X10 ").replace("X10\nG1", "X20\nG1") + "G0 X24 Z5\nG70 Q100\nM2\n"
    p["lathe-g70-face"] = ("G18 G21 G90 G8\nF100\nO100 SUB\nG0 X12 Z0\nG1 X6\nG3 X4 Z-2 K0 I-2\n"
                           "G1 X2\nZ-5\nO100 ENDSUB\nG0 X14 Z2\nG70 Q100\nM2\n")
    p["lathe-g70-offset"] = g70.format(arc="G3 X8 Z-8 K-3 I0") + "G0 X12 Z5\nG70 Q100 D1 E0 P2\nM2\n"
    p["err-lathe-g70-not-monotonic"] = g70.format(arc="G2 X8 Z-8 K-3 I0") + "G0 X12 Z5\nG70 Q100\nM2\n"
    p["lathe-diameter-mode"] = "G18 G21 G90\nG7\nG0 X20 Z5\nG1 Z-10 F100\nG8\nG1 X15\nM2\n"
    p["lathe-profile"] = "G18 G21 G90 G94\nG0 X30 Z2\nG1 Z0 F100\nG1 X0\nG0 Z2\nX24\nG1 Z-20\nG2 X30 Z-23 R3\nG0 X40\nZ2\nM2\n"
    p["modal-repeat"] = PRE + "G1 X1 F100\nY1\nX0\nY0\nG0 Z1\nX5\nM2\n"
    p["m2-ends"] = PRE + "G0 X1\nM2\nG0 X2\n"
    p["m30-ends"] = PRE + "G0 X1\nM30\nG0 X2\n"
    p["no-m2"] = PRE + "G0 X1\nG0 X2\n"
    p["tool-change"] = PRE + "T1\nM6\nG0 X1\nT2 M6\nM6 T1\nG0 X2\nM2\n"
    # the language's refusals
    p["err-divide-by-zero"] = PRE + "G0 X[1/0]\nM2\n"
    p["err-two-motion"] = PRE + "G0 G1 X1\nM2\n"
    p["err-two-spindle"] = PRE + "M3 M5\nM2\n"
    p["err-axis-without-motion"] = "G80\nX1\nM2\n"
    p["err-g1-and-g92"] = PRE + "G1 G92 X1 F100\nM2\n"
    p["err-undefined-named"] = PRE + "G0 X#<nope>\nM2\n"
    p["err-unclosed-sub"] = PRE + "o100 sub\nG0 X1\nM2\n"
    p["err-endwhile-alone"] = PRE + "o1 endwhile\nM2\n"
    p["err-unknown-g"] = PRE + "G65 X1\nM2\n"
    p["err-unknown-m"] = PRE + "M123\nM2\n"
    p["err-word-twice"] = PRE + "G0 X1 X2\nM2\n"
    p["err-unclosed-comment"] = PRE + "G0 X1 (open\nM2\n"
    p["err-bad-operator"] = PRE + "G0 X[1 ? 2]\nM2\n"
    p["err-sqrt-negative"] = PRE + "G0 X[SQRT[-1]]\nM2\n"
    p["err-ln-zero"] = PRE + "G0 X[LN[0]]\nM2\n"
    p["err-acos-range"] = PRE + "G0 X[ACOS[2]]\nM2\n"
    p["err-i-without-arc"] = PRE + "G1 X1 I2 F100\nM2\n"
    p["err-p-without-use"] = PRE + "G0 X1 P2\nM2\n"
    p["err-g4-no-p"] = PRE + "G4\nM2\n"
    p["err-zero-feed"] = "G21 G90 G17\nG1 X1\nM2\n"
    p["err-negative-feed"] = PRE + "G1 X1 F-5\nM2\n"
    p["err-param-out-of-range"] = PRE + "#6000=1\nM2\n"
    p["err-n-not-first"] = PRE + "G0 X1 N5\nM2\n"
    p["err-call-unknown"] = PRE + "o<nowhere> call\nM2\n"
    p["err-else-alone"] = PRE + "o1 else\nM2\n"
    return p


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for old in OUT.glob("*.ngc"):
        if not old.name.startswith("hand-"):
            old.unlink()
    programs = {**arcs(), **offsets(), **cycles(), **splines(), **language(), **compensation(),
                **refusals(), **tool_number(), **polar(),
                **saved_state(), **lathe_cycles()}
    for name, text in programs.items():
        (OUT / f"{name}.ngc").write_text(text)
    print(f"{len(programs)} programs written to {OUT}")


if __name__ == "__main__":
    main()
