"""The one place the compiler is fenced off: ``kernel`` compiles with Numba when it is installed.

Without Numba every kernel stays a plain Python function: slower, but giving the same numbers
(the kernels use only IEEE-754 arithmetic, ``math.sqrt``, ``math.exp`` and ``math.log``).
Compiled kernels are cached on disk, so the compile cost is paid once per machine.
"""

from __future__ import annotations

import os

try:
    if os.environ.get("RETROFIT_NO_NUMBA"):
        raise ImportError("RETROFIT_NO_NUMBA is set")
    from numba import njit as _njit
    HAVE_NUMBA = True
except ImportError:            # pragma: no cover - exercised by the no-numba test run
    _njit = None
    HAVE_NUMBA = False


def kernel(func):
    """Compile ``func`` with Numba (no fastmath, cached) when available; else return it as is."""
    if _njit is None:
        return func
    return _njit(cache=True, nogil=True)(func)
