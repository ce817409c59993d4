"""Kernels compiled ahead of time: taken only for the exact argument types, else Numba's JIT.

A compiled function given an array it was not compiled for does not refuse it: it can convert
it, or read a strided array as if it were contiguous (wrong numbers, no error). So every call
goes through a guard that types the arguments as Numba would; these tests hold that typing to
Numba's own ``typeof``, check the guard's choices, the hand-over to Numba's JIT on a miss, and
(slow) that runs with a built module give the same report and VCD bytes as Numba's kernels and
the Python ones, without importing Numba at all.
"""

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from retrofit.motion import _aot
from retrofit.motion._jit import HAVE_NUMBA

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="Numba is not installed")


def values():
    a = np.arange(12, dtype=np.int64)
    ro = np.zeros(3)
    ro.flags.writeable = False
    return [0, -5, 2**62, 1.5, True, False, None, np.int8(3), np.float32(2.5), np.uint8(7), np.bool_(True),
            a, a[::2], a.reshape(3, 4), a.reshape(3, 4).T, a.reshape(3, 4)[:, 1:], ro,
            np.zeros(4, np.uint8), np.zeros(4, np.int8), np.zeros((2, 2), np.bool_), np.zeros(5, np.float32),
            np.zeros(0), np.zeros((0, 3), np.int64), (1, 2, 3), (1, 2.0), (a, 4), ((1, 2), 3.0)]


@needs_numba
def test_the_guard_types_arguments_as_numba_does():
    from numba import typeof
    for v in values():
        assert _aot.describe(v) == _aot.describe_type(typeof(v)), repr(v)


def test_what_the_guard_cannot_type_is_a_miss():
    odd = [2**64, np.zeros(3, ">f8"), np.zeros(3, np.complex128), [1, 2], "text", {1: 2},
           np.zeros(3, [("a", "i4")]), (1, [2])]
    assert [_aot.describe(v) for v in odd] == [None] * len(odd)


def test_the_guard_calls_the_export_of_the_exact_types_and_hands_any_other_call_on():
    def add(a, n):
        return a[0] + n
    add.__module__ = "retrofit.example"
    module = SimpleNamespace(k0_0=lambda a, n: ("compiled", a[0] + n))
    library = _aot.Library(module, {"retrofit.example:" + add.__qualname__: {"int64[1C]|int64": "k0_0"}})
    missed = []

    def on_miss(func):
        missed.append(func)
        return func
    guard = library.guard(add, on_miss)
    a = np.arange(6, dtype=np.int64)
    assert guard(a, 2) == ("compiled", 2)
    assert guard.py_func is add and guard.__name__ == "add"
    ro = a.copy()
    ro.flags.writeable = False
    for args in [(a[::2], 2), (a.astype(np.float64), 2), (a, 2.0), (ro, 2), (a.astype(np.int32), 2)]:
        assert guard(*args) == args[0][0] + args[1]           # the Python function answered
    assert guard(a, n=2) == 2                                # by name: the Python function
    assert missed == [add] * 6


def test_a_contiguous_column_takes_the_export_built_for_any_layout():
    # a window of one move makes counts[:, a] C-contiguous; the export is built for the 'A' layout
    # of longer windows, which Numba's 'A' code also takes: it must answer, not load Numba
    def first(a):
        return a[0]
    first.__module__ = "retrofit.example"
    module = SimpleNamespace(k0_0=lambda a: ("compiled", a[0]))
    library = _aot.Library(module, {"retrofit.example:" + first.__qualname__: {"int64[1A]": "k0_0"}})
    missed = []
    guard = library.guard(first, lambda func: missed.append(func) or func)
    counts = np.arange(6, dtype=np.int64).reshape(3, 2)
    one_row = counts[:1]
    assert _aot.describe(counts[:, 1]) == "int64[1A]" and _aot.describe(one_row[:, 1]) == "int64[1C]"
    assert guard(counts[:, 1]) == ("compiled", 1) and guard(one_row[:, 1]) == ("compiled", 1)
    assert guard(counts[:, 1].astype(np.int32)) == 1 and missed == [first]   # another type: a miss


SWITCH = '''
import importlib.util, json, sys
import numpy as np
from types import SimpleNamespace
from retrofit.motion import _aot, _jit
spec = importlib.util.spec_from_file_location("retrofit.kernels_under_test", "kernels_under_test.py")
k = sys.modules[spec.name] = importlib.util.module_from_spec(spec)
spec.loader.exec_module(k)
fake = SimpleNamespace(k0_0=lambda a, n: -1.0)          # stands for the compiled export
_aot.load = lambda: _aot.Library(fake, {"retrofit.kernels_under_test:total": {"float64[1C]|int64": "k0_0"}})
assert _jit.compiled()
seen = {"guard": not hasattr(k.total, "signatures") and k.total.py_func.__name__ == "total"}
a = np.linspace(0.0, 1.0, 11)
seen["exact"] = k.total(a, 3)                          # the export
seen["numba_before_miss"] = "numba" in sys.modules
seen["miss"] = k.total(a[::2], 3)                      # strided: Numba's JIT from now on
seen["after"] = k.total(a, 3)
seen["dispatcher"] = hasattr(k.total, "signatures")
seen["python_miss"] = k.total.py_func(a[::2], 3)
seen["python_after"] = k.total.py_func(a, 3)
print(json.dumps(seen))
'''

KERNEL = '''
from retrofit.motion._jit import kernel


@kernel
def total(a, n):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * n
    return s
'''


@needs_numba
def test_a_miss_hands_every_kernel_to_numba(tmp_path):
    (tmp_path / "kernels_under_test.py").write_text(KERNEL)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), RETROFIT_NUMBA="", RETROFIT_NO_AOT="")
    proc = subprocess.run([sys.executable, "-c", SWITCH], capture_output=True, text=True, env=env, cwd=tmp_path,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert seen["guard"] and seen["exact"] == -1.0 and not seen["numba_before_miss"]
    assert seen["dispatcher"]                             # the module's name now names Numba's kernel
    assert seen["miss"] == seen["python_miss"] and seen["after"] == seen["python_after"]
    assert seen["after"] != -1.0                          # the export is no longer called


def run(args: list[str], env: dict, cwd: Path) -> str:
    code = ("import sys; from retrofit.cli import main; code = main(sys.argv[1:]); "
            "print('numba imported' if 'numba' in sys.modules else 'no numba', file=sys.stderr); sys.exit(code)")
    proc = subprocess.run([sys.executable, "-c", code] + args, capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc.stderr.strip().splitlines()[-1]


SQUARE = ("G21 G90 G17\nG0 X10 Y10\nF3000\n" + "G1 X110 Y10\nG1 X110 Y110\nG1 X10 Y110\n"
          "G1 X10 Y10\nG0 X60 Y45\nG2 X60 Y45 I0 J15\n" + "M2\n")        # Klipper's shape: 60 k steps


@pytest.mark.slow
@needs_numba
@pytest.mark.parametrize("job", [["square.ngc", "--machine", "engraver"], ["lathe-profile.ngc", "--controller"]],
                         ids=["square-engraver", "lathe-profile-controller"])
def test_runs_with_the_built_module_match_numba_and_python_without_loading_numba(tmp_path, job):
    # the module `retrofit kernels` built (the README's set-up; .ci/run builds it on a cold cache and
    # fails when the build does), so no test compiles every kernel again under the stage's limit
    env = dict(os.environ, RETROFIT_NUMBA="")
    status = subprocess.run([sys.executable, "-m", "retrofit.cli", "kernels", "--status"], env=env,
                            capture_output=True, text=True)
    assert status.returncode == 0, f"run `retrofit kernels` first: {status.stdout}{status.stderr}"
    (tmp_path / "square.ngc").write_text(SQUARE)
    # Numba from the first kernel (RETROFIT_NUMBA=always), so a short program still runs compiled code
    modes = {"aot": {}, "jit": {"RETROFIT_NO_AOT": "1", "RETROFIT_NUMBA": "always"}, "python": {"RETROFIT_NO_NUMBA": "1"}}
    seen = {}
    for name, extra in modes.items():
        folder = tmp_path / name
        folder.mkdir()
        program = [str(tmp_path / job[0])] if job[0] == "square.ngc" else [job[0]]
        loaded = run(["run"] + program + job[1:] + ["--output", "sim://", "--output", f"vcd://{folder / 'o.vcd'}",
                                                    "--report", str(folder / "r.json"), "--progress", "off",
                                                    "--allow-violations"], dict(env, **extra), folder)
        seen[name] = ((folder / "r.json").read_text(), (folder / "o.vcd").read_bytes(), loaded)
    assert seen["aot"][2] == "no numba" and seen["jit"][2] == "numba imported"
    assert seen["aot"][:2] == seen["jit"][:2] == seen["python"][:2]
    assert json.loads(seen["aot"][0])["axes"]
