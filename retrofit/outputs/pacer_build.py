"""Builds and loads the compiled paced writer (``pacer_c.c``) the first time a port is paced.

The shared library is compiled with the system C compiler (``$CC``, else ``gcc``) into the
user's cache folder (``$XDG_CACHE_HOME/retrofit``, else ``~/.cache/retrofit``), named after a
hash of the source and the compiler, so a changed source is rebuilt and an unchanged one is
loaded as is. Nothing is built for users who never pace a port. When it cannot be built, the
caller gets the reason and paces with the Python loop instead.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..motion._aot import cache_dir

SOURCE = Path(__file__).with_name("pacer_c.c")
_loaded: dict[str, ctypes.CDLL] = {}


class BuildError(Exception):
    """The compiled writer could not be built or loaded (the message says why)."""


def compiler() -> str:
    return os.environ.get("CC") or "gcc"


def library_path(source: Path = SOURCE) -> Path:
    """Where the library of this source, built by this compiler, is cached."""
    digest = hashlib.sha256(source.read_bytes() + compiler().encode()).hexdigest()[:16]
    return cache_dir() / f"pacer_c-{digest}-{platform.machine()}.so"


def build(source: Path = SOURCE) -> Path:
    """Compile ``source`` into the cache (unless already there); return the library's path."""
    target = library_path(source)
    if target.exists():
        return target
    cc = shutil.which(compiler())
    if cc is None:
        raise BuildError(f"no C compiler: {compiler()!r} not found on PATH (install gcc, or set CC)")
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".so", dir=target.parent)
    os.close(fd)
    try:
        done = subprocess.run([cc, "-O2", "-shared", "-fPIC", "-o", tmp, str(source)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            lines = done.stderr.strip().splitlines() or ["no message"]
            first = next((line for line in lines if "error" in line), lines[0])
            raise BuildError(f"{compiler()} failed to build {source.name} (exit {done.returncode}): {first}")
        os.replace(tmp, target)             # atomic: a concurrent build never loads half a file
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return target


def load(source: Path = SOURCE) -> ctypes.CDLL:
    """The compiled writer, built at first use; raises BuildError saying why it is not available."""
    key = str(library_path(source))
    if key not in _loaded:
        try:
            lib = ctypes.CDLL(str(build(source)), use_errno=True)
        except OSError as exc:
            raise BuildError(f"cannot load the compiled writer: {exc}") from None
        i64, p = ctypes.c_int64, ctypes.c_void_p
        lib.retrofit_now_ns.restype, lib.retrofit_now_ns.argtypes = i64, []
        lib.retrofit_pace.restype = i64
        lib.retrofit_pace.argtypes = [p, p, i64, i64, i64, i64, ctypes.c_int, ctypes.c_int, p, p]
        _loaded[key] = lib
    return _loaded[key]
