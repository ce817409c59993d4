"""Screenshot tests of the console and the HTML report in headless Chromium, by structure: in each
fixed state of tests/console_screens.py the elements the operator must see are drawn inside the
window, the regions never overlap and stand where the layout puts them, at 1 280, 1 600 and
1 920 px. The screenshots are kept with the test's files; docs/make_gallery.py draws the same."""

from __future__ import annotations

import pytest
from console_kit import browser, needs_chromium, wait_for  # noqa: F401 (browser)
from console_screens import STATES, bring, faults, structure

pytestmark = needs_chromium
#: every plot has followed its box's new width (plotly resizes after the window does)
SETTLED = ("return [...document.querySelectorAll('.js-plotly-plot')].every(p => { const s = p.querySelector('.main-svg');"
           " return !s || Math.abs(s.getBoundingClientRect().width - p.getBoundingClientRect().width) < 2; })")


@pytest.mark.slow
@pytest.mark.parametrize("state", STATES, ids=[s.name for s in STATES])
def test_each_state_is_drawn_without_overlap_at_every_width(browser, state, tmp_path):
    served = bring(browser, state, tmp_path)
    try:
        for width in (1280, 1600, 1920):
            browser.set_window_size(width, 1000)
            wait_for(browser, f"return Math.abs(window.outerWidth - {width}) < 2")
            wait_for(browser, state.drawn)
            wait_for(browser, SETTLED)
            seen = structure(browser, state)
            browser.save_screenshot(str(tmp_path / f"{state.name}-{width}.png"))
            assert faults(state, seen) == [], (width, seen)
    finally:
        browser.set_window_size(1500, 1100)
        if served is not None:
            served.close()


def test_the_structure_check_sees_an_overlap_and_a_cut_element():
    """The check itself: a panel pushed over the preview, and one beyond the window, are faults."""
    state = STATES[0]
    good = {"boxes": {"header": [0, 0, 1280, 40], "#left": [8, 48, 300, 600], "#preview": [308, 48, 972, 600],
                      "#right": [980, 48, 1272, 600]}, "width": 1280, "scroll": 1280}
    assert faults(state, good) == []
    over = {**good, "boxes": {**good["boxes"], "#right": [900, 48, 1272, 600]}}
    assert faults(state, over) == [f"#preview {good['boxes']['#preview']} and #right [900, 48, 1272, 600] overlap",
                                   f"#preview {good['boxes']['#preview']} is not left of #right [900, 48, 1272, 600]"]
    cut = {**good, "boxes": {**good["boxes"], "#right": [980, 48, 1400, 600]}, "scroll": 1400}
    assert len(faults(state, cut)) == 2
