"""Published Fanuc lathe examples run under the Fanuc dialect and cut their published coordinates.

The programs in tests/data/fanuc/manuals were typed again from the figures of published examples
(their coordinates, depths, allowances and feeds); each test names its source. Positions here
are what the machine does: X a radius in mm (the programs write diameters), Z in mm.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

DATA = Path(__file__).parent / "data" / "fanuc"


def run(name: str, **kw):
    text = (DATA / "manuals" / name).read_text()
    return text, compile_program(text, load_machine(DATA / "fanuc-school-lathe.toml"), name, **kw)


def line_of(text: str, start: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if line.startswith(start))


def moves(program, line: int | None = None) -> list[tuple[str, float, float]]:
    """(kind, X diameter, Z) of the FMOV/PMOV commands (of one source line if given)."""
    out = []
    for command, at in zip(program.commands, program.lines):
        name, *words = str(command).split()
        if name in ("FMOV", "PMOV") and (line is None or at == line):
            v = {w[0]: float(w[1:]) for w in words}
            out.append((name, round(2 * v["X"], 6), round(v["Z"], 6)))
    return out


def moves_upto(program, index: int):
    return [c for c in program.commands[:index + 1] if str(c).split()[0] in ("FMOV", "PMOV")]


def corners(path) -> list[tuple[float, float]]:
    return [(x, z) for _, x, z in path]


def test_g71_g70_with_arcs_published_profile_and_passes():
    """Figures from https://blog.csdn.net/weixin_33670352/article/details/112205304 (a Fanuc
    G71/G70 teaching example): start A X46 Z3, 1.5 mm a side, retract 1, allowances X0.4 Z0.1;
    the part: chamfer to X10 Z-2, X10 to Z-20, R5 to X20 Z-25, X20 to Z-35, R7 to X34 Z-42, X34
    to Z-52, taper to X44 Z-62, X44 to Z-82."""
    text, program = run("g71-arcs-chamfer.nc")
    profile = [(10, -2), (10, -20), (20, -25), (20, -35), (34, -42), (34, -52), (44, -62), (44, -82)]
    rough_end = max(i for i, at in enumerate(program.lines) if at == line_of(text, "N40"))
    g70_end = max(i for i, at in enumerate(program.lines) if at == line_of(text, "N135"))
    finish = corners(moves(program)[len(moves_upto(program, rough_end)):
                                    len(moves_upto(program, g70_end))])
    for corner in profile:
        assert any(math.dist(corner, p) < 1e-6 for p in finish), f"G70 misses the corner {corner}"
    assert finish[-1] == (46.0, 3.0)                           # G70 ends at its start point
    rough = moves(program, line_of(text, "N40"))
    cuts = [x for kind, x, _ in rough if kind == "PMOV"]
    levels = sorted({x for x in cuts if any(abs(x - (46 - 3 * k)) < 1e-9 for k in range(1, 16))},
                    reverse=True)
    assert levels == [46 - 3 * k for k in range(1, 16)]        # 1.5 mm a side down to X1
    for x, z in profile:                                       # the last roughing pass: the profile
        assert any(math.dist((x + 0.4, z + 0.1), p) < 1e-6 for p in corners(rough)), (x, z)
    assert rough[-1] == ("FMOV", 46.0, 3.0)


def test_student_shaft_rough_with_one_tool_finish_with_another():
    """Figures from https://slackerblud.com/WeChatMiniProgram/rzzhhaopke.html (a Fanuc lathe
    student program): T0101 S500, G71 U1 R0.3, P10 Q20 U0.1 W0.05 F0.15, profile X16 Z1 -> Z0
    -> X20 Z-2 -> Z-20 -> X30 Z-35 -> X40 -> Z-45 -> X46 -> X50 Z-47 -> Z-60 -> X52; M00; T0202
    S1000 G70 P10 Q20 at the profile's F0.05."""
    text, program = run("g71-student-shaft.nc")
    finish = corners(moves(program, None))
    profile = [(16, 0), (20, -2), (20, -20), (30, -35), (40, -35), (40, -45), (46, -45), (50, -47),
               (50, -60), (52, -60)]
    g70 = [c for c, at in zip(program.commands, program.lines) if at == line_of(text, "G70")]
    assert "PAUS M0" in [str(c) for c in program.commands]
    assert "TOOL T2" in [str(c) for c in program.commands]
    for corner in profile:
        assert corner in finish
    levels = {x for kind, x, z in moves(program) if kind == "PMOV" and z < 0 and x > 16.1}
    assert {52 - 2 * k for k in range(1, 18)} <= levels        # 1 mm a side: X50 .. X18
    feeds = [str(c) for c in program.commands if str(c).startswith("PFDR")]
    assert feeds[0] == "PFDR F75"                               # 0.15 mm/rev at 500 rpm
    assert "PFDR F50" in feeds                                  # the profile's 0.05 at 1000 rpm
    assert g70 and str(g70[-1]) == "FMOV X26 Z1"                # back at the start point
    assert any("T0101" in m[3] for m in program.messages)       # no tool table: said, not hidden


def test_g32_taper_thread_passes_at_their_published_coordinates():
    """Coordinates from https://pastebin.com/m6fC0VK4 (a real Fanuc lathe program threading a
    taper of lead 6.35 mm with G32): each pass starts at Z9.621, 9.452, 9.29, 9.141 on X51.347,
    51.331, 51.241, 51.082 and ends at Z-53.97 on X59.296, 59.258, 59.148, 58.97."""
    _text, program = run("g32-taper-thread.nc")
    starts = [(51.347, 9.621), (51.331, 9.452), (51.241, 9.29), (51.082, 9.141)]
    ends = [(59.296, -53.97), (59.258, -53.97), (59.148, -53.97), (58.97, -53.97)]
    names = [str(c).split()[0] for c in program.commands]
    assert names.count("ISTP") == 4 and names.count("CSTP") == 4
    synced, here = [], None
    for command in program.commands:
        name, *words = str(command).split()
        if name in ("FMOV", "PMOV"):
            v = {w[0]: float(w[1:]) for w in words}
            point = (2 * v["X"], v["Z"])
            if name == "PMOV":
                synced.append((here, point))
            here = point
        if name == "PFDR":
            lead_along_path = float(words[0][1:])
    for (a, b), start, end in zip(synced, starts, ends):
        assert math.dist(a, start) < 1e-6 and math.dist(b, end) < 1e-6
    a, b = synced[-1]
    along_z = lead_along_path * abs(b[1] - a[1]) / math.hypot((b[0] - a[0]) / 2, b[1] - a[1])
    assert along_z == pytest.approx(6.35, abs=1e-9)             # F is the lead along Z


def test_student_program_surface_speed_and_feed_per_revolution_by_default():
    """Coordinates from https://pastebin.com/0SE4gqSn (a school's Fanuc lathe exercise): G96 S150
    F0.15 M4 with no G98/G99 (feed per revolution, the control's default), faces at Z71 and Z70
    from X32 to X-2, turns X28, 26, 24, 22, 20.5 to Z30.1 and X20 to Z30, ends at X60 Z125."""
    _, program = run("student-oevning2.nc")
    turns = {(x, z) for kind, x, z in moves(program) if kind == "PMOV"}
    for x in (28, 26, 24, 22, 20.5):
        assert (x, 30.1) in turns
    assert (20, 30) in turns and (-2, 71) in turns and (-2, 70) in turns
    assert moves(program)[-1] == ("FMOV", 60.0, 125.0)
    spins = [str(c) for c in program.commands if str(c).startswith("SPIN")]
    assert f"SPIN S{1000 * 150 / (math.pi * 32):.3f} D-1" in spins   # 150 m/min at X32, M4
