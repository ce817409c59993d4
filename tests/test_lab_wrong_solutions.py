"""The labs' checks reject wrong work: every known-wrong solution kept in a lab's ``wrong/`` folder
fails at least one check, and the first check it fails is one of the TODO its docstring names.

Each wrong solution is the reference solution with one mistake a student could make (off-by-one
counters, sign errors, truncation for rounding, constants written in, swapped axes, closed forms
that skip the algorithm the lab teaches). The reference solution passing every check is proved in
tests/test_labs.py. One process per lab; each wrong solution runs until its first failed check.
"""

import ast
import re
from pathlib import Path

import pytest

from retrofit.labs import CHECK_SECONDS_ENV as SECONDS_ENV, check_lab, list_labs

ROOT = Path(__file__).resolve().parent.parent / "labs"
# every lab but 09 and 10, which prove their own wrong solutions in tests/test_lab_09.py and _10.py
LABS = [lab for lab in list_labs(ROOT) if (lab.path / "wrong").is_dir() and lab.number not in ("09", "10")]
DOC = re.compile(r"^Wrong in TODO (\d+): .+\.$")
HANGS = {"waits_for_the_pulse.py"}     # never returns: proved with a short time limit below


def wrong_files(lab):
    return sorted((lab.path / "wrong").glob("*.py"))


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


def test_every_lab_of_the_eight_has_ten_wrong_solutions_with_a_docstring_naming_the_mistake():
    assert len(LABS) >= 8
    for lab in LABS:
        files = wrong_files(lab)
        assert len(files) >= 10, f"{lab.path.name}: {len(files)} wrong solutions"
        for path in files:
            doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
            assert doc and "\n" not in doc and DOC.match(doc), f"{path}: docstring {doc!r}"
            assert "TODO" not in path.read_text(encoding="utf-8").split('"""', 2)[2], f"{path}: a stub, not a solution"


def test_title_parsing():
    assert todos_named("TODO 1, 2: tick by tick") == {1, 2}
    assert todos_named("TODOs 1-3: your whole experiment") == {1, 2, 3}
    assert todos_named("TODO 1 or TODO 2: at least one") == {1, 2}
    assert todos_named("Your whole analysis: ...") == set()


@pytest.mark.parametrize("lab", LABS, ids=[lab.path.name for lab in LABS])
def test_wrong_solutions_fail_a_check_of_their_todo(lab, monkeypatch):
    monkeypatch.setenv(SECONDS_ENV, "10")
    escaped, blamed = [], []
    for path in (p for p in wrong_files(lab) if p.name not in HANGS):
        todo = int(DOC.match(ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))))[1])
        results = check_lab(lab, target=path, first_failure=True)
        failed = [r for r in results if r.status == "failed"]
        if not failed:
            escaped.append(path.name)
        elif todo not in todos_named(failed[0].title):
            blamed.append(f"{path.name} (TODO {todo}) first fails: {failed[0].title}")
        else:
            assert "Traceback" not in failed[0].message and failed[0].message, failed[0].message
    assert not escaped, f"{lab.path.name}: wrong solutions that pass every check: {escaped}"
    assert not blamed, f"{lab.path.name}: caught by a check of another TODO:\n" + "\n".join(blamed)


def test_a_solution_that_never_returns_fails_naming_its_todo(monkeypatch):
    monkeypatch.setenv(SECONDS_ENV, "1")
    lab = next(lab for lab in LABS if lab.number == "02")
    results = check_lab(lab, target=lab.path / "wrong" / "waits_for_the_pulse.py", first_failure=True)
    failed = [r for r in results if r.status == "failed"]
    assert [r.title.split(":")[0] for r in failed] == ["TODO 2"]
    message = failed[0].message
    assert message.startswith("TODO 2") and "did not finish within 1 s" in message and "\n" not in message
    assert "waits_for_the_pulse.py line" in message and "in set_pas_avans" in message
