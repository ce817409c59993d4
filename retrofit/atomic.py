"""Output files that are either complete or absent: written beside, flushed to disk, renamed.

Every file a run writes (report, plot, VCD, recordings, the spindle record, the tool table) goes
through :func:`staged`: the writer gets a temporary file in the same folder; when it has finished,
the file is flushed to disk (fsync) and renamed over the real name, which is atomic on one file
system. On an error or Ctrl-C the temporary file is removed, so a reader (or a power cut) sees the
old file or the whole new one, never half of one. A file that cannot be written is one
:class:`~retrofit.errors.OutputError` line naming it and the reason.

Links are never written through. The temporary file is created new (``O_EXCL``, a random name,
:func:`tempfile.mkstemp`), so a link planted at a name it may take is stepped over; it is renamed
into place only if it is still the regular file created (a link swapped in for it is refused); and
a link at the real name is replaced by the new file, its target left untouched.

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
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from . import hold
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


def _make_temp(path: Path) -> tuple[Path, os.stat_result]:
    """A new, empty regular file beside ``path`` (O_EXCL: never an existing name or link), with
    the permissions a new file gets (the umask's), and its identity (device, inode)."""
    # the suffix is kept: matplotlib and others choose the format from it
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)
        return Path(name), os.fstat(fd)
    finally:
        os.close(fd)


def _still_ours(tmp: Path, made: os.stat_result) -> None:
    """An OSError unless ``tmp`` is still the regular file :func:`_make_temp` created."""
    now = os.lstat(tmp)
    if not stat.S_ISREG(now.st_mode) or (now.st_dev, now.st_ino) != (made.st_dev, made.st_ino):
        raise OSError(errno.EEXIST, f"the temporary file {tmp.name} was replaced (by a link or "
                                    "another file) while it was written; nothing was renamed")


def check_target(path: Path) -> None:
    """An OutputError when ``path`` cannot be a file: a directory in the way, no such folder."""
    if path.is_dir():
        raise OutputError(f"{path}: cannot write the file: a directory is in the way")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: cannot write the file: folder {path.parent} does not exist")


@contextmanager
def staged(path: str | Path, keep_on_error: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write ``path`` through; rename it into place when the block ends.

    An OSError inside the block or while finishing becomes one OutputError naming ``path``.
    ``keep_on_error``: when the block fails but the writer has written something (a port's
    recording, closed with the byte that stopped the machine last), that is renamed into place
    too, and the error goes on.
    """
    path = Path(path)
    check_target(path)
    try:
        tmp, made = _make_temp(path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {reason(exc)}") from None
    try:
        try:
            if hold.AT:
                hold.hold(f"open {path.name}")
            yield tmp
        except BaseException:
            if keep_on_error:
                _keep(tmp, made, path)
            raise
        _finish(tmp, made, path)
    except OutputError as exc:
        raise OutputError(str(exc).replace(str(tmp), str(path))) from None
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {reason(exc)}") from None
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass


def _finish(tmp: Path, made: os.stat_result, path: Path) -> None:
    _still_ours(tmp, made)
    fsync_file(tmp)
    if hold.AT:
        hold.hold(f"wrote {path.name}")
    os.replace(tmp, path)
    fsync_dir(path.parent)
    WRITTEN.append(path)
    if hold.AT:
        hold.hold(f"renamed {path.name}")


def _keep(tmp: Path, made: os.stat_result, path: Path) -> None:
    """What a failed writer left, put in place when it is not empty (else nothing)."""
    try:
        if os.lstat(tmp).st_size:
            _finish(tmp, made, path)
    except OSError:
        pass                        # the run's own error is the one to report


def fsync_file(path: Path) -> None:
    """Flush a written file's data to the disk."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
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
