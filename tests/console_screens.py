"""Fixed states of the console and of the HTML report, as the screenshot tests check them and the
docs' gallery shows them (``python3 docs/make_gallery.py``).

A state is compared by its structure, not its pixels: the elements the operator must see are
there and drawn (a box of some size, inside the window's width), the regions never overlap, and
each stands where the layout puts it (left of, above ...), as written here by hand."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from console_kit import DIALOGS, console_page, open_text, run, wait_for

#: a mill program with plunges along Z (drilled holes) and a pocket at two depths
MILL_JOB = ("G21 G90\nG0 Z-5\nG0 X10 Y10\nG1 Z-20 F200\nG0 Z-5\nG0 X30 Y10\nG1 Z-20\nG0 Z-5\n"
            "G0 X15 Y25\nG1 Z-12\nG1 X30 Y25 F300\nG1 X30 Y35\nG1 X15 Y35\nG1 X15 Y25\nG1 Z-16\n"
            "G1 X30 Y25\nG1 X30 Y35\nG1 X15 Y35\nG1 X15 Y25\nG0 Z0\nM30\n")


@dataclass
class State:
    """What a state shows: ``regions`` (CSS selectors) that must be drawn and never overlap,
    ``inside`` elements that must be drawn within the window, ``order``: (a, relation, b) with
    relation "left of" or "above", and ``drawn``: a script true once the plots are in."""

    name: str
    caption: str
    regions: list[str]
    order: list[tuple[str, str, str]]
    inside: list[str] = field(default_factory=list)
    drawn: str = "return true"


STATES = [
    State("console-empty", "the console before a program is open: the lathe's soft limits and where it stands",
          ["header", "#left", "#preview", "#right"],
          [("#left", "left of", "#preview"), ("#preview", "left of", "#right"), ("header", "above", "#preview")],
          drawn="const d = document.getElementById('preview').data; return d && d.some(t => t.name === 'soft limits')"),
    State("console-error", "a refused MDI line: the message names the line and the rule, and stays",
          ["header", "#message", "#left", "#preview", "#right"],
          [("header", "above", "#message"), ("#message", "above", "#preview"), ("#preview", "left of", "#right")],
          drawn="return document.getElementById('message-text').textContent.includes('soft limits')"),
    State("console-run", "after a run of lathe-profile.ngc: the backplot, the timeline and the pulse view",
          ["#left", "#preview", "#right", "#timeline", "#pulses"],
          [("#left", "left of", "#preview"), ("#preview", "left of", "#right"), ("#preview", "above", "#timeline"),
           ("#timeline", "above", "#pulses")],
          drawn="return document.body.dataset.views === 'ready'"),
    State("console-tool-dialog", "a manual tool change holds the run until the operator answers",
          ["#left", "#preview", "#right"], [("#preview", "left of", "#right")], inside=["#dialog", "#dialog-ok"],
          drawn="return document.getElementById('dialog').open"),
    State("console-mill", "tul-mill: a program with plunges in 3D, framed on the part",
          ["#left", "#preview", "#right"], [("#left", "left of", "#preview"), ("#preview", "left of", "#right")],
          inside=["#preview .gl-container canvas"],
          drawn="return !!document.querySelector('#preview .gl-container canvas')"),
    State("report-lathe", "the HTML report of lathe-profile.ngc (retrofit run --html)",
          ["#preview", "#listing", "#timeline", "#pulses"],
          [("#preview", "left of", "#listing"), ("#preview", "above", "#timeline"), ("#timeline", "above", "#pulses")],
          drawn="return document.body.dataset.views === 'ready'"),
]


def bring(driver, state: State, folder: Path):
    """Bring the page in ``driver`` into ``state``; what to close afterwards (or None)."""
    if state.name == "report-lathe":
        proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", "lathe-profile.ngc", "--machine",
                               "chivu-lathe", "--html", "run.html", "--progress", "off"], cwd=folder,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        driver.get((folder / "run.html").as_uri())
        served = None
    else:
        served = console_page(driver, "tul-mill" if state.name == "console-mill" else "chivu-lathe")
    if state.name == "console-error":
        driver.execute_script("document.getElementById('mdi').value = 'G0 X999'")
        driver.find_element("id", "mdi-go").click()
    elif state.name == "console-run":
        driver.execute_script("document.getElementById('example').value = 'lathe-profile.ngc'")
        driver.find_element("id", "open").click()
        wait_for(driver, "return document.getElementById('program-name').textContent === 'lathe-profile.ngc'")
        run(driver, "0")
    elif state.name == "console-tool-dialog":
        open_text(driver, "tool-change.cmds", DIALOGS)
        run(driver, "0")
    elif state.name == "console-mill":
        open_text(driver, "holes-and-pocket.ngc", MILL_JOB)
    wait_for(driver, state.drawn, timeout=120)
    return served


def structure(driver, state: State) -> dict:
    """The boxes of the state's elements, the window's width and how far the page scrolls sideways."""
    return driver.execute_script("""
        const box = (sel) => { const e = document.querySelector(sel); if (!e) return null;
          const b = e.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
        return {boxes: Object.fromEntries(arguments[0].map(s => [s, box(s)])),
                width: document.documentElement.clientWidth, scroll: document.documentElement.scrollWidth}""",
                                 state.regions + state.inside)


def faults(state: State, seen: dict) -> list[str]:
    """What is wrong with the structure ``seen`` of ``state`` (nothing: an empty list)."""
    out, boxes = [], seen["boxes"]
    for sel in state.regions + state.inside:
        b = boxes[sel]
        if b is None or b[2] - b[0] < 20 or b[3] - b[1] < 10:
            out.append(f"{sel} is not drawn: {b}")
        elif b[0] < -0.5 or b[2] > seen["width"] + 0.5:
            out.append(f"{sel} leaves the window ({seen['width']} px wide): {b}")
    if seen["scroll"] > seen["width"]:
        out.append(f"the page scrolls sideways: {seen['scroll']} px in a {seen['width']} px window")
    drawn = [s for s in state.regions if boxes[s] is not None]
    for i, a in enumerate(drawn):
        for b in drawn[i + 1:]:
            p, q = boxes[a], boxes[b]
            if min(p[2], q[2]) - max(p[0], q[0]) > 0.5 and min(p[3], q[3]) - max(p[1], q[1]) > 0.5:
                out.append(f"{a} {p} and {b} {q} overlap")
    for a, relation, b in state.order:
        p, q = boxes[a], boxes[b]
        if p is None or q is None:
            continue
        ok = p[2] <= q[0] + 0.5 if relation == "left of" else p[3] <= q[1] + 0.5
        if not ok:
            out.append(f"{a} {p} is not {relation} {b} {q}")
    return out
