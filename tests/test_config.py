"""Machine files: loading by name and path, and strict errors naming file, section and key."""

import subprocess
import sys

import pytest

from retrofit.errors import ConfigError
from retrofit.machine.config import list_machines, load_machine, machines_dir

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


# -- hostile and careless machine files: one line naming file [section] key and the rule --------

MITIC_TEXT = (machines_dir() / "mitic-lathe.toml").read_text()


def test_a_utf16_file_is_named_with_the_encoding_to_use(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text(LATHE_TEXT, encoding="utf-16")
    with pytest.raises(ConfigError, match=r"wide.toml: not UTF-8 text \(it is UTF-16\); "
                                          r"TOML files are UTF-8: save it as UTF-8"):
        load_machine(path)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + LATHE_TEXT.encode())
    assert load_machine(path).axis("X").steps_per_mm == 40.0


@pytest.mark.parametrize("old, new, expected", [
    ("min_mm = -40.0", "min_mm = -1e308",
     "[axis.x] min_mm = -1e+308: must be >= -5.36871e+07"),           # 2**31-1 steps / 40 per mm
    ("max_velocity_mm_s = 25.0", "max_velocity_mm_s = 1.8e308",
     "[axis.z] max_velocity_mm_s = inf: must be a finite number"),
    ("max_velocity_mm_s = 25.0", "max_velocity_mm_s = 1.7e308",
     "[axis.z] max_velocity_mm_s = 1.7e+308: must be <= 10000"),
    ("steps_per_mm = 40.0", "steps_per_mm = nan", "[axis.x] steps_per_mm = nan: must be a finite"),
    ("tick_us = 50.0", "tick_us = 1" + "0" * 400, "[machine] tick_us = 1000"),
], ids=["min-mm-huge", "velocity-overflows-to-inf", "velocity-huge", "nan", "integer-400-digits"])
def test_numbers_must_be_finite_and_fit_what_the_machine_represents(tmp_path, old, new, expected):
    with pytest.raises(ConfigError) as err:
        load_machine(broken(tmp_path, old, new))
    assert "bad-lathe.toml" in str(err.value) and expected in str(err.value)
    assert "\n" not in str(err.value)


def test_a_time_that_cannot_become_ticks_is_refused(tmp_path):
    path = tmp_path / "noisy.toml"
    assert "noise_interval_ms = 200.0" in MITIC_TEXT
    path.write_text(MITIC_TEXT.replace("noise_interval_ms = 200.0", "noise_interval_ms = 1e308"))
    with pytest.raises(ConfigError, match=r"noisy.toml \[spindle.sim\] noise_interval_ms = 1e\+308: "
                                          r"must be within \+-1e\+09"):
        load_machine(path)


@pytest.mark.parametrize("header, expected", [
    ('[axis.""]', "[axis.'']: '' is not an axis name; an axis is named by one letter of XYZABCUVW"),
    ('[axis."X Y"]', "[axis.'X Y']: 'X Y' is not an axis name"),
    ('[axis."z\\n"]', "[axis.'z\\n']: 'z\\n' is not an axis name"),
    ("[axis.1]", "[axis.1]: '1' is not an axis name"),
    ("[axis.Q]", "[axis.Q]: 'Q' is not an axis name"),
    ("[axis.X]", "[axis.X]: axis X is already defined by [axis.x]; each axis is defined once"),
], ids=["empty", "two-letters", "newline", "digit", "not-rs274", "twice-by-case"])
def test_axes_are_one_rs274_letter_each_defined_once(tmp_path, header, expected):
    assert "[axis.z]" in LATHE_TEXT
    with pytest.raises(ConfigError) as err:
        load_machine(broken(tmp_path, "[axis.z]", header))
    assert f"bad-lathe.toml {expected}" in str(err.value) and "\n" not in str(err.value)


def test_a_key_with_a_newline_is_shown_quoted_on_one_line(tmp_path):
    with pytest.raises(ConfigError) as err:
        load_machine(broken(tmp_path, "steps_per_mm = 40.0", 'steps_per_mm = 40.0\n"a\\nb" = 1'))
    assert "bad-lathe.toml [axis.x] 'a\\nb': unknown key" in str(err.value)
    assert "\n" not in str(err.value)


def test_a_directory_in_place_of_the_file_is_one_line(tmp_path):
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(ConfigError, match=r"dir.toml: cannot read it"):
        load_machine(tmp_path / "dir.toml")


def test_cli_on_a_utf16_machine_file_is_one_line_exit_2(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text(LATHE_TEXT, encoding="utf-16")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "demo", "circle", "--machine",
                           str(path)], capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip() .endswith("save it as UTF-8")
