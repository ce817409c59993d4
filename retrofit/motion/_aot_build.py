"""Builds the ahead-of-time kernel module (``retrofit kernels``): Numba's ``pycc`` on every kernel.

The argument types come from Numba's own cache: first a few shipped runs (the lathe through the
controller and the fast path, the engraver, with ``vcd://``) with the just-in-time kernels, which
fills the cache for the common types, then every kernel's cache index, which also holds the types
of any earlier run on this machine. Each (kernel, types) pair becomes one exported function; the
table beside the module says which, and the hash of every kernel module's source.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.machinery
import io
import json
import os
import pkgutil
import tempfile
import time
import warnings
from pathlib import Path

from . import _aot, _jit

#: the runs that fill Numba's cache before the build: (program, machine, extra arguments)
WARM_UP = (("lathe-profile.ngc", "chivu-lathe", ["--controller"]),
           ("lathe-profile.ngc", "chivu-lathe", []),
           ("engraving.ngc", "engraver", []))


def kernel_modules() -> list[str]:
    """Every ``retrofit`` module that defines kernels (its source holds ``@kernel``)."""
    import retrofit
    names = []
    for info in pkgutil.walk_packages(retrofit.__path__, "retrofit."):
        spec = importlib.util.find_spec(info.name)
        if spec and spec.origin and spec.origin.endswith(".py") and not info.name.endswith("._jit"):
            if "\n@kernel\n" in Path(spec.origin).read_text(encoding="utf-8"):
                names.append(info.name)
    return names


def warm_up(folder: Path) -> None:
    """The shipped runs, with the just-in-time kernels, whatever their size."""
    from ..cli import main
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


def build(progress=print) -> Path:
    """Compile every kernel for every argument type known; the module's folder."""
    os.environ["RETROFIT_NO_AOT"] = "1"          # this process runs Numba's own kernels
    for name in kernel_modules():
        importlib.import_module(name)
    _jit.to_jit()
    with tempfile.TemporaryDirectory() as scratch:
        warm_up(Path(scratch))
        progress("warm-up runs done; compiling the kernels ahead of time")
        return _compile(Path(scratch))


def _compile(scratch: Path) -> Path:
    import llvmlite.binding as llvm
    from numba.pycc import CC
    stamp = f"{NAME_PREFIX}{time.time_ns():x}"
    cc = CC(_aot.NAME)
    cc.output_dir = str(scratch)
    cc.target_cpu = llvm.get_host_cpu_name()          # as Numba's JIT does: this machine's CPU
    cc.output_file = stamp + importlib.machinery.EXTENSION_SUFFIXES[0]
    kernels: dict[str, dict[str, str]] = {}
    for n, (key, func) in enumerate(sorted(_jit._kernels.items(), key=lambda kv: _aot.kernel_name(kv[1]))):
        dispatcher = _jit._current[key]
        for m, sig in enumerate(signatures(dispatcher)):
            described = [_aot.describe_type(t) for t in sig]
            if None in described:
                continue
            dispatcher.compile(sig)
            export = f"k{n}_{m}"
            cc.export(export, dispatcher.overloads[sig].signature)(func)
            kernels.setdefault(_aot.kernel_name(func), {})["|".join(described)] = export
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cc.compile()
    folder = _aot.folder()
    folder.mkdir(parents=True, exist_ok=True)
    os.replace(scratch / cc.output_file, folder / cc.output_file)
    modules = sorted({func.__module__ for func in _jit._kernels.values()})
    table = {"file": cc.output_file, "cpu": _aot.cpu_identity(), "modules": {m: _aot.module_hash(m) for m in modules}, "kernels": kernels}
    tmp = folder / f"{_aot.TABLE}.{stamp}"
    tmp.write_text(json.dumps(table, indent=1))
    os.replace(tmp, folder / _aot.TABLE)
    for old in folder.glob(f"{NAME_PREFIX}*"):
        if old.name != cc.output_file:
            old.unlink(missing_ok=True)
    return folder


NAME_PREFIX = "kernels-"
