"""The lathe cycle programs of the differential corpus: G70, G71 and G72 (and .1, .2).

Each exercises one part of the cycles as LinuxCNC 2.9 reads them: type I and type II
(pocketed) profiles, arcs by I K and by R, facing and boring, inch and mm, radius and diameter
mode, the offsets D, U, W, the depth I and retract R, finishing passes D E P, F S T on the
cycle's line, and the cycles' refusals (``err-*``).
"""

from __future__ import annotations

HEAD = "G18 G21 G90 G94 G40 G8\nF200\n"
#: a turned profile, monotonic: chamfer, diameter, arc shoulder, taper, diameter
TURN = ("O100 SUB\nG0 X4 Z1\nG1 X6 Z0\nZ-8\nG2 X9 Z-11 I3 K0\nG1 X11 Z-14\nZ-20\n"
        "G1 X14\nO100 ENDSUB\n")
#: the same with its arcs by R and a G3 fillet
TURN_R = ("O100 SUB\nG0 X3 Z1\nG1 X5 Z-1\nZ-6\nG3 X7 Z-8 R2\nG1 Z-12\nG2 X10 Z-15 R3\n"
          "G1 Z-20\nX14\nO100 ENDSUB\n")
#: type II: a groove between two diameters (the profile falls and climbs)
POCKET = ("O100 SUB\nG0 X6 Z1\nG1 Z-4\nX9 Z-6\nZ-9\nX5 Z-12\nZ-15\nX10 Z-18\nZ-24\nX14\n"
          "O100 ENDSUB\n")
#: type II with arcs: a round-bottomed groove
POCKET_ARC = ("O100 SUB\nG0 X8 Z1\nG1 Z-5\nG2 X8 Z-13 I0 K-4\nG1 Z-16\nX10 Z-18\nZ-22\n"
              "X14\nO100 ENDSUB\n")
#: a facing profile: Z falls step by step while X climbs (G72)
FACE = ("O100 SUB\nG0 X0 Z0\nG1 X4\nZ-1\nX8 Z-2\nZ-4\nG3 X10 Z-6 I0 K-2\nG1 X14\nO100 ENDSUB\n")
#: a facing profile with a pocket on the face
FACE_POCKET = ("O100 SUB\nG0 X0 Z-1\nG1 X3\nZ-4\nX6\nZ-2\nX9\nZ-6\nX14\nO100 ENDSUB\n")
#: a diameter running into a concave G3 and a G3 rising from the axis: offset, each meets the
#: next segment inside the corner, not at its end
CONCAVE = ("O100 SUB\nG0 X4 Z1\nG1 X6 Z0\nZ-5\nG3 X10 Z-9 I0 K-4\nG1 Z-12\nX14\nO100 ENDSUB\n")
BALL = ("O100 SUB\nG0 X2 Z1\nG1 X2 Z0\nG3 X6 Z-4 I0 K-4\nG1 Z-12\nX14\nO100 ENDSUB\n")
#: a bore: X climbs from the start (inside the part)
BORE = ("O100 SUB\nG0 X10 Z1\nG1 Z-3\nX8 Z-5\nZ-10\nG3 X6 Z-12 I-2 K0\nG1 Z-18\nX2\n"
        "O100 ENDSUB\n")


def _prog(profile: str, body: str, head: str = HEAD) -> str:
    return head + profile + body + "M2\n"


def lathe_cycles() -> dict[str, str]:
    p = {}
    g0 = "G0 X16 Z3\n"
    p["g71-turn"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 I1 R0.5\n")
    p["g71-turn-allowance"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 D0.4 I0.8 R0.3\n")
    p["g71-turn-allowance-under"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 D-0.3 I0.8 R0.3\n")   # under size
    p["g71-concave-arc-allowance"] = _prog(CONCAVE, g0 + "G71 Q100 X16 Z3 D0.4 I0.8 R0.3\n")
    p["g71-arc-from-axis-allowance"] = _prog(BALL, g0 + "G71 Q100 X16 Z3 D0.4 I0.8 R0.3\n")
    p["g71-turn-no-xz"] = _prog(TURN, g0 + "G71 Q100 D0.2 I1.5\n")
    p["g71-turn-r-arcs"] = _prog(TURN_R, g0 + "G71 Q100 X16 Z3 D0.3 I1 R0.5\n")
    p["g71-turn-then-g70"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 D0.5 I1\nG70 Q100 X16 Z3 D0.5 E0.1 P3\n")
    p["err-g71-uw"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 U0.3 W0.1 I1\n")
    p["g71-turn-retract-0"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 I1 R0\n")
    p["g71-turn-deep-cut"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 I6 R1\n")
    p["g71-turn-fst"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 I1 F120 S800\nG1 X20 Z5\n")
    p["g71-pocket"] = _prog(POCKET, g0 + "G71 Q100 X16 Z3 D0.2 I1 R0.4\n")
    p["g71.1-pocket"] = _prog(POCKET, g0 + "G71.1 Q100 X16 Z3 D0.2 I1 R0.4\n")
    p["g71.2-pocket"] = _prog(POCKET, g0 + "G71.2 Q100 X16 Z3 D0.2 I1 R0.4\n")
    p["g71-pocket-arc"] = _prog(POCKET_ARC, g0 + "G71 Q100 X16 Z3 D0.2 I0.7 R0.3\n")
    p["g71.1-pocket-arc"] = _prog(POCKET_ARC, g0 + "G71.1 Q100 X16 Z3 I0.7 R0.3\n")
    p["g71-pocket-then-g70"] = _prog(POCKET, g0 + "G71 Q100 X16 Z3 D0.3 I1\nG70 Q100 X16 Z3 D0.3 P2\n")
    p["g72-face"] = _prog(FACE, "G0 X16 Z2\nG72 Q100 X16 Z2 I0.5 R0.3\n")
    p["g72-face-allowance"] = _prog(FACE, "G0 X16 Z2\nG72 Q100 X16 Z2 D0.2 I0.7\n")
    p["g72-face-pocket"] = _prog(FACE_POCKET, "G0 X16 Z1\nG72 Q100 X16 Z1 I0.6 R0.2\n")
    p["g72.1-face-pocket"] = _prog(FACE_POCKET, "G0 X16 Z1\nG72.1 Q100 X16 Z1 I0.6 R0.2\n")
    p["g72.2-face-pocket"] = _prog(FACE_POCKET, "G0 X16 Z1\nG72.2 Q100 X16 Z1 I0.6 R0.2\n")
    p["g72-face-then-g70"] = _prog(FACE, "G0 X16 Z2\nG72 Q100 X16 Z2 D0.3 I1\nG70 Q100 X16 Z2 D0.3 P2\n")
    p["g71-bore"] = _prog(BORE, "G0 X1 Z3\nG71 Q100 X1 Z3 D0.2 I1 R0.3\n")
    p["g70-bore"] = _prog(BORE, "G0 X1 Z3\nG70 Q100 X1 Z3 D0.4 E0.1 P3\n")
    p["g71-inch"] = _prog(
        "O200 SUB\nG0 X0.16 Z0.04\nG1 X0.24 Z0\nZ-0.32\nG2 X0.36 Z-0.44 I0.12 K0\nG1 X0.44 Z-0.56\n"
        "Z-0.8\nX0.56\nO200 ENDSUB\n",
        "G0 X0.64 Z0.12\nG71 Q200 X0.64 Z0.12 D0.01 I0.04 R0.02\nG70 Q200 X0.64 Z0.12\n",
        head="G18 G20 G90 G94 G40 G8\nF8\n")
    p["g71-diameter-g7"] = _prog(
        "O100 SUB\nG0 X8 Z1\nG1 X12 Z-1\nZ-8\nX18 Z-11\nZ-14\nX22 Z-16\nZ-20\nX28\nO100 ENDSUB\n",
        "G0 X32 Z3\nG71 Q100 X32 Z3 D0.4 I2 R0.5\nG70 Q100 X32 Z3\nG8\n",
        head="G18 G21 G90 G94 G40 G7\nF200\n")
    p["g71-g901-centres"] = _prog(TURN.replace("I3 K0", "I9 K-8"), g0 + "G71 Q100 X16 Z3 I1\n",
                                  head=HEAD + "G90.1\n")
    p["g71-repeat-profile"] = _prog(
        "O100 SUB\nG0 X3 Z1\nO101 REPEAT [3]\nG1 Z[#<_z>-4]\nG1 X[#<_x>+3]\nO101 ENDREPEAT\n"
        "O100 ENDSUB\n", "G0 X14 Z3\nG71 Q100 X14 Z3 I1 R0.5\n")
    p["g71-approach-behind"] = _prog(TURN, "G0 X16 Z-3\nG71 Q100 X16 Z-3 I1\n")
    p["g70-passes"] = _prog(TURN_R, g0 + "G70 Q100 X16 Z3 D1 E0.2 P4\n")
    p["g70-pocket-arcs"] = _prog(POCKET_ARC, g0 + "G70 Q100 X16 Z3 D0.5 P2\n")
    p["g71-pawn"] = _prog(
        "O100 SUB\nG0 X0.202 Z3.041\nG2 X1.081 Z0.919 I3.0 K0.0\nG1 X3.0 Z-1.0\nG1 Z-4.0\n"
        "X2.268 Z-5.268\nG2 X2.0 Z-6.268 I1.73205 K-1.0\nG1 Z-6.732\nG2 X4.0 Z-8.732 I2.0 K0.0\n"
        "G1 X4.5\nG3 X6.285 Z-12.982 I-0.0 K-2.5\nG2 Z-19.982 I3.57071 K-3.5\nG1 X10\n"
        "G1 X8.5 Z-22.58\nG1 X10.0 Z-25.178\nG1 Z-27.178\nG2 X11.014 Z-35.1 I5.70735 K-3.29514\n"
        "G1 X12.0 Z-36.1\nG1 Z-38.1\nG0 X15.0\nO100 ENDSUB\n",
        "T2 M6 G43\nG71.1 Q100 X15 Z3.041 D1 I1 R0.3\nG71.2 Q100 X15 Z3.041 D0.51 I0.5 R0.3\n"
        "G70 Q100 X15 Z3.041 E0 D0.5 P2\n")
    p["g71-tool-on-line"] = _prog(TURN, g0 + "G71 Q100 X16 Z3 I1 T3 S500 F150\nM6\nG70 Q100 X16 Z3\n")
    p["g72-diameter-g7"] = _prog(
        "O100 SUB\nG0 X0 Z0\nG1 X8\nZ-1\nX16 Z-2\nZ-4\nX28\nO100 ENDSUB\n",
        "G0 X32 Z2\nG72 Q100 X32 Z2 D0.2 I0.5 R0.3\nG70 Q100 X32 Z2\nG8\n",
        head="G18 G21 G90 G94 G40 G7\nF200\n")
    # refusals
    p["err-g71-incremental"] = _prog(TURN, g0 + "G91\nG71 Q100 X0 Z0 I1\n")
    p["err-g71-no-q"] = _prog(TURN, g0 + "G71 X16 Z3 I1\n")
    p["err-g71-unknown-q"] = _prog(TURN, g0 + "G71 Q300 X16 Z3 I1\n")
    p["err-g71-comp-on"] = _prog(TURN, "T3 M6\nG0 X16 Z3\nG42\nG0 X16 Z4\nG71 Q100 X16 Z3 I1\n")
    p["err-g71-not-monotonic"] = _prog(
        "O100 SUB\nG0 X4 Z1\nG1 Z-6\nX6\nZ-3\nX8\nZ-10\nX14\nO100 ENDSUB\n", g0 + "G71 Q100 X16 Z3 I1\n")
    p["err-g72-arc-no-ik"] = _prog("O100 SUB\nG0 X0 Z0\nG1 X4\nG3 X8 Z-2\nG1 X14\nO100 ENDSUB\n",
                                   "G0 X16 Z2\nG72 Q100 X16 Z2 I0.5\n")
    unreadable = TURN.replace("Z-20\n", "Z-20 ~\n")            # a profile line that cannot be read
    p["err-g71-profile-unreadable"] = _prog(unreadable, g0 + "G71 Q100 X16 Z3 I1\n")
    p["err-g70-profile-unreadable"] = _prog(unreadable, g0 + "G70 Q100 X16 Z3\n")
    return p
