"""Messages a new user meets first: the machine a command takes when none is named, machine-file
keys missing or misspelt, points on a soft limit, a tool missing from the tool table."""

from __future__ import annotations

import subprocess
import sys

import pytest

from retrofit.errors import ConfigError, GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine, machines_dir
from retrofit.machine.tooltable import ToolTable

LATHE_TEXT = (machines_dir() / "chivu-lathe.toml").read_text()


def machine_file(tmp_path, old: str, new: str):
    assert old in LATHE_TEXT
    path = tmp_path / "mylathe.toml"
    path.write_text(LATHE_TEXT.replace(old, new, 1))
    return path


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "retrofit.cli", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


def test_a_missing_step_pin_is_named_with_the_rule_not_taken_for_a_typo(tmp_path):
    path = machine_file(tmp_path, "step_pin = 4                   # b2\n", "")
    with pytest.raises(ConfigError) as err:
        load_machine(path)
    message = str(err.value)
    assert message.startswith("mylathe.toml [axis.x] step_pin: missing; step_pin is needed on port \"db25\"")
    assert 'port = "none"' in message and "steps_per_mm" not in message


@pytest.mark.parametrize("old,new,key,meant", [
    ("max_accel_mm_s2 = 200.0", "max_acel_mm_s2 = 200.0", "max_acel_mm_s2", "max_accel_mm_s2"),   # optional
    ("backlash_mm = 0.10", "backlash = 0.10", "backlash", "backlash_mm"),                         # optional
    ("step_pin = 4 ", "stepp_pin = 4 ", "stepp_pin", "step_pin"),                                # required
], ids=["optional-accel", "optional-backlash", "required-pin"])
def test_every_misspelt_key_gets_did_you_mean(tmp_path, old, new, key, meant):
    with pytest.raises(ConfigError) as err:
        load_machine(machine_file(tmp_path, old, new))
    assert str(err.value) == f"mylathe.toml [axis.x] {key}: unknown key (did you mean {meant}?)"


def test_a_point_a_tenth_of_a_step_beyond_a_limit_is_on_it_and_no_minus_zero_is_printed():
    engraver = load_machine("engraver")                     # X 0..200 mm, 80 steps/mm: a step 12.5 um
    step = 1 / 80
    on = compile_program(f"G0 X{-0.09 * step:.7f} Y5\nG0 X{200 + 0.09 * step:.7f}\n", engraver)
    assert len(on.commands) >= 2
    spiral = compile_program("G0 X10 Y10\nG2 X0 Y10 I-5 J0 F300\n", engraver)   # ends on X = 0 exactly
    assert spiral.commands
    with pytest.raises(GcodeError) as err:
        compile_program(f"G0 X{-0.2 * step:.7f}\n", engraver)
    assert "X -0.003 mm is outside the soft limits 0..200 mm" in str(err.value)
    from retrofit.gcode.validate import shown_mm
    x = engraver.axis("X")
    assert [shown_mm(v, x) for v in (-0.0004, -1e-12, 200.0004)] == ["-0.000400", "0.000000000", "200.000400"]


def test_a_tool_missing_from_the_tool_table_names_the_table(tmp_path):
    table = tmp_path / "shop.tbl"
    table.write_text("T1 P1 Z10\n")
    with pytest.raises(GcodeError) as err:
        compile_program("G43 H4\n", load_machine("tul-mill"), "job.ngc", tool_table=ToolTable.load(table))
    assert f"job.ngc:1: G43 H4: tool 4 is not in the tool table {table}" in str(err.value)


def test_the_default_machine_is_named_in_help_and_in_the_summary(tmp_path):
    helped = cli("run", "--help", cwd=tmp_path)
    assert "(default: chivu-lathe)" in " ".join(helped.stdout.split())
    ran = cli("run", "lathe-profile.ngc", "--progress", "off", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    assert "  machine: chivu-lathe (the default; --machine chooses another)" in ran.stdout
    chosen = cli("run", "lathe-profile.ngc", "--progress", "off", "--machine", "chivu-lathe", cwd=tmp_path)
    assert "the default" not in chosen.stdout
