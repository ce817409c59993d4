"""Numba's start: cached kernels load without its full target refresh, a new kernel still compiles.

Each case runs in fresh processes with an empty Numba cache of its own: the first process
compiles a small kernel (a cache miss: Numba's whole target is needed), the second loads it from
that cache. Both must give the numbers the plain Python kernel gives, bit for bit.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from retrofit.motion._jit import HAVE_NUMBA

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="Numba is not installed")

KERNELS = '''
import math
import numpy as np
from retrofit.motion._jit import kernel


@kernel
def decay(x, rate):
    return math.exp(-rate * x) * math.sqrt(x + 1.0)


@kernel
def table(n, rate):
    out = np.empty(n, np.float64)
    for i in range(n):
        out[i] = decay(i / 7.0, rate)
    return out
'''

RUN = '''
import importlib.util, json, sys
from retrofit.motion import _jit
# a module of the package, as the switch to compiled kernels replaces kernels only there
spec = importlib.util.spec_from_file_location("retrofit.kernels_under_test", "kernels_under_test.py")
k = sys.modules[spec.name] = importlib.util.module_from_spec(spec)
spec.loader.exec_module(k)
python = k.table(50, 0.3).tolist()
assert _jit.compiled()
machine = k.table(50, 0.3).tolist()
print(json.dumps({"python": python, "machine": machine,
                  "full_target": "numba.typed.typeddict" in sys.modules,
                  "scipy": "scipy" in sys.modules,
                  "cache_hits": sum(k.table.stats.cache_hits.values())}))
'''


def run_once(folder: Path) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(folder / "cache"), RETROFIT_NUMBA="", RETROFIT_NO_AOT="1")
    proc = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True, env=env,
                          cwd=folder, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_new_kernel_compiles_then_loads_from_the_cache_with_the_same_numbers(tmp_path):
    (tmp_path / "kernels_under_test.py").write_text(KERNELS)
    first = run_once(tmp_path)                   # compiled here: Numba's whole target loaded
    second = run_once(tmp_path)                  # loaded from the cache written by the first
    assert first["cache_hits"] == 0 and second["cache_hits"] == 1
    assert first["machine"] == first["python"]   # == on floats: bit for bit (no NaN here)
    assert second["machine"] == second["python"] == first["python"]
    assert first["full_target"]                  # compiling needed the full refresh
    assert not second["full_target"]             # loading did without it
    assert not second["scipy"]                   # nor did Numba's BLAS check import SciPy
