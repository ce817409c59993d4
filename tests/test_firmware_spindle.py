"""The spindle in the loop: in ``retrofit firmware sim`` the firmware's own spindle outputs (the
PWM on D10, the direction on D11) drive the spindle of ``sim://``, whose encoder feeds ICLK and
SIND back; a thread pass that sees no index pulse stops with an error naming its line, on the
firmware and on sim://."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import retrofit
from retrofit.cli import main
from retrofit.machine.config import load_machine

from tests.conformance.targets import SimavrTarget, missing_tools

needs_avr = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make "
                               "and libsimavr: apt-get install gcc-avr avr-libc libsimavr-dev")
fs = pytest.importorskip("retrofit.firmware.sim")

G76 = ("G18 G21 G90\nG0 X12 Z3\nM3 S600\n"
       "G76 P1.5 Z-6 I-0.5 J0.3 K0.92 R2 Q0 H1\nG0 X20\nM5\nM2\n")
G76_LINE = 4
LATHE = Path(retrofit.__file__).parent / "machines" / "mitic-lathe.toml"


def stalled_lathe(tmp_path) -> Path:
    """mitic-lathe whose simulated spindle is jammed ([spindle.sim] stalled = true)."""
    text = LATHE.read_text().replace("[spindle.sim]\n", "[spindle.sim]\nstalled = true\n")
    path = tmp_path / "mitic-lathe.toml"            # the same name: the firmware's banner agrees
    path.write_text(text)
    return path


def frames(machine, texts):
    import sys
    sys.path.insert(0, str(Path(retrofit.__file__).parents[1] / "bench"))
    from firmware_steprate import frames as make
    return make(machine, texts)


@needs_avr
def test_m3_m4_m5_from_the_firmware_turn_the_sim_spindle_tick_for_tick():
    """SPIN S600 forwards, then backwards, then off: the harness's encoder counts are, tick for
    tick, those of retrofit.sim's SimSpindle (ramp and load noise of [spindle.sim]) driven by the
    speed the firmware's PWM asks (600 rpm in 1/256ths of the 2000 rpm full scale), and they stop
    after M5 once the drive has ramped down."""
    from retrofit.firmware.spindle import replay
    machine = load_machine("mitic-lathe")
    S = fs.F_CPU
    script = frames(machine, [(2_000_000, "SPIN S600 D1"), (int(0.8 * S), "SPIN S600 D-1"),
                              (int(1.2 * S), "SPIN S0 D0")])
    log = fs.Harness(fs.build("mitic-lathe"), machine, script=script, cycles=int(1.6 * S)).run()
    duty = (int(600 * 255 / 2000) + 1) / 256 * 2000          # OCR2A + 1 of 256
    assert [round(rpm, 4) for _, _, rpm in log.drive] == [round(duty, 4), round(-duty, 4), 0.0]
    iclk = np.array([c for c, p, b, level in log.inputs if (p, b, level) == ("D", 0, 1)])
    sind = np.array([c for c, p, b, level in log.inputs if (p, b, level) == ("D", 1, 1)])
    assert len(iclk) > 2000 and len(sind) == len(iclk) // 400
    tc = round(machine.tick_us * 16)                 # a drive tick: 1600 cycles
    tick = -(-iclk // tc) - 2                        # the tick each count came in: its edges are
    early = -(-(iclk - 8) // tc) - 2                 # spread over the next tick's cycles (+8: simavr)
    spindle = replay(log, machine)
    spindle.advance_to(int(tick.max()) + 2)
    counts = np.frombuffer(spindle.history, dtype=np.int64) >> 16
    n = np.arange(1, len(iclk) + 1)
    assert np.all(counts[tick] >= n) and np.all(counts[early - 1] < n)
    assert counts[-1] == len(iclk)                  # nothing more after the ramp down


def report_of(log, machine) -> dict:
    return fs.report(log, machine)


def run_report(prog: Path, machine: str, output: str, report: Path) -> int:
    return main(["run", str(prog), "--machine", machine, "--output", output, "--progress", "off",
                 "--report", str(report)])


G76_SHORT = ("G18 G21 G90\nG0 X12 Z3\nM3 S600\n"
             "G76 P1.5 Z-4 I-0.5 J0.45 K0.92 R1 Q0 H0\nG0 X20\nM5\nM2\n")


@needs_avr
@pytest.mark.slow
def test_m3_s600_and_g76_on_retrofit_firmware_sim_end_where_sim_ends(tmp_path):
    """A user's program, M3 S600 then G76, through `retrofit firmware sim --machine mitic-lathe`
    with no spindle option: the firmware turns the spindle itself and ends where sim:// ends
    (the run's own local simulation of the same program, `axes` in its report)."""
    machine = load_machine("mitic-lathe")
    prog = tmp_path / "g76.ngc"
    prog.write_text(G76_SHORT)
    fs.build("mitic-lathe")
    with SimavrTarget("mitic-lathe", "--speed", "0") as fw:
        assert run_report(prog, "mitic-lathe", f"{fw.output_url}?wait_s=120", tmp_path / "fw.json") == 0
    report = json.loads((tmp_path / "fw.json").read_text())
    part = report["remote"][0]
    expected = {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in report["axes"].items()}
    assert part["position_steps"] == expected == {"X": 2000, "Z": -320}
    assert "ERROR" not in part["status"] and "SPINDLE_ON" not in part["status"]


@pytest.mark.slow          # a whole G76 on the simulated lathe, twice: a long run
@pytest.mark.parametrize("kernels", ["as-they-come", "compiled"])
def test_a_stalled_spindle_stops_g76_on_sim_with_its_line(tmp_path, kernels):
    """On sim:// (the 002 controller), the pass's wait for the index ends after 5 s of machine
    time, whether the controller ticks it or its compiled kernels run the wait in spans."""
    import subprocess
    import sys
    prog = tmp_path / "g76.ngc"
    prog.write_text(G76)
    jit = "from retrofit.motion import _jit; _jit.to_jit(); " if kernels == "compiled" else ""
    code = (f"{jit}from retrofit.cli import main; raise SystemExit(main(['run', {str(prog)!r}, "
            f"'--machine', {str(stalled_lathe(tmp_path))!r}, '--progress', 'off']))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=240)
    assert run.returncode == 2
    assert re.search(rf"g76.ngc:{G76_LINE}: PMOV .* no spindle index pulse for 5 s", run.stderr), run.stderr


@needs_avr
def test_a_stalled_spindle_stops_g76_on_the_firmware_with_its_line(tmp_path, capsys):
    """The machine's spindle is jammed (the harness's --spindle-stall; the host's own plan has a
    turning one): the firmware waits INDEX_TIMEOUT_MS for the index, then raises ERROR, and the
    host names the line of the pass."""
    machine = load_machine("mitic-lathe")
    prog = tmp_path / "g76.ngc"
    prog.write_text(G76)
    harness = fs.Harness(fs.build("mitic-lathe"), machine, listen="127.0.0.1:0", speed=0,
                         spindle_stalled=True).start()
    try:
        code = run_report(prog, "mitic-lathe", f"serial+socket://{harness.address}?wait_s=120",
                          tmp_path / "r.json")
    finally:
        log = harness.stop()
    err = capsys.readouterr().err
    assert code != 0
    assert re.search(rf"g76.ngc:{G76_LINE}: the thread pass saw no spindle index pulse within 5 s", err), err
    assert not any((p, b) == ("D", 0) for _, p, b, _ in log.inputs)      # no count ever came
    assert [rpm for _, _, rpm in log.drive] == []        # jammed: it never turns, whatever M3 asks
    rises, _, dirs = fs.step_times(log, machine, "Z")
    takeup = round(machine.axis("Z").backlash_mm * machine.axis("Z").steps_per_mm)
    assert int((dirs == 0).sum()) == takeup            # towards -Z only the pass's take-up: no
    assert report_of(log, machine)["carriage_mm"]["Z"] == pytest.approx(3.0, abs=0.02)   # thread step


def test_the_firmware_sim_refuses_a_machine_whose_encoder_it_cannot_follow(tmp_path, capsys):
    text = LATHE.read_text().replace("encoder_counts_per_rev = 400", "encoder_counts_per_rev = 4000")
    path = tmp_path / "mitic-lathe.toml"
    path.write_text(text)
    assert main(["firmware", "sim", "--machine", str(path), "--listen", "127.0.0.1:0"]) == 2
    err = capsys.readouterr().err
    from retrofit.firmware import limits as fl
    assert re.search(r"\[spindle\]: encoder_counts_per_rev = 4000 at max_rpm = 2000 .* is 153333 "
                     rf"counts/s; the firmware follows at most {fl.load().encoder_counts_s:.0f} counts/s",
                     err), err


def statuses(log, machine, upto: int | None = None) -> list[list[str]]:
    """The flag names of every STAT the firmware sent (in its first ``upto`` bytes)."""
    from retrofit.link.replies import Status, flag_names
    from retrofit.link.script import ScriptedHost
    data = log.answer_bytes()[:upto]
    return [flag_names(r.flags) for r in ScriptedHost(machine).replies(data) if isinstance(r, Status)]


def first_error_cycle(log, machine) -> int:
    """The cycle of the last byte of the first STAT that says ERROR."""
    lo, hi = 0, len(log.uart)
    assert any("ERROR" in names for names in statuses(log, machine))
    while lo < hi:
        mid = (lo + hi) // 2
        if any("ERROR" in names for names in statuses(log, machine, mid)):
            hi = mid
        else:
            lo = mid + 1
    return log.uart[lo - 1][0]


@needs_avr
def test_a_spindle_that_jams_during_a_pass_stops_it_with_error_5_s_after_its_last_index():
    """SPIN S600, ISTP, PMOV Z-5 (400 steps over 10 turns); the spindle stops dead 0.5 s into the
    pass: the steps stop with it, and ERROR (SPINDLE_ON, no INDEX_SEEN) comes 5 s after the last
    index pulse, not before; nothing waits for ever."""
    machine = load_machine("mitic-lathe")
    S = fs.F_CPU
    jam = int(1.0 * S)
    polls = [(c, "RDST") for c in range(int(0.3 * S), int(7.0 * S), int(0.05 * S))]
    script = frames(machine, [(2_000_000, "SPIN S600 D1"), (3_000_000, "ISTP"), (3_100_000, "PFDR F0.5"),
                              (3_200_000, "PMOV Z-5")] + polls)
    log = fs.Harness(fs.build("mitic-lathe"), machine, script=script, cycles=int(7.2 * S),
                     spindle_stalled=jam).run()
    sind = [c for c, p, b, level in log.inputs if (p, b, level) == ("D", 1, 1)]
    rises, _, _ = fs.step_times(log, machine, "Z")
    assert sind[-1] < jam and 0 < len(rises) < 400 and rises[-1] < jam + S // 100
    first_error = first_error_cycle(log, machine)
    assert 5.0 <= (first_error - sind[-1]) / S <= 5.0 + 0.05 + 0.002
    names = statuses(log, machine)[-1]
    assert "ERROR" in names and "SPINDLE_ON" in names and "INDEX_SEEN" not in names


def test_a_spindle_that_jams_during_a_pass_stops_it_on_the_python_controller(monkeypatch):
    """The 002 controller (sim://'s), ticking every tick itself: the same pass, the simulated
    spindle stopped dead 0.5 s into it: a ProgramError naming the PMOV."""
    import retrofit.controller.spans as spans
    monkeypatch.setattr(spans, "compiled", lambda work=None: False)   # the jam is set per tick
    from retrofit.commands import parse_command
    from retrofit.controller.program import ProgramError, run_commands
    from retrofit.sim import SimMachine
    machine = load_machine("mitic-lathe")
    sim = SimMachine(machine)
    spindle = sim.spindle
    commands = [parse_command(t) for t in ("SPIN S600 D1", "DELY P0.3", "ISTP", "PFDR F0.5", "PMOV Z-5")]
    jam_tick = round(0.8 / machine.tick_s)               # 0.5 s into the pass

    def advance(tick, _orig=spindle.advance_to):
        if tick >= jam_tick and spindle.target_rpm:
            _orig(jam_tick - 1)
            spindle.rpm = spindle.target_rpm = 0.0       # stops dead
        _orig(tick)
    spindle.advance_to = advance
    with pytest.raises(ProgramError, match=r"PMOV Z-5 under ISTP: no spindle index pulse for 5 s") as exc:
        run_commands(commands, machine, sim=sim)
    assert exc.value.command_index == 4
    z = sim.traces["Z"]
    assert 0 < abs(z.motor_steps[-1]) < 400                           # stopped in the pass
