"""`retrofit run --html`: the lathe program's report opens offline in Chromium with no network
request, and its pulse view zooms down to single pulses of the width the machine file sets."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from console_kit import chromium, needs_chromium, wait_for

from retrofit.machine.config import load_machine

pytestmark = needs_chromium


@pytest.fixture(scope="module")
def report_page(tmp_path_factory):
    folder = tmp_path_factory.mktemp("html-report")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", "lathe-profile.ngc", "--html", "run.html",
                           "--report", "run.json"], cwd=folder, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "html: run.html" in proc.stdout
    driver = chromium(tmp_path_factory.mktemp("chromium-profile"))
    driver.get((folder / "run.html").as_uri())
    wait_for(driver, "return document.body.dataset.views === 'ready'")
    yield driver, folder
    driver.save_screenshot(str(folder / "report.png"))
    driver.quit()


def requested_urls(driver) -> list[str]:
    urls = []
    for entry in driver.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg["method"] == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    return urls


def test_report_opens_offline_without_a_network_request(report_page):
    driver, folder = report_page
    urls = requested_urls(driver)
    network = [u for u in urls if u.split(":", 1)[0] in ("http", "https", "ws", "wss", "ftp")]
    assert network == []                                  # (the browser's own chrome:// pages aside)
    assert (folder / "run.html").as_uri() in urls
    resources = driver.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert all(u.startswith(("file://", "data:")) for u in resources), resources
    drawn = driver.execute_script("""
        const d = document.getElementById('preview').data;
        return {dash: d.find(t => t.name.startsWith('rapid')).line.dash, stock: d.some(t => t.name.startsWith('stock')),
                backplot: d[d.length - 1].x.length}""")
    assert drawn["dash"] == "dash" and drawn["stock"] and drawn["backplot"] > 100
    title = driver.execute_script("return document.querySelector('h2').textContent")
    assert title == "lathe-profile.ngc on the chivu-lathe, backlash compensation on"


@pytest.mark.slow
def test_pulse_view_zooms_to_single_pulses_of_the_machines_width(report_page):
    driver, folder = report_page
    lathe = load_machine("chivu-lathe")
    report = json.loads((folder / "run.json").read_text())
    end = report["ticks"]
    shown = driver.execute_script("return document.getElementById('pulses').data[0].name")
    assert shown.endswith("(busy)")                       # the whole run: activity, not pulses
    t0 = end // 3
    driver.execute_script("return window.retrofitViews.zoom('pulses', arguments[0], arguments[1])", t0, t0 + 4000)
    wait_for(driver, f"return document.getElementById('pulses').dataset.window === '{t0}:{t0 + 4000}'")
    widths = driver.execute_script("""
        const tr = document.getElementById('pulses').data, out = {};
        for (const t of tr) {
          if (!t.name.endsWith('step')) continue;
          const base = Math.min(...t.y), w = [];
          for (let i = 1; i < t.x.length; i++) {
            if (!(t.y[i] > base && t.y[i - 1] === base)) continue;
            let j = i + 1;
            while (j < t.x.length && t.y[j] > base) j++;
            if (j < t.x.length) w.push(Math.round((t.x[j] - t.x[i]) / arguments[0]));
          }
          out[t.name] = w;
        }
        return out;""", lathe.tick_s)
    assert any(widths.values())
    for name, w in widths.items():
        axis = lathe.axis(name.split()[0])
        assert set(w) <= {axis.pulse_high_ticks}, (name, w)
    zooms = driver.execute_script("return window.retrofitZoomMs")
    assert zooms[-1]["view"] == "pulses"


@pytest.mark.slow
def test_a_zoomed_timeline_is_computed_from_every_step(report_page):
    """Zoomed in, the report's timeline is not the kept (downsampled) trace but every step, as the
    console's server computes it: the position at each tick shown is the run's, to the step."""
    import numpy as np
    from test_html_report_size import run_frames

    from retrofit.console.views import axis_steps, mean_rate
    driver, folder = report_page
    lathe = load_machine("chivu-lathe")
    end = json.loads((folder / "run.json").read_text())["ticks"]
    t0 = end // 3
    driver.execute_script("return window.retrofitViews.zoom('timeline', arguments[0], arguments[1])", t0, t0 + 40_000)
    wait_for(driver, f"return document.getElementById('timeline').dataset.window === '{t0}:{t0 + 40000}'")
    drawn = driver.execute_script("""
        const d = document.getElementById('timeline').data, tr = (n, ax) => d.find(t => t.name === n && t.yaxis === ax);
        return {t: tr('Z', 'y').x, z: tr('Z', 'y').y, v: tr('Z', 'y2').y,
                title: document.getElementById('timeline').layout.yaxis2.title.text}""")
    assert len(drawn["t"]) > 1000                             # the kept trace has a few dozen points here
    ticks = np.round(np.asarray(drawn["t"]) / lathe.tick_s).astype(np.int64)
    z = axis_steps(run_frames("lathe-profile.ngc", lathe), lathe)[lathe.axis_names.index("Z")]
    per_mm = lathe.axis("Z").steps_per_mm
    assert np.array_equal(np.round(np.asarray(drawn["z"]) * per_mm).astype(np.int64), z.at(ticks))
    half = max(int(0.05 / lathe.tick_s / 2), int(ticks[1] - ticks[0]))
    speed = mean_rate(z, ticks, half) * 60.0 / (per_mm * lathe.tick_s)
    assert np.allclose(drawn["v"], speed, atol=1e-6)
    assert drawn["title"] == "velocity [mm/min], mean over 50 ms"
