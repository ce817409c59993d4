"""What the operator sees in the console, in a real headless Chromium: refusals that stay on the
screen, after-run plots for every run, a layout whose parts never overlap, a program that survives
a reload, the machine drawn before a program is open, and tool changes by the mill's carousel."""

from __future__ import annotations

import json

import pytest
from console_kit import Served, browser, console_page, needs_chromium, open_text, polls_later, run, wait_for  # noqa: F401

from retrofit.machine.config import load_machine

pytestmark = needs_chromium

#: two short programs whose runs end at different machine times
SHORT = "G21 G90\nG0 X5 Z1\nG1 Z-4 F300\nG0 X10\nM30\n"
LONGER = "G21 G90\nG0 X5 Z1\nG1 Z-12 F300\nG0 X12\nG0 Z2\nM30\n"


@pytest.fixture
def lathe(browser):
    served = console_page(browser)
    yield served
    served.close()


def message(driver) -> dict:
    return driver.execute_script("const m = document.getElementById('message'); "
                                 "return {shown: !m.hidden && m.offsetHeight > 0, kind: m.className, "
                                 "text: document.getElementById('message-text').textContent}")


def test_a_refused_mdi_line_and_a_missing_file_stay_on_screen(browser, lathe):
    browser.execute_script("document.getElementById('mdi').value = 'G0 X999'")
    browser.find_element("id", "mdi-go").click()
    wait_for(browser, "return document.getElementById('message-text').textContent.includes('G0 X999')")
    first = message(browser)
    assert first["kind"] == "error" and "soft limits" in first["text"]     # the line and the rule
    polls_later(browser, 20)                                 # twenty polls (2 s of the page's time) later
    assert message(browser) == first
    browser.execute_script("document.getElementById('path').value = 'no-such-part.ngc'")
    browser.find_element("id", "open").click()
    wait_for(browser, "return document.getElementById('message-text').textContent.includes('no-such-part.ngc')")
    missing = message(browser)
    assert missing["shown"] and missing["kind"] == "error" and "no such program" in missing["text"]
    polls_later(browser, 20)
    assert message(browser) == missing
    browser.find_element("id", "message").click()            # a click dismisses it
    assert not message(browser)["shown"]
    browser.execute_script("document.getElementById('mdi').value = 'G0 X999'")
    browser.find_element("id", "mdi-go").click()
    wait_for(browser, "return !document.getElementById('message').hidden")
    browser.execute_script("document.getElementById('mdi').value = 'G0 X3 Z-2'")
    browser.find_element("id", "mdi-go").click()             # the next successful action clears it
    wait_for(browser, "return document.getElementById('message').hidden && "
                      "document.getElementById('cmd-X').textContent === '3.000'")


@pytest.mark.slow
def test_a_feed_the_axes_cannot_keep_is_a_warning_that_stays(browser, lathe):
    open_text(browser, "fast.ngc", "G21 G90\nG0 X5 Z1\nG1 Z-10 F99999\nG1 X8 F100\n")
    shown = message(browser)
    assert shown["shown"] and shown["kind"] == "warning"
    assert shown["text"].startswith("fast.ngc:3: F99999 is above machine chivu-lathe's fastest feed 1500 mm/min")
    assert "feeds run at 1500 mm/min" in shown["text"]       # 25 mm/s, the machine file's max_velocity_mm_s
    polls_later(browser, 20)
    assert message(browser) == shown


def after_run(driver) -> dict:
    """What "After the run" shows: the drawn traces and the time the timeline spans."""
    return driver.execute_script("""
        const t = document.getElementById('timeline'), p = document.getElementById('pulses');
        const last = (d) => Math.max(...d.data.map(tr => Math.max(...tr.x.filter(v => v !== null))));
        return {timeline: t.querySelectorAll('.main-svg path.js-line').length,
                pulses: p.querySelectorAll('.main-svg path.js-line').length,
                end_s: t.data ? last(t) : null, ticks: window.retrofitReport.ticks,
                tick_us: window.retrofitReport.tick_us}""")


@pytest.mark.slow
def test_two_runs_in_a_row_each_draw_their_after_run_plots(browser, lathe):
    ends = []
    for name, text in (("short.ngc", SHORT), ("longer.ngc", LONGER)):
        open_text(browser, name, text)
        run(browser, "0")
        wait_for(browser, "return document.body.dataset.views === 'ready' && "
                          "document.getElementById('state').textContent === 'done'", timeout=90)
        seen = after_run(browser)
        assert seen["timeline"] >= 8 and seen["pulses"] >= 4       # 2 axes x 4 rows; 2 x (step, dir)
        assert seen["end_s"] == pytest.approx(seen["ticks"] * seen["tick_us"] * 1e-6, rel=0.01)
        ends.append(seen["end_s"])
    assert ends[1] > ends[0] * 1.5                           # the second plots are the second run's


@pytest.mark.slow
@pytest.mark.parametrize("width", [1280, 1600, 1920])
def test_the_preview_and_the_right_panel_never_intersect(browser, lathe, width):
    browser.set_window_size(width, 1000)
    wait_for(browser, f"return Math.abs(window.outerWidth - {width}) < 2")
    browser.execute_script("document.getElementById('example').value = 'lathe-profile.ngc'")
    browser.find_element("id", "open").click()
    wait_for(browser, "return document.getElementById('program-name').textContent === 'lathe-profile.ngc'")
    run(browser, "0")
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=90)
    polls_later(browser, 5)                                  # plotly's responsive resize settles
    boxes = browser.execute_script("""
        const r = (el) => { const b = el.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
        const right = document.getElementById('right');
        return {preview: r(document.getElementById('preview')),
                svg: r(document.querySelector('#preview .main-svg')), right: r(right),
                page: document.documentElement.clientWidth, scroll: document.documentElement.scrollWidth,
                cut: [...right.querySelectorAll('*')].filter(e => e.scrollWidth > e.clientWidth + 1 &&
                      getComputedStyle(e).overflow === 'visible').map(e => e.id || e.tagName)}""")
    assert boxes["page"] >= width - 20
    for drawn in ("preview", "svg"):
        assert boxes[drawn][2] <= boxes["right"][0], (width, boxes)          # ends left of the panel
    assert boxes["right"][2] <= boxes["page"] and boxes["scroll"] <= boxes["page"], boxes
    status = browser.find_element("id", "status").text
    assert "state:" in status and "spindle" in status
    browser.set_window_size(1500, 1100)


@pytest.mark.slow
def test_a_reload_keeps_the_program_and_the_views(browser, lathe):
    open_text(browser, "short.ngc", SHORT)
    run(browser, "0")
    wait_for(browser, "return document.body.dataset.views === 'ready'", timeout=90)
    browser.refresh()
    wait_for(browser, "return document.getElementById('program-name').textContent === 'short.ngc' && "
                      "document.body.dataset.views === 'ready'", timeout=90)
    listing = browser.execute_script("return document.getElementById('listing').textContent")
    assert "G1 Z-4 F300" in listing
    assert after_run(browser)["timeline"] >= 8
    cuts = browser.execute_script("return document.getElementById('preview').data.find("
                                  "t => t.name.startsWith('cut')).x.filter(v => v !== null).length")
    assert cuts == 2                                          # the one cut, drawn again
    assert browser.execute_script("return document.body.dataset.control") == "yours"


@pytest.mark.slow
def test_before_a_program_is_open_the_envelope_the_position_and_the_state_are_drawn(browser, lathe):
    machine = lathe.console.machine
    lathe.console.act("jog", axis="X", step=4.0)             # the machine stands away from zero
    lathe.wait(lambda s: s["state"] == "done" and s["commanded_mm"]["X"] == 4.0)
    browser.refresh()
    wait_for(browser, "return document.getElementById('cmd-X').textContent === '4.000'")
    drawn = wait_for(browser, """
        const d = document.getElementById('preview').data;
        const limits = d && d.find(t => t.name === 'soft limits');
        const here = d && d.find(t => t.name.startsWith('the machine'));
        return limits && here && here.y[0] === 4 && {x: limits.x, y: limits.y, here: [here.x[0], here.y[0]],
                state: document.getElementById('state').textContent,
                name: document.getElementById('program-name').textContent}""")
    z, x = machine.axis("Z"), machine.axis("X")
    assert sorted(set(drawn["x"])) == [z.min_mm, z.max_mm] and sorted(set(drawn["y"])) == [x.min_mm, x.max_mm]
    assert drawn["here"] == [0, 4] and drawn["state"] == "done" and drawn["name"] == "no program"


@pytest.mark.slow
def test_tul_mill_console_changes_t3_by_the_carousel_and_records_it(browser):
    """The console changes tools as ``retrofit run`` does: the carousel's sequence, from the tool
    the (simulated) spindle record holds, and the record says T3 afterwards; no manual dialog."""
    from retrofit.atc.state import state_paths
    from retrofit.console.server import Console
    machine = load_machine("tul-mill")
    served = Served(Console(machine))
    first = browser.current_window_handle
    try:
        browser.switch_to.new_window("tab")
        browser.get(served.url)
        wait_for(browser, "return document.body.dataset.control === 'yours'")
        open_text(browser, "change.ngc", "G21 G90\nG0 X10 Y10 Z-5\nT3\nG0 X20 Y5 Z-10\nM30\n")
        run(browser, "0")
        wait_for(browser, "return document.body.dataset.views === 'ready' && "
                          "document.getElementById('state').textContent === 'done'", timeout=120)
        assert browser.execute_script("return document.getElementById('tool').textContent") == "3"
        assert not browser.execute_script("return document.getElementById('dialog').open")
        assert browser.find_element("id", "violations").text == "no violations"   # the magazine checked too
        report = browser.execute_script("return window.retrofitReport")
        changes = [e["text"] for e in report["events"] if e["kind"] == "tool change"]
        assert changes == ["tool change T0 -> T3 by the changer (condition 1)"]
        _, record = state_paths(machine, simulated=True)
        assert json.loads(record.read_text())["spindle_tool"] == 3
        open_text(browser, "change.ngc", "G21 G90\nT5\nM30\n")              # starts from the record's T3
        run(browser, "0")
        wait_for(browser, "return document.body.dataset.views === 'ready' && "
                          "document.getElementById('tool').textContent === '5'", timeout=120)
        report = browser.execute_script("return window.retrofitReport")
        assert [e["text"] for e in report["events"] if e["kind"] == "tool change"] == \
            ["tool change T3 -> T5 by the changer (condition 2)"]
        assert json.loads(record.read_text())["spindle_tool"] == 5
    finally:
        browser.close()
        browser.switch_to.window(first)
        served.close()
