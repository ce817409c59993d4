"""LinuxCNC's own interpreter (``rs274``) reads the LinuxCNC twins of the Fanuc cycles as retrofit
does: the twins of tests/test_fanuc_twins.py are checked at their source.

Each ``*-linuxcnc.ngc`` of tests/data/fanuc/twins runs through ``rs274`` (where it is installed)
and through retrofit, without the tool offsets (rs274 without a configuration reads tool tables
in inches); every canonical move must be matched by retrofit within 1e-4 mm, the G76 twins'
(diameter mode, I J K as diameters) included.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from retrofit.commands import FMov, PMov, ZMov
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

from tests.test_gcode_rs274 import canon_events, compare

DATA = Path(__file__).parent / "data" / "fanuc"
RS274 = shutil.which("rs274") or "/usr/bin/rs274"
TWINS = sorted((DATA / "twins").glob("*-linuxcnc.ngc"))

pytestmark = pytest.mark.skipif(not Path(RS274).exists(),
                                reason="LinuxCNC's rs274 is not installed (Debian linuxcnc-uspace)")


def points(program) -> list[tuple]:
    """Retrofit's move end points as (x, 0, z); the pieces of one straight move (G96 cuts a feed
    move where the spindle speed changes) count as one move."""
    here, out = (0.0, 0.0, 0.0), []
    for command, line, file in zip(program.commands, program.lines, program.files):
        if isinstance(command, (FMov, PMov)):
            axes = dict(command.axes)
            here = (axes["X"], 0.0, axes["Z"])
        elif isinstance(command, ZMov):
            here = (0.0, 0.0, 0.0)            # rs274's G28 position: machine 0
        else:
            continue
        if isinstance(command, PMov) and len(out) >= 2 and out[-1][1] == (file, line) \
                and _collinear(out[-2][0], out[-1][0], here):
            out[-1] = (here, (file, line))
            continue
        out.append((here, (file, line)))
    return out


def _collinear(a, b, c) -> bool:
    cross = (b[0] - a[0]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[0] - a[0])
    return abs(cross) < 1e-9 and min(a[2], c[2]) - 1e-9 <= b[2] <= max(a[2], c[2]) + 1e-9


@pytest.mark.parametrize("twin", TWINS, ids=[p.stem for p in TWINS])
def test_rs274_reads_the_linuxcnc_twin_as_retrofit_does(twin, tmp_path):
    text = re.sub(r"(?m)^G43 H\d+\n", "", twin.read_text())
    program = tmp_path / twin.name
    program.write_text(text)
    for _attempt in range(3):              # rs274 now and then dies of a signal: run it again
        proc = subprocess.run([RS274, "-g", str(program)], stdin=subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=60, cwd=tmp_path,
                              check=False)
        if proc.returncode >= 0:
            break
    assert proc.returncode == 0, proc.stderr
    machine = load_machine(DATA / "fanuc-school-lathe.toml")
    ours = compile_program(text, machine, twin.name, dialect="rs274")
    events = canon_events(proc.stdout)
    assert len(events) >= 5
    compare(events, points(ours))
