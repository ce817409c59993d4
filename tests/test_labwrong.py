"""Lab variants kept as patches: a patch gives back the file it was made from, follows the reference
when lines are added above it, and says which patch and hunk no longer fit; every lab's variants apply."""

import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.errors import ConfigError
from retrofit.lab.core import list_labs
from retrofit.lab.wrong import apply_variant, make_variant, materialise, read_variant, variants

ROOT = Path(__file__).resolve().parent.parent / "labs"
REFERENCE = "".join(f"line {k}\n" for k in range(1, 31))


def _variant(tmp_path, changed, description="Wrong in TODO 2: line 12 says twelve.", name="twelve"):
    path = tmp_path / f"{name}.patch"
    path.write_text(make_variant(description, REFERENCE, changed, name), encoding="utf-8")
    return read_variant(path)


def test_a_patch_gives_back_the_changed_file(tmp_path):
    changed = REFERENCE.replace("line 12\n", "twelve\nand more\n").replace("line 25\n", "")
    variant = _variant(tmp_path, changed)
    assert (variant.todo, variant.right, variant.name, len(variant.hunks)) == (2, False, "twelve", 2)
    assert apply_variant(variant, REFERENCE) == changed
    assert len(variant.path.read_text().splitlines()) < 20


def test_a_patch_follows_the_reference_when_lines_are_added_above_it(tmp_path):
    variant = _variant(tmp_path, REFERENCE.replace("line 12\n", "twelve\n"))
    moved = "# a new first line\n# and a second\n" + REFERENCE
    assert apply_variant(variant, moved) == moved.replace("line 12\n", "twelve\n")


def test_a_hunk_whose_lines_are_gone_is_an_error_naming_patch_and_line(tmp_path):
    variant = _variant(tmp_path, REFERENCE.replace("line 12\n", "twelve\n"))
    with pytest.raises(ConfigError, match=r"twelve\.patch:4: the hunk's old lines are no longer in solution.py"):
        apply_variant(variant, REFERENCE.replace("line 11\n", "line eleven\n"))


def test_a_hunk_found_twice_equally_near_is_an_error(tmp_path):
    source = "a\nb\nc\nx\nc\nb\na\n"
    path = tmp_path / "twice.patch"
    path.write_text("Right: c is C.\n--- solution.py\n+++ twice.py\n@@ -4,1 +4,1 @@\n-c\n+C\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"twice\.patch:4: .* lines 3 and 5 .* give it more context"):
        apply_variant(read_variant(path), source)


@pytest.mark.parametrize("text, error", [
    ("Wrong: no TODO.\n@@ -1 +1 @@\n-a\n+b\n", r":1: the first line must say"),
    ("Right: fine.\n--- solution.py\n+++ x.py\n", r"no hunk"),
    ("Right: fine.\nsomething else\n@@ -1 +1 @@\n-a\n+b\n", r":2: 'something else': only the"),
    ("Right: fine.\n@@ -1,2 +1,1 @@\n-a\n+b\n", r":2: the hunk has 1 old and 1 new lines; its header says 2 and 1"),
    ("Right: fine.\n@@ -1 +1 @@\n*a\n", r":3: '\*a': a hunk line starts with"),
], ids=["description", "no-hunk", "junk", "count", "tag"])
def test_a_malformed_patch_is_an_error_naming_its_line(tmp_path, text, error):
    path = tmp_path / "bad.patch"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=error):
        read_variant(path)


def test_a_variant_that_changes_nothing_is_refused():
    with pytest.raises(ConfigError, match="the same as solution.py"):
        make_variant("Right: nothing.", REFERENCE, REFERENCE, "same")


def test_materialise_writes_the_variant_beside_the_labs_data_only(tmp_path):
    lab = next(lab for lab in list_labs(ROOT) if lab.number == "05")
    variant = variants(lab.path, "wrong")[0]
    target = materialise(lab.path, variant, tmp_path)
    assert target == tmp_path / f"{variant.name}.py"
    assert (tmp_path / "engraver-x.toml").read_text() == (lab.path / "engraver-x.toml").read_text()
    assert {p.name for p in tmp_path.iterdir()} == {target.name, "engraver-x.toml"}


@pytest.mark.parametrize("kind", ["wrong", "right"])
def test_every_labs_variants_apply_and_change_its_solution(kind):
    for lab in list_labs(ROOT):
        reference = (lab.path / "solution.py").read_text(encoding="utf-8")
        for variant in variants(lab.path, kind):
            changed = apply_variant(variant, reference)
            assert changed != reference, variant.path
            compile(changed, str(variant.path), "exec")
            # a file that hands a whole TODO to the library (oracle_*) replaces a function body
            limit = 80 if variant.name.startswith("oracle_") else 60
            assert len(variant.path.read_text(encoding="utf-8").splitlines()) <= limit, f"{variant.path}: not small"


def test_a_patch_written_by_diff_u_with_its_dates_is_read(tmp_path):
    path = tmp_path / "dated.patch"
    path.write_text("Wrong in TODO 1: line 3 is gone.\n--- solution.py\t2026-11-27 09:00:00.000000000 +0000\n"
                    "+++ mine.py\t2026-11-27 09:01:00.000000000 +0000\n@@ -2,3 +2,2 @@\n line 2\n-line 3\n line 4\n",
                    encoding="utf-8")
    assert apply_variant(read_variant(path), REFERENCE) == REFERENCE.replace("line 3\n", "")


LINES = st.lists(st.sampled_from(["a = 1", "b = 2", "", "    return a", "def f():", "x += 1", "# note"]),
                 min_size=1, max_size=40)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(reference=LINES, changed=LINES)
def test_any_change_made_into_a_patch_gives_the_changed_file_back(tmp_path_factory, reference, changed):
    """Files of few distinct lines, so hunks often look alike: found at the right place or refused, never
    applied at the wrong one."""
    ref_text, new_text = "\n".join(reference) + "\n", "\n".join(changed) + "\n"
    if ref_text == new_text:
        return
    path = tmp_path_factory.mktemp("p") / "v.patch"
    path.write_text(make_variant("Right: another file.", ref_text, new_text, "v"), encoding="utf-8")
    try:
        assert apply_variant(read_variant(path), ref_text) == new_text
    except ConfigError as exc:
        assert "as near as each other" in str(exc)


def test_materialise_links_the_labs_data_not_the_caches_tools_left_in_its_folder(tmp_path):
    """A lab folder a tool has written into (pytest-benchmark's .benchmarks, pytest's cache,
    Hypothesis's database: a student who ran pytest there) lends the variant its data files only;
    a suite run twice on one checkout once found .benchmarks linked beside the variant."""
    lab_copy = tmp_path / "05_acceleration"
    shutil.copytree(next(lab for lab in list_labs(ROOT) if lab.number == "05").path, lab_copy,
                    ignore=shutil.ignore_patterns(".*", "__pycache__"))
    for cache in (".benchmarks", ".pytest_cache", ".hypothesis"):
        (lab_copy / cache).mkdir()
    variant = variants(lab_copy, "wrong")[0]
    target = materialise(lab_copy, variant, tmp_path / "out")
    assert {p.name for p in target.parent.iterdir()} == {target.name, "engraver-x.toml"}
