"""`retrofit run` on a terminal: the screen after a run, the progress bar's estimate (Ctrl-C: test_run_interrupt.py)."""

import io
import math
import os
import re
import shutil
import subprocess
import sys
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
        for _ in range(1200):                      # a ceiling of 2 minutes: the run's end is the event
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
