"""``retrofit run --html run.html``: the run as one self-contained, interactive HTML file.

Everything the page needs is inside it -- plotly.js (its gl3d bundle, :func:`report_plotly`), the
console's drawing code (``static/views.js``) and the run's data -- so it opens offline, from a
file, with no network request. The library and the data are packed (:func:`packed`: gzip and
base64, unpacked by the browser) and each timeline trace is cut to its minima and maxima per
column, so a report stays within a few megabytes. It shows what the console shows after a run: the preview with the carriage's
path over it, the timeline (position, velocity, acceleration, carriage error per axis, with the
violations marked at their program line) and the step and direction lines down to single pulses.
"""

from __future__ import annotations

import base64
import gzip
import html
import json
from pathlib import Path

import numpy as np

from ..config import Machine
from ..frames import PortFrames
from .api import STATIC, plotly_js
from .views import axis_steps, preview, timeline

#: ticks at which the timeline is computed (evenly spread over the run)
TIMELINE_POINTS = 20_000
#: points each timeline trace keeps: the smallest and the largest value of each of half as many
#: columns of the run (tsdownsample's MinMaxLTTB), so no peak is lost at any zoom the page shows
TRACE_POINTS = 3_000
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
    plotly = packed(np.frombuffer(report_plotly().read_bytes(), np.uint8), np.uint8)
    return _PAGE.format(title=html.escape(title), plotly=plotly,
                        views=(STATIC / "views.js").read_text(encoding="utf-8"), data=payload,
                        summary=summary, listing=listing)


def report_plotly() -> Path:
    """The plotly.js the report carries: the whole bundle the ``plotly`` package ships (3.6 MB,
    about 1.1 MB of the report once packed)."""
    return plotly_js()


def run_data(machine: Machine, frames: PortFrames, sim, report: dict, program, source: str, start_steps) -> dict:
    """What the page draws: preview, backplot, timeline, port frames, violations."""
    from ..plot import carriage_path
    steps = axis_steps(frames, machine, start_steps)
    if program is not None:
        pv = preview(program, machine, source)
        pv["segments"] = packed_segments(pv["segments"], len(machine.axes))
    else:
        pv = {"lathe": False, "axes": [{"name": a.name, "label": a.label, "min": a.min_mm, "max": a.max_mm}
                                       for a in machine.axes], "segments": [], "rapids": 0, "cuts": 0}
        from ..plot import is_lathe
        pv["lathe"] = is_lathe(machine)
    carriage = np.asarray(carriage_path(sim), np.float64)
    stride = max(1, len(carriage) // BACKPLOT_POINTS)
    backplot = {"axes": len(machine.axes), "mm": packed(carriage[::stride].ravel(), np.float32)}

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
    ticks = frames.ticks[:n].astype(np.int64)
    return {"preview": pv, "backplot": backplot, "tick_s": machine.tick_s, "end_tick": end,
            "timeline": packed_timeline(timeline(steps, machine, 0, end, carriage_at, TIMELINE_POINTS),
                                        machine.tick_s),
            "frames": {"ticks": packed(np.diff(ticks, prepend=0), np.uint32),
                       "values": packed(frames.values[:n], np.uint8), "lines": lines,
                       "shown": n, "total": len(frames)},
            "violations": report.get("violations", [])}


def packed(values, dtype) -> str:
    """``values`` as the page unpacks them (``RV.unpack``): little-endian ``dtype``, its bytes
    grouped by place (every first byte, then every second ...: the high bytes of small numbers
    are runs of zeros that gzip packs to almost nothing), gzip, base64."""
    dtype = np.dtype(dtype).newbyteorder("<")
    raw = np.frombuffer(np.ascontiguousarray(values, dtype=dtype).tobytes(), np.uint8)
    planes = raw.reshape(-1, dtype.itemsize).T.tobytes()
    return base64.b64encode(gzip.compress(planes, 9, mtime=0)).decode("ascii")


def packed_timeline(data: dict, tick_s: float, points: int = TRACE_POINTS) -> dict:
    """Each trace of ``data`` (views.timeline) cut to ``points`` by min/max per column, packed:
    the ticks of the whole timeline once, and per trace the indices of the points it keeps."""
    from tsdownsample import MinMaxLTTBDownsampler
    t = np.asarray(data["t"], np.float64)
    ticks = np.round(t / tick_s).astype(np.int64)
    out = {"ticks": packed(np.diff(ticks, prepend=0), np.uint32), "axes": {}, "window_s": data["window_s"]}
    for name, series in data["axes"].items():
        out["axes"][name] = {}
        for key, values in series.items():
            y = np.asarray(values, np.float64)
            keep = np.arange(len(y)) if len(y) <= points else \
                MinMaxLTTBDownsampler().downsample(t, y, n_out=points)
            out["axes"][name][key] = {"i": packed(keep, np.uint32), "y": packed(y[keep], np.float32)}
    return out


def packed_segments(segments: list[dict], axes: int) -> dict:
    """The preview's segments packed: kind (0 rapid, 1 cut), program line, start and end (mm)."""
    ends = np.array([s["start"] + s["end"] for s in segments], np.float64).reshape(-1, 2 * axes)
    return {"count": len(segments), "axes": axes,
            "cut": packed([s["kind"] == "cut" for s in segments], np.uint8),
            "line": packed([s["line"] or 0 for s in segments], np.uint32),
            "mm": packed(ends.ravel(), np.float32)}


def _summary(report: dict) -> list[str]:
    from ..report import summary_lines
    return summary_lines(report)


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title><link rel="icon" href="data:,">
<style>
body {{ font: 13px/1.4 system-ui, sans-serif; margin: 12px; color: #222; }}
#top {{ display: grid; grid-template-columns: minmax(0, 1fr) 330px; gap: 10px; }}
#top > div, #timeline, #pulses {{ min-width: 0; overflow: hidden; }}
#preview {{ height: 560px; }}
#listing {{ font: 12px/1.4 monospace; height: 560px; overflow: auto; border: 1px solid #ccc; white-space: pre; }}
#listing span.n {{ color: #999; display: inline-block; width: 3em; text-align: right; margin-right: 6px; }}
#listing div.flag {{ background: #f8c8c8; }}
</style>
<script>{views}</script>
<script type="text/plain" id="plotly-gz">{plotly}</script>
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
RV.unpack(document.getElementById("plotly-gz").textContent, Uint8Array).then(code => {{
  const lib = document.createElement("script");          // plotly.js, unpacked: runs as it is inserted
  lib.textContent = new TextDecoder().decode(code);
  document.head.appendChild(lib);
  return RV.unpackRun(JSON.parse(document.getElementById("run-data").textContent));
}}).then(run => {{
RV.drawPreview(document.getElementById("preview"), run.preview, "commanded path and carriage", {{position: false}});
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
}});
</script>
</body></html>
"""
