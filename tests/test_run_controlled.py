"""retrofit run through the 002 controller (homing against switches: the carousel's ZMOV on the
mill) stops at a pause where the program pauses, as the console does, not at the end of the run."""

from __future__ import annotations

from types import SimpleNamespace

from retrofit.machine.config import load_machine
from retrofit.run.program import STAGE_WEIGHTS, pause_tick, run_program
from retrofit.run.progress import silent

#: a change to T3 by the carousel (a ZMOV E: the controller's run), a cut, a pause, a rapid home
PAUSED = "G21 G90\nG0 X10 Y10 Z-5\nT3\nG1 X20 Y5 F300\nM0\nG0 X0 Y0\nM30\n"


def test_a_pause_on_the_controller_waits_where_the_program_pauses(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    import retrofit.run.runner as runner  # the VCD file stands for a machine's port
    monkeypatch.setattr(runner, "is_real", lambda url: url.startswith("vcd://"))
    machine = load_machine("tul-mill")
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, before_outputs=None,
                           urls=["sim://", f"vcd://{tmp_path}/port.vcd"])
    asked = []
    run = run_program(PAUSED, "paused.ngc", machine, opts, silent(STAGE_WEIGHTS), wait=asked.append)
    assert run.how == "002 controller (homing against switches)"
    assert asked == ["line 5: program pause (M0)"]
    assert [p["line"] for p in run.report["pauses"]] == [5]
    where = run.sim.state_at(pause_tick(run, run.expanded.pauses[0].index))
    assert (where["X"][1], where["Y"][1]) == (20.0, 5.0)       # the cut of line 4 done, the rapid not begun
    assert (run.report["axes"]["X"]["carriage_mm"], run.report["axes"]["Y"]["carriage_mm"]) == (0.0, 0.0)
