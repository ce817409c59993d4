"""parport://: the missing-device message, pin inversions of Table 1, [parport] section, lazy imports, hardware."""

import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from retrofit.demo import circle_targets
from retrofit.errors import ConfigError, OutputError
from retrofit.machine.config import load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output
from retrofit.outputs.parport import DB25, control_bits, status_levels

LATHE_TOML = open(os.path.join(os.path.dirname(__file__), "..", "retrofit", "machines", "chivu-lathe.toml")).read()


def lathe_with(tmp_path, section: str):
    path = tmp_path / "lathe.toml"
    path.write_text(LATHE_TOML + "\n" + section)
    return load_machine(path)


def test_missing_device_is_one_clear_line_and_exit_2():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "demo", "circle", "--radius", "2", "--points", "8",
                           "--output", "parport:///dev/parport9"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    line = lines[0]
    assert line.startswith("retrofit: error: parport:///dev/parport9: cannot open /dev/parport9")
    for hint in ("ppdev", "rmmod lp", "group lp"):
        assert hint in line
    assert "Traceback" not in proc.stderr


def test_default_device_and_unknown_option():
    lathe = load_machine("chivu-lathe")
    assert open_output("parport://", lathe).device == "/dev/parport0"
    assert open_output("parport:///dev/parport1", lathe).device == "/dev/parport1"
    with pytest.raises(OutputError, match=r"unknown option 'speed'; expected parport://"):
        open_output("parport://?speed=3", lathe)


def test_a_machine_not_wired_to_a_db25_port_is_refused():
    ramps = replace(load_machine("chivu-lathe"), port="ramps")
    with pytest.raises(OutputError, match="port = 'ramps'"):
        open_output("parport://", ramps)


@pytest.mark.parametrize("pin, inverted", [(1, True), (14, True), (16, False), (17, True)],
                         ids=["strobe", "linefeed", "reset", "select-printer"])
def test_control_pins_follow_table_1(pin, inverted):
    mask, bits_high = control_bits(pin, True)
    assert mask == 1 << DB25[pin].bit
    assert bool(bits_high) is not inverted, "5 V on an inverted pin is a 0 in the register"


def test_status_pins_undo_busy_inversion():
    assert status_levels(0x00) == {10: False, 11: True, 12: False, 13: False, 15: False}
    assert status_levels(0x80) == {10: False, 11: False, 12: False, 13: False, 15: False}
    assert status_levels(0x40 | 0x20 | 0x10 | 0x08) == {10: True, 11: True, 12: True, 13: True, 15: True}


def test_enable_pin_and_switches_from_the_machine_file(tmp_path):
    machine = lathe_with(tmp_path, '[parport]\nenable_pin = 14\nenable_level = "low"\n'
                                   'pin10 = "x_limit"\npin11 = "z_home"\n')
    settings = machine.parts["parport"]
    assert (settings.enable_pin, settings.enable_level) == (14, False)
    out = open_output(f"parport+record://{tmp_path / 'r.bin'}?paced=0", machine)
    with out:
        rec = out.recording
        assert rec.control_register & 0b10, "pin 14 at 0 V while open: register bit 1 set (inverted pin)"
        rec.status_register = 0x40          # Ack high, Busy register bit 0 -> pin 11 at 5 V
        assert out.read_switches() == {"x_limit": True, "z_home": True}
        rec.status_register = 0x80
        assert out.read_inputs()[11] is False
    assert not rec.control_register & 0b10, "drivers disabled (pin 14 back at 5 V) after close"


@pytest.mark.parametrize("section, message", [
    ("[parport]\nenable_pin = 5\n", "must be a control pin"),
    ("[parport]\nenable_level = \"up\"\n", "must be one of high, low"),
    ("[parport]\npin14 = \"x_limit\"\n", "unknown key"),
    ("[parport]\npin10 = \"a\"\npin12 = \"a\"\n", "own name"),
], ids=["data-pin-as-enable", "bad-level", "control-pin-as-switch", "duplicate-name"])
def test_parport_section_is_read_strictly(tmp_path, section, message):
    with pytest.raises(ConfigError, match=message):
        lathe_with(tmp_path, section)


def test_outputs_import_no_hardware_or_plot_library():
    code = ("import sys, retrofit.outputs as o, retrofit.cli.outputs\n"
            "for s in ('parport', 'parport+record', 'vcd', 'sim'): o.output_class(s)\n"
            "print(sorted(m for m in ('parallel', 'serial', 'matplotlib', 'vcd') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_outputs_command_lists_every_grammar():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "outputs"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    for grammar in ("parport://[/dev/parportN]", "parport+record://FILE", "vcd://FILE.vcd", "sim://"):
        assert grammar in proc.stdout


def test_timing_command_plots_the_lateness_histogram(tmp_path):
    png = tmp_path / "lat.png"
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "timing", "--seconds", "0.5", "--tick-us", "200",
                           "--plot", str(png)], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr
    assert "lateness p50" in proc.stdout and "later than half a tick" in proc.stdout
    assert "calibration:" in proc.stdout and "realtime:" in proc.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.hardware
def test_drives_a_real_parallel_port():
    if not os.path.exists("/dev/parport0"):
        pytest.skip("no /dev/parport0 on this computer (load ppdev, or plug in a parallel port card)")
    lathe = load_machine("chivu-lathe")
    log = PositionErrorLoop(lathe).run(circle_targets(lathe, 1.0, 8))
    try:
        out = open_output("parport:///dev/parport0?force=1", lathe)
        out.quiet = True
        with out:
            inputs = out.read_inputs()
            out.write(log.frames)
    except OutputError as exc:
        pytest.skip(f"/dev/parport0 is there but cannot be used: {exc}")
    assert sorted(inputs) == [10, 11, 12, 13, 15]
    assert out.timing.writes == len(log.frames)
    assert np.isfinite(out.timing.p99_ns)
