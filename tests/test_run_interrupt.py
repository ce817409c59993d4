"""`retrofit run` stopped at named moments (Ctrl-C, SIGTERM): every file complete or absent, one line.

Each moment is an event of the run, not a time: the run holds there (``RETROFIT_HOLD_AT``,
:mod:`retrofit.hold`) and says so on standard error, and the signal is sent then. So part way
through the work, with each file's temporary copy empty, half written or whole, and after the
report are each reached on any machine at any load. What the folder holds at the moment is
checked too, so a moment that did not fall where its name says fails.
"""

import os
import select
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: the most a step of a run may take on a loaded machine (a wait, never a pace)
CEILING_S = 120
#: the files of a run with --plot, in the order the run writes them (and names those not written)
PLOTTED = ("x.vcd", "p.png", "r.json")
#: without --plot the program is read ahead (a window at a time)
READ_AHEAD = ("x.vcd", "r.json")


def _start(folder: Path, plot: bool, moment: str | None = None) -> subprocess.Popen:
    """``retrofit run`` of the lathe program writing the files of ``PLOTTED`` (``READ_AHEAD``
    without ``plot``), held at ``moment`` if given. Each run has a state folder of its own, as on a
    fresh machine: the report names the spindle record's tool."""
    state = tempfile.mkdtemp(prefix="state-", dir=folder.parent)
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", XDG_STATE_HOME=state)
    if moment:
        env["RETROFIT_HOLD_AT"] = moment
    return subprocess.Popen([sys.executable, "-m", "retrofit.cli", "run", "lathe-profile.ngc",
                             "--output", "vcd://x.vcd", "--report", "r.json"] + (["--plot", "p.png"] if plot else []),
                            cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            preexec_fn=_ctrl_c_heard)


def _ctrl_c_heard() -> None:
    """In the child: Ctrl-C acts, as on a terminal, even when the tests run in the background of
    a shell (which starts them with SIGINT ignored, and Python then leaves it ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _reference(folder: Path, plot: bool) -> dict[str, bytes]:
    """The files of the run not interrupted."""
    proc = _start(folder, plot)
    _, err = proc.communicate(timeout=CEILING_S)
    assert proc.returncode == 0, err.decode()
    return {name: (folder / name).read_bytes() for name in (PLOTTED if plot else READ_AHEAD)}


@pytest.fixture(scope="module")
def plotted(tmp_path_factory):
    return _reference(tmp_path_factory.mktemp("whole"), plot=True)


@pytest.fixture(scope="module")
def read_ahead(tmp_path_factory):
    return _reference(tmp_path_factory.mktemp("whole"), plot=False)


def _until_held(proc: subprocess.Popen) -> bytes:
    """Standard error up to the line saying the run is held (each read waits at most CEILING_S)."""
    said = b""
    while b"retrofit: held at " not in said or not said.endswith(b"\n"):
        ready, _, _ = select.select([proc.stderr], [], [], CEILING_S)
        assert ready, f"no word from the run in {CEILING_S} s: {said.decode()}"
        chunk = os.read(proc.stderr.fileno(), 4096)
        assert chunk, f"the run ended without reaching its moment: {said.decode()}"
        said += chunk
    return said


def _temporary(folder: Path, name: str) -> list[Path]:
    stem, suffix = name.split(".")
    return [p for p in folder.iterdir() if p.name.startswith(f".{stem}.") and p.name.endswith(f".tmp.{suffix}")]


def _stop_at(moment: str, sig: signal.Signals, reference: dict[str, bytes], folder: Path,
             placed: int, temporary: str | None) -> None:
    """Hold the run at ``moment``, check the folder then (the first ``placed`` files in place, the
    next one's temporary copy ``empty``, ``part`` written or ``whole``, or none), send ``sig``,
    and check what the run leaves and says."""
    names = list(reference)
    proc = _start(folder, "p.png" in reference, moment)
    try:
        held = _until_held(proc)
        assert held == f"retrofit: held at {moment}\n".encode(), held     # nothing said before
        for name in names[:placed]:
            assert (folder / name).read_bytes() == reference[name], name
        assert not any((folder / name).exists() for name in names[placed:])
        copies = [p for name in names for p in _temporary(folder, name)]
        if temporary is None:
            assert copies == []
        else:
            writing = names[placed]
            assert [p.name for p in copies] == [p.name for p in _temporary(folder, writing)] != []
            data = copies[0].read_bytes()
            whole = reference[writing]
            assert {"empty": data == b"", "part": 0 < len(data) < len(whole) and whole.startswith(data),
                    "whole": data == whole}[temporary], (writing, len(data), len(whole))
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=CEILING_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    what = "interrupted" if sig == signal.SIGINT else f"stopped by {sig.name}"
    lost = ", ".join(names[placed:])
    assert err.decode() == f"retrofit: {what}" + (f"; not written: {lost}" if lost else "") + "\n"
    assert proc.returncode == 128 + sig and out == b""
    assert sorted(p.name for p in folder.iterdir()) == sorted(names[:placed])     # no temporary file left
    for name in names[:placed]:
        assert (folder / name).read_bytes() == reference[name], name


INT, TERM = signal.SIGINT, signal.SIGTERM
#: (moment, signal, files in place, the next file's temporary copy) in the order of the run
PLOTTED_MOMENTS = [
    ("progress 1", INT, 0, None),            # the program read and compiled
    ("progress 800", TERM, 0, None),         # planned and executed
    ("open x.vcd", INT, 0, "empty"),
    ("progress 881", INT, 0, "part"),        # the frames part way out
    ("wrote x.vcd", TERM, 0, "whole"),
    ("renamed x.vcd", INT, 1, None),
    ("open p.png", INT, 1, "empty"),
    ("draw p.png", TERM, 1, "empty"),        # drawn, its bytes not yet written
    ("wrote p.png", INT, 1, "whole"),
    ("renamed p.png", INT, 2, None),
    ("open r.json", TERM, 2, "empty"),
    ("wrote r.json", INT, 2, "whole"),
    ("renamed r.json", INT, 3, None),        # every file written; the summary not yet printed
]


@pytest.mark.slow
@pytest.mark.parametrize("moment, sig, placed, temporary", PLOTTED_MOMENTS, ids=[m[0] for m in PLOTTED_MOMENTS])
def test_a_stopped_run_leaves_every_file_complete_or_absent(moment, sig, placed, temporary, plotted, tmp_path):
    _stop_at(moment, sig, plotted, tmp_path, placed, temporary)


READ_AHEAD_MOMENTS = [
    ("progress 1", INT, 0, "part"),          # the first window out
    ("wrote x.vcd", INT, 0, "whole"),
    ("renamed x.vcd", TERM, 1, None),
    ("open r.json", INT, 1, "empty"),
    ("renamed r.json", INT, 2, None),
]


@pytest.mark.slow
@pytest.mark.parametrize("moment, sig, placed, temporary", READ_AHEAD_MOMENTS,
                         ids=[m[0] for m in READ_AHEAD_MOMENTS])
def test_a_stopped_run_read_ahead_leaves_every_file_complete_or_absent(moment, sig, placed, temporary,
                                                                       read_ahead, tmp_path):
    """Without --plot the program is read ahead: interpreter, planner and outputs a window at a
    time, the report made as the run goes."""
    _stop_at(moment, sig, read_ahead, tmp_path, placed, temporary)
