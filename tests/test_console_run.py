"""The console's run, stepped chunk by chunk (no thread, no browser): the feed override halves the
move running, STOP ends the pulses within a tick, a hold stands the axes still, host commands wait
for the operator, a real output gets the same port frames."""

from __future__ import annotations

import pytest

from retrofit.console.engine import SteeredRun
from retrofit.console.runreport import console_report
from retrofit.console.server import Console, command_list
from retrofit.gcode.program import compile_program
from retrofit.machine.config import load_machine

LONG_MOVE = "G21 G90\nG0 X5 Z1\nG1 Z-29 F150\nG0 X10\nG0 Z5\n"


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def steered(machine, text: str, name: str = "long.ngc") -> SteeredRun:
    program = command_list(text, name) if name.endswith(".cmds") else compile_program(text, machine, name)
    run = SteeredRun(machine, program.commands, program.lines)
    run.begin()
    return run


def step_until(run: SteeredRun, done, limit: int = 100_000) -> None:
    for _ in range(limit):
        if done():
            return
        assert run.step(), f"the run ended first ({run.state})"
    raise AssertionError("condition never met")


def into_the_cut(run: SteeredRun, seconds: float) -> None:
    step_until(run, lambda: run.snapshot()["line"] == 3)
    start = run.ctl.ticks
    step_until(run, lambda: run.ctl.ticks - start >= seconds / run.machine.tick_s)


def finish(run: SteeredRun) -> dict:
    while run.step():
        pass
    return console_report(run)


def test_feed_override_mid_move_halves_the_measured_feed(lathe):
    run = steered(lathe, LONG_MOVE)
    into_the_cut(run, 3.0)
    run.act("feed", pct=50)
    report = finish(run)
    cut = next(m for m in report["moves"] if m["line"] == 3)
    before, after = cut["feed_mm_min"]
    assert before["measured"] == pytest.approx(150, rel=0.005)
    assert after["measured"] == pytest.approx(75, rel=0.005)
    rapid = next(m for m in report["moves"] if m["line"] == 4)     # rapids keep their own feed
    assert rapid["feed_mm_min"][0]["measured"] > 500
    assert report["axes"]["Z"]["target_mm"] == 5.0


def test_rapid_override_slows_the_rapids_only(lathe):
    run = steered(lathe, LONG_MOVE)
    run.act("rapid", pct=25)
    report = finish(run)
    full = SteeredRun(lathe, run.commands, run.lines)
    full.begin()
    plain = finish(full)
    speed = lambda rep, line: next(m for m in rep["moves"] if m["line"] == line)["feed_mm_min"][-1]["measured"]  # noqa: E731
    assert speed(plain, 5) == pytest.approx(run.base_rapid, rel=0.01)
    assert speed(report, 5) == pytest.approx(run.base_rapid / 4, rel=0.01)
    assert speed(report, 3) == pytest.approx(150, rel=0.005)


def test_stop_leaves_no_step_after_the_next_tick(lathe):
    run = steered(lathe, LONG_MOVE)
    into_the_cut(run, 2.0)
    run.act("stop")
    report = finish(run)
    stop = next(e["tick"] for e in report["events"] if e["kind"] == "stop")
    assert report["last_step_tick"] <= stop + 1
    assert run.state == "stopped" and "STOPPED" in run.snapshot()["flags"]
    assert -29 < report["axes"]["Z"]["carriage_mm"] < 0


def test_hold_stands_the_axes_still_and_resume_finishes_the_program(lathe):
    run = steered(lathe, LONG_MOVE)
    into_the_cut(run, 2.0)
    run.act("hold")
    step_until(run, lambda: run.waiting)
    held_at = run.snapshot()["commanded_mm"]["Z"]
    ticks = run.ctl.ticks
    for _ in range(20):
        assert run.step()
    assert run.ctl.ticks == ticks and run.snapshot()["state"] == "held"
    run.act("resume")
    report = finish(run)
    assert -29 < held_at < 0
    assert report["axes"]["Z"]["target_mm"] == 5.0 and run.state == "done"
    assert report["axes"]["Z"]["carriage_mm"] == pytest.approx(5.0, abs=0.021)


def test_resume_after_hold_comes_back_at_the_programmed_feed_without_a_burst(lathe):
    import numpy as np

    from retrofit.console.views import axis_steps
    run = steered(lathe, LONG_MOVE)
    into_the_cut(run, 2.0)
    run.act("hold")
    step_until(run, lambda: run.waiting)
    resume = run.ctl.ticks
    run.act("resume")
    finish(run)
    z = axis_steps(run.ctl.frames(), lathe)[1]
    window = int(0.2 / lathe.tick_s)
    ticks = np.arange(resume, resume + 10 * window, window)
    speed = np.abs(np.diff(z.at(ticks))) / lathe.axis("Z").steps_per_mm / 0.2 * 60
    assert speed.max() <= 150 * 1.05, speed


def test_tool_change_waits_at_rest_for_the_operator(lathe):
    run = steered(lathe, "FMOV X5 Z1\nTOOL T3\nPMOV Z-3\nPAUS M1\nFMOV X8 Z2\n", "t.cmds")
    step_until(run, lambda: run.dialog is not None)
    assert run.dialog["kind"] == "tool" and run.snapshot()["line"] == 2      # the TOOL line is shown
    assert run.snapshot()["commanded_mm"] == {"X": 5.0, "Z": 1.0} and "MOVING" not in run.snapshot()["flags"]
    ticks = run.ctl.ticks
    for _ in range(5):
        run.step()
    assert run.ctl.ticks == ticks                          # nothing moves until answered
    run.act("answer")
    step_until(run, lambda: run.dialog is not None and run.dialog["kind"] == "pause")
    assert run.snapshot()["tool"] == 3 and run.snapshot()["commanded_mm"]["Z"] == -3.0
    assert "optional stop (M1)" in run.dialog["text"]
    run.act("answer")
    report = finish(run)
    assert [e["kind"] for e in report["events"]] == ["tool", "answer", "pause", "answer"]
    assert run.snapshot()["commanded_mm"] == {"X": 8.0, "Z": 2.0}


def test_a_vcd_output_gets_the_runs_port_frames(lathe, tmp_path):
    from vcdvcd import VCDVCD
    vcd = tmp_path / "run.vcd"
    con = Console(lathe, ["sim://", f"vcd://{vcd}"])
    con.open(name="short.ngc", text="G0 X2 Z1\nG1 Z-1 F300\n")
    con.start(0)
    con.run.join(60)
    assert con.run.state == "done"
    frames = con.frames()
    con.close()
    signals = VCDVCD(str(vcd)).signals
    z_step = next(s for s in signals if "z" in s.lower() and "step" in s.lower())
    rises = [t for t, v in VCDVCD(str(vcd))[z_step].tv if v == "1"]
    from retrofit.run.program import execute, plan_compiled  # the planner's fast path: the same steps
    fast = execute(plan_compiled(compile_program("G0 X2 Z1\nG1 Z-1 F300\n", lathe, "short.ngc"), lathe)[1])
    assert len(rises) == con.report()["axes"]["Z"]["steps"] == fast.steps_emitted["Z"] >= 150
    assert frames.end_tick == con.report()["ticks"]
