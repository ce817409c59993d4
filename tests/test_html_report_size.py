"""`retrofit run --html` makes reports of sensible size: about 2 MB for the shipped examples and
3.6 MB for LinuxCNC's 3D_Chips (plotly.js is most of it), and what they draw is what the run did (every preview segment, the
extremes of every timeline trace kept by the min/max downsampling, pulses down to single ones)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from retrofit.config import load_machine, machines_dir
from test_console_browser import CHROMEDRIVER, chromium, wait_for

pytestmark = pytest.mark.skipif(not Path(CHROMEDRIVER).exists(), reason="needs chromium-driver")
CHIPS = Path(__file__).parent / "gcode" / "linuxcnc" / "3D_Chips.ngc"


def chips_job(folder: Path) -> tuple[str, str]:
    """3D_Chips as its comments describe it (450 mm/min, a 100 x 100 x 50 mm block around the
    zero) on the engraver's axes with travel for it."""
    program = folder / "3D_Chips.ngc"
    program.write_text(CHIPS.read_text().replace("#<fscale> = 10000.0", "#<fscale> = 1.0"))
    text = (machines_dir() / "engraver.toml").read_text()
    for old, new in (("min_mm = 0.0", "min_mm = -150.0"), ("max_mm = 200.0", "max_mm = 150.0"),
                     ("min_mm = -20.0", "min_mm = -50.0"), ("max_mm = 20.0", "max_mm = 50.0")):
        text = text.replace(old, new)
    (folder / "wide.toml").write_text(text)
    return str(program), str(folder / "wide.toml")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    driver = chromium(tmp_path_factory.mktemp("chromium-profile"))
    yield driver
    driver.quit()


@pytest.mark.parametrize("job,limit", [("lathe", 2_150_000), ("engraving", 2_250_000), ("chips", 3_700_000)])
def test_report_size_and_what_it_draws(browser, tmp_path, job, limit):
    program, machine = {"lathe": ("lathe-profile.ngc", "chivu-lathe"),
                        "engraving": ("engraving.ngc", "engraver")}.get(job) or chips_job(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", program, "--machine", machine,
                           "--html", "run.html", "--progress", "off"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    size = (tmp_path / "run.html").stat().st_size
    browser.get((tmp_path / "run.html").as_uri())
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=120)
    opened_ms = browser.execute_script("return performance.now()")
    print(f"{job}: {size} bytes, views ready {opened_ms:.0f} ms after the page began loading")
    assert size <= limit

    from retrofit.console.views import axis_steps, preview, timeline
    from retrofit.gcode import load_program
    from retrofit.runprogram import resolve_program
    m = load_machine(machine)
    segs = preview(load_program(resolve_program(program), m), m)["segments"]
    drawn = browser.execute_script("""
        const d = document.getElementById('preview').data;
        const n = (name) => d.find(t => t.name.startsWith(name)).x.filter(v => v === null).length;
        const x = document.getElementById('timeline').data.find(t => t.name === arguments[0]);
        return {type: d[0].type || 'scatter', cuts: n('cut'), rapids: n('rapid'), high: Math.max(...x.y), low: Math.min(...x.y)}""",
        m.axes[0].name)
    assert drawn["type"] == ("scatter" if job == "lathe" else "scatter3d")
    assert drawn["cuts"] == sum(s["kind"] == "cut" for s in segs)
    assert drawn["rapids"] == sum(s["kind"] == "rapid" for s in segs)
    # the first axis's position trace keeps the extremes the full-resolution timeline has
    frames = run_frames(program, m)
    full = timeline(axis_steps(frames, m), m, 0, max(frames.end_tick, 2), points=20_000)
    pos = np.asarray(full["axes"][m.axes[0].name]["position_mm"])
    assert drawn["high"] == pytest.approx(pos.max(), abs=1e-4)
    assert drawn["low"] == pytest.approx(pos.min(), abs=1e-4)


def run_frames(program: str, machine):
    """The port frames of the program's run (the fast path, as retrofit run makes them)."""
    from types import SimpleNamespace
    from retrofit.progress import silent
    from retrofit.runprogram import STAGE_WEIGHTS, read_program, run_program
    text, name = read_program(program)
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=True, keep_commands=True, before_outputs=None)
    return run_program(text, name, machine, opts, silent(STAGE_WEIGHTS)).log.frames
