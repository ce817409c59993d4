"""The labs' checks reject wrong work and accept right work: every known-wrong variant kept in a
lab's ``wrong/`` folder fails a check, first one of the TODO its description names, and every
known-right variant in ``right/`` (another valid way to write the lab) passes every check.

A variant is the reference solution plus a small change, kept as a patch (``retrofit.lab.wrong``).
Among the wrong ones: off-by-one counters, sign errors, truncation for rounding, constants written
in, swapped axes, closed forms that skip the algorithm the lab teaches, inputs assumed regular
(whole-step radii, a carriage at 0, samples 1 ms apart), and files that call the library's own
answer instead of computing it (``oracle_*``). The reference passing is proved in tests/test_labs.py.
"""

import ast
import re
from pathlib import Path

import pytest

from retrofit.lab.check import borrowed
from retrofit.lab.core import CHECK_SECONDS_ENV as SECONDS_ENV
from retrofit.lab.core import check_lab, list_labs, result_lines
from retrofit.lab.wrong import materialise, variants

ROOT = Path(__file__).resolve().parent.parent / "labs"
LABS = list_labs(ROOT)
HANGS = {"waits_for_the_pulse"}     # never returns: proved with a short time limit below
WRONG = [(lab, v) for lab in LABS for v in variants(lab.path, "wrong") if v.name not in HANGS]
RIGHT = [(lab, v) for lab in LABS for v in variants(lab.path, "right")]


def _sampled(cases):
    """Every case; all but each lab's first two run in the slow stage (each is a sandboxed check)."""
    seen: dict[str, int] = {}
    out = []
    for lab, variant in cases:
        seen[lab.number] = seen.get(lab.number, 0) + 1
        marks = () if seen[lab.number] <= 2 else (pytest.mark.slow,)
        out.append(pytest.param(lab, variant, marks=marks, id=f"{lab.number}-{variant.name}"))
    return out


def todos_named(title: str) -> set[int]:
    """The TODO numbers a check's title names: 'TODO 1, 2: ...' -> {1, 2}; 'TODOs 1-3: ...' -> {1, 2, 3}."""
    match = re.match(r"TODOs? ([\d, -]+(?:or TODO \d+)?)", title)
    if not match:
        return set()
    numbers = set()
    for part in re.findall(r"\d+-\d+|\d+", match[1]):
        low, _, high = part.partition("-")
        numbers |= set(range(int(low), int(high or low) + 1))
    return numbers


def test_every_lab_keeps_wrong_and_right_variants_of_its_own():
    assert len(LABS) == 13
    for lab in LABS:
        assert not list((lab.path / "wrong").glob("*.py")), f"{lab.path.name}: wrong/ holds patches, not copies"
        wrong, right = variants(lab.path, "wrong"), variants(lab.path, "right")
        assert len(wrong) >= 12, f"{lab.path.name}: {len(wrong)} wrong variants"
        # labs 11 and 12 check against a model of their own, tick by tick (tests/test_lab_11.py, _12.py)
        assert len(right) >= 3 or int(lab.number) >= 11, f"{lab.path.name}: {len(right)} right variants"
        assert all(not v.right for v in wrong) and all(v.right for v in right)
        assert any(v.name.startswith("oracle_") for v in wrong), f"{lab.path.name}: no file calling the library's answer"


def test_title_parsing():
    assert todos_named("TODO 1, 2: tick by tick") == {1, 2}
    assert todos_named("TODOs 1-3: your whole experiment") == {1, 2, 3}
    assert todos_named("TODO 1 or TODO 2: at least one") == {1, 2}
    assert todos_named("Your whole analysis: ...") == set()


@pytest.mark.parametrize("lab, variant", _sampled(WRONG))
def test_wrong_variant_fails_a_check_of_its_todo(lab, variant, tmp_path, monkeypatch):
    monkeypatch.setenv(SECONDS_ENV, "30")   # the first check in a fresh checkout compiles kernels
    results = check_lab(lab, target=materialise(lab.path, variant, tmp_path), first_failure=True)
    failed = [r for r in results if r.status == "failed"]
    assert failed, f"{variant.path.name} passes every check:\n" + "\n".join(result_lines(results))
    assert variant.todo in todos_named(failed[0].title), \
        f"{variant.path.name} (TODO {variant.todo}) first fails: {failed[0].title}"
    assert failed[0].message and "Traceback" not in failed[0].message, failed[0].message


@pytest.mark.parametrize("lab, variant", _sampled(RIGHT))
def test_right_variant_passes_every_check(lab, variant, tmp_path, monkeypatch):
    monkeypatch.setenv(SECONDS_ENV, "20")
    results = check_lab(lab, target=materialise(lab.path, variant, tmp_path))
    assert all(r.status == "passed" for r in results), \
        f"{variant.path.name}: {variant.description}\n" + "\n".join(result_lines(results))


def test_a_solution_that_never_returns_fails_naming_its_todo(monkeypatch, tmp_path):
    monkeypatch.setenv(SECONDS_ENV, "1")
    lab = next(lab for lab in LABS if lab.number == "02")
    variant = next(v for v in variants(lab.path, "wrong") if v.name == "waits_for_the_pulse")
    results = check_lab(lab, target=materialise(lab.path, variant, tmp_path), first_failure=True)
    failed = [r for r in results if r.status == "failed"]
    assert [r.title.split(":")[0] for r in failed] == ["TODO 2"]
    message = failed[0].message
    assert message.startswith("TODO 2") and "did not finish within 1 s" in message and "\n" not in message
    assert "waits_for_the_pulse.py line" in message and "in set_pas_avans" in message


#: per lab, the library functions that would hand over the answer: no check may take its expected
#: values from them (a student's file could call them too); an empty set forbids the whole module
ANSWERS = {"01": ({"retrofit.demo": set()}, frozenset()),
           "02": ({"retrofit.motion.stepgen": set()}, frozenset()),
           "03": ({"retrofit.motion.bresenham": set(), "retrofit.motion.dda": set()}, frozenset()),
           "05": ({}, frozenset({"max_accel_steps_s2", "max_rate_steps_s"})),
           "07": ({"retrofit.camlink.model": {"Comparison", "compare"}}, frozenset({"overshoot", "following_error"})),
           "08": ({}, frozenset({"pocket_position"})),
           "09": ({"retrofit.link": {"encode_frame"}, "retrofit.link.framing": {"encode_frame", "stuff"}}, frozenset()),
           "10": ({"retrofit.gcode": set()}, frozenset()),
           "13": ({"retrofit.fpga": set()}, frozenset())}
#: the checks of the checks, worth no points, may compare the checks' oracle with the library's
CHECKS_OF_CHECKS = {"by_retrofit", "test_recorded_and_retrofit_agree_where_both_run"}


@pytest.mark.parametrize("lab", [lab for lab in LABS if lab.number in ANSWERS], ids=lambda lab: lab.number)
def test_no_check_takes_its_expected_values_from_the_library(lab):
    tree = ast.parse(lab.checks.read_text(encoding="utf-8"))
    names = {node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))} - CHECKS_OF_CHECKS
    modules, methods = ANSWERS[lab.number]
    assert borrowed(lab.checks, modules, within=names, methods=methods, strings=False) == []
