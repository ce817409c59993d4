"""`retrofit run --html` makes reports of sensible size: at most 2 MB for any program (plotly.js
is three quarters of it), LinuxCNC's 3D_Chips included, and what they draw is what the run did
(every preview segment, the extremes of every timeline trace kept by the min/max downsampling, the
port frames the pulse view holds equal to the run's, the listing's text as written)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from console_kit import browser, needs_chromium, wait_for  # noqa: F401 (browser)

from retrofit.console.report_html import REPORT_BYTES
from retrofit.machine.config import load_machine, machines_dir

pytestmark = [needs_chromium, pytest.mark.slow]
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


def make_report(folder: Path, program: str, machine: str) -> Path:
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", program, "--machine", machine,
                           "--html", "run.html", "--progress", "off"], cwd=folder, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return folder / "run.html"


def open_report(browser, page: Path) -> dict:
    """Open the report; when its parts were ready (ms after the page began loading)."""
    browser.get(page.as_uri())
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=120)
    return browser.execute_script("return Object.fromEntries(performance.getEntriesByType('mark')"
                                  ".map(m => [m.name, Math.round(m.startTime)]))")


@pytest.mark.parametrize("job", ["lathe", "engraving", "chips"])
def test_report_size_and_what_it_draws(browser, tmp_path, job):
    program, machine = {"lathe": ("lathe-profile.ngc", "chivu-lathe"),
                        "engraving": ("engraving.ngc", "engraver")}.get(job) or chips_job(tmp_path)
    page = make_report(tmp_path, program, machine)
    size = page.stat().st_size
    marks = open_report(browser, page)
    print(f"{job}: {size} bytes; ms after the page began loading: {marks}")
    assert size <= REPORT_BYTES

    from retrofit.console.views import axis_steps, preview, timeline
    from retrofit.gcode import load_program
    from retrofit.run.program import resolve_program
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
    # the pulse view's frames are the run's, as far as the report holds them
    held = browser.execute_script("const f = window.retrofitRun.frames; return {shown: f.shown, total: f.total, "
                                  "last: f.ticks[f.shown - 1], sum: f.ticks.reduce((a, b) => a + b, 0), "
                                  "values: f.values.reduce((a, b) => a + b, 0), "
                                  "note: [...document.querySelectorAll('.note')].map(p => p.textContent)}")
    n = held["shown"]
    assert held["total"] == len(frames) and n > 0
    assert held["last"] == frames.ticks[n - 1] and held["sum"] == frames.ticks[:n].astype(np.float64).sum()
    assert held["values"] == int(frames.values[:n].astype(np.int64).sum())
    if job == "chips":                                       # 2.2 million frames do not all fit in 2 MB
        assert n < len(frames) and held["note"] == [
            f"the pulse view holds the first {n} of {len(frames)} port frames (what fits in a report of at most 2 MB)"]
    else:
        assert n == len(frames) and held["note"] == []


def test_listing_and_title_keep_their_characters(browser, tmp_path):
    """The page is windows-1252 with its store written byte for byte: a program's comments in any
    language, and its name, read as they were written."""
    text = "(Ø 20 mm – Körper; 切削 🙂)\nG21 G90\nG0 X5 Z1\nG1 Z-3 F300 ; <script> & \"=\"\nM30\n"
    (tmp_path / "ü.ngc").write_text(text, encoding="utf-8")
    page = make_report(tmp_path, "ü.ngc", "chivu-lathe")
    assert max(page.read_bytes()[:page.read_bytes().index(b'id="store"')]) < 128     # ASCII before the store
    open_report(browser, page)
    seen = browser.execute_script("return {rows: [...document.querySelectorAll('#listing > div')].map(d => "
                                  "d.childNodes[1].textContent), title: document.querySelector('h2').textContent}")
    assert seen["rows"] == text.splitlines()
    assert seen["title"].startswith("ü.ngc on the chivu-lathe")


def run_frames(program: str, machine):
    """The port frames of the program's run (the fast path, as retrofit run makes them)."""
    from types import SimpleNamespace

    from retrofit.run.program import STAGE_WEIGHTS, read_program, run_program
    from retrofit.run.progress import silent
    text, name = read_program(program)
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=True, keep_commands=True, before_outputs=None)
    return run_program(text, name, machine, opts, silent(STAGE_WEIGHTS)).log.frames


def test_a_program_with_megabytes_of_comments_stays_within_the_limit(browser, tmp_path):
    """1.5 MB of comments that do not pack (random letters): the report keeps the listing's first
    lines within its share, says how many, and stays within 2 MB."""
    import random
    import string
    r = random.Random(7)
    lines = ["G21 G90", "G0 Z1", "G1 Z-0.5 F300"]
    lines += [f"G1 X{10 + i % 7} Y{10 + i % 5} F1500 ; " + "".join(r.choices(string.ascii_letters, k=1500))
              for i in range(1000)]
    (tmp_path / "notes.ngc").write_text("\n".join(lines + ["G0 Z1", "M30"]) + "\n")
    page = make_report(tmp_path, "notes.ngc", "engraver")
    assert page.stat().st_size <= REPORT_BYTES
    open_report(browser, page)
    seen = browser.execute_script("return {rows: [...document.querySelectorAll('#listing > div')].map(d => "
                                  "d.childNodes[1].textContent), notes: [...document.querySelectorAll('.note')]"
                                  ".map(p => p.textContent)}")
    kept = len(seen["rows"])
    assert 10 < kept < len(lines) and seen["rows"] == lines[:kept]
    assert f"the listing shows the first {kept} of {len(lines) + 2} lines" in seen["notes"]
