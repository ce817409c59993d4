"""The rates the firmware keeps (firmware/limits.toml, measured by bench/firmware_limits.py) and a
firmware run planned within them: feeds clamped and said so, over-rate encoders refused."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import retrofit
from retrofit.cli import main
from retrofit.errors import ConfigError, GcodeError
from retrofit.firmware import limits as fl
from retrofit.machine.config import load_machine

from tests.conformance.targets import missing_tools

needs_avr = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make "
                               "and libsimavr: apt-get install gcc-avr avr-libc libsimavr-dev")
MACHINES = Path(retrofit.__file__).parent / "machines"
NOWHERE = "serial+socket://127.0.0.1:9"          # refused before any connection is tried


def test_the_table_was_measured_on_this_trees_firmware():
    """The table names the build it was measured on: this tree's firmware sources. A change to the
    step engine fails here until `python3 bench/firmware_limits.py` has measured it again."""
    limits = fl.load()
    assert limits.identity == fl.build_identity(), (
        "firmware/limits.toml was measured on another build of the firmware: run "
        "python3 bench/firmware_limits.py")


def test_the_table_is_the_benchs_writing_of_its_measurements():
    """Never typed by hand: the file is, byte for byte, what the bench writes for the rates it
    records, and every planned rate is the measured one times the margin, rounded down."""
    text = fl.TABLE.read_text()
    limits = fl.load()
    assert text.startswith("# firmware/limits.toml - the rates the firmware keeps, measured in "
                           "simavr by bench/firmware_limits.py")
    measured = {k: v for k, v in limits.measured.items() if k != "encoder_counts_s"}
    assert text == fl.table_text(measured, limits.measured["encoder_counts_s"], limits.margin)
    for case, rate in measured.items():
        assert limits.steps[case] <= rate * limits.margin < limits.steps[case] + 500
    assert set(measured) >= {"1", "2", "3", "4", "3:bresenham"}


def test_no_shipped_machine_file_allows_a_rate_above_the_table():
    """Every firmware machine's axes top out below the lowest planned rate (the firmware caps
    each axis at its machine-file speed), and its encoder at max_rpm below the encoder limit."""
    from retrofit.firmware.sim import supported_machines
    limits = fl.load()
    lowest = min(limits.steps.values())
    for name in supported_machines():
        machine = load_machine(name)
        for a in machine.axes:
            assert a.max_velocity_mm_s * a.steps_per_mm <= lowest, (name, a.name)
        fl.check_encoder(machine, limits)


def fast_mill(tmp_path) -> Path:
    """tul-mill with speeds and accelerations far above what the firmware keeps."""
    text = (MACHINES / "tul-mill.toml").read_text()
    text = text.replace('name = "tul-mill"', 'name = "fast-mill"')
    text = re.sub(r"max_velocity_mm_s = [\d.]+", "max_velocity_mm_s = 600.0", text)
    text = re.sub(r"max_accel_mm_s2 = [\d.]+", "max_accel_mm_s2 = 20000.0", text)
    text = re.sub(r"rapid_feed_mm_min = [\d.]+", "rapid_feed_mm_min = 30000.0", text)
    path = tmp_path / "fast-mill.toml"
    path.write_text(text)
    return path


FAST = "G21 G90\nG0 X20\nG1 X40 F30000\nG1 X0 Y20 F6000\nM2\n"


def planned(text: str, machine):
    from retrofit.atc.front import expand_host_commands
    from retrofit.gcode import compile_program
    exp = expand_host_commands(compile_program(text, machine, file="fast.ngc"), machine)
    return exp, fl.plan_within_limits(exp, machine)


def test_a_feed_above_the_limit_is_clamped_and_the_summary_says_where(tmp_path):
    machine = load_machine(fast_mill(tmp_path))
    one, words = fl.load().step_rate(1, True, long_pulse=True)          # tul-mill's pulse: 10 us
    exp, notes = planned(FAST, machine)
    feed = math.floor(one / 100.0 * 60.0 * 10) / 10          # X: 100 steps/mm
    assert words.startswith("on 1 axis")
    assert notes == [f"feed clamped to {feed:.1f} mm/min on lines 2, 3: the firmware keeps "
                     f"{one / 1000:g} kHz {words}"]
    text = [str(c) for c in exp.commands]
    assert text[0] == f"FFDR F{feed:g}"                       # the rapids' feed, for every rapid
    assert text[1].startswith("FMOV X20 ")
    assert text[2:4] == [f"PFDR F{feed:g}", "PMOV X40 Y0 Z0 E0"]      # the G1 at F30000, lowered
    assert text[4:6] == ["PFDR F6000", "PMOV X0 Y20 Z0 E0"]           # the program's feed again
    assert exp.lines == [2, 2, 3, 3, 4, 4]


def test_a_slow_program_is_sent_as_it_is():
    machine = load_machine("tul-mill")
    exp, notes = planned("G21 G90\nG0 X20 Y10\nG1 X30 F1200\nM2\n", machine)
    assert notes == [] and str(exp.commands[0]).startswith("FMOV X20 Y10")


@needs_avr
def test_the_firmware_run_steps_no_faster_than_the_limit_and_says_it_clamped(tmp_path, capsys):
    """The program asks X for 50 kHz (F30000 on 100 steps/mm; the machine file allows 60 kHz):
    on the firmware's pins no X interval is shorter than the table's rate allows (1 axis, with
    tul-mill's 10 us pulse), the clamped feed is reached, and the run's summary names the lines."""
    from retrofit.firmware import sim as fs
    path = fast_mill(tmp_path)
    machine = load_machine(path)
    rate, words = fl.load().step_rate(1, True, long_pulse=True)
    elf = fs.build_copy(machine, tmp_path / "build")
    prog = tmp_path / "fast.ngc"
    prog.write_text(FAST)
    harness = fs.Harness(elf, machine, listen="127.0.0.1:0", speed=0).start()
    try:
        code = main(["run", str(prog), "--machine", str(path), "--progress", "off",
                     "--output", f"serial+socket://{harness.address}?wait_s=300"])
    finally:
        log = harness.stop()
    out = " ".join(capsys.readouterr().out.split())       # the summary wraps at 80 columns
    assert code == 0
    assert f"mm/min on lines 2, 3: the firmware keeps {rate / 1000:g} kHz {words}" in out, out
    rises, _, _ = fs.step_times(log, machine, "X")
    assert len(rises) == 2000 + 2000 + 4000                       # X 20, 40, 0
    shortest = np.diff(rises).min()
    assert shortest >= fs.F_CPU / rate - 16                        # +-1 us of the limit's period
    assert shortest <= fs.F_CPU / rate * 1.02                      # and it ran at the limit


def lathe_with(tmp_path, **values) -> Path:
    text = (MACHINES / "mitic-lathe.toml").read_text()
    for key, value in values.items():
        text = re.sub(rf"^{key} = [\d.]+", f"{key} = {value}", text, flags=re.M)
    path = tmp_path / "mitic-lathe.toml"
    path.write_text(text)
    return path


def test_a_machine_whose_encoder_outruns_the_firmware_is_refused_for_a_firmware_run(tmp_path, capsys):
    """1000 lines (4000 counts) at 2000 rpm: the host's run to the firmware refuses the machine
    file, with the limit, before anything is sent; sim:// runs it."""
    path = lathe_with(tmp_path, encoder_counts_per_rev=4000)
    prog = tmp_path / "p.ngc"
    prog.write_text("G21 G90\nG0 X10\nM2\n")
    assert main(["run", str(prog), "--machine", str(path), "--output", NOWHERE, "--progress", "off"]) == 2
    err = capsys.readouterr().err
    limit = fl.load().encoder_counts_s
    assert re.search(rf"mitic-lathe.toml \[spindle\]: encoder_counts_per_rev = 4000 at max_rpm = 2000 "
                     rf"\(\+15%\) is 153333 counts/s; the firmware follows at most {limit:.0f} counts/s", err), err
    with pytest.raises(ConfigError, match="the firmware follows at most"):
        fl.check_encoder(load_machine(path))
    assert main(["run", str(prog), "--machine", str(path), "--progress", "off"]) == 0


def test_a_thread_at_a_speed_the_firmware_cannot_follow_is_refused_with_its_line(tmp_path, capsys):
    """G33 at S3000 on mitic-lathe (400 counts): 23 000 counts/s with the 15 % margin, above the
    limit; at S1500 it is accepted."""
    limit = fl.load().encoder_counts_s
    assert 400 * 3000 / 60 * 1.15 > limit > 400 * 1500 / 60 * 1.15
    prog = tmp_path / "g33.ngc"
    prog.write_text("G18 G21 G90\nG0 X9 Z2\nM3 S3000\nG33 Z-10 K0.5\nG0 X12\nM5\nM2\n")
    assert main(["run", str(prog), "--machine", "mitic-lathe", "--output", NOWHERE, "--progress", "off"]) == 2
    err = capsys.readouterr().err
    most = math.floor(limit * 60 / 400 / 1.15)
    assert re.search(rf"g33.ngc:4: thread at S3000: .* 23000 counts/s; the firmware follows at most "
                     rf"{limit:.0f} counts/s: S{most} at most", err), err
    machine = load_machine("mitic-lathe")
    with pytest.raises(GcodeError):
        planned(prog.read_text(), machine)
    planned(prog.read_text().replace("S3000", "S1500"), machine)        # no error


def test_retrofit_firmware_limits_prints_the_table_and_the_shipped_machines(capsys):
    assert main(["firmware", "limits"]) == 0
    out = capsys.readouterr().out
    limits = fl.load()
    assert "(this tree's firmware)" in out
    assert re.search(rf"3:bresenham\s+{limits.measured['3:bresenham']:.0f}\s+{limits.steps['3:bresenham']:.0f}", out)
    assert "mitic-lathe encoder: 15333 counts/s at max_rpm, within" in out
    assert "ABOVE" not in out and "REFUSED" not in out


def test_a_pause_stays_between_the_moves_it_stood_between_when_feeds_are_clamped(tmp_path):
    machine = load_machine(fast_mill(tmp_path))
    exp, notes = planned("G21 G90\nG0 X20\nM0\nG1 X40 F30000\nM2\n", machine)
    (pause,) = exp.pauses
    before = [str(c) for c in exp.commands[:pause.index]]
    after = [str(c) for c in exp.commands[pause.index:]]
    assert before[-2].startswith("FMOV X20") and before[-1] == "DELY P0" and after[0].startswith("PFDR F")
    assert after[1].startswith("PMOV X40") and pause.line == 3


def test_the_pass_a_stopped_controller_stands_on_is_found_part_way_along_it():
    a, b = {"X": 1120, "Z": 240}, {"X": 1120, "Z": -480}
    assert fl._on_line({"X": 1120, "Z": 240}, a, b) and fl._on_line({"X": 1120, "Z": -77}, a, b)
    assert not fl._on_line({"X": 1100, "Z": -77}, a, b) and not fl._on_line({"X": 1120, "Z": 250}, a, b)
    taper = {"X": 1000, "Z": -480}
    assert fl._on_line({"X": 1060, "Z": -120}, a, taper) and not fl._on_line({"X": 1060, "Z": -200}, a, taper)


def test_homing_never_raises_the_fast_feed():
    """G28 on mitic-lathe: its seeks at 1500 mm/min are far below the limit; nothing is sent
    that was not in the program (an FFDR at the limit's feed would raise the machine's rapid)."""
    machine = load_machine("mitic-lathe")
    text = "G21 G90\nG28\nG0 X10 Z5\nM2\n"
    exp, notes = planned(text, machine)
    from retrofit.atc.front import expand_host_commands
    from retrofit.gcode import compile_program
    plain = expand_host_commands(compile_program(text, machine, file="fast.ngc"), machine)
    assert notes == [] and [str(c) for c in exp.commands] == [str(c) for c in plain.commands]


def test_homing_on_a_fast_machine_is_clamped_and_said(tmp_path):
    machine = load_machine(fast_mill(tmp_path))
    one, words = fl.load().step_rate(1, True, long_pulse=True)
    exp, notes = planned("G21 G90\nG28\nM2\n", machine)
    feed = math.floor(one / 160.0 * 60.0 * 10) / 10          # E: 160 steps/mm, the finest axis
    assert [str(c) for c in exp.commands][:2] == [f"FFDR F{feed:g}", "ZMOV"]
    assert notes == [f"feed clamped to {feed:.1f} mm/min on line 2: the firmware keeps "
                     f"{one / 1000:g} kHz {words}"]
