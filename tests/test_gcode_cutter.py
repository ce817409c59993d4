"""Cutter radius compensation (G40-G42.1), checked against hand computations on squares and circles.

The differential corpus (tests/test_gcode_rs274.py, programs ``comp-*``) holds the same paths
against LinuxCNC's own ``rs274``; here every expected point is worked out by hand.
"""
import math
import random
import re
import subprocess
from pathlib import Path

import pytest

from retrofit.commands import Cool, PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.gcode.cutter import find_turn
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

from tests.gcode.regenerate import RS274, inch_tool_table

HERE = Path(__file__).resolve().parent / "gcode"
MILL = load_machine(HERE / "rs274-mill.toml")
TOOLS = ToolTable.load(HERE / "tool.tbl")


def moves(text: str) -> list[tuple[float, float, float]]:
    prog = compile_program(text, MILL, tool_table=TOOLS)
    return [tuple(v for _, v in c.axes) for c in prog.commands if hasattr(c, "axes")]


def close(p, q, tol=1e-6) -> bool:
    return all(abs(a - b) <= tol for a, b in zip(p, q))


def test_inside_corner_ends_both_offset_lines_at_their_intersection():
    # G41 (tool left) along +X then up +Y: an inside corner; the offsets y=1 and x=9 meet at (9, 1)
    out = moves("G0 X-10 Y0\nG41.1 D2\nG1 X10 Y0 F100\nX10 Y10\nG40 G1 X0 Y20\nM2\n")
    assert [p[:2] for p in out] == [(-10, 0), (9, 1), (9, 10), (0, 20)]


def test_outside_corner_is_rounded_by_an_arc_around_the_programmed_corner():
    # G42 (tool right) on the same path: the corner (10, 0) is outside; the tool goes from
    # (10, -1) around it to (11, 0) on a 1 mm arc, then up the offset x = 11
    out = moves("G0 X-10 Y0\nG42.1 D2\nG1 X10 Y0 F100\nX10 Y10\nG40 G1 X20 Y20\nM2\n")
    assert close(out[1], (10, -1, 0))
    corner = out[2:out.index((11, 0, 0)) + 1]
    assert len(corner) >= 2 and all(math.isclose(math.dist(p[:2], (10, 0)), 1.0) for p in corner)
    assert out[-2:] == [(11, 10, 0), (20, 20, 0)]


def test_tool_diameter_comes_from_the_table_by_d_or_from_the_spindle():
    # T1 is a 6 mm end mill: G41 D1 and G41 with T1 loaded both offset by 3 mm
    by_d = moves("G0 X-20 Y0\nG41 D1\nG1 X10 Y0 F100\nX10 Y10\nG40 X0 Y20\nM2\n")
    loaded = moves("T1 M6\nG0 X-20 Y0\nG41\nG1 X10 Y0 F100\nX10 Y10\nG40 X0 Y20\nM2\n")
    assert by_d[1][:2] == (7, 3) and loaded == by_d
    assert moves("G0 X-20 Y0\nG41 D0\nG1 X10 Y0 F100\nG40 X0 Y20\nM2\n")[1] == (10, 0, 0)


def test_inch_diameter_and_negative_diameter_swap_the_side():
    # G20: D0.1 is 2.54 mm; a negative diameter puts the tool on the other side
    out = moves("G20\nG0 X-1 Y0\nG41.1 D0.1\nG1 X1 Y0 F10\nX1 Y1\nG40 X0 Y2\nM2\n")
    assert close(out[1], (25.4 - 1.27, 1.27, 0))
    swapped = moves("G20\nG0 X-1 Y0\nG42.1 D-0.1\nG1 X1 Y0 F10\nX1 Y1\nG40 X0 Y2\nM2\n")
    assert swapped == out


def test_pocket_circle_runs_inside_at_the_circle_radius_less_the_tool_radius():
    # entry along y=0 to (10, 0), then a full CCW circle of radius 10 around the origin with the
    # tool inside (G41): the entry stops where y=1 meets the 9 mm circle, x = sqrt(80)
    out = moves("G0 X0 Y0\nG41.1 D2\nG1 X10 Y0 F100\nG3 I-10 J0\nG40 G1 X0 Y0\nM2\n")
    assert close(out[1], (math.sqrt(80), 1, 0))
    circle = out[2:-1]
    assert all(math.isclose(math.hypot(*p[:2]), 9.0) for p in circle)
    assert close(circle[-1], (9, 0, 0)) and len(circle) > 20


def test_plunge_waits_behind_the_held_move_and_coolant_keeps_its_place():
    prog = compile_program("G0 X-10 Y0 Z5\nG41.1 D2\nG1 X10 Y0 F100\nM8\nZ-1\nX10 Y10\n"
                           "G40 X0 Y20\nM2\n", MILL)
    cmds = [c for c in prog.commands if isinstance(c, (PMov, Cool))]
    ends = [tuple(v for _, v in c.axes) if isinstance(c, PMov) else "M8" for c in cmds]
    # the entry ends at the inside corner (9, 1), then the coolant, then the plunge there
    assert ends[:4] == [(9, 1, 5), "M8", (9, 1, -1), (9, 10, -1)]
    assert prog.lines[prog.commands.index(cmds[1])] == 4


def test_incremental_moves_count_from_the_programmed_point():
    absolute = moves("G0 X-10 Y0\nG41.1 D2\nG1 X10 Y0 F100\nX10 Y10\nG40 X0 Y20\nM2\n")
    relative = moves("G0 X-10 Y0\nG41.1 D2\nG91 G1 X20 Y0 F100\nY10\nG40 X-10 Y10\nM2\n")
    assert relative == absolute


def test_lathe_insert_orientation_moves_the_reference_corner():
    # G18 (Z first, X second): G42.1 D2 L0 vs L2 (corner -Z -X of the nose): every point shifts
    # by one radius in -Z and -X
    text = "G18\nG0 X10 Z10\nG42.1 D2 L{}\nG1 X10 Z0 F100\nX0 Z0\nG40 X-5 Z0\nM2\n"
    plain, insert = moves(text.format(0)), moves(text.format(2))
    assert close(insert[1], (plain[1][0] - 1, 0, plain[1][2] - 1))


@pytest.mark.parametrize("text, line, message", [
    ("G0 X0 Y0\nG41.1 D4\nG1 X1.5 F100\nM2", 3,
     "G41.1: entry move of 1.5000 mm after G41/G42 is not longer than the tool radius 2.0000 mm"),
    ("G0 X-10 Y0\nG41.1 D2\nG1 X10 Y0 F100\nX10 Y0.5\nX-10 Y0.5\nM2", 5,
     "G41.1: straight feed into an inside corner tighter than the tool"),
    ("G0 X10 Y0\nG41.1 D2\nG1 X1 Y0 F100\nG3 X0 Y1 R0.7071\nM2", 4,
     "G41.1: arc radius 0.7071 mm is not larger than the tool radius 1.0000 mm"),
    ("G0 X-10 Y0\nG41.1 D2\nG1 X0 F100\nG40\nG2 X10 Y0 R5\nM2", 5,
     "G2: the move just after G40 must be straight"),
    ("G41.1 D2\nG41.1 D2\nM2", 2, "G41.1: cutter radius compensation is already on (G41.1)"),
    ("G19\nG41.1 D2\nM2", 2, "G41.1: cutter radius compensation works in G17 (XY) or G18"),
    ("G41.1\nM2", 1, "G41.1 with no D word"),
    ("G41.1 D2 L3\nM2", 1, "G41.1 L3: L (lathe tool orientation) needs plane G18"),
    ("G41 D1.5\nM2", 1, "G41 D1.5: D is a tool number"),
    ("G41 D8\nM2", 1, "G41 D8: requested tool 8 not found in the tool table"),
    ("G41 D7\nM2", 1, "G41 D7: tool 7 is a lathe tool (orientation 7), but the plane is not G18"),
    ("G41.1 D2\nG18\nM2", 2, "G18: cannot change planes with cutter radius compensation on"),
    ("G41.1 D2\nT1 M6\nM2", 2, "M6: cannot change tools with cutter radius compensation on"),
    ("G41.1 D2\nG43 H1\nM2", 2, "G43: cannot change tool offsets"),
    ("G41.1 D2\nG55\nM2", 2, "G55: cannot change coordinate systems"),
    ("G41.1 D2\nG28\nM2", 2, "G28: not allowed with cutter radius compensation on"),
    ("G41.1 D2\nG92 X0\nM2", 2, "G92: not allowed with cutter radius compensation on"),
    ("G41.1 D2\nG10 L2 P1 X1\nM2", 2, "G10 L2: cannot change the coordinate system in use"),
    ("G41.1 D2\nG81 X1 Y1 Z-1 R1 F100\nM2", 2, "G81: cannot use canned cycles"),
    ("G41.1 D2\nG98\nM2", 2, "G98: cannot change the canned cycle return mode"),
    ("G41.1 D2\nG64\nM2", 2, "G64: cannot change the path control mode"),
    ("G0 X-9 Y0\nG41.1 D2\nG53 G1 X0 F100\nM2", 3, "G53: cannot move in machine coordinates"),
    ("G41.1 D2\n#1=#5420\nM2", 2, "#5420: cannot read the current position"),
], ids=lambda v: v if isinstance(v, str) and len(v) < 30 else None)
def test_refusals_name_the_line_and_the_rule(text, line, message):
    with pytest.raises(GcodeError) as err:
        compile_program(text, MILL, file="p.ngc", tool_table=TOOLS)
    assert str(err.value).startswith(f"p.ngc:{line}: {message}"), str(err.value)


def test_a_program_ending_with_a_move_held_back_is_refused_not_cut_short():
    with pytest.raises(GcodeError, match="ends with cutter radius compensation on .G41.1. and its "
                                         "last move held back"):
        compile_program("G0 X-10 Y0\nG41.1 D2\nG1 X10 Y0 F100\nX10 Y10\n", MILL)
    # M2 sends the held move out where it ends: (9, 10) beside the programmed (10, 10)
    assert moves("G0 X-10 Y0\nG41.1 D2\nG1 X10 Y0 F100\nX10 Y10\nM2\n")[-1] == (9, 10, 0)


def test_a_gouge_found_at_g40_names_g40():
    # G42 with a 10 mm tool: the second move is shorter than the pull-back of the inside corner
    # that G40 leaves it in; rs274 refuses the same line ("Straight feed in concave corner")
    with pytest.raises(GcodeError, match=r"p.ngc:6: G40: straight feed into an inside corner"):
        compile_program("G20 F4\nG0 X0.0994 Y-1.4544\nG42.1 D0.3937\nG1 X0.6803 Y-0.2171\n"
                        "G1 X0.7052 Y-0.9500\nG40 G1 X-2.2224 Y-1.2508\nM2", MILL, file="p.ngc")


def test_g40_alone_and_comp_off_changes_nothing():
    plain = moves("G0 X1 Y1\nG1 X5 F100\nM2\n")
    assert moves("G40\nG0 X1 Y1\nG1 X5 F100\nG40\nM2\n") == plain


def test_find_turn_counts_counter_clockwise_positive():
    assert math.isclose(find_turn((1, 0), (0, 0), 1, (0, 1)), math.pi / 2)
    assert math.isclose(find_turn((1, 0), (0, 0), -1, (0, 1)), -3 * math.pi / 2)
    assert math.isclose(find_turn((1, 0), (0, 0), 2, (1, 0)), 4 * math.pi)


#: each refusal of the corpus: what rs274 said (golden file) and what retrofit says
SAME_REASON = {
    "entry-too-short": ("entry move is not greater than the tool radius", "entry move of"),
    "inside-corner-gouge": ("Straight feed in concave corner", "straight feed into an inside corner"),
    "gouge-at-g40": ("Straight feed in concave corner", "G40: straight feed into an inside corner"),
    "inside-arc-too-small": ("Tool radius not less than arc radius", "is not larger than the tool "
                                                                       "radius"),
    "line-arc-gouge": ("Arc to straight motion makes a corner", "arc then line make an inside "
                                                                  "corner"),
    "arc-after-g40": ("must be straight, not an arc", "must be straight"),
    "plane-change": ("Cannot change planes", "cannot change planes"),
    "g43": ("Cannot change tool offset", "cannot change tool offsets"),
    "tool-change": ("Cannot change tools", "cannot change tools"),
    "on-twice": ("Cannot turn cutter radius comp on when on", "is already on"),
    "g19": ("allowed only in XY, XZ planes", "works in G17 (XY) or G18 (ZX) only"),
    "g28": ("Cannot use g28 or g30", "G28: not allowed"),
    "g92": ("Cannot change axis offsets", "G92: not allowed"),
    "cycle": ("Cannot use canned cycles", "cannot use canned cycles"),
    "coordinate-system": ("Cannot change coordinate systems", "cannot change coordinate systems"),
    "read-position": ("Cannot read current position", "cannot read the current position"),
    "g41-1-no-d": ("G41.1 with no D word", "G41.1 with no D word"),
    "d-not-whole": ("requires D word to be a whole number", "D is a tool number, a whole number"),
    "d-unknown-tool": ("Requested tool 8 not found", "requested tool 8 not found"),
    "g53": ("Cannot use g53 with cutter radius comp", "cannot move in machine coordinates"),
    "lathe-tool-in-g17": ("with lathe tool, but plane is not G18", "is a lathe tool"),
    "override": ("Cannot enable overrides", "cannot enable or disable overrides"),
    "g10-l2-in-use": ("Cannot change the active coordinate system", "cannot change the "
                                                                   "coordinate system in use"),
}


@pytest.mark.parametrize("name", sorted(SAME_REASON))
def test_corpus_refusals_are_for_the_reason_rs274_gives(name):
    program = HERE / "programs" / f"err-crc-{name}.ngc"
    status = (HERE / "golden" / "programs" / f"err-crc-{name}.canon").read_text().splitlines()[0]
    theirs, ours = SAME_REASON[name]
    assert status.startswith("# rs274 exit 1") and theirs in status
    with pytest.raises(GcodeError, match=re.escape(ours)):
        compile_program(program.read_text(), MILL, tool_table=TOOLS)


def test_every_corpus_refusal_is_checked_for_its_reason():
    names = {p.stem.removeprefix("err-crc-") for p in (HERE / "programs").glob("err-crc-*.ngc")}
    assert names == set(SAME_REASON) and len(names) >= 20


def random_compensated_program(rng) -> str:
    """A G41/G42 path of lines, plunges, rapids and I/J and R arcs in G17 or G18, mm or inch."""
    plane = rng.choice((17, 17, 18))
    a, b, ia, ib, n = ("X", "Y", "I", "J", "Z") if plane == 17 else ("Z", "X", "K", "I", "Y")
    k = 1 / 25.4 if rng.random() < 0.3 else 1.0
    lines = [f"G{20 if k != 1 else 21} G90 G94 G40 G{plane} F{100 * k:.3f}"]
    pa, pb = rng.uniform(-50, 50), rng.uniform(-50, 50)
    lines += [f"G0 {a}{pa * k:.4f} {b}{pb * k:.4f}",
              f"{rng.choice(('G41.1', 'G42.1'))} D{rng.choice((0.5, 2, 6, 10, 20)) * k:.4f}"]
    for i in range(rng.randint(2, 7)):
        qa, qb, roll = rng.uniform(-50, 50), rng.uniform(-50, 50), rng.random()
        if i and roll < 0.15:
            lines.append(f"G1 {n}{rng.uniform(-5, 5) * k:.4f}")
            continue
        if i and roll < 0.25:
            lines.append(f"G0 {a}{qa * k:.4f} {b}{qb * k:.4f}")
        elif i and roll < 0.4:
            ca, cb, turn = rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(0, 2 * math.pi)
            radius = math.hypot(ca, cb)
            qa, qb = pa + ca + radius * math.cos(turn), pb + cb + radius * math.sin(turn)
            lines.append(f"G{rng.choice((2, 3))} {a}{qa * k:.5f} {b}{qb * k:.5f} "
                         f"{ia}{ca * k:.5f} {ib}{cb * k:.5f}")
        elif i and roll < 0.6:
            radius = math.dist((pa, pb), (qa, qb)) / 2 * rng.uniform(1.0, 2.0)
            lines.append(f"G{rng.choice((2, 3))} {a}{qa * k:.4f} {b}{qb * k:.4f} R{radius * k:.4f}")
        else:
            lines.append(f"G1 {a}{qa * k:.4f} {b}{qb * k:.4f}")
        pa, pb = qa, qb
    lines += [f"G40 G1 {a}{rng.uniform(-60, 60) * k:.4f} {b}{rng.uniform(-60, 60) * k:.4f}", "M2"]
    return "\n".join(lines) + "\n"


@pytest.mark.slow
@pytest.mark.skipif(not Path(RS274).exists(), reason="LinuxCNC's rs274 is not installed")
def test_random_compensated_paths_agree_with_live_rs274(tmp_path):
    """300 random paths: where rs274 runs one, every move agrees; where it refuses, so does
    retrofit (about a fifth are refused, for gouges and tight arcs)."""
    from tests.test_gcode_rs274 import canon_events, compare, retrofit_points  # noqa: PLC0415
    rng, agreed, refused, table = random.Random(13), 0, 0, str(inch_tool_table())
    for _ in range(300):
        text = random_compensated_program(rng)
        (tmp_path / "p.ngc").write_text(text)
        run = None
        for _attempt in range(3):          # rs274 now and then dies of a signal: run it again
            run = subprocess.run([RS274, "-t", table, "-g", "p.ngc"],
                                 cwd=tmp_path, capture_output=True, text=True, timeout=60,
                                 stdin=subprocess.DEVNULL)
            if run.returncode >= 0:
                break
        try:
            mine = compile_program(text, MILL, tool_table=TOOLS)
        except GcodeError as exc:
            assert run.returncode != 0, f"rs274 runs it, retrofit refuses ({exc}):\n{text}"
            refused += 1
            continue
        assert run.returncode == 0, f"rs274 refuses ({run.stderr.strip()}), retrofit runs:\n{text}"
        compare(canon_events(run.stdout), retrofit_points(mine))
        agreed += 1
    assert agreed >= 200 and refused >= 20
