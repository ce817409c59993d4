"""The one place the compiler is fenced off: kernels run as Python, or compiled once the work pays.

Every ``@kernel`` function is plain Python (IEEE-754 arithmetic, ``math.sqrt``, ``math.exp``,
``math.log``), so it gives the same numbers compiled or not. Loading Numba and its cached
machine code costs over a second, more than a small program's whole run, so kernels stay Python
until some stage asks for :func:`compiled` with enough work (``COMPILE_ABOVE`` steps or frames):
then Numba compiles every kernel (cached on disk, so the compile cost is paid once per machine)
and the compiled versions replace the Python ones in every ``retrofit`` module, for the rest of
the process.

``RETROFIT_NO_NUMBA=1`` keeps Python kernels; ``RETROFIT_NUMBA=always`` compiles from the start.
"""

from __future__ import annotations

import importlib.util
import os
import sys

HAVE_NUMBA = (not os.environ.get("RETROFIT_NO_NUMBA")
              and importlib.util.find_spec("numba") is not None)

#: steps (or frames) of work from which a stage switches to compiled kernels
COMPILE_ABOVE = 100_000

_kernels: dict[int, object] = {}     # id(python function) -> python function
_active = False


def kernel(func):
    """Register ``func`` as a kernel: Python until :func:`compiled` switches to Numba."""
    if _active:
        return _njit(func)
    _kernels[id(func)] = func
    return func


def _start_numba() -> None:
    """Load Numba's CPU target now, telling its BLAS check there is none.

    When it first loads a kernel, Numba imports SciPy's linear algebra to see whether ``np.dot``
    could be compiled (0.2 s and 30 MB); no kernel here uses linear algebra, so while the target
    loads SciPy reads as absent (unless something imported it already). SciPy imports normally
    afterwards.
    """
    blocked = "scipy" not in sys.modules
    if blocked:
        sys.modules["scipy"] = None
    try:
        from numba.core.registry import cpu_target
        cpu_target.target_context.refresh()
        cpu_target.typing_context.refresh()
    finally:
        if blocked:
            del sys.modules["scipy"]


def _njit(func):
    from numba import njit
    return njit(cache=True, nogil=True)(func)


def compiled(work: int | None = None) -> bool:
    """True when kernels run compiled; switches to them now if ``work`` (None: any) is large enough."""
    global _active
    if _active or not HAVE_NUMBA:
        return _active
    if work is not None and work < COMPILE_ABOVE:
        return False
    _start_numba()
    table = {key: _njit(func) for key, func in _kernels.items()}
    for name, module in list(sys.modules.items()):
        if not (name == "retrofit" or name.startswith("retrofit.")) or module is None:
            continue
        for attr, value in list(vars(module).items()):
            if id(value) in table and _kernels[id(value)] is value:
                setattr(module, attr, table[id(value)])
    _active = True
    return True


if HAVE_NUMBA and os.environ.get("RETROFIT_NUMBA") == "always":     # pragma: no cover
    _start_numba()
    _active = True
