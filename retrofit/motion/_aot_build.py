"""Builds the ahead-of-time kernel module (``retrofit kernels``): Numba's ``pycc`` on every kernel.

The argument types come from Numba's own cache: first a few shipped runs (the lathe through the
controller and the fast path, the engraver, with ``vcd://``) with the just-in-time kernels, which
fills the cache for the common types, then every kernel's cache index, which also holds the types
of any earlier run on this machine. Each (kernel, types) pair becomes one exported function; the
table beside the module says which, and the hash of every kernel module's source.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.machinery
import io
import json
import os
import tempfile
import warnings
from pathlib import Path
from typing import Any

from . import _aot, _jit

#: the runs that fill Numba's cache before the build: (program, machine, extra arguments)
WARM_UP: tuple[tuple[str, str, list[str]], ...] = (("lathe-profile.ngc", "chivu-lathe", ["--controller"]),
           ("lathe-profile.ngc", "chivu-lathe", []),
           ("engraving.ngc", "engraver", []))


def kernel_modules() -> list[str]:
    """Every ``retrofit`` module that defines kernels (a line of its source is ``@kernel``)."""
    root = Path(_aot.__file__).parents[1]
    names = []
    for path in sorted(root.rglob("*.py")):
        if path.name != "_jit.py" and "\n@kernel\n" in path.read_text(encoding="utf-8"):
            parts = path.relative_to(root.parent).with_suffix("").parts
            names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def warm_up(folder: Path, main) -> None:
    """The shipped runs, with the just-in-time kernels, whatever their size; ``main`` is the
    command line's (``retrofit.cli.main``), handed down so motion imports nothing above it."""
    for i, (program, machine, extra) in enumerate(WARM_UP):
        argv = ["run", program, "--machine", machine, "--output", "sim://", "--output",
                f"vcd://{folder / f'w{i}.vcd'}", "--tool-table", str(folder / f"t{i}.tbl"),
                "--progress", "off", "--allow-violations"] + extra
        with contextlib.redirect_stdout(io.StringIO()):
            main(argv)


def signatures(dispatcher) -> list:
    """The argument types of ``dispatcher``: compiled in this process or held by its disk cache."""
    cache = dispatcher._cache
    codegen = dispatcher.targetctx.codegen()
    held = [key[0] for key in cache._cache_file._load_index()
            if cache._index_key(key[0], codegen) == key]
    return list(dict.fromkeys(list(dispatcher.signatures) + held))


def build(main, progress=print) -> Path:
    """Compile every kernel for every argument type known, after the warm-up runs of ``main``
    (``retrofit.cli.main``); the module's folder."""
    os.environ["RETROFIT_NO_AOT"] = "1"          # this process runs Numba's own kernels
    for name in kernel_modules():
        importlib.import_module(name)
    _jit.to_jit()
    with tempfile.TemporaryDirectory() as scratch:
        warm_up(Path(scratch), main)
        progress("warm-up runs done; compiling the kernels ahead of time")
        return _compile(Path(scratch))


def _compile(scratch: Path) -> Path:
    import llvmlite.binding as llvm
    from numba.pycc import CC
    cc = CC(_aot.NAME)
    cc.output_dir = str(scratch)
    cc.target_cpu = llvm.get_host_cpu_name()          # as Numba's JIT does: this machine's CPU
    kernels = _exports(cc)
    modules = sorted({func.__module__ for func in _jit._kernels.values()})
    table = {"cpu": _aot.cpu_identity(), "modules": {m: _aot.module_hash(m) for m in modules}, "kernels": kernels}
    stamp = "kernels-" + hashlib.sha256(json.dumps(table, sort_keys=True).encode()).hexdigest()[:16]
    cc.output_file = table["file"] = stamp + importlib.machinery.EXTENSION_SUFFIXES[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                # pycc's pending deprecation
        cc.compile()
    folder = _aot.folder()
    folder.mkdir(parents=True, exist_ok=True)
    os.replace(scratch / cc.output_file, folder / cc.output_file)
    tmp = folder / f"{_aot.TABLE}.{stamp}"
    tmp.write_text(json.dumps(table, indent=1))
    os.replace(tmp, folder / _aot.TABLE)
    for old in folder.glob("kernels-*"):             # modules of earlier builds
        if old.name != cc.output_file:
            old.unlink(missing_ok=True)
    return folder


def _exports(cc) -> dict[str, dict[str, str]]:
    """Mark every (kernel, argument types) for export; the table: kernel -> types -> export name."""
    kernels: dict[str, dict[str, str]] = {}
    ordered = sorted(_jit._kernels.items(), key=lambda item: _aot.kernel_name(item[1]))
    for n, (key, func) in enumerate(ordered):
        dispatcher: Any = _jit._current[key]           # a Numba dispatcher (to_jit() ran)
        for m, sig in enumerate(signatures(dispatcher)):
            described = _aot.joined([_aot.describe_type(t) for t in sig], "|")
            if described is None:
                continue
            dispatcher.compile(sig)
            export = f"k{n}_{m}"
            cc.export(export, dispatcher.overloads[sig].signature)(func)
            kernels.setdefault(_aot.kernel_name(func), {})[described] = export
    return kernels
