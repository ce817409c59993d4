"""The labs' check helpers: seeded cases a student can draw again, and the look at a student's file
for library functions that would hand over the lab's answer."""

import pytest

from retrofit.errors import ConfigError
from retrofit.lab.check import SEED_ENV, borrowed, cases, seed_note

ANSWERS = {"retrofit.demo": {"circle_targets"}, "retrofit.gcode": set()}
STUDENT = '''\
import importlib
import retrofit.demo
from retrofit import demo as d
from retrofit.demo import circle_targets as ct
from retrofit.gcode.lexer import tokens
from retrofit.motion.bresenham import bresenham_cycles


def circle(machine):
    return helper(machine)


def helper(machine):
    return d.circle_targets(machine)


def plot(machine):
    return bresenham_cycles(machine), motor.max_accel_steps_s2(0)


def loaded():
    return importlib.import_module("retrofit.demo")
'''


def test_the_same_seed_draws_the_same_cases_and_says_so(monkeypatch):
    monkeypatch.setenv(SEED_ENV, "7")
    first = [cases("a check").random() for _ in range(3)]
    assert first == [cases("a check").random() for _ in range(3)] != [cases("another").random() for _ in range(3)]
    assert seed_note() == f"cases drawn with seed 7 ({SEED_ENV}=7 draws them again)"
    monkeypatch.setenv(SEED_ENV, "8")
    assert [cases("a check").random() for _ in range(3)] != first
    monkeypatch.setenv(SEED_ENV, "seven")
    with pytest.raises(ConfigError, match=f"{SEED_ENV}=seven: not a whole number"):
        cases("a check")


def test_borrowed_finds_every_way_of_reaching_an_answer(tmp_path):
    path = tmp_path / "student.py"
    path.write_text(STUDENT, encoding="utf-8")
    # importing a module is no harm (line 2, 3): reading the answer from it is
    assert borrowed(path, ANSWERS) == ["line 4: from retrofit.demo import circle_targets",
                                       "line 5: from retrofit.gcode.lexer import tokens",
                                       "line 14: retrofit.demo.circle_targets", "line 22: 'retrofit.demo'"]


def test_borrowed_within_follows_the_functions_called_and_skips_the_given_code(tmp_path):
    path = tmp_path / "student.py"
    path.write_text(STUDENT, encoding="utf-8")
    assert borrowed(path, ANSWERS, within={"circle"}) == ["line 14: retrofit.demo.circle_targets"]
    assert borrowed(path, {"retrofit.motion.bresenham": {"bresenham_cycles"}}, within={"circle"}) == []
    assert borrowed(path, {"retrofit.motion.bresenham": {"bresenham_cycles"}}, within={"plot"}) == [
        "line 18: bresenham_cycles (retrofit.motion.bresenham.bresenham_cycles)"]
    assert borrowed(path, {}, within={"plot"}, methods=frozenset({"max_accel_steps_s2"})) == [
        "line 18: .max_accel_steps_s2"]


def test_a_file_that_does_not_parse_borrows_nothing(tmp_path):
    path = tmp_path / "student.py"
    path.write_text("def broken(:\n", encoding="utf-8")
    assert borrowed(path, ANSWERS) == []
