"""The Fanuc/Haas lathe dialect against LinuxCNC: each cycle written both ways cuts the same path.

Every pair in tests/data/fanuc/twins is one part: ``NAME-fanuc.nc`` in the Fanuc dialect (G71
two-block form, G76 two blocks, G92, G90/G94, G74/G75, G73, G70 P Q, T0101, U/W, G50, G96/G99,
M98) and ``NAME-linuxcnc.ngc`` in LinuxCNC's syntax (G7, one-line G76, G33, G70 Q with a
subroutine, G92, G96 D, G95) -- for G71, G72, G73, G74/G75 and G90/G94, whose LinuxCNC forms are
other cycles, the passes are written out by hand from the cycle's definition. Both run on the
same machine and must give the same commands, every position within 1e-4 mm.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable

DATA = Path(__file__).parent / "data" / "fanuc"
TWINS = sorted(p.name[:-len("-fanuc.nc")] for p in (DATA / "twins").glob("*-fanuc.nc"))
MACHINE = DATA / "fanuc-school-lathe.toml"


def path_of(program) -> list[tuple[str, list[tuple[str, float]]]]:
    """The commands as (name, [(letter, value)]), moves to where the tool already is left out."""
    out, here = [], [("X", 0.0), ("Z", 0.0)]        # the machine starts at 0, 0
    for command in program.commands:
        name, *words = str(command).split()
        values = [(w[0], float(w[1:])) for w in words]
        if name in ("FMOV", "PMOV"):
            if values == here:
                continue
            here = values
        elif name == "ZMOV":
            here = None
        out.append((name, values))
    return out


def compile_pair(name: str):
    machine = load_machine(MACHINE)
    table = ToolTable.load(DATA / "tools.tbl")
    fanuc = compile_program((DATA / "twins" / f"{name}-fanuc.nc").read_text(), machine,
                            f"{name}-fanuc.nc", tool_table=table)
    linuxcnc = compile_program((DATA / "twins" / f"{name}-linuxcnc.ngc").read_text(), machine,
                               f"{name}-linuxcnc.ngc", tool_table=table, dialect="rs274")
    return fanuc, linuxcnc


def test_every_cycle_has_a_twin():
    assert {"g70", "g71", "g72", "g73", "g74", "g76", "g90", "g92", "basics"} <= set(TWINS)


@pytest.mark.parametrize("name", TWINS)
def test_fanuc_form_cuts_the_path_of_its_linuxcnc_twin(name):
    fanuc, linuxcnc = compile_pair(name)
    a, b = path_of(fanuc), path_of(linuxcnc)
    assert [n for n, _ in a] == [n for n, _ in b], f"{name}: the command kinds differ"
    way_out = _g76_way_out(a, b) if name.startswith("g76") else set()
    for k, ((name_a, va), (_, vb)) in enumerate(zip(a, b)):
        assert [w for w, _ in va] == [w for w, _ in vb], f"{name} command {k}: {name_a}"
        if k in way_out:
            continue
        worst = max((abs(x - y) for (_, x), (_, y) in zip(va, vb)), default=0.0)
        assert worst <= 1e-4, f"{name} command {k}: {name_a} {va} != {vb}"
    assert sum(n in ("FMOV", "PMOV") for n, _ in a) >= 5


def _g76_way_out(a, b) -> set[int]:
    """G76's rapids out and back, where the forms differ by design (docs/fanuc.md): Fanuc goes
    back to the start point A's X, LinuxCNC to the drive line plus the depth still to cut. Only
    those: each is checked to be at A's X (Fanuc) and at or beyond it, away from the work
    (LinuxCNC), at the same Z."""
    first_cut = next(k for k, (n, _) in enumerate(a) if n == "PMOV")
    rapids = [k for k in range(first_cut) if a[k][0] == "FMOV"]
    x_a = dict(a[rapids[-3]][1])["X"]           # A; then back along A's X and in, then the cut
    x_cut = dict(a[first_cut][1])["X"]
    away = 1.0 if x_a > x_cut else -1.0
    out = set()
    for k, ((name, va), (_, vb)) in enumerate(zip(a, b)):
        fa, fb = dict(va), dict(vb)
        if name == "FMOV" and abs(fa["X"] - fb["X"]) > 1e-4:
            assert abs(fa["X"] - x_a) <= 1e-4 and away * (fb["X"] - x_a) > 0.0, (k, va, vb)
            assert abs(fa["Z"] - fb["Z"]) <= 1e-4, (k, va, vb)
            out.add(k)
    assert out, "the LinuxCNC twin goes out to the drive line plus the depth still to cut"
    return out


def test_the_machine_file_chooses_the_dialect_and_the_same_text_reads_otherwise_in_rs274():
    """``dialect = "fanuc"`` in [machine] reads X as a diameter; the same line read as RS274
    (radius mode, the LinuxCNC default) would go twice as far: the silent factor of two."""
    machine = load_machine(MACHINE)
    assert machine.dialect == "fanuc"
    text = "G98\nG00 X40. Z2.\nM30\n"
    fanuc = compile_program(text, machine, "part.nc")
    rs274 = compile_program(text.replace("G98", "G94"), machine, "part.ngc", dialect="rs274")
    assert str(fanuc.commands[-1]) == "FMOV X20 Z2"      # 40 mm diameter: 20 mm from the axis
    assert str(rs274.commands[-1]) == "FMOV X40 Z2"


@pytest.mark.parametrize("name", ["g71", "g72"])
def test_fanuc_roughing_cuts_where_linuxcnc_roughing_cuts(name):
    """The same part roughed by the Fanuc G71/G72 (two blocks, no allowance) and by LinuxCNC's
    G71/G72 with a subroutine profile (retrofit's RS274 cycles, made apart from the Fanuc ones):
    every cut ends at the same point. LinuxCNC's form also cuts a layer on the start point's line
    and leaves the profile at feed there; those are left out, the rapids differ by design."""
    machine = load_machine(MACHINE)
    folder = DATA / "cycles"
    fanuc = compile_program((folder / f"{name}-fanuc.nc").read_text(), machine, "f.nc")
    linuxcnc = compile_program((folder / f"{name}-linuxcnc.ngc").read_text(), machine, "l.ngc",
                               dialect="rs274")
    start = {"g71": ("X", 21.0), "g72": ("Z", 2.0)}[name]

    def cuts(program):
        ends = [dict(w) for n, w in path_of(program) if n == "PMOV"]
        return [(e["X"], e["Z"]) for e in ends if abs(e[start[0]] - start[1]) > 1e-9]
    ours, theirs = cuts(fanuc), cuts(linuxcnc)
    assert len(ours) >= 8
    assert len(ours) == len(theirs)
    for a, b in zip(ours, theirs):
        assert abs(a[0] - b[0]) <= 1e-4 and abs(a[1] - b[1]) <= 1e-4, (a, b)
