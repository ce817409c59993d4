"""A CAM program is interpreted at least as fast as LinuxCNC's rs274 reads it, in blocks per
CPU-second measured in one run (bench/gcode_speed.py's program and ratio), with the same moves."""

import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "bench"))
from gcode_speed import cam_program  # noqa: E402

RS274 = shutil.which("rs274") or ("/usr/bin/rs274" if Path("/usr/bin/rs274").exists() else None)


def rs274_cpu_s(path: Path) -> tuple[float, str]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([RS274, "-g", str(path)], stdin=subprocess.DEVNULL, capture_output=True,
                         text=True, timeout=120).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out


@pytest.mark.slow
@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed")
def test_a_cam_program_is_interpreted_at_least_as_fast_as_rs274_reads_it(tmp_path):
    machine = load_machine(HERE / "gcode" / "rs274-mill.toml")
    text = cam_program(20_000)
    path = tmp_path / "cam.ngc"
    path.write_text(text)
    ours, theirs = [], []
    for _ in range(3):                      # the least of three on each side: a busy machine's noise
        started = time.process_time()
        program = compile_program(text, machine, "cam.ngc")
        ours.append(time.process_time() - started)
        spent, listing = rs274_cpu_s(path)
        theirs.append(spent)
    feeds = listing.count("STRAIGHT_FEED(") + listing.count("ARC_FEED(")
    traverses = listing.count("STRAIGHT_TRAVERSE(")
    kinds = [type(c).__name__ for c in program.commands]
    assert kinds.count("FMov") == traverses
    assert kinds.count("PMov") > feeds > 19_000         # an arc is one ARC_FEED there, its chords here
    assert min(theirs) / min(ours) >= 1.0, (ours, theirs)
