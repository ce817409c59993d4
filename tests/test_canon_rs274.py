"""The canon seam against LinuxCNC's rs274, call for call: on a few programs, every straight
traverse, straight feed and arc (its end, its centre, its plane, its sense and its turns) the
interpreter emits (:mod:`retrofit.canon`) is the call rs274 prints (tests/gcode/golden), within
its 4 printed decimals (rs274 alone prints a feed to where the tool already is for a G1 without
axis words: moves that go nowhere are left out on both sides); and running every line through the seam, plain G0/G1 lines included,
gives the very commands the plain-line fast path gives."""

from __future__ import annotations

import re

import pytest

from retrofit.canon import ArcFeed
from retrofit.canon.calls import MOVES
from retrofit.gcode.lazylines import LazyLines
from retrofit.gcode.ocode import Source, scan
from retrofit.gcode.program import gcode_errors, start_interpreter

from tests.test_gcode_rs274 import HERE, MACHINE, TOOLS, canon_events, golden

PROGRAMS = ["programs/arc-g17-g2-full-g20-g91", "programs/arc-g18-g3-ijk-g21-g90",
            "programs/arc-g19-g2-rneg-g21-g91", "programs/arc-helix", "programs/arc-g901-absolute-centre",
            "programs/cycle-g83-g98", "programs/crc-g41-circle-p2-helix", "linuxcnc/arcspiral"]
_ROTATION = re.compile(r"ARC_FEED\((?:[^,]*,){4}\s*(-?\d+)")


def compile_through_canon(name: str, plain_path: bool):
    """(canonical calls made, commands) of program ``name``."""
    path = HERE / f"{name}.ngc"
    interpreter = start_interpreter(MACHINE, path.name, tool_table=TOOLS, search_path=[path.parent])
    tr = interpreter.tr
    tr.plain_path = plain_path
    calls, canon = [], tr.canon

    class Log:
        def commands(self, call):
            calls.append(call)
            return canon.commands(call)

        def chord_points(self, arc):
            return canon.chord_points(arc)

    tr.canon = Log()
    with gcode_errors(path.name):
        interpreter.run(scan(Source(path.name, LazyLines(path.read_text()))))
        tr.finish()
    return calls, tr.commands


@pytest.mark.parametrize("name", PROGRAMS)
def test_the_canon_calls_are_rs274s(name):
    accepted, _, body = golden(HERE / f"{name}.ngc")
    assert accepted
    theirs = _going_somewhere([e for e in canon_events(body) if e[0] in ("line", "arc")],
                              lambda e: e[0] == "arc", lambda e: e[1])
    senses = iter(int(m) for m in _ROTATION.findall(body))
    calls, _ = compile_through_canon(name, plain_path=False)
    ours = _going_somewhere([c for c in calls if isinstance(c, MOVES)],
                            lambda c: isinstance(c, ArcFeed), lambda c: c.end)
    assert [e[0] for e in theirs] == ["arc" if isinstance(c, ArcFeed) else "line" for c in ours]
    for k, (event, call) in enumerate(zip(theirs, ours)):
        tol = event[-1] if event[0] == "line" else event[4]
        assert call.end == pytest.approx(event[1], abs=tol), f"call {k}: {call} against {event}"
        if isinstance(call, ArcFeed):
            _, _, centre, plane, _, turns = event
            rotation = next(senses)
            assert call.plane == plane and call.extra_turns + 1 == turns, f"call {k}: {call}"
            assert call.clockwise == (rotation < 0), f"call {k}: rs274's rotation {rotation}"
            assert [call.centre[i] for i in plane] == pytest.approx([centre[i] for i in plane], abs=tol)


def _going_somewhere(moves: list, is_arc, end_of) -> list:
    """``moves`` without the lines that end where the tool already is (mm, within 1e-4)."""
    kept, here = [], (0.0, 0.0, 0.0)
    for move in moves:
        if is_arc(move) or end_of(move) != pytest.approx(here, abs=1e-4):
            kept.append(move)
        here = end_of(move)
    return kept


@pytest.mark.parametrize("name", ["programs/cycle-g83-g98", "linuxcnc/arcspiral"])
def test_plain_lines_through_the_seam_make_the_fast_paths_commands(name):
    assert compile_through_canon(name, True)[1] == compile_through_canon(name, False)[1]
