"""``retrofit kernels``: compile the kernels ahead of time, so a compiled run starts without Numba."""

from __future__ import annotations

import sys

from ..errors import RetrofitError


def add_commands(sub) -> None:
    k = sub.add_parser("kernels", help="compile the kernels ahead of time (once per install): faster starts",
                       description="Compile every motion and simulator kernel ahead of time into one module "
                                   "in the user's cache folder. A run whose work is large enough to compile "
                                   "then loads that module instead of Numba and its cached kernels (0.2 s "
                                   "less CPU at every start); same numbers. Run again after an upgrade: an "
                                   "out-of-date module is ignored, never used.")
    k.add_argument("--status", action="store_true",
                   help="only say whether a current module is there (exit 0) or not (exit 1)")
    k.set_defaults(func=cmd_kernels)


def cmd_kernels(args) -> int:
    from ..motion import _aot
    from ..motion._jit import HAVE_NUMBA
    if not HAVE_NUMBA:
        raise RetrofitError("kernels: Numba is not installed (or RETROFIT_NO_NUMBA is set); runs keep the "
                            "Python kernels. Install numba to compile them")
    if args.status:
        library = _aot.load()
        where = _aot.folder()
        print(f"kernels compiled ahead of time: {'current' if library else 'none current'} in {where}")
        return 0 if library else 1
    import importlib.util
    if importlib.util.find_spec("numba.pycc") is None:
        print("kernels: this Numba has no ahead-of-time compiler (numba.pycc); runs keep Numba's "
              "just-in-time kernels, with the same numbers", file=sys.stderr)
        return 0
    from ..motion._aot_build import build
    print("running the shipped examples with Numba's kernels, then compiling (a minute or two)",
          file=sys.stderr, flush=True)
    from . import main
    folder = build(main, progress=lambda says: print(says, file=sys.stderr, flush=True))
    print(f"kernels compiled ahead of time: {folder}")
    return 0
