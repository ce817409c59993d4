"""Kernels compiled ahead of time: one extension module a run loads without Numba.

``retrofit kernels`` (:mod:`retrofit.motion._aot_build`) has Numba compile every kernel, for
every argument type its cache on disk holds, into one extension module in the user's cache
folder, next to a table of what it holds. A compiled run then loads that module (milliseconds)
instead of Numba and its cached kernels (0.2 s of CPU); the machine code comes from the same
compiler, for the same CPU, on the same Python source, without fast-math, so the numbers are
the same. (Unlike Numba's kernels, these hold the GIL while they run.)

The module is used only while it is current: built by this Python, NumPy and Numba, on this CPU,
from kernel modules whose source is unchanged (each checked against its hash in the table). Each
kernel becomes a guard that calls the compiled function whose argument types are exactly those
of the call (dtype, dimensions, layout, writability, as Numba would type them); any other call,
like any kernel the module lacks, hands the whole process over to Numba's just-in-time kernels."""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import platform
import re
import sys
from pathlib import Path
from typing import cast

import numpy as np

NAME = "retrofit_kernels"
TABLE = "table.json"
_SCALARS = {bool: "bool", int: "int64", float: "float64"}


def cache_dir() -> Path:
    """retrofit's folder of built things: $XDG_CACHE_HOME/retrofit (~/.cache/retrofit)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "retrofit"


def folder() -> Path:
    """Where this Python, NumPy and Numba keep their ahead-of-time kernels."""
    numba = importlib.util.find_spec("numba")
    version = Path(numba.origin).with_name("_version.py").read_bytes() if numba and numba.origin else b""
    digest = hashlib.sha256(sys.version.encode() + np.__version__.encode() + version).hexdigest()[:16]
    return cache_dir() / f"kernels-{digest}-{platform.machine()}"


def module_hash(name: str) -> str | None:
    """Hash of a ``retrofit`` module's source, found without importing its package; None: no such file."""
    path = Path(__file__).parents[1].joinpath(*name.split(".")[1:]).with_suffix(".py")
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def cpu_identity() -> str:
    """This machine's CPU (vendor, model, instruction sets): the module is built for it alone."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as fh:
            first = fh.read(1 << 16).split("\n\n", 1)[0]
    except OSError:
        return f"{platform.machine()} {platform.processor()}"
    keep = ("vendor_id", "cpu family", "model", "flags")
    lines = [line for line in first.splitlines() if line.split(":")[0].strip() in keep]
    return hashlib.sha256("\n".join(lines).encode()).hexdigest()[:16]


def kernel_name(func) -> str:
    return f"{func.__module__}:{func.__qualname__}"


def joined(parts: list[str | None], sep: str) -> str | None:
    """The described parts joined by ``sep``, or None when one has no description (no kernel takes it)."""
    return None if None in parts else sep.join(cast("list[str]", parts))


def describe(value) -> str | None:
    """How Numba would type ``value`` as an argument, as a string; None for what this cannot say."""
    kind = _SCALARS.get(type(value))
    if kind is not None:
        return kind if kind != "int64" or -2**63 <= value < 2**63 else None
    if type(value) is np.ndarray:             # every guarded call: the answer kept per kind of array
        key = (value.dtype, value.ndim, value.flags.num)
        said = _ARRAYS.get(key, _ARRAYS)
        if said is _ARRAYS:
            said = _ARRAYS[key] = _describe_array(value)
        return said
    if isinstance(value, np.generic):
        return _dtype_name(value.dtype) or None
    if type(value) is tuple:
        parts = joined([describe(v) for v in value], ",")
        return None if parts is None else f"({parts})"
    if value is None:
        return "none"
    return None


#: :func:`describe` of an array by (dtype, dimensions, flags): its type follows from these alone
_ARRAYS: dict = {}


def _describe_array(value: np.ndarray) -> str | None:
    name, flags = _dtype_name(value.dtype), value.flags
    if not (name and flags.aligned):
        return None
    layout = "C" if flags.c_contiguous else "F" if flags.f_contiguous else "A"
    return f"{name}[{value.ndim}{layout}{'' if flags.writeable else 'r'}]"


_NAMES: dict = {}


def _dtype_name(dtype) -> str:
    """Numba's name for a native boolean, integer or float dtype (bool, int64...), else ''."""
    name = _NAMES.get(dtype)
    if name is None:
        name = _NAMES[dtype] = dtype.name if dtype.isnative and dtype.kind in "biuf" else ""
    return name


def describe_type(t) -> str | None:
    """:func:`describe` for a Numba type (what the build knows), None for any other kind."""
    from numba.core import types
    if isinstance(t, types.Array):
        if not t.aligned or not isinstance(t.dtype, (types.Integer, types.Float, types.Boolean)):
            return None
        return f"{t.dtype.name}[{t.ndim}{t.layout}{'r' if not t.mutable else ''}]"
    if isinstance(t, types.Boolean):
        return "bool"
    if isinstance(t, (types.Integer, types.Float)):
        return t.name
    if isinstance(t, types.BaseTuple) and not isinstance(t, types.BaseNamedTuple):
        parts = joined([describe_type(v) for v in t.types], ",")  # type: ignore[attr-defined]  # Numba: every tuple has it
        return None if parts is None else f"({parts})"
    if isinstance(t, types.NoneType):
        return "none"
    return None


class Library:
    """A loaded ahead-of-time module: :meth:`guard` makes a kernel's stand-in."""

    def __init__(self, module, kernels: dict):
        self.module, self.kernels = module, kernels

    def guard(self, func, on_miss):
        """What modules call instead of ``func``: the exact compiled match, else ``on_miss(func)``."""
        exports = {tuple(key.split("|")) if key else (): getattr(self.module, name)
                   for key, name in self.kernels.get(kernel_name(func), {}).items()}

        def call(*args, **named):
            compiled = None
            if not named:
                key = tuple(map(describe, args))
                compiled = exports.get(key)
                if compiled is None and None not in key:
                    compiled = exports[key] = _any_layout(exports, key)
            if compiled is None:
                return on_miss(func)(*args, **named)
            return compiled(*args)
        call.__name__, call.__qualname__, call.__doc__ = func.__name__, func.__qualname__, func.__doc__
        call.__module__, call.__wrapped__, call.py_func = func.__module__, func, func   # py_func: as Numba's
        call.exports = exports          # empty: every call hands the process over to Numba's JIT
        return call


def _any_layout(exports: dict, key: tuple):
    """The export built for any layout (``A``) of the arrays ``key`` has as contiguous ones: a column
    of a one-row window is C-contiguous, the same column of a longer one is not."""
    for built, compiled in exports.items():
        if len(built) == len(key) and all(b == k or (b.endswith("A]") or b.endswith("Ar]")) and
                                          re.sub(r"[CF](r?\])$", r"A\1", k) == b
                                          for b, k in zip(built, key)):
            return compiled
    return None


def load() -> Library | None:
    """The current ahead-of-time module, None where there is none (or it is out of date)."""
    try:
        table = json.loads((folder() / TABLE).read_text())
        if table["cpu"] != cpu_identity() or any(module_hash(name) != digest
                                                 for name, digest in table["modules"].items()):
            return None
        path = folder() / table["file"]
        loader = importlib.machinery.ExtensionFileLoader(NAME, str(path))
        spec = importlib.util.spec_from_file_location(NAME, path, loader=loader)
        assert spec is not None                   # a loader is given: there is always a spec
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except (OSError, ValueError, KeyError, ImportError):
        return None
    return Library(module, table["kernels"])
