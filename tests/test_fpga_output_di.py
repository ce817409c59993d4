"""fpga-sim://?variant=di: `retrofit run` hands the digital-integration gateware the plan's line
records (the plan through ``Output.wants_plan``); its pins equal the frames sim:// decodes; a bad
variant, a run without a plan, and records that do not match the run are errors that say so."""

import json
import re
from dataclasses import replace
from importlib import resources

import numpy as np
import pytest

from retrofit.cli import main
from retrofit.errors import OutputError
from retrofit.frames import PinMap, PortFrames
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.outputs import open_output
from retrofit.outputs.deliver import hand_plan
from retrofit.outputs.fpga_sim import FpgaSimOutput
from retrofit.outputs.sim import SimOutput
from retrofit.run.program import plan_compiled

#: the engraver with a 20 us tick: the same program in a twentieth of the simulated ticks
COARSE = replace(load_machine("engraver"), tick_us=20.0)
PROGRAM = "G21 G90\nG1 X0.1 Y0.05 Z0.005 F3000\nG1 X0.05 Y0.1 Z-0.005\n"


def coarse_engraver_file(folder):
    text = (resources.files("retrofit") / "machines" / "engraver.toml").read_text()
    assert "tick_us = 1.0" in text
    path = folder / "engraver-20us.toml"
    path.write_text(text.replace("tick_us = 1.0", "tick_us = 20.0", 1))
    return path


def plan_and_frames(text: str):
    _, plan = plan_compiled(compile_program(text, COARSE, file="t.ngc"), COARSE)
    return plan, execute_fast(plan).frames


def joined(chunks: list[PortFrames]) -> PortFrames:
    return PortFrames(np.concatenate([c.ticks for c in chunks]), np.concatenate([c.values for c in chunks]),
                      chunks[-1].end_tick)


def x_rises(frames: PortFrames) -> np.ndarray:
    """The ticks X's step pin rises on."""
    pins = PinMap(COARSE)
    step = ((frames.per_tick() ^ pins.invert) & pins.step_masks[0]) != 0
    return np.flatnonzero(np.diff(step.astype(int)) == 1) + 1


def test_retrofit_run_through_the_di_gateware_makes_the_frames_sim_decodes(tmp_path, monkeypatch, capsys):
    """One `retrofit run` with sim:// and fpga-sim://?variant=di: what the gateware's pins did
    (recorded as it ran) is what sim:// was given, every tick; the report is the gateware's."""
    given, pins = [], []
    monkeypatch.setattr(SimOutput, "write", lambda self, frames: (given.append(frames), self.sim.feed(frames)))
    finish = FpgaSimOutput._finish
    monkeypatch.setattr(FpgaSimOutput, "_finish", lambda self: (finish(self), pins.append(self.run)))
    (tmp_path / "p.ngc").write_text(PROGRAM)
    machine = coarse_engraver_file(tmp_path)
    monkeypatch.chdir(tmp_path)
    code = main(["run", "p.ngc", "--machine", str(machine), "--output", "sim://",
                 "--output", "fpga-sim://?variant=di", "--report", "r.json"])
    assert code == 0, capsys.readouterr().err
    (run,) = pins
    assert run.frames == joined(given) and len(run.frames) > 20
    assert run.positions == [4, 8, -2] and not run.underrun and not run.fault
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["violations"] == [] and rep["axes"]["Z"]["reversals"] == 1
    assert [rep["axes"][a]["carriage_mm"] for a in "XYZ"] == pytest.approx([0.05, 0.1, -0.005])


def test_frames_handed_over_in_short_slices_make_the_same_pins():
    """The turn records come with each slice, the line records all with the first: slices of 97
    ticks (shorter than the ticks a slice's end is held open) still give every tick's byte."""
    from retrofit.run.runner import slice_frames
    plan, frames = plan_and_frames(PROGRAM + "G1 X0.1 Y0\n")
    out = open_output("fpga-sim://?variant=di", COARSE)
    hand_plan([out], plan)
    with out:
        for start in range(0, frames.end_tick, 97):
            out.write(slice_frames(frames, start, min(start + 97, frames.end_tick)))
    assert out.run.frames == frames and out.run.positions == [8, 0, -2]


@pytest.mark.parametrize("url, says", [
    ("fpga-sim://?variant=dda", r"variant='dda' is not one of pulse, di; expected fpga-sim://\[\?variant=pulse\|di&"),
    ("fpga-sim://?varient=di", r"unknown option 'varient'.*\(options: variant, limit_s, clocks_per_tick, sim\)"),
], ids=["bad-variant", "unknown-key"])
def test_a_bad_variant_or_key_is_refused_in_one_line_naming_what_is_accepted(tmp_path, monkeypatch, capsys, url, says):
    (tmp_path / "p.ngc").write_text("G21 G90\nG1 X0.01 F3000\n")
    monkeypatch.chdir(tmp_path)
    assert main(["run", "p.ngc", "--machine", "engraver", "--output", url]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"retrofit: error: {url}: ")
    assert re.search(says, err), err


def test_a_run_without_a_plan_is_refused_and_the_pulse_variant_needs_none():
    machine = load_machine("engraver")
    frames = PortFrames(np.array([0]), np.array([0], np.uint8), 10)
    di, pulse = open_output("fpga-sim://?variant=di", machine), open_output("fpga-sim://", machine)
    hand_plan([pulse], None)                               # the circle demo's frames: no plan
    with pytest.raises(OutputError, match=r"is fed the run's plan .* this run has none .*use variant=pulse"):
        hand_plan([di], None)
    assert not any(open_output(url, machine).wants_plan() for url in ("sim://", "vcd://x.vcd"))
    with pytest.raises(OutputError, match="opened without the run's plan"):
        with di:
            di.write(frames)


def test_a_plan_past_the_bound_is_refused_before_any_record_is_made():
    """Checked on the plan when the output opens (either variant), not after the first slices of
    a long run's frames have been simulated."""
    machine = load_machine("engraver")
    _, plan = plan_compiled(compile_program("G21 G90\nG1 X40 F600\n", machine, file="t.ngc"), machine)
    end = round(plan.end_s * 1e6)                          # the engraver's tick is 1 us
    assert end > 4_000_000
    for url in ("fpga-sim://?variant=di", "fpga-sim://"):
        out = open_output(url, machine)
        hand_plan([out], plan)
        with pytest.raises(OutputError, match=rf"tick {end} or later, past the bound of 500000 ticks .*limit_s"):
            out.open()
        assert not out.is_open


def test_records_that_do_not_match_the_run_are_an_underrun_or_a_pin_mismatch_that_says_so():
    """A run whose direction turn is missing from the frames: the gateware's X waits for it and
    stops (underrun); a plan of a longer move than the frames': its pins differ, at a named tick."""
    plan, frames = plan_and_frames("G21 G90\nG1 X0.1 F3000\nG1 X0.05\n")
    x_dir = PinMap(COARSE).dir_masks[0]
    first = frames.values[np.flatnonzero(frames.values & x_dir)[0]] & x_dir
    no_turn = PortFrames(frames.ticks, (frames.values & (0xFF ^ x_dir)) | first, frames.end_tick)  # X never turns back
    out = open_output("fpga-sim://?variant=di", COARSE)
    hand_plan([out], plan)
    with pytest.raises(OutputError, match=r"gateware stopped at tick (\d+) \(underrun\)") as stopped:
        with out:
            out.write(no_turn)
    rises = x_rises(frames)
    tick = int(stopped.value.args[0].split("tick ")[1].split(" ")[0])
    assert rises[7] < tick < rises[8] + 260            # 8 steps out; the first step back never comes

    _, frames = plan_and_frames("G21 G90\nG1 X0.1 F3000\n")           # 8 steps
    longer, _ = plan_and_frames("G21 G90\nG1 X0.2 F3000\n")           # 16 steps, the same way
    out = open_output("fpga-sim://?variant=di", COARSE)
    hand_plan([out], longer)
    differs = r"pins differ from the run's frames: tick (\d+): reference ([01]{8})"
    with pytest.raises(OutputError, match=differs) as differ:
        with out:
            out.write(frames)
    tick, want = differ.value.args[0].split("tick ")[1].split(": reference ")
    rises = x_rises(frames)
    assert frames.value_at(int(tick)) == int(want.split(",")[0], 2) and rises[0] < int(tick) <= rises[-1]


def test_a_stopped_run_leaves_the_gateware_without_a_verdict():
    """Ctrl-C mid-run: the output goes safe and closes without finishing the simulation (as the
    pulse variant): the interrupt is what the run reports, not a pin mismatch."""
    plan, frames = plan_and_frames(PROGRAM)
    out = open_output("fpga-sim://?variant=di", COARSE)
    hand_plan([out], plan)
    with pytest.raises(KeyboardInterrupt):
        with out:
            out.write(PortFrames(frames.ticks[:3], frames.values[:3], int(frames.ticks[3])))
            raise KeyboardInterrupt
    assert not out.is_open and not hasattr(out, "run")

