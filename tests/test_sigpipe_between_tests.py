"""A library imported by the tests must not make a closed socket fatal to the test process.

vcdvcd (which the VCD tests read files with) sets SIGPIPE to its default action when imported,
and every pytest worker imports it while collecting: from then on a write to a socket whose peer
has gone killed the worker outright (xdist: "worker crashed"), where Python ignores SIGPIPE and
raises BrokenPipeError. The CAM link's hostile-client test did exactly that on a loaded machine,
when the server refused a client that was still writing. Every test now starts with Python's own
SIGPIPE disposition (tests/conftest.py).
"""

from __future__ import annotations

import signal
import socket
import subprocess
import sys

import vcdvcd  # noqa: F401  (imported here as every worker imports it: the disposition it leaves)


def test_importing_vcdvcd_sets_sigpipe_to_its_default_action():
    """The cause, checked in a fresh interpreter: Python ignores SIGPIPE until vcdvcd is imported."""
    probe = ("import signal; a = signal.getsignal(signal.SIGPIPE); import vcdvcd; "
             "print(int(a), int(signal.getsignal(signal.SIGPIPE)))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert out.stdout.split() == [str(int(signal.SIG_IGN)), str(int(signal.SIG_DFL))]


def test_a_write_to_a_socket_whose_peer_closed_raises_instead_of_killing_the_test():
    """In a test after that import, writing to a closed peer is an error the test can see."""
    left, right = socket.socketpair()
    right.close()
    raised = None
    try:
        for _ in range(4):
            left.sendall(b"x" * 65536)
    except OSError as exc:                   # BrokenPipeError, or a reset
        raised = exc
    finally:
        left.close()
    assert isinstance(raised, (BrokenPipeError, ConnectionResetError))
