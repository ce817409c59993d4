"""The console in a real headless Chromium (Debian's, driven by Selenium and chromium-driver):
open the shipped lathe program, run it, steer it, answer its dialogs; screenshots of each state
are saved with the test's files."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from console_kit import DIALOGS, LONG_MOVE, Served, browser, console_page, needs_chromium, open_text, run, wait_for  # noqa: F401

from retrofit.machine.config import load_machine
from retrofit.run.program import resolve_program

pytestmark = needs_chromium


@pytest.fixture(scope="module")
def console(browser):
    served = console_page(browser)
    assert "token" not in browser.current_url                # the page took it out of the address bar
    yield served.console
    served.close()


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    return tmp_path_factory.mktemp("console-screenshots")


def state(driver) -> str:
    return driver.execute_script("return document.getElementById('state').textContent")


def set_slider(driver, name: str, pct: int) -> None:
    driver.execute_script("const s = document.getElementById(arguments[0]); s.value = arguments[1];"
                          "s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'));", name, pct)


def rs274_counts(path: Path) -> dict:
    """Canonical calls LinuxCNC's interpreter makes for a program (the independent oracle)."""
    out = subprocess.run(["rs274", "-g", str(path)], input="", capture_output=True, text=True, timeout=60).stdout
    return {k: len(re.findall(rf"\b{k}\(", out)) for k in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED")}


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("rs274") is None, reason="needs LinuxCNC's rs274")
def test_preview_draws_the_programs_cuts_and_rapids(browser, console, shots):
    browser.execute_script("document.getElementById('example').value = 'lathe-profile.ngc'")
    browser.find_element("id", "open").click()
    wait_for(browser, "return document.getElementById('preview-info').dataset.cuts")
    drawn = browser.execute_script("""
        const d = document.getElementById('preview').data;
        const segs = (name) => d.find(t => t.name.startsWith(name)).x.filter(v => v === null).length;
        return {rapid: segs('rapid'), cut: segs('cut'), dash: d.find(t => t.name.startsWith('rapid')).line.dash,
                stock: d.some(t => t.name.startsWith('stock')), part: d.some(t => t.name.startsWith('part')),
                cutLines: +document.getElementById('preview-info').dataset.cutLines}""")
    oracle = rs274_counts(resolve_program("lathe-profile.ngc"))
    assert drawn["rapid"] == oracle["STRAIGHT_TRAVERSE"]
    assert drawn["cutLines"] == oracle["STRAIGHT_FEED"] + oracle["ARC_FEED"]
    assert drawn["cut"] > drawn["cutLines"]                  # the two arcs are drawn as chords
    assert drawn["dash"] == "dash" and drawn["stock"] and drawn["part"]
    browser.save_screenshot(str(shots / "1-preview.png"))


def test_run_on_sim_brings_the_dro_to_the_programs_end(browser, console, shots):
    browser.execute_script("document.getElementById('example').value = 'lathe-profile.ngc'")
    browser.find_element("id", "open").click()
    wait_for(browser, "return document.getElementById('program-name').textContent === 'lathe-profile.ngc'")
    run(browser, "0")
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=90)
    dro = browser.execute_script("return ['X', 'Z'].map(a => document.getElementById('cmd-' + a).textContent)")
    assert dro == ["30.000", "10.000"]                       # the program ends at G0 X30, G0 Z10
    carriage = browser.execute_script("return ['X', 'Z'].map(a => +document.getElementById('car-' + a).textContent)")
    assert abs(carriage[0] - 30) <= 0.025 and abs(carriage[1] - 10) <= 0.02
    backplot = browser.execute_script("const d = document.getElementById('preview').data; return d[d.length - 1].x.length")
    assert backplot > 100
    assert state(browser) == "done"
    browser.save_screenshot(str(shots / "2-run-done.png"))


@pytest.mark.slow
def test_feed_override_halves_the_feed_of_the_move_running(browser, console, shots):
    open_text(browser, "long-move.ngc", LONG_MOVE)
    run(browser, "5")
    wait_for(browser, "return document.getElementById('line').textContent === '3' && "
                      "+document.getElementById('time').textContent > 1.5")
    set_slider(browser, "feed", 50)
    wait_for(browser, "return document.getElementById('flags').textContent.includes('MOVING')")
    browser.save_screenshot(str(shots / "3-feed-50.png"))
    browser.execute_script("document.getElementById('speed').value = '0';"
                           "document.getElementById('speed').dispatchEvent(new Event('change'))")
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=90)
    report = browser.execute_script("return window.retrofitReport")
    move = next(m for m in report["moves"] if m["line"] == 3)
    before, after = move["feed_mm_min"]
    assert move["programmed_feed_mm_min"] == 150
    assert before["measured"] == pytest.approx(150, rel=0.01)
    assert after["measured"] == pytest.approx(75, rel=0.01)
    assert after["from_tick"] == next(e["tick"] for e in report["events"] if e["kind"] == "feed")
    set_slider(browser, "feed", 100)


@pytest.mark.slow
def test_stop_ends_the_pulses_within_a_tick(browser, console, shots):
    open_text(browser, "long-move.ngc", LONG_MOVE)
    run(browser, "5")
    wait_for(browser, "return document.getElementById('line').textContent === '3' && "
                      "+document.getElementById('time').textContent > 1.0")
    browser.find_element("id", "stop").click()
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=90)
    report = browser.execute_script("return window.retrofitReport")
    stop = next(e["tick"] for e in report["events"] if e["kind"] == "stop")
    assert report["last_step_tick"] <= stop + 1              # no rising step edge after the next tick
    assert report["axes"]["Z"]["target_mm"] < 0.5 and report["axes"]["Z"]["carriage_mm"] > -38
    assert state(browser) == "stopped"
    browser.save_screenshot(str(shots / "4-stopped.png"))


@pytest.mark.slow
def test_manual_tool_change_and_pause_dialogs_hold_the_run_until_answered(browser, console, shots):
    program = "FMOV X5 Z1\nTOOL T2\nPMOV Z-3\nPAUS M0\nFMOV X8 Z2\n"
    open_text(browser, "tool-change.cmds", program)
    run(browser, "0")
    wait_for(browser, "return document.getElementById('dialog').open")
    text = browser.execute_script("return document.getElementById('dialog-text').textContent")
    assert "tool 2" in text
    dro = browser.execute_script("return ['X', 'Z'].map(a => document.getElementById('cmd-' + a).textContent)")
    assert dro == ["5.000", "1.000"]                         # stands at the tool-change point
    browser.save_screenshot(str(shots / "5-tool-change.png"))
    browser.find_element("id", "dialog-ok").click()
    wait_for(browser, "const d = document.getElementById('dialog'); return d.open && d.dataset.kind === 'pause'")
    dro = browser.execute_script("return ['X', 'Z'].map(a => document.getElementById('cmd-' + a).textContent)")
    assert dro == ["5.000", "-3.000"]                        # the cut after the change ran
    assert browser.execute_script("return document.getElementById('tool').textContent") == "2"
    browser.find_element("id", "dialog-ok").click()
    wait_for(browser, "return document.body.dataset.views === 'ready'")
    dro = browser.execute_script("return ['X', 'Z'].map(a => document.getElementById('cmd-' + a).textContent)")
    assert dro == ["8.000", "2.000"]


@pytest.mark.slow
def test_jog_and_mdi_move_the_machine_after_a_run(browser, console):
    browser.execute_script("document.getElementById('jog-axis').value = 'X';"
                           "document.getElementById('jog-step').value = '1'")
    before = float(browser.execute_script("return document.getElementById('cmd-X').textContent"))
    browser.find_element("id", "jog-plus").click()
    wait_for(browser, f"return +document.getElementById('cmd-X').textContent === {before + 1}")
    browser.execute_script("document.getElementById('mdi').value = 'G0 X2 Z-1'")
    browser.find_element("id", "mdi-go").click()
    wait_for(browser, "return document.getElementById('cmd-X').textContent === '2.000' && "
                      "document.getElementById('cmd-Z').textContent === '-1.000'")


def ten_million_step_run(machine):
    """Back and forth across the lathe's travel at rapid feed until 10 M steps are taken (fast path)."""
    from retrofit.gcode.program import compile_program
    from retrofit.run.program import execute, plan_compiled
    passes = 810
    text = "G21 G90\n" + "".join(f"G0 X{30 if i % 2 else -30} Z{-190 if i % 2 == 0 else 10}\n" for i in range(passes))
    _, plan = plan_compiled(compile_program(text, machine, "ten-million.ngc"), machine)
    return execute(plan)


@pytest.mark.slow
def test_ten_million_step_run_zooms_within_a_second_per_step(browser, tmp_path):
    from retrofit.console.server import Console
    machine = load_machine("chivu-lathe")
    log = ten_million_step_run(machine)
    assert sum(log.steps_emitted.values()) >= 10_000_000
    con = Console(machine)
    con.show_run(log)
    served = Served(con)
    try:
        browser.get(served.url)
        wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=120)
        end = log.frames.end_tick
        centre = int(axis_steps_mid(log))
        steps = []
        for view in ("timeline", "pulses"):
            span = end
            while span > 400:
                span = max(span // 10, 400)
                t0 = max(centre - span // 2, 0)
                if view == "timeline":                    # as a user's zoom does: relayout, then a fetch
                    browser.execute_script("Plotly.relayout('timeline', {'xaxis.range': [arguments[0], arguments[1]]})",
                                           t0 * machine.tick_s, (t0 + span) * machine.tick_s)
                    wait_for(browser, f"return document.getElementById('timeline').dataset.window === '{t0}:{t0 + span}'")
                else:
                    browser.execute_script("return window.retrofitViews.zoom('pulses', arguments[0], arguments[1])",
                                           t0, t0 + span)
                steps.append(browser.execute_script("return window.retrofitZoomMs[window.retrofitZoomMs.length - 1]"))
        browser.save_screenshot(str(tmp_path / "ten-million-pulses.png"))
        print("zoom steps (view, window ticks, ms):", [(s["view"], s["t1"] - s["t0"], round(s["ms"])) for s in steps])
        assert len(steps) >= 10
        assert max(s["ms"] for s in steps) < 1000
        single = browser.execute_script("return document.getElementById('pulses').data[0].name")
        assert not single.endswith("(busy)")              # the last window shows single pulses
    finally:
        served.close()


def axis_steps_mid(log) -> int:
    """A tick in the middle of the run where the port is busy."""
    return int(log.frames.ticks[len(log.frames) // 2])


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("rs274") is None, reason="needs LinuxCNC's rs274")
def test_a_mill_program_is_previewed_in_3d_inside_its_work_envelope(browser, tmp_path):
    from retrofit.console.server import Console
    served = Served(Console(load_machine("engraver")))
    try:
        browser.get(served.url)
        wait_for(browser, "return document.getElementById('example').options.length > 0")
        browser.execute_script("document.getElementById('example').value = 'engraving.ngc'")
        browser.find_element("id", "open").click()
        wait_for(browser, "return document.getElementById('preview-info').dataset.cuts")
        drawn = browser.execute_script("""
            const d = document.getElementById('preview').data;
            const t = (name) => d.find(x => x.name.startsWith(name));
            return {types: [...new Set(d.map(x => x.type))], rapid: t('rapid').x.filter(v => v === null).length,
                    dash: t('rapid').line.dash, box: [Math.min(...t('work').x.filter(v => v !== null)),
                                                      Math.max(...t('work').x.filter(v => v !== null))]}""")
        oracle = rs274_counts(resolve_program("engraving.ngc"))
        assert drawn["types"] == ["scatter3d"] and drawn["dash"] == "dash"
        assert drawn["rapid"] == oracle["STRAIGHT_TRAVERSE"] - count_null_traverses(resolve_program("engraving.ngc"))
        machine = load_machine("engraver")
        assert drawn["box"] == [machine.axis("X").min_mm, machine.axis("X").max_mm]
        browser.save_screenshot(str(tmp_path / "mill-preview.png"))
    finally:
        served.close()


def count_null_traverses(path: Path) -> int:
    """Traverses rs274 reports that go nowhere (to where the tool already is): not drawn."""
    out = subprocess.run(["rs274", "-g", str(path)], input="", capture_output=True, text=True, timeout=60).stdout
    here, null = None, 0
    for m in re.finditer(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED)\(([^)]*)\)", out):
        values = [float(v) for v in m[2].split(",")]
        if m[1] == "ARC_FEED":
            here = None
            continue
        if m[1] == "STRAIGHT_TRAVERSE" and values[:3] == here:
            null += 1
        here = values[:3]
    return null


@pytest.mark.slow
def test_a_second_tab_watches_and_takes_control_only_when_asked(browser):
    """Two tabs on one console: the second shows who holds control and cannot act; its STOP says
    it takes control, and does; the first tab then watches."""
    from retrofit.console.server import Console
    served = Served(Console(load_machine("chivu-lathe")))
    first = browser.current_window_handle
    try:
        browser.switch_to.new_window("tab")
        operator = browser.current_window_handle
        browser.get(served.url)
        wait_for(browser, "return document.body.dataset.control === 'yours'")
        open_text(browser, "tool-change.cmds", DIALOGS)
        run(browser, "0")
        wait_for(browser, "return document.getElementById('dialog').open")
        browser.switch_to.new_window("tab")
        browser.get(served.url)
        wait_for(browser, "return document.body.dataset.control === 'watching' && "
                          "document.getElementById('message').textContent.includes('waiting for the operator')")
        assert not browser.execute_script("return document.getElementById('dialog').open")   # not the watcher's
        assert "operator 1" in browser.find_element("id", "control").text
        assert browser.find_element("id", "stop").text == "Take control + STOP"
        refusal = browser.execute_async_script("act('hold').then(() => 'acted', e => e.message)"
                                                ".then(arguments[arguments.length - 1])")
        assert "held by operator 1" in refusal
        assert served.state()["dialog"]["kind"] == "tool"         # the watcher's hold was refused
        browser.find_element("id", "stop").click()
        wait_for(browser, "return document.getElementById('state').textContent === 'stopped' && "
                          "document.body.dataset.control === 'yours'")
        browser.switch_to.window(operator)
        wait_for(browser, "return document.body.dataset.control === 'watching' && "
                          "document.getElementById('control').textContent.includes('operator 2')")
    finally:
        for handle in browser.window_handles:
            if handle != first:
                browser.switch_to.window(handle)
                browser.close()
        browser.switch_to.window(first)
        served.close()


@pytest.mark.slow
def test_an_error_in_the_run_is_shown_and_stop_still_answers(browser):
    from retrofit.console.server import Console
    served = Served(Console(load_machine("chivu-lathe")))
    first = browser.current_window_handle
    try:
        browser.switch_to.new_window("tab")
        browser.get(served.url)
        wait_for(browser, "return document.body.dataset.control === 'yours'")
        open_text(browser, "long-move.ngc", LONG_MOVE)
        run(browser, "1")
        wait_for(browser, "return +document.getElementById('time').textContent > 0.5")

        def broken(limit):
            raise RuntimeError("a fault in the planner")
        served.console.run.ctl.run_until_idle = broken
        wait_for(browser, "return document.getElementById('state').textContent === 'error' && "
                          "document.getElementById('message').textContent.includes('a fault in the planner')")
        browser.find_element("id", "stop").click()
        wait_for(browser, "return document.getElementById('message').textContent.includes('a fault in the planner')")
        assert served.console.run.outputs == [] and served.state()["state"] == "error"
    finally:
        browser.close()
        browser.switch_to.window(first)
        served.close()
