"""Differential test: retrofit's interpreter against LinuxCNC's own (``rs274``), program by program.

The corpus is ``tests/gcode/programs`` (written for every feature, ``make_programs.py``) and
``tests/gcode/linuxcnc`` (LinuxCNC's nc_files, GPL-2, see SOURCE.md there). rs274's canonical
calls are recorded in ``tests/gcode/golden`` (``regenerate.py``). For every program both accept,
every end point of every move and every arc's centre and end agree within 1e-4 mm (1e-4 inch
under G20: rs274 prints 4 decimals in the program's units); where rs274
refuses a program, retrofit refuses it too, except the allowances listed here and in
docs/gcode.md. A live run of rs274 checks that the golden files are current where it is installed.
"""

from __future__ import annotations

import math
import re
import shutil
from dataclasses import replace
from pathlib import Path

import pytest

from retrofit.commands import FMov, Paus, PMov, ZMov
from retrofit.errors import GcodeError
from retrofit.gcode import load_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

HERE = Path(__file__).resolve().parent / "gcode"
MACHINE = load_machine(HERE / "rs274-mill.toml")
TOOLS = ToolTable.load(HERE / "tool.tbl")
TOL_MM = 1e-4
PROGRAMS = sorted((HERE / "programs").glob("*.ngc")) + sorted((HERE / "linuxcnc").glob("*.ngc"))
_CALL = re.compile(r"^\s*\d+ N\S* +([A-Z_0-9]+)\((.*)\)\s*$")

#: rs274 refuses, retrofit runs: the grbl-flavoured allowances (docs/gcode.md)
RETROFIT_ALLOWS = {
    "err-zero-feed": "a feed move before any F uses the machine's default feed",
}
#: rs274 runs (or would, given its configuration), retrofit refuses: features retrofit does not
#: have or refuses on purpose (docs/gcode.md), by reason
RETROFIT_REFUSES = {
    **dict.fromkeys(("gridprobe", "smartprobe", "tool-length-probe", "x-trim"),
                    "G38 probing: the test machine has no probe input"),
    **dict.fromkeys(("b-index", "daisy"), "axes A/B: not on this test machine (tests/test_gcode_rotary.py "
                                          "runs them on XYZA and XYZB machines)"),
    "threading": "G33 on a machine without a spindle encoder",
    "err-unclosed-sub": "an o-sub never closed (rs274 stops at the M2 inside it)",
}
#: programs where retrofit makes one rapid more than rs274: G88 retracts Z after its pause with
#: the spindle stopped (rs274 leaves the retract to the operator's hands)
RETRACT_AFTER_PAUSE = {"cycle-g88"}


def canon_events(text: str) -> list[tuple]:
    """rs274's moves in machine mm: ("line", (x, y, z)) and ("arc", end, centre, plane)."""
    units, g5x, g92, tlo, plane = 1.0, [0.0] * 3, [0.0] * 3, [0.0] * 3, "XY"
    events = []
    for raw in text.splitlines():
        m = _CALL.match(raw)
        if not m:
            continue
        name, args = m.group(1), m.group(2)
        nums = [float(v) for v in re.findall(r"-?\d+\.\d+|-?\d+", args)]
        if name == "USE_LENGTH_UNITS":
            units = 25.4 if "INCHES" in args else (10.0 if "CM" in args else 1.0)
        elif name == "SET_G5X_OFFSET":
            g5x = [v * units for v in nums[1:4]]
        elif name == "SET_G92_OFFSET":
            g92 = [v * units for v in nums[0:3]]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            tlo = [v * units for v in nums[0:3]]
        elif name == "SELECT_PLANE":
            plane = args.split("_")[-1]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            events.append(("line", _machine(nums[0:3], units, g5x, g92, tlo), TOL_MM * units))
        elif name == "ARC_FEED":
            order = {"XY": (0, 1, 2), "XZ": (2, 0, 1), "YZ": (1, 2, 0)}[plane]
            end, centre = [0.0] * 3, [0.0] * 3
            end[order[0]], end[order[1]], end[order[2]] = nums[0], nums[1], nums[5]
            centre[order[0]], centre[order[1]] = nums[2], nums[3]
            events.append(("arc", _machine(end, units, g5x, g92, tlo),
                           _machine(centre, units, g5x, g92, tlo), order[:2], TOL_MM * units,
                           abs(int(nums[4]))))
        elif name == "NURBS_FEED":        # rs274 prints no points: the next move shows the end
            events.append(("curve", TOL_MM * units))
    return events


def _machine(p, units, g5x, g92, tlo):
    return tuple(v * units + a + b + c for v, a, b, c in zip(p, g5x, g92, tlo))


def retrofit_points(program) -> list[tuple]:
    """Retrofit's move end points (machine mm) and the (file, line) each came from; ZMOV homes
    its axes to 0 on this machine."""
    here, points = [0.0, 0.0, 0.0], []
    for cmd, line, file in zip(program.commands, program.lines, program.files):
        if isinstance(cmd, (FMov, PMov)):
            here = [dict(cmd.axes)[n] for n in "XYZ"]
        elif isinstance(cmd, ZMov):
            here = [0.0 if not cmd.names or n in cmd.names else v for n, v in zip("XYZ", here)]
        else:
            continue
        points.append((tuple(here), (file, line)))
    return points


def compare(events: list[tuple], points: list[tuple]) -> None:
    """Every canon move matched, in order, by retrofit's commands (an arc or a spline by the
    chords of its block; the move after a spline shows where it ended); a move of rs274's that
    goes nowhere may have no command in retrofit."""
    j, here = 0, (0.0, 0.0, 0.0)
    for k, event in enumerate(events):
        tol = event[4] if event[0] == "arc" else event[-1]
        if event[0] == "line" and _close(event[1], here, tol) and \
                (j >= len(points) or not _close(points[j][0], here, tol)):
            continue                      # a move to where the tool already is
        assert j < len(points), f"move {k} {event}: retrofit has no more moves"
        if event[0] == "curve":           # the chords of one spline block (tests/test_splines.py)
            source = points[j][1]
            while j < len(points) and points[j][1] == source:
                j += 1
            here = points[j - 1][0]
            continue
        if event[0] == "line":
            p = points[j][0]
            assert _close(p, event[1], tol), f"move {k}: rs274 {event[1]}, retrofit {p}"
            here, j = p, j + 1
            continue
        _, end, centre, (a, b), tol, turns = event
        band = 2 * tol        # rs274 prints the start and the centre to 4 decimals each
        r0 = math.hypot(here[a] - centre[a], here[b] - centre[b])
        r1 = math.hypot(end[a] - centre[a], end[b] - centre[b])
        source = points[j][1]
        while j < len(points) and points[j][1] == source:   # the chords, up to the arc's end
            p = points[j][0]
            r = math.hypot(p[a] - centre[a], p[b] - centre[b])
            assert min(r0, r1) - band <= r <= max(r0, r1) + band, \
                f"arc {k}: chord point {p} is {r:.6f} from rs274's centre, radius {r0:.6f}..{r1:.6f}"
            j += 1
            turns -= _close(p, end, tol)
            if turns <= 0:
                break         # a block may make more than one arc (compensation rounds corners)
        assert _close(points[j - 1][0], end, tol), \
            f"arc {k}: rs274 ends at {end}, retrofit {points[j - 1][0]}"
        here = end
    assert j == len(points), f"retrofit makes {len(points) - j} moves more than rs274"


def _close(p, q, tol=TOL_MM) -> bool:
    return all(abs(u - v) <= tol for u, v in zip(p, q))


def golden(program: Path) -> tuple[bool, str, str]:
    """(rs274 accepted, its error, its output) from the recorded golden file."""
    text = (HERE / "golden" / program.parent.name / f"{program.stem}.canon").read_text()
    head, _, body = text.partition("\n")
    code, _, status = head.removeprefix("# rs274 exit ").partition(": ")
    accepted = code == "0" or status.startswith("File ended with no percent sign")
    return accepted, status, body


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_retrofit_agrees_with_rs274(program):
    accepted, status, body = golden(program)
    try:
        compiled = load_program(program, MACHINE, tool_table=TOOLS)
        refusal = None
    except GcodeError as exc:
        compiled, refusal = None, str(exc)
    if program.stem in RETROFIT_REFUSES:
        assert refusal, f"expected: retrofit refuses ({RETROFIT_REFUSES[program.stem]})"
        return
    if program.stem in RETROFIT_ALLOWS:
        assert not accepted and refusal is None
        return
    if not accepted:
        assert refusal is not None, f"rs274 refuses ({status}); retrofit runs it"
        return
    assert refusal is None, f"rs274 runs it; retrofit refuses: {refusal}"
    if program.stem in RETRACT_AFTER_PAUSE:
        compiled = _without_retract_after_pause(compiled)
    compare(canon_events(body), retrofit_points(compiled))


def _without_retract_after_pause(program):
    """``program`` without the FMOV that follows each PAUS (G88's retract), which is checked to be
    a move of Z alone."""
    keep = []
    for k, cmd in enumerate(program.commands):
        after_pause = k and isinstance(program.commands[k - 1], Paus)
        if after_pause and isinstance(cmd, FMov):
            before = next(c for c in reversed(program.commands[:k]) if isinstance(c, (FMov, PMov)))
            assert [a for a, b in zip(cmd.axes, before.axes) if a != b][0][0] == "Z"
            continue
        keep.append(k)
    return replace(program, commands=[program.commands[k] for k in keep],
                   lines=[program.lines[k] for k in keep], files=[program.files[k] for k in keep])


def test_the_corpus_is_large_enough_and_both_accept_most():
    both = [p for p in PROGRAMS if golden(p)[0] and p.stem not in RETROFIT_REFUSES]
    assert len(PROGRAMS) >= 150 and len(both) >= 150


@pytest.mark.skipif(shutil.which("rs274") is None and not Path("/usr/bin/rs274").exists(),
                    reason="LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace)")
@pytest.mark.parametrize("name", ["programs/g28-named-axis-bug1.ngc", "programs/g28-after-g92-bug2.ngc",
                                  "programs/oword-recursion.ngc", "programs/cycle-g83-g98.ngc",
                                  "programs/g71-pocket.ngc", "programs/g72.2-face-pocket.ngc"])
def test_golden_files_are_what_rs274_prints_today(name):
    from tests.gcode.regenerate import run_rs274  # noqa: PLC0415
    program = HERE / name
    recorded = (HERE / "golden" / program.parent.name / f"{program.stem}.canon").read_text()
    assert run_rs274(program) == recorded
