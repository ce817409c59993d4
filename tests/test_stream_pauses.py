"""A pause (M0, a tool change answered unattended on sim://) is a point in the streamed run: the
run stays streamed and reports what the same run held whole reports."""

from types import SimpleNamespace

import pytest

import retrofit.run.program as runprogram
from retrofit.machine.config import load_machine
from retrofit.motion._jit import compiled
from retrofit.run.program import STAGE_WEIGHTS, run_program
from retrofit.run.progress import silent

PASSES = "G1 X30 Y10\nG1 X10 Y20\nG0 X20 Y5\n" * 8
PROGRAMS = {"M0": "G21 G90 F900\nG1 Z-1\n" + PASSES + "M0 (look at the cut)\n" + PASSES + "G0 Z0\nM2\n",
            "T1 M6": "G21 G90 F900\nG1 Z-1\n" + PASSES + "T1 M6\n" + PASSES + "G0 Z0\nM2\n"}


def run(text: str, streamed: bool):
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=not streamed, keep_commands=False)
    return run_program(text, "pause.ngc", load_machine("engraver"), opts, silent(STAGE_WEIGHTS))


@pytest.mark.parametrize("pause", sorted(PROGRAMS))
def test_a_pause_stays_in_the_stream(monkeypatch, pause):
    compiled()
    monkeypatch.setattr(runprogram, "STREAM_WINDOW_STEPS", 300)
    held, streamed = run(PROGRAMS[pause], False), run(PROGRAMS[pause], True)
    assert not len(streamed.log.frames) and len(held.log.frames)       # really streamed, really held
    assert [p["line"] for p in streamed.report["pauses"]] == [27]
    assert streamed.report == held.report
