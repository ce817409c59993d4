"""Draw docs/gallery.md and its pictures again: the run plots (a mill program with Z, the lathe
with and without backlash compensation) by ``retrofit run --plot``, and the console and the HTML
report in their fixed states (tests/console_screens.py, the states the screenshot tests check),
shot in headless Chromium at 1 600 x 1 000 px.

    python3 docs/make_gallery.py          # from the checkout; needs chromium and chromium-driver
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
OUT = DOCS / "gallery"
sys.path.insert(0, str(DOCS.parent / "tests"))

#: (file, caption, program, machine, extra options) of the run plots
PLOTS = [
    ("plot-mill-holes.png", "tul-mill: two drilled holes and a pocket at two depths; top view and side view "
     "(Z against X) with the plunges marked", "holes-and-pocket.ngc", "tul-mill", []),
    ("plot-mill-engraving.png", "the engraver: engraving.ngc, top view and side view", "engraving.ngc", "engraver", []),
    ("plot-lathe-comp.png", "chivu-lathe: lathe-profile.ngc with backlash compensation", "lathe-profile.ngc",
     "chivu-lathe", []),
    ("plot-lathe-no-comp.png", "chivu-lathe: lathe-profile.ngc without backlash compensation (the carriage "
     "lags by the clearance after each reversal)", "lathe-profile.ngc", "chivu-lathe", ["--no-backlash-comp"]),
]


def draw_plots(work: Path) -> list[tuple[str, str]]:
    from console_screens import MILL_JOB
    (work / "holes-and-pocket.ngc").write_text(MILL_JOB)
    shown = []
    for name, caption, program, machine, extra in PLOTS:
        subprocess.run([sys.executable, "-m", "retrofit.cli", "run", program, "--machine", machine,
                        "--plot", str(OUT / name), "--progress", "off", *extra], cwd=work, check=True,
                       capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
        shown.append((name, caption))
    return shown


def shoot_states(work: Path) -> list[tuple[str, str]]:
    from console_kit import chromium
    from console_screens import STATES, bring, faults, structure
    driver = chromium(work / "profile", 1600, 1000)
    shown = []
    try:
        for state in STATES:
            served = bring(driver, state, work)
            try:
                problems = faults(state, structure(driver, state))
                if problems:
                    print(f"{state.name}: {problems}", file=sys.stderr)
                driver.save_screenshot(str(OUT / f"{state.name}.png"))
                shown.append((f"{state.name}.png", state.caption))
            finally:
                if served is not None:
                    served.close()
    finally:
        driver.quit()
    return shown


def main() -> None:
    OUT.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["XDG_STATE_HOME"] = tmp              # the spindle records of these runs stay here
        plots = draw_plots(Path(tmp))
        screens = shoot_states(Path(tmp))
    text = ["# Gallery", "", "Drawn by `python3 docs/make_gallery.py`; the console and report states are the ones",
            "`tests/test_console_screens_browser.py` checks (elements drawn, no overlap, the layout's order).", ""]
    for title, pictures in (("Run plots (`retrofit run --plot`)", plots), ("Console and HTML report", screens)):
        text += [f"## {title}", ""]
        for name, caption in pictures:
            text += [f"**{caption}**", "", f"![{caption}](gallery/{name})", ""]
    (DOCS / "gallery.md").write_text("\n".join(text))
    print(f"wrote {DOCS / 'gallery.md'} and {len(plots) + len(screens)} pictures in {OUT}")


if __name__ == "__main__":
    main()
