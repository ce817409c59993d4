"""`retrofit run` on a terminal: the screen after a run, the progress bar's estimate, Ctrl-C."""

import io
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from retrofit.run.progress import Progress

ROOT = Path(__file__).resolve().parents[1]
ENV = f"env PYTHONPATH={ROOT} MPLBACKEND=Agg"


def spiral(path: Path, segments: int = 8000) -> Path:
    """A long program: a spiral of short G1 segments on the lathe."""
    lines = ["G21 G90", "G0 X0 Z0", "F300"]
    for i in range(segments):
        r = 1 + 12 * i / segments
        lines.append(f"G1 X{r * math.sin(i * 0.05):.3f} Z{-r * math.cos(i * 0.05) - 14:.3f}")
    path.write_text("\n".join(lines + ["M2"]) + "\n")
    return path


@pytest.mark.skipif(not shutil.which("tmux"), reason="tmux is not installed")
def test_under_tmux_at_80_columns_only_the_summary_stays_on_the_screen(tmp_path):
    plain = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", "lathe-profile.ngc", "--progress", "off"],
                           capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert plain.returncode == 0, plain.stderr
    sock, name = f"retrofit-test-{os.getpid()}", "run"
    tmux = ["tmux", "-L", sock, "-f", "/dev/null"]
    subprocess.run(tmux + ["new-session", "-d", "-s", name, "-x", "80", "-y", "40", "-c", str(tmp_path),
                           f"{ENV} python3 -m retrofit.cli run lathe-profile.ngc; echo EXIT=$?; sleep 60"],
                   check=True)
    try:
        screen = ""
        for _ in range(600):
            screen = subprocess.run(tmux + ["capture-pane", "-p", "-t", name], capture_output=True,
                                    text=True).stdout
            if "EXIT=" in screen:
                break
            time.sleep(0.1)
        width = subprocess.run(tmux + ["display", "-p", "-t", name, "#{pane_width}"], capture_output=True,
                               text=True).stdout.strip()
    finally:
        subprocess.run(tmux + ["kill-server"], capture_output=True)
    assert width == "80"
    shown = [line.rstrip() for line in screen.splitlines() if line.strip()]
    assert shown == plain.stdout.splitlines() + ["EXIT=0"]          # no bar, nothing glued on
    assert all(len(line) <= 80 for line in shown)


class Ticks:
    """A clock that moves only when the test moves it: seconds = ticks x 50 us."""

    def __init__(self):
        self.ticks = 0

    def __call__(self) -> float:
        return self.ticks * 50e-6


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def estimates(text: str) -> list[tuple[int, int, int]]:
    return [(int(p), int(eta), int(so_far)) for p, eta, so_far in
            re.findall(r"(\d+)% \|[^|]*\| eta (\d+) s \((\d+) s so far\)", text)]


def test_the_estimate_is_the_time_left_at_a_steady_pace_on_the_runs_clock():
    clock, screen = Ticks(), Terminal()
    bar = Progress({"plan": 1.0, "execute": 3.0}, stream=screen, clock=clock)
    for stage, seconds in (("plan", 25), ("execute", 75)):         # 1 % of the bar a second
        for s in range(1, seconds + 1):
            clock.ticks += 20_000                                   # one second in 50 us ticks
            bar.fraction(stage, s / seconds)
    samples = [s for s in estimates(screen.getvalue()) if s[0] > 0]
    assert [p for p, _, _ in samples] == list(range(1, 101))        # every percent shown once
    for p, eta, so_far in samples:
        assert so_far == p and abs(eta - (100 - p)) <= 2, (p, eta, so_far)   # 100 s in all, in ticks
    bar.close()
    assert screen.getvalue().endswith("\r") or "\x1b" in screen.getvalue()[-20:]   # the bar is cleared


def test_the_estimate_follows_a_pace_that_halves():
    clock, screen = Ticks(), Terminal()
    bar = Progress({"execute": 1.0}, stream=screen, clock=clock)
    for s in range(1, 101):                    # 1 %/s to half way, then 0.5 %/s: 50 s + 100 s
        clock.ticks += 20_000 if s <= 50 else 40_000
        bar.fraction("execute", s / 100)
    shown = {p: (eta, so_far) for p, eta, so_far in estimates(screen.getvalue())}
    assert shown[49] == (51, 49)                                   # at 49 %: the pace so far, 1 %/s
    for p in range(80, 100):                                       # 0.5 %/s by now: 2 s a percent left
        assert shown[p] == (2 * (100 - p), 50 + 2 * (p - 50)), (p, shown[p])


@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("script"), reason="script (util-linux) is not installed")
def test_under_script_the_bar_shows_and_is_cleared_before_the_summary(tmp_path):
    program = spiral(tmp_path / "spiral.ngc", segments=100_000)
    typescript = tmp_path / "typescript"
    subprocess.run(["script", "-qec", f"stty cols 80 rows 24; {ENV} python3 -m retrofit.cli run {program}",
                    str(typescript)], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, timeout=280, check=True)
    text = typescript.read_text(errors="replace")
    assert estimates(text), "no progress bar on the terminal"
    end = text.rstrip().splitlines()
    at = max(i for i, line in enumerate(end) if line.strip().startswith("violations: 0"))
    assert at >= len(end) - 4 and not any("eta " in line for line in end[at:])   # bar cleared first


def _run(tmp_path: Path, interrupt_after_s: float | None = None, plot: bool = True) -> subprocess.CompletedProcess:
    """``retrofit run`` of the lathe program with three outputs (two without ``plot``: the run is
    then read ahead); SIGINT after the delay if given.
    Each run starts from a state folder of its own, as on a fresh machine: the report names the
    spindle record's tool, which a fixture wider than one test may have changed in a shared one."""
    state = tempfile.mkdtemp(prefix="state-", dir=tmp_path.parent)
    proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "run", "lathe-profile.ngc",
                             "--output", "vcd://x.vcd", "--report", "r.json"] + (["--plot", "p.png"] if plot else []),
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", XDG_STATE_HOME=state))
    if interrupt_after_s is not None:
        time.sleep(interrupt_after_s)
        proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def _whole(tmp_path_factory, plot: bool):
    """The run not interrupted: when the command is up (Python started, ``retrofit.cli`` read: a
    Ctrl-C before that is the interpreter's own), how long the run took here, and its files."""
    started = time.monotonic()
    subprocess.run([sys.executable, "-m", "retrofit.cli", "--version"], capture_output=True, check=True,
                   env=dict(os.environ, PYTHONPATH=str(ROOT)))
    up_s = time.monotonic() - started
    whole = tmp_path_factory.mktemp("whole")
    started = time.monotonic()
    done = _run(whole, plot=plot)
    run_s = time.monotonic() - started
    assert done.returncode == 0, done.stderr
    names = ("x.vcd", "r.json", "p.png") if plot else ("x.vcd", "r.json")
    return up_s, run_s, {name: (whole / name).read_bytes() for name in names}


@pytest.fixture(scope="module")
def whole_run(tmp_path_factory):
    return _whole(tmp_path_factory, plot=True)


CTRL_C_PARTS = 4            # 20 interruptions, 5 a test, each test's spread from early to late in the run


def _moments(part: int) -> list[float]:
    """This part's share of 20 random moments (fractions of the run): every 4th of them in order."""
    rng = random.Random(12)
    return sorted(rng.uniform(0.05, 1.1) for _ in range(20))[part::CTRL_C_PARTS]


@pytest.mark.slow
@pytest.mark.parametrize("part", range(CTRL_C_PARTS))
def test_ctrl_c_at_random_moments_leaves_every_file_complete_or_absent(part, whole_run, tmp_path):
    _interrupt_at(_moments(part), whole_run, tmp_path, plot=True)


@pytest.mark.slow
def test_ctrl_c_in_a_run_read_ahead_leaves_every_file_complete_or_absent(tmp_path_factory, tmp_path):
    """Without --plot the program is read ahead: interpreter, planner and outputs a window at a
    time, the report made as the run goes."""
    _interrupt_at(_moments(1), _whole(tmp_path_factory, plot=False), tmp_path, plot=False)


def _interrupt_at(moments: list[float], whole_run, tmp_path: Path, plot: bool) -> None:
    # the interruptions are spread over the run as long as it took here (only to pick moments)
    up_s, run_s, reference = whole_run
    seen: set[tuple[str, ...]] = set()

    def interrupt(attempt: int, moment: float) -> None:
        folder = tmp_path / f"try{attempt}"
        folder.mkdir()
        result = _run(folder, up_s + moment * max(run_s - up_s, 0.0), plot)
        assert result.returncode in (0, 130), result.stderr
        assert "Traceback" not in result.stderr
        for name, data in reference.items():
            path = folder / name
            assert not path.exists() or path.read_bytes() == data, (moment, name)
        assert {p.name for p in folder.iterdir()} <= set(reference)      # no temporary file left
        if result.returncode == 130:
            missing = [n for n in reference if not (folder / n).exists()]
            assert result.stderr.startswith("retrofit: interrupted")
            if result.stderr.startswith("retrofit: interrupted; nothing was written"):
                assert missing == list(reference), result.stderr      # before the run began
            elif missing:
                assert result.stderr.startswith("retrofit: interrupted; not written: ")
                assert all(n in result.stderr for n in missing), result.stderr
        seen.add(tuple(sorted(p.name for p in folder.iterdir())))

    for attempt, moment in enumerate(moments):
        interrupt(attempt, moment)
    # a busier computer than when the whole run was timed: later moments, until the outcomes differ
    late = max(moments)
    while len(seen) < 2 and late < 50:
        late *= 2
        interrupt(len(moments) + int(late), late)
    assert len(seen) >= 2, seen            # the interruptions fell at different moments of the run
