"""The cutter radius compensation programs of the differential corpus (``crc-*``, ``err-crc-*``).

Written by ``make_programs.py``. Paths are cut left (G41) and right (G42) of squares, circles and
rounded profiles, inside and outside, in mm and inch, in G17 and G18 (a lathe profile); the
``err-crc-*`` programs break one of LinuxCNC's compensation rules each. Tools are those of
``tool.tbl`` (T1: 6 mm, T3: 0.8 mm insert) or a diameter given with G41.1/G42.1.
"""

from __future__ import annotations

PRE = "G21 G90 G94 G40 G49 G80 G54 G91.1 G17\n"
#: a square of side 40 from the origin, counter-clockwise (the tool left of it is inside)
SQUARE_CCW = "G1 X40 Y0\nX40 Y40\nX0 Y40\nX0 Y0\n"
SQUARE_CW = "G1 X0 Y40\nX40 Y40\nX40 Y0\nX0 Y0\n"
#: a 60 x 40 rectangle with 8 mm corner radii, clockwise from the middle of its bottom side
ROUNDED_CW = ("G1 X8 Y0\nG2 X0 Y8 I0 J8\nG1 X0 Y32\nG2 X8 Y40 I8 J0\nG1 X52 Y40\n"
              "G2 X60 Y32 I0 J-8\nG1 X60 Y8\nG2 X52 Y0 I-8 J0\nG1 X30 Y0\n")
ROUNDED_CCW = ("G1 X52 Y0\nG3 X60 Y8 I0 J8\nG1 X60 Y32\nG3 X52 Y40 I-8 J0\nG1 X8 Y40\n"
               "G3 X0 Y32 I0 J-8\nG1 X0 Y8\nG3 X8 Y0 I8 J0\nG1 X30 Y0\n")


def _cut(start: str, comp: str, path: str, leave: str, pre: str = PRE) -> str:
    return f"{pre}F300\nG0 {start}\nG1 Z-1\n{comp}\n{path}G40 {leave}\nG0 Z5\nM2\n"


def compensation() -> dict[str, str]:
    """Programs both interpreters run: every end point must agree."""
    p = {}
    p["crc-g41-square-outside"] = _cut("X-20 Y-20", "G41 D1", SQUARE_CW, "G1 X-20 Y-20")
    p["crc-g42-square-outside"] = _cut("X-20 Y-20", "G42 D1", SQUARE_CCW, "G1 X-20 Y-20")
    p["crc-g41-square-pocket"] = _cut("X20 Y10", "G41 D1", SQUARE_CCW.replace("X0 Y0\n", "X0 Y0\nX20 Y0\n"), "G1 X20 Y10")
    p["crc-g42-square-pocket"] = _cut("X20 Y10", "G42 D1", SQUARE_CW.replace("X0 Y0\n", "X0 Y0\nX20 Y0\n"), "G1 X20 Y10")
    p["crc-g41-rounded-outside"] = _cut("X30 Y-20", "G41 D1", "G1 X30 Y0\n" + ROUNDED_CW, "G1 X30 Y-20")
    p["crc-g42-rounded-outside"] = _cut("X30 Y-20", "G42 D1", "G1 X30 Y0\n" + ROUNDED_CCW, "G1 X30 Y-20")
    p["crc-g41-rounded-pocket"] = _cut("X30 Y20", "G41 D1", "G1 X30 Y0\n" + ROUNDED_CCW, "G1 X30 Y20")
    p["crc-g42-rounded-pocket"] = _cut("X30 Y20", "G42 D1", "G1 X30 Y0\n" + ROUNDED_CW, "G1 X30 Y20")
    p["crc-g41-circle-pocket"] = _cut("X0 Y0", "G41.1 D6", "G1 X20 Y0\nG3 I-20 J0\n", "G1 X0 Y0")
    p["crc-g42-circle-boss"] = _cut("X40 Y-10", "G42.1 D6", "G1 X20 Y0\nG3 I-20 J0\nG1 X0 Y20\n", "G1 X-10 Y30")
    p["crc-g41-circle-p2-helix"] = _cut("X0 Y0", "G41.1 D6", "G1 X20 Y0\nG3 I-20 J0 Z-3 P2\n", "G1 X0 Y0")
    p["crc-g20-square-outside"] = ("G20 G90 G94 G40 G17\nF10\nG0 X-1 Y-1\nG41.1 D0.25\n"
                                   "G1 X0 Y2\nX2 Y2\nX2 Y0\nX0 Y0\nX0 Y2\nG40 G1 X-1 Y3\nM2\n")
    p["crc-g20-r-arcs"] = ("G20 G90 G94 G40 G17\nF10\nG0 X1 Y-1\nG42 D1\nG1 X1 Y0\n"
                           "G3 X2 Y1 R1\nG2 X3 Y2 R1\nG1 X3 Y3\nG3 X1 Y3 R1\nG1 X0 Y2\n"
                           "G40 G1 X-1 Y2\nM2\n")
    p["crc-arc-entry"] = _cut("X-10 Y0", "G41.1 D4", "G2 X0 Y10 I10 J0\nG1 X20 Y10\nX20 Y0\n", "G1 X30 Y-10")
    p["crc-arc-entry-r"] = _cut("X-10 Y0", "G42.1 D4", "G3 X10 Y0 R10\nG1 X10 Y20\n", "G1 X0 Y30")
    p["crc-g91-incremental"] = (PRE + "F300\nG0 X-20 Y-20\nG41 D1\nG91 G1 X20 Y20\nY40\nX40\n"
                                "Y-40\nX-40\nG90 G40 G1 X-20 Y-20\nM2\n")
    p["crc-plunges-and-feeds"] = (PRE + "F300\nG0 X-20 Y-20 Z5\nG42 D1\nG1 X0 Y0\nZ-1\nM8\n"
                                  "F200 X40\nZ-2\nG4 P0.5\nX40 Y40\nS1000 M3\nX0 Y40\n"
                                  "G40 G1 X-20 Y60\nM9\nM2\n")
    p["crc-g0-corners"] = (PRE + "G0 X-20 Y-20\nG41 D1\nG0 X0 Y0\nX0 Y40\nX40 Y40\nG40 G0 X60 Y60\nM2\n")
    p["crc-tangent-line-arc-line"] = _cut("X-20 Y-10", "G41 D1", "G1 X0 Y0\nX20 Y0\nG3 X40 Y20 I0 J20\n"
                                          "G1 X40 Y40\nG3 X20 Y60 I-20 J0\nG1 X0 Y60\n", "G1 X-20 Y70")
    p["crc-arc-arc-m-shape"] = _cut("X-10 Y-10", "G42.1 D4", "G1 X0 Y0\nG2 X20 Y0 I10 J0\n"
                                    "G2 X40 Y0 I10 J0\nG1 X40 Y-20\n", "G1 X50 Y-30")
    p["crc-h-shape"] = _cut("X50 Y-10", "G42.1 D4", "G1 X40 Y0\nG3 X20 Y0 I-10 J0\nG1 X20 Y-30\n",
                            "G1 X10 Y-40")
    p["crc-arc-then-line-inside"] = _cut("X30 Y-10", "G41.1 D4", "G1 X30 Y0\nG3 X0 Y30 I-30 J0\n"
                                         "G1 X30 Y30\n", "G1 X40 Y40")
    p["crc-exit-at-angle"] = _cut("X-20 Y-20", "G42 D1", "G1 X0 Y0\nX40 Y0\n", "G1 X60 Y35")
    p["crc-d0-radius-zero"] = _cut("X-20 Y-20", "G41 D0", SQUARE_CW, "G1 X-20 Y-20")
    p["crc-g18-lathe-profile"] = ("G18 G21 G90 G94 G40\nF100\nG0 X30 Z5\nG42 D3\nG1 X20 Z0\n"
                                  "G1 Z-20\nG2 X25 Z-25 R5\nG1 X25 Z-40\nG40 G1 X40 Z-45\nM2\n")
    p["crc-g18-lathe-orientation"] = ("G18 G21 G90 G94 G40\nF100\nG0 X30 Z5\nG41.1 D1.6 L3\n"
                                      "G1 X20 Z0\nG1 Z-20\nG3 X10 Z-30 R10\nG1 Z-40\n"
                                      "G40 G1 X5 Z-45\nM2\n")
    # every insert orientation L1..L9 on one profile: each shifts the reference corner its own way
    p["crc-g18-lathe-orientations"] = "G18 G21 G90 G94 G40\nF100\n" + "".join(
        f"G0 X30 Z5\nG42.1 D1.6 L{q}\nG1 X20 Z0\nG1 Z-20\nG2 X25 Z-25 R5\nG40 G1 X40 Z-30\n"
        for q in range(1, 10)) + "M2\n"
    p["crc-g18-lathe-arc-entry"] = ("G18 G21 G90 G94 G40\nF100\nG0 X30 Z5\nG42.1 D1.6 L2\n"
                                    "G2 X20 Z-5 R10\nG1 Z-30\nG40 G1 X40 Z-30\nM2\n")
    return p


def refusals() -> dict[str, str]:
    """Programs both interpreters refuse, each for one of compensation's rules."""
    pre = PRE + "F300\nG0 X-20 Y0\n"
    p = {
        "err-crc-entry-too-short": PRE + "F300\nG0 X0 Y0\nG41.1 D6\nG1 X2 Y0\nX20\nG40 X30\nM2\n",
        "err-crc-inside-corner-gouge": pre + "G41 D1\nG1 X20 Y0\nX20 Y2\nX-10 Y2\nG40 X-20\nM2\n",
        "err-crc-inside-arc-too-small": pre + "G41.1 D6\nG1 X0 Y0\nG3 X4 Y0 R2\nG40 G1 X10\nM2\n",
        "err-crc-line-arc-gouge": pre + "G41.1 D6\nG1 X0 Y0\nG3 X2 Y2 R5\nG1 X-10 Y2\nG40 X-20\nM2\n",
        "err-crc-arc-after-g40": pre + "G41 D1\nG1 X20 Y0\nG40\nG2 X30 Y10 R10\nM2\n",
        "err-crc-plane-change": pre + "G41 D1\nG1 X20 Y0\nG18\nM2\n",
        "err-crc-g43": pre + "G41 D1\nG1 X20 Y0\nG43 H1\nM2\n",
        "err-crc-tool-change": pre + "G41 D1\nG1 X20 Y0\nT2 M6\nM2\n",
        "err-crc-on-twice": pre + "G41 D1\nG1 X20 Y0\nG42 D1\nM2\n",
        "err-crc-g19": PRE + "G19\nG41.1 D6\nM2\n",
        "err-crc-g28": pre + "G41 D1\nG1 X20 Y0\nG28\nM2\n",
        "err-crc-g92": pre + "G41 D1\nG1 X20 Y0\nG92 X0\nM2\n",
        "err-crc-cycle": pre + "G41 D1\nG1 X20 Y0\nG81 X30 Y0 Z-5 R2\nM2\n",
        "err-crc-coordinate-system": pre + "G41 D1\nG1 X20 Y0\nG55\nM2\n",
        "err-crc-read-position": pre + "G41 D1\nG1 X20 Y0\n#1=#5420\nM2\n",
        "err-crc-g41-1-no-d": PRE + "G41.1\nM2\n",
        "err-crc-d-not-whole": PRE + "G41 D1.5\nM2\n",
        "err-crc-d-unknown-tool": PRE + "G41 D8\nM2\n",
        "err-crc-g53": pre + "G41 D1\nG1 X20 Y0\nG53 G1 X30\nM2\n",
        "err-crc-lathe-tool-in-g17": PRE + "G41 D7\nM2\n",
        "err-crc-override": pre + "G41 D1\nG1 X20 Y0\nM48\nM2\n",
        "err-crc-g10-l2-in-use": pre + "G41 D1\nG1 X20 Y0\nG10 L2 P1 X5\nM2\n",
        "err-crc-gouge-at-g40": ("G20 G90 G94 G40 G17\nF4\nG0 X0.0994 Y-1.4544\nG42.1 D0.3937\n"
                                 "G1 X0.6803 Y-0.2171\nG1 X0.7052 Y-0.9500\n"
                                 "G40 G1 X-2.2224 Y-1.2508\nM2\n"),
    }
    return p
