"""A Ctrl-C or an ending signal that a library turns into an error of its own still ends the
command as stopped (130, or 128 + the signal), saying so in one line, with no traceback."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: a command whose work is cut short by a signal and whose library answers with its own error, as
#: matplotlib did when Ctrl-C landed while it drew ("Invalid bounding box")
SCRIPT = """
import argparse, os, signal, sys
import retrofit.cli as cli
from retrofit.errors import RetrofitError

def work(args):
    from retrofit.failsafe import signals_raise
    with signals_raise():                  # as a run does: SIGTERM raises into it too
        try:
            if args.signal != "none":
                os.kill(os.getpid(), getattr(signal, args.signal))
                for _ in range(10_000_000):        # the handler raises at the next bytecode
                    pass
        except BaseException:
            pass
        raise (RetrofitError if args.kind == "retrofit" else ValueError)("Invalid bounding box")

def parser(command=None):
    p = argparse.ArgumentParser(prog="retrofit")
    p.add_argument("signal")
    p.add_argument("kind")
    p.set_defaults(func=work)
    return p

cli._parser = parser
sys.argv = ["retrofit"] + sys.argv[1:]
sys.exit(cli.main())
"""


def _run(*args: str, ctrl_c_ignored: bool = False) -> subprocess.CompletedProcess:
    """The command in a process of its own; ``ctrl_c_ignored``: started with SIGINT ignored, as
    a shell without job control starts its background jobs."""
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ctrl_c_ignored else None
    return subprocess.run([sys.executable, "-c", SCRIPT, *args], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120,
                          preexec_fn=ignore)


@pytest.mark.parametrize("kind", ["value", "retrofit"])
def test_a_ctrl_c_turned_into_another_error_ends_the_command_as_interrupted(kind):
    done = _run("SIGINT", kind)
    assert done.returncode == 130, done.stderr
    assert done.stderr.startswith("retrofit: interrupted"), done.stderr
    assert "Traceback" not in done.stderr and "Invalid bounding box" not in done.stderr


def test_a_command_started_with_ctrl_c_ignored_still_stops_on_it():
    """A script that starts `retrofit run` in its background, or CI from a shell without job
    control, hands it SIGINT ignored; the operator's Ctrl-C (SIGINT to the process group) must
    stop the machine all the same: exit 130, one line."""
    done = _run("SIGINT", "retrofit", ctrl_c_ignored=True)
    assert done.returncode == 130, done.stderr
    assert done.stderr.startswith("retrofit: interrupted"), done.stderr


def test_a_sigterm_turned_into_another_error_ends_the_command_as_stopped_by_it():
    done = _run("SIGTERM", "value")
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr.startswith("retrofit: stopped by SIGTERM"), done.stderr


def test_an_error_with_no_signal_is_still_the_error():
    done = _run("none", "retrofit")
    assert done.returncode == 2 and done.stderr.startswith("retrofit: error: Invalid bounding box"), done.stderr
