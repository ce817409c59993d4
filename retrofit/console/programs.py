"""The programs the console may open: the shipped examples and the files of one folder (``--programs``).

A request names a program; the name is looked up in the list of files the console offers and is
never handed to the file system. A name not in the list (an absolute path, ``../``, a link that
leads out of the folder, ``/proc/self/environ``, a file that does not exist) gets one and the
same refusal, which says nothing of whether such a file exists.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from .schema import PROGRAM_BYTES, BadRequest

#: what a program file may end with
SUFFIXES = (".ngc", ".nc", ".tap", ".txt", ".cmds")
#: the most files of the programs folder the console lists
MAX_FILES = 2000
REFUSAL = ("no such program: open one the console lists (GET /api/machine: examples, programs) "
           "or upload its text")


def examples() -> dict[str, Path]:
    folder = resources.files("retrofit") / "examples"
    return {p.name: Path(str(p)) for p in folder.iterdir() if p.name.endswith(".ngc")}


class ProgramFolder:
    """The examples plus the program files under ``root`` (None: the examples only)."""

    def __init__(self, root: str | Path | None = None):
        self.root = Path(root).resolve() if root is not None else None
        if self.root is not None and not self.root.is_dir():
            raise BadRequest(f"--programs {root}: not a folder")

    def listing(self) -> dict[str, Path]:
        """name -> file: the examples, then the folder's files by their path inside it (a link
        counts only if it stays inside the folder)."""
        files = examples()
        if self.root is None:
            return files
        found = 0
        for top, dirs, names in os.walk(self.root):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            for name in sorted(names):
                path = Path(top) / name
                if name.startswith(".") or not name.endswith(SUFFIXES) or not self._inside(path):
                    continue
                files[path.relative_to(self.root).as_posix()] = path
                found += 1
                if found >= MAX_FILES:
                    return files
        return files

    def programs(self) -> list[str]:
        """The names of the folder's files (not the examples)."""
        shipped = examples()
        return sorted(n for n, p in self.listing().items() if shipped.get(n) != p)

    def read(self, name: str) -> tuple[str, str]:
        """(text, name) of a listed program; the one refusal (status 404) for anything else."""
        path = self.listing().get(name)
        if path is None or not (self._inside(path) or path == examples().get(name)):
            raise BadRequest(REFUSAL, status=404)
        try:
            with open(path, "rb") as f:
                data = f.read(PROGRAM_BYTES + 1)
        except OSError:
            raise BadRequest(REFUSAL, status=404) from None
        if len(data) > PROGRAM_BYTES:
            raise BadRequest(f"{name}: longer than {PROGRAM_BYTES} bytes, the most the console opens", status=413)
        return data.decode(errors="replace"), Path(name).name

    def _inside(self, path: Path) -> bool:
        """True for a regular file whose real path lies inside the folder."""
        if self.root is None:
            return False
        try:
            real = path.resolve(strict=True)
        except (OSError, RuntimeError):
            return False
        return real.is_file() and real.is_relative_to(self.root)
