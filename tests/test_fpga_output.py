"""fpga-sim://: a run's pulse records streamed into the simulated gateware, whose pins drive the
simulated machine; a run past the bound, or pins that differ, are errors that say so."""

import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from retrofit.errors import OutputError
from retrofit.frames import PortFrames
from retrofit.machine.config import load_machine
from retrofit.outputs import known_schemes, open_output


@pytest.mark.slow
@pytest.mark.parametrize("url", ["fpga-sim://", "fpga-sim://?variant=di"], ids=["pulse", "di"])
def test_run_on_the_engraver_through_the_gateware_lands_the_carriages(tmp_path, url):
    (tmp_path / "p.ngc").write_text("G21 G90\nG1 X0.025 Y0.0125 F3000\nG1 X0.0125\n")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", "p.ngc", "--machine", "engraver",
                           "--output", url, "--output", "vcd://p.vcd", "--report", "r.json"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"] == []
    assert rep["axes"]["X"]["carriage_mm"] == pytest.approx(0.0125) and rep["axes"]["X"]["reversals"] == 1
    assert rep["axes"]["Y"]["carriage_mm"] == pytest.approx(0.0125)
    assert "fpga-sim" in known_schemes() and "$var" in (tmp_path / "p.vcd").read_text()


def test_a_run_past_the_bound_is_refused_before_it_is_simulated():
    machine = load_machine("engraver")
    frames = PortFrames(np.array([0], np.int64), np.array([0], np.uint8), 2_000_000)
    with pytest.raises(OutputError, match=r"tick 2000000 or later, past the bound of 500000 ticks.*limit_s"):
        with open_output("fpga-sim://", machine) as out:
            out.write(frames)


def test_frames_the_gateware_cannot_make_are_an_error_naming_the_tick():
    machine = replace(load_machine("engraver"), tick_us=20.0)
    x_dir, x_step = 1 << machine.axes[0].dir_bit, 1 << machine.axes[0].step_bit
    # a turn at tick 10 and a rise at tick 11: the driver's 5-tick direction set-up is broken
    frames = PortFrames(np.array([0, 10, 11, 16]), np.array([0, x_dir, x_dir | x_step, x_dir]), 40)
    with pytest.raises(OutputError, match="stopped at tick 11 .a record refused"):
        with open_output("fpga-sim://", machine) as out:
            out.write(frames)
