"""A lab's known-wrong and known-right variants, kept as small patches to its reference solution.

``labs/NN_topic/wrong/NAME.patch`` (and ``right/NAME.patch``) is a unified diff of the lab's
``solution.py``: one line saying what the variant does (``Wrong in TODO 3: rounds instead of
truncating.`` or ``Right: the error term kept doubled.``), then the diff::

    Wrong in TODO 1: math.floor goes down for negative values.
    --- solution.py
    +++ floors.py
    @@ -26,2 +26,2 @@
    -    x = math.trunc(radius_mm * math.sin(angle) * kt)
    +    x = math.floor(radius_mm * math.sin(angle) * kt)

A hunk is found by its exact old lines (context and removed lines), nearest to the line number its
header gives, so a change elsewhere in ``solution.py`` moves it without breaking it; a hunk whose
old lines are not in the file, or sit at two places equally near, is an error naming the patch and
the hunk. :func:`materialise` writes the patched file (named ``NAME.py``) into a folder of its own,
beside links to the lab's data files, so the variant is checked like any student's file.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError

_HUNK = re.compile(r"^@@ -(\d+)(?:,(\d+))? \+(\d+)(?:,(\d+))? @@")
_DESCRIPTION = re.compile(r"^(Wrong in TODO (\d+)|Right): \S.*\.$")
#: what a variant's folder of its own gets besides the variant: the lab's data, never its code or notes
_NOT_DATA = {"wrong", "right", "out", "__pycache__", ".ipynb_checkpoints", "teacher.md"}


@dataclass(frozen=True)
class Hunk:
    """One hunk: where it claims to start (1-based, in the old file), the old lines and the new lines."""

    line: int           # the patch's header line number, for error messages
    start: int
    old: tuple[str, ...]
    new: tuple[str, ...]


@dataclass(frozen=True)
class Variant:
    """One patch file: its description line, the TODO a wrong variant gets wrong (0 for a right one), its hunks."""

    path: Path
    description: str
    todo: int
    hunks: tuple[Hunk, ...]

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def right(self) -> bool:
        return self.todo == 0


def read_variant(path: str | Path) -> Variant:
    """Parse a variant's patch file; errors name the file, the line and what is accepted."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    if not lines or not _DESCRIPTION.match(lines[0]):
        raise ConfigError(f"{path}:1: the first line must say what the variant does, as "
                          "'Wrong in TODO n: <the mistake>.' or 'Right: <how it differs>.'")
    match = _DESCRIPTION.match(lines[0])
    hunks, k = [], 1
    while k < len(lines) and not lines[k].startswith("@@"):
        if not lines[k].startswith(("--- ", "+++ ")) and lines[k].strip():
            raise ConfigError(f"{path}:{k + 1}: {lines[k]!r}: only the '--- ' and '+++ ' lines may come before the "
                              "first '@@' hunk")
        k += 1
    while k < len(lines):
        hunk, k = _read_hunk(path, lines, k)
        hunks.append(hunk)
    if not hunks:
        raise ConfigError(f"{path}: no hunk; a variant is the reference solution with a change (a '@@' hunk)")
    return Variant(path, lines[0], int(match[2] or 0), tuple(hunks))


def _read_hunk(path: Path, lines: list[str], k: int) -> tuple[Hunk, int]:
    header = _HUNK.match(lines[k])
    if not header:
        raise ConfigError(f"{path}:{k + 1}: {lines[k]!r}: expected a hunk header '@@ -a,b +c,d @@'")
    want_old = int(header[2]) if header[2] is not None else 1
    want_new = int(header[4]) if header[4] is not None else 1
    old, new, first = [], [], k + 1
    k += 1
    while k < len(lines) and (len(old) < want_old or len(new) < want_new):
        text = lines[k]
        tag, body = (text[:1], text[1:]) if text else (" ", "")
        if tag == "\\":                      # '\ No newline at end of file'
            k += 1
            continue
        if tag not in " -+":
            raise ConfigError(f"{path}:{k + 1}: {text!r}: a hunk line starts with ' ', '-' or '+'")
        if tag in " -":
            old.append(body)
        if tag in " +":
            new.append(body)
        k += 1
    if (len(old), len(new)) != (want_old, want_new):
        raise ConfigError(f"{path}:{first}: the hunk has {len(old)} old and {len(new)} new lines; its header "
                          f"says {want_old} and {want_new}")
    while k < len(lines) and lines[k].startswith("\\"):
        k += 1
    return Hunk(first, int(header[1]), tuple(old), tuple(new)), k


def apply_variant(variant: Variant, source: str) -> str:
    """The reference ``source`` with the variant's hunks applied (each found by its old lines)."""
    lines = source.splitlines()
    out: list[str] = []
    at, shift = 0, 0                        # next unread line of the source; how far hunks moved so far
    for hunk in variant.hunks:
        place = _find(variant.path, hunk, lines, at, hunk.start - 1 + shift)
        shift = place - (hunk.start - 1)
        out += lines[at:place] + list(hunk.new)
        at = place + len(hunk.old)
    out += lines[at:]
    return "\n".join(out) + "\n"


def _find(path: Path, hunk: Hunk, lines: list[str], lowest: int, wanted: int) -> int:
    """Where the hunk's old lines are, at or after ``lowest``, nearest to ``wanted``."""
    size = len(hunk.old)
    if size == 0:                           # pure insertion: trust the line number
        return min(max(wanted, lowest), len(lines))
    places = [i for i in range(lowest, len(lines) - size + 1) if tuple(lines[i:i + size]) == hunk.old]
    if not places:
        raise ConfigError(f"{path}:{hunk.line}: the hunk's old lines are no longer in solution.py (first of them: "
                          f"{hunk.old[0]!r}); re-make the variant from the solution as it is now")
    places.sort(key=lambda i: abs(i - wanted))
    if len(places) > 1 and abs(places[0] - wanted) == abs(places[1] - wanted):
        raise ConfigError(f"{path}:{hunk.line}: the hunk's old lines are at lines {places[0] + 1} and "
                          f"{places[1] + 1} of solution.py, as near as each other; give it more context")
    return places[0]


def make_variant(description: str, reference: str, changed: str, name: str, context: int = 2) -> str:
    """The patch file text for ``changed`` against ``reference`` (``solution.py``)."""
    if not _DESCRIPTION.match(description):
        raise ConfigError(f"{description!r}: say 'Wrong in TODO n: <the mistake>.' or 'Right: <how it differs>.'")
    diff = difflib.unified_diff(reference.splitlines(), changed.splitlines(), "solution.py", f"{name}.py",
                                n=context, lineterm="")
    body = list(diff)
    if not body:
        raise ConfigError(f"{name}: the same as solution.py; a variant must change something")
    return "\n".join([description, *body]) + "\n"


def variants(lab_path: str | Path, kind: str = "wrong") -> list[Variant]:
    """Every ``*.patch`` in the lab's ``wrong/`` (or ``right/``) folder, by name."""
    return [read_variant(p) for p in sorted((Path(lab_path) / kind).glob("*.patch"))]


def materialise(lab_path: str | Path, variant: Variant, folder: str | Path) -> Path:
    """Write the variant as ``folder/NAME.py`` beside links to the lab's data files; return its path."""
    lab_path, folder = Path(lab_path), Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    reference = (lab_path / "solution.py").read_text(encoding="utf-8")
    target = folder / f"{variant.name}.py"
    target.write_text(apply_variant(variant, reference), encoding="utf-8")
    for entry in lab_path.iterdir():
        if (entry.name in _NOT_DATA or entry.name.startswith(".") or entry.suffix in (".py", ".md", ".ini")
                or (folder / entry.name).exists()):        # (a dot folder is a tool's cache, not data)
            continue
        (folder / entry.name).symlink_to(entry.resolve(), target_is_directory=entry.is_dir())
    return target
