"""Write the G76 threading programs of the differential corpus into ``g76/``.

Usage: ``python3 tests/gcode/g76_programs.py`` then ``python3 tests/gcode/regenerate.py``.
Each program cuts one thread with LinuxCNC's G76 on a lathe: external and internal threads,
compound angles Q0 and Q29.5, degression R, entry/exit tapers E L, spring passes H, radius (G8)
and diameter (G7) mode, mm and inch, toward -Z and +Z; ``err-*`` break a rule of G76 and must be
refused by both interpreters. ``linuxcnc-*`` take their G76 line from LinuxCNC's own nc_files.
"""

from __future__ import annotations

from pathlib import Path

OUT = Path(__file__).resolve().parent / "g76"
MM = "G18 G21 G90 G94 G40 G8\nS300 M3\n"
INCH = "G18 G20 G90 G94 G40 G8\nS300 M3\n"
DIA = "G18 G21 G90 G94 G40 G7\nS300 M3\n"


def g76_programs() -> dict[str, str]:
    p = {}
    p["ext-q0-r1"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 R1 Q0\nG0 X20\n"
    p["ext-q29.5-r2-h1"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 R2 Q29.5 H1\nG0 X20\n"
    p["ext-no-q-no-r"] = MM + "G0 X12 Z5\nG76 P1 Z-15 I-0.5 J0.15 K0.6\nG0 X20\n"
    p["ext-exact-last-pass"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.8 R1 Q29.5\nG0 X20\n"
    p["int-q29.5-r1.5-h2"] = MM + "G0 X8 Z5\nG76 P1.5 Z-20 I1 J0.15 K0.9 R1.5 Q29.5 H2\nG0 X4\n"
    p["ext-toward-plus-z"] = MM + "G0 X12 Z-30\nG76 P2 Z-5 I-0.5 J0.25 K1.2 R2 Q30\nG0 X20\n"
    p["int-toward-plus-z-taper"] = MM + ("G0 X8 Z-30\nG76 P2 Z-5 I0.5 J0.3 K1.2 R2 Q29.5 "
                                         "E1.5 L3 H1\nG0 X4\n")
    p["ext-entry-taper"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 R2 Q0 E2 L1\nG0 X20\n"
    p["ext-exit-taper-q29.5"] = MM + ("G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 R2 Q29.5 E1.5 L2\n"
                                      "G0 X20\n")
    p["ext-both-tapers-h1"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.3 K0.92 R1 Q0 E1 L3 H1\nG0 X20\n"
    p["ext-taper-l0"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.3 K0.92 R1 E2 L0\nG0 X20\n"
    p["ext-g91-z"] = MM + "G0 X12 Z5\nG91\nG76 P1.5 Z-25 I-1 J0.3 K0.92 R2 Q29.5\nG90 G0 X20\n"
    p["diameter-ext-q29.5"] = DIA + "G0 X24 Z5\nG76 P1.5 Z-20 I-4 J0.6 K1.84 R2 Q29.5 H1\nG0 X40\n"
    p["diameter-int-taper"] = DIA + ("G0 X16 Z5\nG76 P1.5 Z-20 I2 J0.4 K1.8 R2 Q29.5 E1.5 L3\n"
                                     "G0 X8\n")
    p["diameter-then-radius"] = DIA + ("G0 X24 Z5\nG76 P1 Z-10 I-2 J0.3 K1.2 R1 Q0\nG8\n"
                                       "G0 X14 Z5\nG76 P1 Z-10 I-2 J0.3 K1.2 R1 Q0\nG0 X20\n")
    p["inch-ext-q29.5"] = INCH + ("G0 X0.5 Z0.2\nG76 P0.0625 Z-0.8 I-0.04 J0.005 K0.0383 R2 Q29.5 "
                                  "H1\nG0 X1\n")
    p["inch-diameter"] = ("G18 G20 G90 G94 G40 G7\nS300 M3\nG0 X0.85 Z0.2\n"
                          "G76 P0.1 Z-1 I-0.05 J0.024 K0.0812 R2 Q30\nG0 X3 Z3\n")
    # the G76 line of LinuxCNC's nc_files/g76.ngc (and lathe-g76.ngc): 1/4-20 with an exit taper
    p["linuxcnc-g76-ngc"] = ("G20 G18 G90 G94 G40 G8\nS300 M3\nG0 Z0.2 X0.2\n"
                             "g76 p.05 z-.5 i-.075 j.008 k.045 h3 r2.0 q29.5 e.05 l2\n"
                             "g0x.5\ng0z0\nM5\nM2\n")
    p["ext-negative-q"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 R2 Q-29.5 H1\nG0 X20\n"
    p["inch-diameter-exact-passes"] = ("G18 G20 G90 G94 G40 G7\nS300 M3\nG0 X0.6 Z0.2\n"
                                       "G76 P0.05 Z-0.6 I-0.02 J0.01 K0.04 R1 Q29.5\nG0 X1\n")
    p["q-minus-one"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.2 K0.92 Q-1\nG0 X20\n"
    p["err-k-not-above-j"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0.5 K0.5\n"
    p["err-i-zero"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I0 J0.2 K0.9\n"
    p["err-j-zero"] = MM + "G0 X12 Z5\nG76 P1.5 Z-20 I-1 J0 K0.9\n"
    return {name: text + "M2\n" if not text.endswith("M2\n") else text for name, text in p.items()}


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for name, text in g76_programs().items():
        (OUT / f"{name}.ngc").write_text(text)


if __name__ == "__main__":
    main()
