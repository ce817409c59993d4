"""A run told to end ends as a Ctrl-C does: the machine stops and its outputs go safe before anything else.

SIGHUP (the terminal was closed) and SIGTERM (``kill``, a service manager) would end the process
where it stands, the port's last byte held and its drivers enabled. Inside :func:`signals_raise`
they raise :class:`Terminated` into the run instead, as SIGINT raises KeyboardInterrupt: the
run's outputs get ``safe_stop()`` (:func:`stop_all`), its files are finished or removed, and the
command exits with 128 + the signal's number (129 for SIGHUP, 143 for SIGTERM; 130 is Ctrl-C).

The first of these signals (or Ctrl-C) ends the run; the ones after it are ignored until the
command has exited, so a second Ctrl-C cannot cut the safe stop short. SIGKILL cannot be caught:
what a parallel port holds then is the last byte (docs/wiring.md).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

#: the signals that end a run by raising into it (SIGINT raises KeyboardInterrupt)
ENDING = (signal.SIGHUP, signal.SIGTERM)


class Terminated(BaseException):
    """The process was told to end by signal ``signum``; it exits with 128 + ``signum``.

    A BaseException, as KeyboardInterrupt: no ``except Exception`` on the way swallows it.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


#: what a signal raised into the command (one at most: the ones after it are ignored)
_ENDED: list[BaseException] = []


def _ignore_the_rest() -> None:
    for sig in ENDING + (signal.SIGINT,):
        signal.signal(sig, signal.SIG_IGN)


def _raise(signum, frame) -> None:
    _ignore_the_rest()
    _ENDED.append(Terminated(signum))
    raise _ENDED[-1]


def ctrl_c(signum, frame) -> None:
    """SIGINT's handler: KeyboardInterrupt, once, and remembered (:func:`ended_by`)."""
    _ignore_the_rest()
    _ENDED.append(KeyboardInterrupt())
    raise _ENDED[-1]


def ended_by() -> BaseException | None:
    """The KeyboardInterrupt or :class:`Terminated` a signal raised into this process, if one did:
    a library may catch it where it lands and raise an error of its own instead (matplotlib, cut
    short while drawing, says "Invalid bounding box"); the command was stopped all the same."""
    return _ENDED[0] if _ENDED else None


@contextmanager
def signals_raise() -> Iterator[None]:
    """Within the block, SIGHUP and SIGTERM raise :class:`Terminated` and SIGINT KeyboardInterrupt,
    once; the handlers before it come back when it ends, unless a signal ended it. (Signals reach
    the main thread only: elsewhere this does nothing.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {sig: signal.getsignal(sig) for sig in ENDING + (signal.SIGINT,)}
    for sig in ENDING:
        signal.signal(sig, _raise)
    if old[signal.SIGINT] is signal.default_int_handler:
        signal.signal(signal.SIGINT, ctrl_c)
    try:
        yield
    finally:
        for sig, handler in old.items():
            if signal.getsignal(sig) in (_raise, ctrl_c):     # (after a signal: ignored, stays so)
                signal.signal(sig, handler)


def stop_all(outputs: Iterable) -> None:
    """``safe_stop()`` on every output, each tried even when one before it fails."""
    for out in outputs:
        try:
            out.safe_stop()
        except Exception:           # the others still stop; the run's own error is reported
            pass
