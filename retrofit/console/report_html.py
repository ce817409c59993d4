"""``retrofit run --html run.html``: the run as one self-contained, interactive HTML file.

Everything the page needs is inside it -- plotly.js (:func:`report_plotly`), the console's drawing
code (``static/views.js``, ``static/unpack.js``) and the run's data -- so it opens offline, from a
file, with no network request. The library, the data and the program's text are gzip-packed into
one store written almost byte for byte into the page (:mod:`.packing`); positions are quantised
to the step; each timeline trace is cut to its minima and maxima per column (tsdownsample's
MinMaxLTTB); the port frames for the pulse view fill the room left under :data:`REPORT_BYTES`.
It shows what the console shows after a run: the preview with the carriage's path over it, the
timeline (position, velocity and acceleration averaged over a stated window, carriage error per
axis, with the violations marked at their program line) and the step and direction lines down to
single pulses.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..frames import PortFrames
from ..machine.config import Machine
from .api import STATIC, plotly_js
from .packing import Store, ascii_page, ascii_script, escaped
from .views import AVERAGE_S, axis_steps, preview, timeline
from .views import TIMELINE_POINTS as WINDOW_POINTS

#: the most a report weighs (bytes); the pulse view's port frames fill what the rest leaves
REPORT_BYTES = 2_000_000
#: ticks at which the timeline is computed (evenly spread over the run)
TIMELINE_POINTS = 20_000
#: points each timeline trace keeps: the smallest and the largest value of each of half as many
#: columns of the run (tsdownsample's MinMaxLTTB), so no peak is lost at any zoom the page shows
TRACE_POINTS = 3_000
#: port frames packed together (an even number: rises and falls keep their places)
FRAME_CHUNK = 131_072
#: port frames embedded for the pulse view at most (a longer run shows its first ones)
MAX_FRAMES = 4_000_000
#: carriage points of the embedded backplot at most
BACKPLOT_POINTS = 20_000
#: packed bytes the preview's segments and the program's listing take at most (the first ones
#: that fit are kept, and the page says so)
SEGMENT_BYTES = 150_000
LISTING_BYTES = 120_000


def write_html_report(args, log, sim, report: dict, commands=None, target: Path | None = None,
                      program: tuple[str, str] | None = None, compiled=None, store=None) -> Path:
    """``--html FILE`` of ``retrofit run`` or ``retrofit demo``: the report of this run.

    ``program`` is the run's (name, G-code text) and ``compiled`` its Program when the caller has
    them; ``store``: what a streamed run kept for the page (:class:`.reportstore.ReportStore`),
    whose log holds no frames.
    """
    from ..run.plot import user_title
    source, what = "", getattr(args, "which", "")
    if program is not None:
        what, source = program
        compiled = compiled or waypoint_program(log, what)
    elif getattr(args, "program", None):
        from ..gcode import load_program
        from ..run.program import resolve_program
        path = resolve_program(args.program)
        compiled, source, what = load_program(path, log.machine), path.read_text(errors="replace"), path.name
    else:                                # a demo: its commanded points, as cuts
        compiled = waypoint_program(log, what)
    program = compiled
    title = user_title(log.machine, what, not args.no_backlash_comp)
    text = html_report(log.machine, log.frames, sim, report, title, program, source, log.start_steps, store)
    from ..atomic import staged
    out = Path(target or args.html)
    with staged(out) as tmp:               # complete or absent, even on Ctrl-C
        tmp.write_bytes(text.encode("latin-1"))
    return out


def waypoint_program(log, name: str):
    """The controller's commanded points as a program of PMOVs (for runs that had no program)."""
    from ..commands import PMov
    from ..gcode.program import Program
    axes = log.machine.axes
    cmds = [PMov(axes=tuple((a.name, a.to_mm(s)) for a, s in zip(axes, w.steps))) for w in log.waypoints]
    return Program(cmds, [0] * len(cmds), name)


def html_report(machine: Machine, frames: PortFrames, sim, report: dict, title: str, program=None,
                source: str = "", start_steps=None, kept=None) -> str:
    """The HTML text of a run's report (see the module's docstring): windows-1252, ASCII but
    for the packed store, at most :data:`REPORT_BYTES` long. ``kept``: a streamed run's
    :class:`.reportstore.ReportStore` (``frames`` then holds only the run's end tick)."""
    store = Store()
    data = run_data(machine, frames, sim, report, program, source, start_steps, store, kept)
    if kept is not None:
        frames = kept.frames(frames.end_tick)
    data["plotly"] = store.text(report_plotly().read_text(encoding="utf-8"))
    summary = "".join(f"<li>{html.escape(line)}</li>" for line in _summary(report))
    parts = {"title": ascii_page(html.escape(title)), "summary": ascii_page(summary),
             "code": ascii_script((STATIC / "views.js").read_text(encoding="utf-8") +
                                  (STATIC / "unpack.js").read_text(encoding="utf-8"))}

    def page() -> str:
        payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
        return _PAGE.format(store=store.page_text(), data=payload, **parts)
    room = REPORT_BYTES - len(page()) - 2_000
    data["frames"].update(frame_chunks(frames, store, room))
    return page()


def report_plotly() -> Path:
    """The plotly.js the report carries: the whole bundle the ``plotly`` package ships (4.8 MB,
    1.5 MB of the report once packed)."""
    return plotly_js()


def run_data(machine: Machine, frames: PortFrames, sim, report: dict, program, source: str, start_steps,
             store: Store, kept=None) -> dict:
    """What the page draws: preview, backplot, timeline, violations, the listing (the port frames
    are added by :func:`frame_chunks`, in the room the rest leaves)."""
    from ..run.plot import carriage_path, is_lathe
    steps = kept.steps() if kept is not None else axis_steps(frames, machine, start_steps)
    per_mm = [a.steps_per_mm for a in machine.axes]
    if program is not None:
        pv = preview(program, machine, source)
        pv["segments"] = packed_segments(pv["segments"], per_mm, store)
    else:
        pv = {"lathe": is_lathe(machine), "axes": [{"name": a.name, "label": a.label, "min": a.min_mm,
              "max": a.max_mm} for a in machine.axes], "segments": [], "rapids": 0, "cuts": 0}
    carriage = np.asarray(carriage_path(sim, BACKPLOT_POINTS), np.float64)
    backplot = {"axes": len(machine.axes), "mm": store.steps(carriage, per_mm)}

    def carriage_at(i, ticks):
        trace = sim.traces[machine.axes[i].name]
        values = np.concatenate(([sim._initial[i][1]], np.asarray(trace.carriage_mm, float)))
        return values[np.searchsorted(np.asarray(trace.ticks, np.int64), ticks, side="right")]
    end = max(frames.end_tick, 2)
    lines = []
    for a in machine.axes:
        lines += [{"name": f"{a.name} step", "bit": a.step_bit, "inv": int(a.invert_step)},
                  {"name": f"{a.name} dir", "bit": a.dir_bit, "inv": int(a.invert_dir)}]
    listed, _ = packed_within(store, lambda lines: store.text("\n".join(lines)), source.splitlines(), LISTING_BYTES)
    return {"preview": pv, "backplot": backplot, "tick_s": machine.tick_s, "end_tick": end,
            "per_mm": per_mm, "start_steps": list(start_steps or [0] * len(machine.axes)),
            "average_s": AVERAGE_S, "window_points": WINDOW_POINTS,
            "timeline": packed_timeline(timeline(steps, machine, 0, kept.timeline_end if kept else end,
                                                 carriage_at, TIMELINE_POINTS), machine.tick_s, store),
            "frames": {"lines": lines, "total": kept.total if kept is not None else len(frames)},
            "source": listed, "source_lines": len(source.splitlines()),
            "violations": report.get("violations", [])}


def frame_chunks(frames: PortFrames, store: Store, room: int) -> dict:
    """The port frames for the pulse view, in chunks of :data:`FRAME_CHUNK` while they fit in
    ``room`` bytes of the page: tick differences (rises and falls apart) and port bytes."""
    ticks = np.asarray(frames.ticks, np.int64)
    chunks, used, shown = [], 0, 0
    for first in range(0, min(len(frames), MAX_FRAMES), FRAME_CHUNK):
        last = min(first + FRAME_CHUNK, len(frames), MAX_FRAMES)
        d = np.diff(ticks[first:last], prepend=ticks[first - 1] if first else 0)
        before = len(store.blocks)
        chunk = {"even": store.array(d[0::2], np.uint32), "odd": store.array(d[1::2], np.uint32),
                 "values": store.array(frames.values[first:last], np.uint8)}
        cost = sum(len(escaped(b)) for b in store.blocks[before:]) + 200
        if used + cost > room:
            store.drop(before)
            break
        chunks.append(chunk)
        used, shown = used + cost, last
    return {"chunks": chunks, "shown": shown}


def packed_timeline(data: dict, tick_s: float, store: Store, points: int = TRACE_POINTS) -> dict:
    """Each trace of ``data`` (views.timeline) cut to ``points`` by min/max per column, packed:
    the ticks of the whole timeline once, and per trace the indices of the points it keeps."""
    from tsdownsample import MinMaxLTTBDownsampler
    t = np.asarray(data["t"], np.float64)
    ticks = np.round(t / tick_s).astype(np.int64)
    out = {"ticks": store.array(np.diff(ticks, prepend=0), np.uint32), "axes": {}, "window_s": data["window_s"]}
    for name, series in data["axes"].items():
        out["axes"][name] = {}
        for key, values in series.items():
            y = np.asarray(values, np.float64)
            keep = np.arange(len(y)) if len(y) <= points else \
                MinMaxLTTBDownsampler().downsample(t, y, n_out=points)
            out["axes"][name][key] = {"i": store.array(np.diff(keep, prepend=0), np.uint32),
                                      "y": store.array(y[keep], np.float32)}
    return out


def packed_segments(segments: list[dict], per_mm: list[float], store: Store) -> dict:
    """The preview's segments packed: kind (0 rapid, 1 cut), program line, and their start and end
    points quantised to the step (the first ones that fit in :data:`SEGMENT_BYTES`)."""
    axes = len(per_mm)

    def pack(kept):
        points = np.array([s["start"] + s["end"] for s in kept], np.float64).reshape(-1, axes)
        return {"count": len(kept), "axes": axes, "cut": store.array([s["kind"] == "cut" for s in kept], np.uint8),
                "line": store.array([s["line"] or 0 for s in kept], np.uint32), "mm": store.steps(points, per_mm)}
    return packed_within(store, pack, segments, SEGMENT_BYTES)[0]


def packed_within(store: Store, pack, items: list, limit: int):
    """(``pack(items[:n])``, n) for the first ``n`` items whose blocks take at most ``limit`` bytes
    of ``store`` (all of them when they fit; cut by the share that fits, a few tries)."""
    n = len(items)
    while True:
        before = len(store.blocks)
        ref = pack(items[:n])
        used = sum(len(b) for b in store.blocks[before:])
        if used <= limit or n == 0:
            return ref, n
        store.drop(before)
        n = int(n * limit / used * 0.95)


def _summary(report: dict) -> list[str]:
    from ..run.report import summary_lines
    return summary_lines(report)


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="windows-1252"><title>{title}</title><link rel="icon" href="data:,">
<style>
body {{ font: 13px/1.4 system-ui, sans-serif; margin: 12px; color: #222; }}
#top {{ display: grid; grid-template-columns: minmax(0, 1fr) 330px; gap: 10px; }}
#top > div, #timeline, #pulses {{ min-width: 0; overflow: hidden; }}
#preview {{ height: 560px; }}
#listing {{ font: 12px/1.4 monospace; height: 560px; overflow: auto; border: 1px solid #ccc; white-space: pre; }}
#listing span.n {{ color: #999; display: inline-block; width: 3em; text-align: right; margin-right: 6px; }}
#listing div.flag {{ background: #f8c8c8; }}
.note {{ color: #555; }}
</style>
<script>{code}</script>
</head><body>
<h2>{title}</h2>
<ul>{summary}</ul>
<div id="violations"></div>
<div id="top"><div id="preview"></div><div id="listing"></div></div>
<div id="timeline"></div>
<div id="pulses"></div>
<script type="text/plain" id="store">{store}</script>
<script type="application/json" id="run-data">{data}</script>
<script>
"use strict";
const store = RV.bytes(document.getElementById("store").textContent);
const packedRun = JSON.parse(document.getElementById("run-data").textContent);
RV.unpack(store, packedRun.plotly).then(code => {{
  const lib = document.createElement("script");          // plotly.js, unpacked: runs as it is inserted
  lib.textContent = code;
  document.head.appendChild(lib);
  performance.mark("plotly");
  return RV.unpackRun(packedRun, store);
}}).then(run => {{
performance.mark("unpacked");
window.retrofitRun = run;
const listing = document.getElementById("listing");
run.source.split("\\n").forEach((text, i) => {{
  const row = document.createElement("div"), n = document.createElement("span");
  row.id = "L" + (i + 1); n.className = "n"; n.textContent = i + 1;
  row.append(n, text);
  listing.appendChild(row);
}});
const note = (where, text) => {{
  const p = document.createElement("p"); p.className = "note"; p.textContent = text; where.before(p); }};
if (run.preview.segments.length < run.preview.rapids + run.preview.cuts)
  note(document.getElementById("top"), `the preview draws the first ${{run.preview.segments.length}} of ` +
       `${{run.preview.rapids + run.preview.cuts}} segments`);
if (listing.children.length < run.source_lines)
  note(listing, `the listing shows the first ${{listing.children.length}} of ${{run.source_lines}} lines`);
RV.drawPreview(document.getElementById("preview"), run.preview, "commanded path and carriage", {{position: false}});
RV.extendBackplot(document.getElementById("preview"), run.preview, run.backplot);
const v = run.violations;
document.getElementById("violations").innerHTML = v.length ? "<b>violations</b>: " + v.slice(0, 50).map(x =>
  `${{x.kind}} ${{x.axis}} at ${{(x.tick * run.tick_s).toFixed(4)}} s` + (x.line ? ` (<a href="#L${{x.line}}">line ${{x.line}}</a>)` : "")).join(", ")
  : "no violations";
for (const x of v) if (x.line) document.getElementById("L" + x.line)?.classList.add("flag");
if (run.frames.shown < run.frames.total)
  note(document.getElementById("pulses"), `the pulse view holds the first ${{run.frames.shown}} of ` +
       `${{run.frames.total}} port frames (what fits in a report of at most 2 MB)`);
RV.attachRunViews(document.getElementById("timeline"), document.getElementById("pulses"), RV.localSource(run),
  run.end_tick, run.tick_s, v).then(views => {{
  performance.mark("drawn"); window.retrofitViews = views; document.body.dataset.views = "ready"; }});
}});
</script>
</body></html>
"""
