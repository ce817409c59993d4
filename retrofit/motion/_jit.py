"""The one place the compiler is fenced off: kernels run as Python, or compiled once the work pays.

Every ``@kernel`` function is plain Python (IEEE-754 arithmetic, ``math.sqrt``, ``math.exp``,
``math.log``), so it gives the same numbers compiled or not. Compiled kernels come from one of
two places, switched to by the first stage that asks :func:`compiled`, for the rest of the
process, in every ``retrofit`` module:

* the ahead-of-time module ``retrofit kernels`` builds (:mod:`retrofit.motion._aot`), taken
  whenever it is current, at any size of work: it loads in milliseconds;
* else Numba's just-in-time kernels, once a stage has ``COMPILE_ABOVE`` steps or frames of work:
  loading Numba costs about 0.15 s of CPU, more than a small program's whole run, and each
  kernel then loads its machine code from Numba's cache on disk at its first call (compiled
  there once per machine), so a run pays only for the kernels it calls.

A call the ahead-of-time module has no exact match for hands every kernel to Numba from then on.
``RETROFIT_NO_NUMBA=1`` keeps Python kernels; ``RETROFIT_NO_AOT=1`` never takes the
ahead-of-time module; ``RETROFIT_NUMBA=always`` compiles from the start.
"""

from __future__ import annotations

import contextlib
import gc
import importlib.util
import os
import sys

HAVE_NUMBA = (not os.environ.get("RETROFIT_NO_NUMBA")
              and importlib.util.find_spec("numba") is not None)

#: steps (or frames) of work from which a stage switches to compiled kernels
COMPILE_ABOVE = 100_000

_kernels: dict[int, object] = {}     # id(python function) -> python function
_current: dict[int, object] = {}     # id(python function) -> what modules call now
_active = False                      # kernels run compiled (ahead of time or by Numba's JIT)
_jit = False                         # Numba's just-in-time kernels loaded
_library = None                      # the ahead-of-time module (retrofit.motion._aot); False: none


def kernel(func):
    """Register ``func`` as a kernel: Python until :func:`compiled` switches to compiled code."""
    _kernels[id(func)] = func
    if _jit:
        _current[id(func)] = _njit(func)
    elif _active and _library:
        _current[id(func)] = _library.guard(func, _missed)
    else:
        _current[id(func)] = func
    return _current[id(func)]


def _start_numba() -> None:
    """Make Numba ready to load cached kernels; what only compiling needs waits for a compile.

    Numba refreshes its whole CPU target before it loads a cached kernel: it imports and
    registers the typing and lowering of every builtin, NumPy function, typed container and
    random generator it knows (0.25 s), none of which running cached machine code uses. Here
    the target gets only what a load needs (the runtime that allocates arrays, and NumPy's
    array lowering whose environments the cached kernels refer to), and the full refresh runs
    at the first compile, which always starts by refreshing the typing context. Where Numba's
    internals differ from what this expects, the target is refreshed in full at once.

    The CPU target is loaded with the collector off and its objects frozen: the hundred
    thousand objects Numba makes at start-up are never garbage, so no collection walks them.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        with _without_scipy():
            if not _start_for_cache():
                _refresh_target()
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


@contextlib.contextmanager
def _without_scipy():
    """SciPy reads as absent while Numba's target loads (unless something imported it already).

    When it first loads its array lowering, Numba imports SciPy's linear algebra to see whether
    ``np.dot`` could be compiled (0.2 s and 30 MB); no kernel here uses linear algebra. SciPy
    imports normally afterwards.
    """
    blocked = "scipy" not in sys.modules
    if blocked:
        sys.modules["scipy"] = None
    try:
        yield
    finally:
        if blocked:
            del sys.modules["scipy"]


def _refresh_target() -> None:
    """Numba's full refresh of its CPU target (typing and lowering of everything it knows)."""
    from numba.core.registry import cpu_target
    cpu_target.target_context.refresh()
    cpu_target.typing_context.refresh()


def _start_for_cache() -> bool:
    """Load only what cached kernels need; the full refresh waits for the first compile.

    False (nothing changed) where this Numba lacks the pieces this relies on.
    """
    try:
        import numba.np.arraymath  # noqa: F401  (array lowering, BLAS check)
        from numba.core.registry import cpu_target
        from numba.core.runtime import rtsys
    except ImportError:
        return False
    target, typing = cpu_target.target_context, cpu_target.typing_context
    if not (callable(getattr(target, "refresh", None)) and callable(getattr(typing, "refresh", None))):
        return False
    rtsys.initialize(target)

    def refresh_in_full() -> None:          # the first compile: back to Numba's own refresh
        del target.refresh, typing.refresh
        with _without_scipy():
            _refresh_target()
    target.refresh = _no_refresh
    typing.refresh = refresh_in_full
    return True


def _no_refresh() -> None:
    """A cached kernel's load asks the target to refresh: it has what a load needs."""


def _njit(func):
    from numba import njit
    return njit(cache=True, nogil=True)(func)


def compiled(work: int | None = None) -> bool:
    """True when kernels run compiled; switches to them now if ``work`` (None: any) is large enough.

    The switch takes the ahead-of-time module built by ``retrofit kernels`` where it is current
    (``RETROFIT_NO_AOT=1``: never), at any size of work since it loads in milliseconds; else
    Numba's just-in-time kernels, from ``COMPILE_ABOVE`` steps or frames of work.
    """
    global _active, _library
    if _active or not HAVE_NUMBA:
        return _active
    if _library is None:
        _library = _load_library()
    if _library:
        _install({key: _library.guard(func, _missed) for key, func in _kernels.items()})
        _active = True
    elif work is None or work >= COMPILE_ABOVE:
        to_jit()
    return _active


def _load_library():
    """The current ahead-of-time module, or False (looked for once a process)."""
    if os.environ.get("RETROFIT_NO_AOT"):
        return False
    from . import _aot
    return _aot.load() or False


def to_jit() -> None:
    """Hand every kernel to Numba's just-in-time compiler (loading from its cache) from now on."""
    global _active, _jit
    if _jit:
        return
    _start_numba()
    _install({key: _njit(func) for key, func in _kernels.items()})
    _active = _jit = True


def _missed(func):
    """A call the ahead-of-time module cannot take: Numba's kernels from now on; ``func``'s own."""
    to_jit()
    return _current[id(func)]


def _install(table: dict) -> None:
    """Every ``retrofit`` module's name for a kernel now names ``table[id(python function)]``."""
    swap = {id(_current[key]): new for key, new in table.items()}
    old = {id(_current[key]): _current[key] for key in table}
    for name, module in list(sys.modules.items()):
        if not (name == "retrofit" or name.startswith("retrofit.")) or module is None:
            continue
        for attr, value in list(vars(module).items()):
            if id(value) in swap and old[id(value)] is value:
                setattr(module, attr, swap[id(value)])
    _current.update(table)


if HAVE_NUMBA and os.environ.get("RETROFIT_NUMBA") == "always":     # pragma: no cover
    compiled()
