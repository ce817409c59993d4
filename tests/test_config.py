"""Machine files: loading by name and path, and strict errors naming file, section and key."""

import subprocess
import sys
from pathlib import Path

import pytest

from retrofit.config import list_machines, load_machine, machines_dir
from retrofit.errors import ConfigError

LATHE_TEXT = (machines_dir() / "chivu-lathe.toml").read_text()


def test_chivu_lathe_has_the_papers_constants():
    m = load_machine("chivu-lathe")
    x, z = m.axis("X"), m.axis("Z")
    assert (x.steps_per_mm, z.steps_per_mm) == (40.0, 50.0)          # KT, KL
    assert (x.min_mm, x.max_mm, z.min_mm, z.max_mm) == (-40, 40, -200, 20)
    assert (z.step_bit, z.dir_bit, x.step_bit, x.dir_bit) == (0, 1, 2, 3)   # b0..b3, pins 2..5
    assert m.sim.dead_band_mm["X"] > 0 and m.sim.dead_band_mm["Z"] > 0
    assert "chivu-lathe" in list_machines()


def test_load_by_path(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(LATHE_TEXT)
    assert load_machine(path).axis("Z").steps_per_mm == 50.0


def broken(tmp_path, old, new):
    assert old in LATHE_TEXT
    path = tmp_path / "bad-lathe.toml"
    path.write_text(LATHE_TEXT.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,expected", [
    ("steps_per_mm = 40.0", "step_per_mm = 40.0", "bad-lathe.toml [axis.x] step_per_mm: unknown key"),
    ("steps_per_mm = 40.0", "steps_per_mm = -5", "bad-lathe.toml [axis.x] steps_per_mm = -5: must be > 0"),
    ("steps_per_mm = 50.0", 'steps_per_mm = "fifty"', "bad-lathe.toml [axis.z] steps_per_mm = 'fifty': must be a number"),
    ("tick_us = 50.0", "tick_us = true", "bad-lathe.toml [machine] tick_us = True: must be a number"),
    ("pulse_high_ticks = 2 ", "pulse_high_ticks = 0 ", "[axis.x] pulse_high_ticks = 0: must be >= 1"),
    ("dead_band_mm = { x = 0.11", "dead_band_mm = { x = -0.11", "[sim.dead_band_mm] x = -0.11: must be >= 0"),
    ("step_pin = 2 ", "step_pin = 4 ", "[axis.z] step_pin = 6: already used by X.step_pin"),
], ids=["typo-key", "negative-steps", "wrong-type", "bool-not-number", "zero-pulse", "negative-band", "pin-clash"])
def test_bad_machine_file_names_file_section_key(tmp_path, old, new, expected):
    with pytest.raises(ConfigError) as err:
        load_machine(broken(tmp_path, old, new))
    if "pin-clash" in expected or "already used" in expected:
        assert "already used" in str(err.value) and "[axis." in str(err.value)
    else:
        assert expected in str(err.value)


def test_unknown_machine_lists_the_shipped_ones():
    with pytest.raises(ConfigError, match="chivu-lathe"):
        load_machine("chivu-lathes")


def test_cli_prints_config_error_in_one_line_exit_2(tmp_path):
    path = broken(tmp_path, "steps_per_mm = 40.0", "steps_per_mm = -5")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "demo", "circle", "--machine", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0
    assert "Traceback" not in proc.stderr
    assert "bad-lathe.toml [axis.x] steps_per_mm = -5: must be > 0" in proc.stderr
