"""Output files that are either complete or absent: written beside, flushed to disk, renamed.

Every file a run writes (report, plot, VCD, recordings, the spindle record, the tool table) goes
through :func:`staged`: the writer gets a temporary name in the same folder; when it has finished,
the file is flushed to disk (fsync) and renamed over the real name, which is atomic on one file
system. On an error or Ctrl-C the temporary file is removed, so a reader (or a power cut) sees the
old file or the whole new one, never half of one. A file that cannot be written is one
:class:`~retrofit.errors.OutputError` line naming it and the reason.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> write_text_atomic(folder / "a.txt", "hello\\n")
>>> (folder / "a.txt").read_text(), sorted(p.name for p in folder.iterdir())
('hello\\n', ['a.txt'])
"""

from __future__ import annotations

import errno
import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .errors import OutputError

#: files a command means to write (it declares them with :func:`plan`) and those written so far
PLANNED: list[Path] = []
WRITTEN: list[Path] = []


def plan(paths) -> None:
    """Declare the files this command will write, so an interruption can name those it has not."""
    PLANNED.extend(Path(p) for p in paths)


def not_written() -> list[Path]:
    """Files declared with :func:`plan` that have not been written (completely) yet."""
    return [p for p in PLANNED if p not in WRITTEN]


def reason(exc: OSError) -> str:
    """Why a file could not be written, in words (``disk full``, ``permission denied``, ...)."""
    if exc.errno == errno.ENOSPC:
        return "disk full"
    if exc.errno == errno.EISDIR:
        return "a directory is in the way"
    return (exc.strerror or str(exc)).lower()


def _temp_name(path: Path) -> Path:
    # the suffix is kept: matplotlib and others choose the format from it
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def check_target(path: Path) -> None:
    """An OutputError when ``path`` cannot be a file: a directory in the way, no such folder."""
    if path.is_dir():
        raise OutputError(f"{path}: cannot write the file: a directory is in the way")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: cannot write the file: folder {path.parent} does not exist")


@contextmanager
def staged(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write ``path`` through; rename it into place when the block ends.

    An OSError inside the block or while finishing becomes one OutputError naming ``path``.
    """
    path = Path(path)
    check_target(path)
    tmp = _temp_name(path)
    try:
        yield tmp
        fsync_file(tmp)
        os.replace(tmp, path)
        fsync_dir(path.parent)
        WRITTEN.append(path)
    except OutputError as exc:
        raise OutputError(str(exc).replace(str(tmp), str(path))) from None
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {reason(exc)}") from None
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass


def fsync_file(path: Path) -> None:
    """Flush a written file's data to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(folder: Path) -> None:
    """Flush a folder's entries (a rename) to the disk, where the system allows it."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_text_atomic(path: str | Path, text: str) -> None:
    """Replace ``path`` with ``text`` (UTF-8), complete or not at all."""
    with staged(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json_atomic(path: str | Path, data: dict) -> None:
    """Replace ``path`` with ``data`` as indented JSON, complete or not at all."""
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")
