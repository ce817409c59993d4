"""G76 against LinuxCNC's own interpreter (``rs274``), move by move and pass by pass.

The programs are ``tests/gcode/g76`` (``g76_programs.py``), rs274's canonical calls are recorded
in ``tests/gcode/golden/g76`` (``regenerate.py``). Every move of rs274 -- each rapid
(STRAIGHT_TRAVERSE), each spindle-synchronised cut (STRAIGHT_FEED between START_SPEED_FEED_SYNC
and STOP_SPEED_FEED_SYNCH) with its lead per revolution -- must be the same kind of move in
retrofit (FMOV; PMOV under ISTP with its PFDR), ending at the same point within 1e-4 mm (1e-4
inch under G20: rs274 prints 4 decimals in the program's units). Where rs274 refuses, retrofit
refuses. Runs on a lathe with a spindle indexer (tests/data/fanuc/fanuc-school-lathe.toml).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from retrofit.commands import CStp, FMov, IStp, PFdr, PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

HERE = Path(__file__).resolve().parent / "gcode"
MACHINE = load_machine(Path(__file__).parent / "data" / "fanuc" / "fanuc-school-lathe.toml")
PROGRAMS = sorted((HERE / "g76").glob("*.ngc"))
TOL_MM = 1e-4
#: rs274 runs them, retrofit refuses on purpose (docs/gcode.md), by reason
RETROFIT_REFUSES = {"q-minus-one": "rs274 reads Q-1 as Q0 (its mark for no Q): ambiguous, refused"}
_CALL = re.compile(r"^\s*\d+ N\S* +([A-Z_0-9]+)\((.*)\)\s*$")


def canon_moves(text: str) -> list[tuple]:
    """rs274's moves as (kind, (x mm, z mm), lead mm/rev or None, tolerance mm); kind is
    "rapid", "sync" (spindle-synchronised) or "feed"."""
    units, sync, moves = 1.0, None, []
    for raw in text.splitlines():
        m = _CALL.match(raw)
        if not m:
            continue
        name, args = m.group(1), m.group(2)
        nums = [float(v) for v in re.findall(r"-?\d+\.\d+|-?\d+", args)]
        if name == "USE_LENGTH_UNITS":
            units = 25.4 if "INCHES" in args else 1.0
        elif name == "START_SPEED_FEED_SYNC":
            sync = nums[0] * units
        elif name == "STOP_SPEED_FEED_SYNCH":
            sync = None
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            kind = "rapid" if name == "STRAIGHT_TRAVERSE" else ("sync" if sync else "feed")
            moves.append((kind, (nums[0] * units, nums[2] * units),
                          sync if kind == "sync" else None, TOL_MM * units))
    return moves


def retrofit_moves(program) -> list[tuple]:
    """Retrofit's moves as (kind, (x, z), lead or None)."""
    moves, indexing, lead = [], False, None
    for cmd in program.commands:
        if isinstance(cmd, IStp):
            indexing = True
        elif isinstance(cmd, CStp):
            indexing = False
        elif isinstance(cmd, PFdr):
            lead = cmd.feed
        elif isinstance(cmd, (FMov, PMov)):
            axes = dict(cmd.axes)
            kind = "rapid" if isinstance(cmd, FMov) else ("sync" if indexing else "feed")
            moves.append((kind, (axes["X"], axes["Z"]), lead if kind == "sync" else None))
    return moves


def assert_same_moves(theirs: list[tuple], ours: list[tuple]) -> None:
    here, j = (0.0, 0.0), 0
    for k, (kind, point, lead, tol) in enumerate(theirs):
        if kind == "rapid" and _close(point, here, tol) and \
                (j >= len(ours) or not _close(ours[j][1], here, tol)):
            continue                                 # a rapid to where the tool already is
        assert j < len(ours), f"move {k}: rs274 {kind} to {point}; retrofit has no more moves"
        o_kind, o_point, o_lead = ours[j]
        assert (o_kind, _close(o_point, point, tol)) == (kind, True), \
            f"move {k}: rs274 {kind} to {point}, retrofit {o_kind} to {o_point}"
        if kind == "sync":
            assert abs(o_lead - lead) <= 1e-5 * max(1.0, lead), \
                f"move {k}: rs274 {lead:.6f} mm/rev, retrofit {o_lead:.6f}"
        here, j = o_point, j + 1
    assert j == len(ours), f"retrofit makes {len(ours) - j} moves more than rs274"


def _close(p, q, tol) -> bool:
    return all(abs(u - v) <= tol for u, v in zip(p, q))


def golden(program: Path) -> tuple[bool, str, str]:
    text = (HERE / "golden" / "g76" / f"{program.stem}.canon").read_text()
    head, _, body = text.partition("\n")
    code, _, status = head.removeprefix("# rs274 exit ").partition(": ")
    return code == "0", status, body


def test_the_corpus_covers_the_words():
    text = "".join(p.read_text().upper() for p in PROGRAMS)
    for needle in ("Q0", "Q29.5", "R2", "E1", "L1", "L2", "L3", "H1", "H3", "G7", "G20", "I1 "):
        assert needle in text, needle
    assert len(PROGRAMS) >= 20 and sum(golden(p)[0] for p in PROGRAMS) >= 15


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_g76_agrees_with_rs274_move_by_move(program):
    accepted, status, body = golden(program)
    try:
        compiled = compile_program(program.read_text(), MACHINE, program.name, dialect="rs274")
        refusal = None
    except GcodeError as exc:
        compiled, refusal = None, str(exc)
    if program.stem in RETROFIT_REFUSES:
        assert accepted and refusal and "Q-1: LinuxCNC reads Q-1 as no compound angle" in refusal
        return
    if not accepted:
        assert refusal is not None, f"rs274 refuses ({status}); retrofit runs it"
        return
    assert refusal is None, f"rs274 runs it; retrofit refuses: {refusal}"
    theirs = canon_moves(body)
    assert sum(kind == "sync" for kind, *_ in theirs) >= 3
    assert_same_moves(theirs, retrofit_moves(compiled))


@pytest.mark.skipif(shutil.which("rs274") is None and not Path("/usr/bin/rs274").exists(),
                    reason="LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace)")
@pytest.mark.parametrize("name", ["diameter-int-taper", "linuxcnc-g76-ngc"])
def test_golden_files_are_what_rs274_prints_today(name):
    from tests.gcode.regenerate import run_rs274  # noqa: PLC0415
    program = HERE / "g76" / f"{name}.ngc"
    assert run_rs274(program) == (HERE / "golden" / "g76" / f"{name}.canon").read_text()
