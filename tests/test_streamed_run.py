"""A run streamed window by window reports what the same run held whole reports."""

from types import SimpleNamespace

import pytest

import retrofit.run.program as runprogram
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.run.program import STAGE_WEIGHTS, run_program
from retrofit.run.progress import silent

ZIGZAG = "G21 G90 G18 F900\n" + "G1 X4 Z-12\nG1 X-3 Z-2\nG0 X1 Z-6\n" * 12 + "M2\n"


def run(machine, streamed: bool):
    opts = SimpleNamespace(backlash_comp=False, reference=False, controller=False, urls=["sim://"],
                           keep_frames=not streamed, keep_commands=False)
    return run_program(ZIGZAG, "zigzag.ngc", machine, opts, silent(STAGE_WEIGHTS))


@pytest.mark.parametrize("window", [200, 1 << 15], ids=["many-windows", "one-window"])
def test_streamed_report_equals_the_held_run(monkeypatch, window):
    compiled()
    monkeypatch.setattr(runprogram, "STREAM_WINDOW_STEPS", window)
    lathe = load_machine("chivu-lathe")
    held, streamed = run(lathe, streamed=False), run(lathe, streamed=True)
    assert not len(streamed.log.frames) and len(held.log.frames)       # really streamed, really held
    assert streamed.report == held.report
    worst = [ax["max_carriage_error_mm"] for ax in streamed.report["axes"].values()]
    # without compensation the carriage lags by the screw's dead band at the reversals
    assert max(worst) >= min(lathe.sim.dead_band_mm.values()) / 2
    assert streamed.program.commands == [] and streamed.command_count == held.command_count
