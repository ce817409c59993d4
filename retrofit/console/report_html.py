"""``retrofit run --html run.html``: the run as one self-contained, interactive HTML file.

Everything the page needs is inside it -- plotly.js (from the ``plotly`` package), the console's
drawing code (``static/views.js``) and the run's data -- so it opens offline, from a file, with
no network request. It shows what the console shows after a run: the preview with the carriage's
path over it, the timeline (position, velocity, acceleration, carriage error per axis, with the
violations marked at their program line) and the step and direction lines down to single pulses.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..config import Machine
from ..frames import PortFrames
from .api import STATIC, plotly_js
from .views import axis_steps, preview, timeline

#: points of the embedded timeline (the page thins them to its window)
TIMELINE_POINTS = 20_000
#: port frames embedded for the pulse view at most (a longer run shows its first ones)
MAX_FRAMES = 2_000_000
#: carriage points of the embedded backplot at most
BACKPLOT_POINTS = 20_000


def write_html_report(args, log, sim, report: dict, commands=None, target: Path | None = None,
                      program: tuple[str, str] | None = None, compiled=None) -> Path:
    """``--html FILE`` of ``retrofit run`` or ``retrofit demo``: the report of this run.

    ``program`` is the run's (name, G-code text) and ``compiled`` its Program when the caller has them.
    """
    from ..plot import user_title
    source, what = "", getattr(args, "which", "")
    if program is not None:
        what, source = program
        compiled = compiled or waypoint_program(log, what)
    elif getattr(args, "program", None):
        from ..gcode import load_program
        from ..runprogram import resolve_program
        path = resolve_program(args.program)
        compiled, source, what = load_program(path, log.machine), path.read_text(errors="replace"), path.name
    else:                                # a demo: its commanded points, as cuts
        compiled = waypoint_program(log, what)
    program = compiled
    title = user_title(log.machine, what, not args.no_backlash_comp)
    text = html_report(log.machine, log.frames, sim, report, title, program, source, log.start_steps)
    from ..atomic import staged
    out = Path(target or args.html)
    with staged(out) as tmp:               # complete or absent, even on Ctrl-C
        tmp.write_text(text, encoding="utf-8")
    return out


def waypoint_program(log, name: str):
    """The controller's commanded points as a program of PMOVs (for runs that had no program)."""
    from ..commands import PMov
    from ..gcode.program import Program
    axes = log.machine.axes
    cmds = [PMov(axes=tuple((a.name, a.to_mm(s)) for a, s in zip(axes, w.steps))) for w in log.waypoints]
    return Program(cmds, [0] * len(cmds), name)


def html_report(machine: Machine, frames: PortFrames, sim, report: dict, title: str, program=None,
                source: str = "", start_steps=None) -> str:
    """The HTML text of a run's report (see the module's docstring)."""
    data = run_data(machine, frames, sim, report, program, source, start_steps)
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    summary = "".join(f"<li>{html.escape(line)}</li>" for line in _summary(report))
    listing = "".join(f'<div id="L{i}"><span class="n">{i}</span>{html.escape(t)}</div>'
                      for i, t in enumerate(source.splitlines(), 1))
    return _PAGE.format(title=html.escape(title), plotly=plotly_js().read_text(encoding="utf-8"),
                        views=(STATIC / "views.js").read_text(encoding="utf-8"), data=payload,
                        summary=summary, listing=listing)


def run_data(machine: Machine, frames: PortFrames, sim, report: dict, program, source: str, start_steps) -> dict:
    """What the page draws: preview, backplot, timeline, port frames, violations."""
    from ..plot import carriage_path
    steps = axis_steps(frames, machine, start_steps)
    if program is not None:
        pv = preview(program, machine, source)
    else:
        pv = {"lathe": False, "axes": [{"name": a.name, "label": a.label, "min": a.min_mm, "max": a.max_mm}
                                       for a in machine.axes], "segments": [], "rapids": 0, "cuts": 0}
        from ..plot import is_lathe
        pv["lathe"] = is_lathe(machine)
    carriage = carriage_path(sim)
    stride = max(1, len(carriage) // BACKPLOT_POINTS)
    rows = [[0.0] + list(r) + list(r) for r in np.round(carriage[::stride], 4).tolist()]

    def carriage_at(i, ticks):
        trace = sim.traces[machine.axes[i].name]
        values = np.concatenate(([sim._initial[i][1]], np.asarray(trace.carriage_mm, float)))
        return values[np.searchsorted(np.asarray(trace.ticks, np.int64), ticks, side="right")]
    end = max(frames.end_tick, 2)
    lines = []
    for a in machine.axes:
        lines += [{"name": f"{a.name} step", "bit": a.step_bit, "inv": int(a.invert_step)},
                  {"name": f"{a.name} dir", "bit": a.dir_bit, "inv": int(a.invert_dir)}]
    n = min(len(frames), MAX_FRAMES)
    return {"preview": pv, "backplot": rows, "tick_s": machine.tick_s, "end_tick": end,
            "timeline": timeline(steps, machine, 0, end, carriage_at, TIMELINE_POINTS),
            "frames": {"ticks": frames.ticks[:n].tolist(), "values": frames.values[:n].tolist(), "lines": lines,
                       "shown": n, "total": len(frames)},
            "violations": report.get("violations", [])}


def _summary(report: dict) -> list[str]:
    from ..report import summary_lines
    return summary_lines(report)


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title><link rel="icon" href="data:,">
<style>
body {{ font: 13px/1.4 system-ui, sans-serif; margin: 12px; color: #222; }}
#top {{ display: grid; grid-template-columns: 1fr 330px; gap: 10px; }}
#preview {{ height: 560px; }}
#listing {{ font: 12px/1.4 monospace; height: 560px; overflow: auto; border: 1px solid #ccc; white-space: pre; }}
#listing span.n {{ color: #999; display: inline-block; width: 3em; text-align: right; margin-right: 6px; }}
#listing div.flag {{ background: #f8c8c8; }}
</style>
<script>{plotly}</script>
<script>{views}</script>
</head><body>
<h2>{title}</h2>
<ul>{summary}</ul>
<div id="violations"></div>
<div id="top"><div id="preview"></div><div id="listing">{listing}</div></div>
<div id="timeline"></div>
<div id="pulses"></div>
<script type="application/json" id="run-data">{data}</script>
<script>
"use strict";
const run = JSON.parse(document.getElementById("run-data").textContent);
RV.drawPreview(document.getElementById("preview"), run.preview, "commanded path and carriage");
RV.extendBackplot(document.getElementById("preview"), run.preview, run.backplot);
const v = run.violations;
document.getElementById("violations").innerHTML = v.length ? "<b>violations</b>: " + v.slice(0, 50).map(x =>
  `${{x.kind}} ${{x.axis}} at ${{(x.tick * run.tick_s).toFixed(4)}} s` + (x.line ? ` (<a href="#L${{x.line}}">line ${{x.line}}</a>)` : "")).join(", ")
  : "no violations";
for (const x of v) if (x.line) document.getElementById("L" + x.line)?.classList.add("flag");
if (run.frames.shown < run.frames.total)
  document.getElementById("pulses").insertAdjacentText("beforebegin",
    `the pulse view holds the first ${{run.frames.shown}} of ${{run.frames.total}} port frames`);
RV.attachRunViews(document.getElementById("timeline"), document.getElementById("pulses"), RV.localSource(run),
  run.end_tick, run.tick_s, v).then(views => {{ window.retrofitViews = views; document.body.dataset.views = "ready"; }});
</script>
</body></html>
"""
