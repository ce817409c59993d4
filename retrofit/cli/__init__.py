"""The ``retrofit`` command line: one module a group of sub-commands, discovered in this package.

Each module ``retrofit/cli/<name>.py`` has ``add_commands(subparsers)`` and imports heavy
libraries only inside its command functions, so building the parser stays cheap. Exit codes of
every command: 0 done, 1 ran and the simulated machine reported violations, 2 refused input or
an output that cannot be used, 130 interrupted (Ctrl-C), 128 + n stopped by signal n (129
SIGHUP, 143 SIGTERM: :mod:`retrofit.failsafe`).
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
from importlib import import_module

# No command uses NumPy's linear algebra: one BLAS thread, so OpenBLAS starts no spinning
# helper threads when NumPy loads (0.05 s of CPU per command). A value the user set is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from ..errors import RetrofitError
from ..failsafe import Terminated

#: modules of this package that are not sub-command groups
_NOT_COMMANDS = {"__main__"}


class DefaultMachine(str):
    """The machine a command takes when ``--machine`` is not given (it says so)."""


def machine_option(parser, default: str, what: str = "shipped machine name or path to a .toml file") -> None:
    """``--machine``, whose default is named in ``--help`` and, by :func:`default_machine_line`, in
    the command's summary."""
    parser.add_argument("--machine", default=DefaultMachine(default), help=f"{what} (default: {default})")


def default_machine_line(arg) -> list[str]:
    """A summary line saying the machine was not chosen, when ``--machine`` was not given."""
    if not isinstance(arg, DefaultMachine):
        return []
    return [f"  machine: {arg} (the default; --machine chooses another)"]


def command_modules() -> list[str]:
    """Modules that add sub-commands: ``retrofit/cli/*.py``, each with ``add_commands(subparsers)``."""
    import pkgutil
    return sorted(f"{__name__}.{m.name}" for m in pkgutil.iter_modules(__path__)
                  if m.name not in _NOT_COMMANDS and not m.name.startswith("_"))


def version() -> str:
    """The installed version of retrofit (the source tree's when it is not installed)."""
    from importlib import metadata
    try:
        return metadata.version("retrofit")
    except metadata.PackageNotFoundError:
        return "unknown"


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata is slow
    to import, and every other command would pay for it)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"retrofit {version()}")
        parser.exit()


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code.

    Called as the program (``argv`` None), the process ends once this returns: its objects are
    frozen first, so that Python's collections at exit do not walk every object the run and its
    libraries made (0.15 s after a compiled run) only for the operating system to free them.
    A Ctrl-C is never lost (:func:`_deliver_ctrl_c`).
    """
    if argv is None:
        sys.unraisablehook = _deliver_ctrl_c
        import signal

        from ..failsafe import ctrl_c
        # a Ctrl-C is remembered (_stopped); heard even when the command was started with it
        # ignored (a background job of a shell without job control): a machine stops on it
        if signal.getsignal(signal.SIGINT) in (signal.default_int_handler, signal.SIG_IGN):
            signal.signal(signal.SIGINT, ctrl_c)
    try:
        return _command(argv)
    finally:
        if argv is None:
            sys.settrace(None)          # a Ctrl-C kept from the last moments: the command is done
            gc.freeze()


def _deliver_ctrl_c(unraisable) -> None:
    """A Ctrl-C that lands while a finalizer or weak-reference callback runs is not lost: Python
    would print it as "Exception ignored" and carry on; it is raised again at the next Python call
    the command makes (raised inside this hook, it would be ignored again)."""
    from ..failsafe import Terminated
    if issubclass(unraisable.exc_type, (KeyboardInterrupt, Terminated)):
        _LOST.append(unraisable.exc_value or unraisable.exc_type())
        sys.settrace(_raise_ctrl_c)
    else:
        sys.__unraisablehook__(unraisable)


#: a Ctrl-C or an ending signal kept from a finalizer, to raise again
_LOST: list[BaseException] = []


def _raise_ctrl_c(frame, event, arg):
    sys.settrace(None)
    raise _LOST.pop() if _LOST else KeyboardInterrupt


def _command(argv: list[str] | None) -> int:
    try:
        parser = _parser()
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help()
            return 2
        return args.func(args) or 0
    except RetrofitError as exc:
        code = _stopped()
        if code is not None:
            return code
        print(f"retrofit: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        import signal
        signal.signal(signal.SIGINT, signal.SIG_IGN)      # one Ctrl-C ends the run, quietly
        _say_stopped("interrupted")
        return 130
    except Terminated as exc:                 # SIGHUP, SIGTERM: the outputs are safe already
        _say_stopped(f"stopped by {exc.name}")
        return exc.exit_code
    except BrokenPipeError:                # output piped into `head` and the reader went away
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception:
        code = _stopped()
        if code is None:
            raise
        return code


def _stopped() -> int | None:
    """The exit code of a command a Ctrl-C or an ending signal stopped although the error that
    reached here is another (a library turned the interruption into an error of its own), after
    saying so; None when no signal came."""
    from ..failsafe import Terminated, ended_by
    cause = ended_by()
    if isinstance(cause, KeyboardInterrupt):
        _say_stopped("interrupted")
        return 130
    if isinstance(cause, Terminated):
        _say_stopped(f"stopped by {cause.name}")
        return cause.exit_code
    return None


def _say_stopped(what: str) -> None:
    """One line: the command was stopped, and which of its files were not written."""
    from ..atomic import PLANNED, WRITTEN, not_written
    lost = ", ".join(str(p) for p in not_written())
    if lost:
        lost = f"; not written: {lost}"
    elif not PLANNED and not WRITTEN:          # before the command knew its files
        lost = "; nothing was written"
    try:
        print(f"retrofit: {what}{lost}", file=sys.stderr, flush=True)
    except OSError:                            # SIGHUP: the terminal may be gone
        pass


def _parser() -> argparse.ArgumentParser:
    """The parser of every command (each command module adds its group)."""
    p, sub = _empty_parser()
    for module in command_modules():
        import_module(module).add_commands(sub)
    return p


def _empty_parser():
    p = argparse.ArgumentParser(prog="retrofit", description="CNC retrofit toolkit: controller, simulator, outputs.")
    p.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    return p, p.add_subparsers(metavar="COMMAND")


if __name__ == "__main__":
    sys.exit(main())
