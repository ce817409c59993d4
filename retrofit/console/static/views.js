// The views of a run, drawn with plotly.js: the preview (rapids dashed, cuts solid, stock and
// part on a lathe, the work envelope), the timeline (position, velocity, acceleration, carriage
// error per axis) and the logic-analyser view of the step and direction lines. Shared by the
// console page and the offline HTML report; each gets its windows from a "source" with
// timeline(t0, t1) and pulses(t0, t1) (ticks) returning promises.
"use strict";

const RV = {};

RV.segmentsXY = function (segs, kind, h, v) {
  const x = [], y = [];
  for (const s of segs) {
    if (s.kind !== kind) continue;
    x.push(s.start[h], s.end[h], null);
    y.push(s.start[v], s.end[v], null);
  }
  return [x, y];
};

RV.planeAxes = function (pv) {
  const names = pv.axes.map(a => a.name);
  if (pv.lathe) return [names.indexOf("Z"), names.indexOf("X")];
  return [0, Math.min(1, names.length - 1)];
};

RV.axisTitle = function (a) {
  const label = (a.label || "").trim();
  return (label === "" || label.toUpperCase() === a.name.toUpperCase()) ? a.name + " [mm]" : a.name + " " + label + " [mm]";
};

// The preview; the last trace is the backplot, which RV.extendBackplot grows.
RV.drawPreview = function (div, pv, title, opts) {
  const traces = [], marker = !(opts && opts.position === false);   // the report has no machine standing
  if (pv.lathe) {
    const [h, v] = RV.planeAxes(pv);
    const ah = pv.axes[h], av = pv.axes[v];
    traces.push({x: [ah.min, ah.max, ah.max, ah.min, ah.min], y: [av.min, av.min, av.max, av.max, av.min],
      mode: "lines", line: {color: "#888", dash: "dot", width: 1}, name: "soft limits", hoverinfo: "skip"});
    if (pv.stock) {
      const [z0, z1] = pv.stock.z, r = pv.stock.radius;
      traces.push({x: [z0, z1, z1, z0, z0], y: [0, 0, r, r, 0], fill: "toself", fillcolor: "rgba(180,180,180,0.35)",
        mode: "lines", line: {color: "#aaa", width: 1}, name: "stock (diameter " + (2 * r) + " mm)", hoverinfo: "skip"});
      traces.push({x: pv.part.z.concat([pv.part.z[pv.part.z.length - 1], pv.part.z[0]]),
        y: pv.part.x.concat([0, 0]), fill: "toself", fillcolor: "rgba(150,150,40,0.45)", mode: "lines",
        line: {color: "rgba(120,120,30,0.8)", width: 1}, name: "part left by the cuts", hoverinfo: "skip"});
    }
    const [rx, ry] = RV.segmentsXY(pv.segments, "rapid", h, v);
    const [cx, cy] = RV.segmentsXY(pv.segments, "cut", h, v);
    traces.push({x: rx, y: ry, mode: "lines", line: {color: "#777", dash: "dash", width: 1.2}, name: "rapid (G0)"});
    traces.push({x: cx, y: cy, mode: "lines", line: {color: "#1f77b4", width: 1.8}, name: "cut (G1/G2/G3)"});
    traces.push({x: [0], y: [0], mode: "markers", marker: {color: "#d62728", size: 10, symbol: "cross-thin",
      line: {width: 2, color: "#d62728"}}, name: "the machine (commanded)", visible: marker});
    traces.push({x: [], y: [], mode: "lines", line: {color: "rgba(214,39,40,0.7)", width: 1.2}, name: "carriage (backplot)"});
    const xs = rx.concat(cx).filter(v => v !== null), ys = ry.concat(cy).filter(v => v !== null).concat([0]);
    const span = (a, lo, hi) => {
      if (!a.length) return [lo, hi];
      const mn = Math.min(...a), mx = Math.max(...a), m = 0.08 * (mx - mn || 1);
      return [Math.max(lo, mn - m), Math.min(hi, mx + m)];
    };
    div.dataset.position = "";
    Plotly.newPlot(div, traces, {title: {text: title || "", font: {size: 14}, x: 0.01, xanchor: "left"}, margin: {t: 40, l: 60, r: 10, b: 50},
      xaxis: {title: {text: RV.axisTitle(ah)}, range: span(xs.concat(pv.stock ? pv.stock.z : []), ah.min, ah.max)},
      yaxis: {title: {text: RV.axisTitle(av)}, scaleanchor: "x", range: span(ys, av.min, av.max)},
      legend: {orientation: "h", y: -0.2}}, {responsive: true, displaylogo: false});
  } else {
    const seg3 = (kind) => {
      const p = [[], [], []];
      for (const s of pv.segments) {
        if (s.kind !== kind) continue;
        for (let k = 0; k < 3; k++) p[k].push(s.start[k] ?? 0, s.end[k] ?? 0, null);
      }
      return p;
    };
    const box = RV.boxEdges(pv.axes);
    traces.push({type: "scatter3d", x: box[0], y: box[1], z: box[2], mode: "lines",
      line: {color: "#999", width: 1}, name: "work envelope", hoverinfo: "skip"});
    const r = seg3("rapid"), c = seg3("cut");
    traces.push({type: "scatter3d", x: r[0], y: r[1], z: r[2], mode: "lines", line: {color: "#777", dash: "dash", width: 2}, name: "rapid (G0)"});
    traces.push({type: "scatter3d", x: c[0], y: c[1], z: c[2], mode: "lines", line: {color: "#1f77b4", width: 3}, name: "cut (G1/G2/G3)"});
    traces.push({type: "scatter3d", x: [0], y: [0], z: [0], mode: "markers", marker: {color: "#d62728", size: 4},
      name: "the machine (commanded)", visible: marker});
    traces.push({type: "scatter3d", x: [], y: [], z: [], mode: "lines", line: {color: "rgba(214,39,40,0.7)", width: 2}, name: "carriage (backplot)"});
    const t = (i) => ({title: {text: pv.axes[i] ? RV.axisTitle(pv.axes[i]) : ""}});
    const framed = RV.frame(pv.segments), scene = Object.assign({aspectmode: "data"}, framed);
    ["xaxis", "yaxis", "zaxis"].forEach((a, i) => { scene[a] = Object.assign(t(i), framed[a]); });
    div.dataset.position = "";
    Plotly.newPlot(div, traces, {title: {text: title || "", font: {size: 14}, x: 0.01, xanchor: "left"}, margin: {t: 40, l: 0, r: 0, b: 0},
      scene: scene, legend: {orientation: "h"}}, {responsive: true, displaylogo: false});
  }
  return {rapids: pv.rapids, cuts: pv.cuts};
};

// A 3D view framed on the program's path (8 % around it, at least 1 mm), not the whole envelope;
// the axes keep their true proportions. Nothing to frame: the envelope, as plotly frames it.
RV.frame = function (segments) {
  if (!segments.length) return {};
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const s of segments) for (const p of [s.start, s.end]) for (let k = 0; k < 3; k++) {
    lo[k] = Math.min(lo[k], p[k] ?? 0); hi[k] = Math.max(hi[k], p[k] ?? 0);
  }
  const pad = lo.map((l, k) => Math.max(0.08 * (hi[k] - l), 1)), span = lo.map((l, k) => hi[k] - l + 2 * pad[k]);
  const big = Math.max(...span), range = (k) => ({range: [lo[k] - pad[k], hi[k] + pad[k]]});
  return {xaxis: range(0), yaxis: range(1), zaxis: range(2), aspectmode: "manual",
          aspectratio: {x: span[0] / big, y: span[1] / big, z: span[2] / big}};
};

RV.boxEdges = function (axes) {
  const lo = [0, 1, 2].map(i => axes[i] ? axes[i].min : 0), hi = [0, 1, 2].map(i => axes[i] ? axes[i].max : 0);
  const x = [], y = [], z = [];
  const corner = (b) => [b & 1 ? hi[0] : lo[0], b & 2 ? hi[1] : lo[1], b & 4 ? hi[2] : lo[2]];
  for (let a = 0; a < 8; a++) for (const bit of [1, 2, 4]) {
    if (a & bit) continue;
    const p = corner(a), q = corner(a | bit);
    x.push(p[0], q[0], null); y.push(p[1], q[1], null); z.push(p[2], q[2], null);
  }
  return [x, y, z];
};

// The machine's commanded position (mm by axis name) as the marker before the backplot.
RV.showPosition = function (div, pv, pos) {
  if (!pv || !div.data || div.data.length < 2) return;
  const names = pv.axes.map(a => a.name), at = (i) => [i < names.length ? pos[names[i]] ?? 0 : 0];
  const key = names.map(n => pos[n]).join(",");
  if (div.dataset.position === key) return;
  div.dataset.position = key;
  const idx = div.data.length - 2;
  if (pv.lathe) {
    const [h, v] = RV.planeAxes(pv);
    Plotly.restyle(div, {x: [at(h)], y: [at(v)]}, [idx]);
  } else {
    Plotly.restyle(div, {x: [at(0)], y: [at(1)], z: [at(2)]}, [idx]);
  }
};

// rows: [time, commanded..., carriage...] as the console's state sends them
RV.extendBackplot = function (div, pv, rows) {
  if (!rows.length) return;
  const n = pv.axes.length, idx = div.data.length - 1;
  const col = (i) => rows.map(r => r[1 + n + i]);
  if (pv.lathe) {
    const [h, v] = RV.planeAxes(pv);
    Plotly.extendTraces(div, {x: [col(h)], y: [col(v)]}, [idx]);
  } else {
    Plotly.extendTraces(div, {x: [col(0)], y: [col(1)], z: [col(2 < n ? 2 : 0)]}, [idx]);
  }
};

RV.timelineFigure = function (data, violations, tickS) {
  const mean = data.window_s ? `, mean over ${+(data.window_s * 1000).toFixed(1)} ms` : "";
  const rows = [["position_mm", "position [mm]"], ["velocity_mm_min", "velocity [mm/min]" + mean],
    ["accel_mm_s2", "acceleration [mm/s²]" + mean], ["error_mm", "carriage − motor [mm]"]];
  const colors = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"];
  const traces = [], layout = {margin: {t: 30, l: 70, r: 10, b: 40}, showlegend: true, height: 620,
    legend: {orientation: "h", y: 1.06}, grid: {rows: rows.length, columns: 1, shared_xaxes: true}};
  const names = Object.keys(data.axes);
  rows.forEach(([key, label], r) => {
    const ax = r === 0 ? "" : String(r + 1);
    layout["yaxis" + ax] = {title: {text: label, font: {size: 10}}, domain: [1 - (r + 1) / rows.length + 0.03, 1 - r / rows.length]};
    layout["xaxis" + ax] = {anchor: "y" + ax, matches: r === 0 ? undefined : "x", showticklabels: r === rows.length - 1};
    names.forEach((name, i) => {
      const s = data.axes[name][key];           // values at data.t, or a trace with its own times {t, y}
      if (!s) return;
      traces.push({x: s.t || data.t, y: s.y || s, mode: "lines", line: {color: colors[i % 4], width: 1.2},
        name: name, legendgroup: name, showlegend: r === 0, xaxis: "x" + ax, yaxis: "y" + ax, type: "scatter"});
    });
  });
  layout["xaxis" + rows.length].title = {text: "machine time [s]"};
  layout.shapes = (violations || []).map(v => ({type: "line", xref: "x", yref: "paper", x0: v.tick * tickS,
    x1: v.tick * tickS, y0: 0, y1: 1, line: {color: "red", width: 1, dash: "dot"}}));
  layout.annotations = (violations || []).slice(0, 20).map(v => ({x: v.tick * tickS, y: 1, xref: "x", yref: "paper",
    text: v.kind + (v.line ? " (line " + v.line + ")" : ""), showarrow: false, font: {color: "red", size: 9}}));
  return {data: traces, layout: layout};
};

RV.pulsesFigure = function (data) {
  const s = data.tick_us * 1e-6, traces = [], n = data.lines.length;
  data.lines.forEach((name, i) => {
    const base = (n - 1 - i) * 1.5;
    if (data.ticks) {
      const x = data.ticks.map(t => t * s).concat([data.t1 * s]);
      const lv = data.levels[i];
      traces.push({x: x, y: lv.concat([lv[lv.length - 1] ?? 0]).map(l => base + l), mode: "lines",
        line: {shape: "hv", width: 1.2}, name: name, type: "scatter"});
    } else {
      const e = data.bands.edges, c = data.bands.counts[i];
      traces.push({x: e.slice(0, -1).map(t => t * s), y: c.map(k => base + (k > 0 ? 1 : 0)), mode: "lines",
        line: {shape: "hv", width: 1.2}, fill: "tonexty", name: name + " (busy)", type: "scatter"});
    }
  });
  const layout = {margin: {t: 30, l: 80, r: 10, b: 40}, height: 60 + 45 * n, showlegend: false,
    title: {text: data.ticks ? "step and direction lines" : "step and direction lines (zoom in to see single pulses)", font: {size: 12}},
    xaxis: {title: {text: "machine time [s]"}, range: [data.t0 * s, data.t1 * s]},
    yaxis: {tickvals: data.lines.map((_, i) => (n - 1 - i) * 1.5 + 0.5), ticktext: data.lines, range: [-0.3, 1.5 * n]}};
  return {data: traces, layout: layout};
};

// Draw the timeline and the pulse view and keep them following the zoom: each zoom fetches the
// window it shows. window.retrofitZoomMs collects how long each redraw took (performance.now()).
RV.attachRunViews = function (timelineDiv, pulsesDiv, source, endTick, tickS, violations) {
  window.retrofitZoomMs = [];
  Plotly.purge(timelineDiv);                   // the last run's plots and their zoom handlers go
  Plotly.purge(pulsesDiv);
  const draw = async (kind, div, t0, t1) => {
    const start = performance.now();
    if (kind === "timeline") {
      const fig = RV.timelineFigure(await source.timeline(t0, t1), violations, tickS);
      fig.layout.xaxis.range = [t0 * tickS, t1 * tickS];
      await Plotly.react(div, fig.data, fig.layout, {displaylogo: false, responsive: true});
    } else {
      const fig = RV.pulsesFigure(await source.pulses(t0, t1));
      await Plotly.react(div, fig.data, fig.layout, {displaylogo: false, responsive: true});
    }
    const ms = performance.now() - start;
    window.retrofitZoomMs.push({view: kind, ms: ms, t0: t0, t1: t1});
    div.dataset.window = t0 + ":" + t1;
    return ms;
  };
  const follow = (kind, div) => div.on("plotly_relayout", (ev) => {
    let a = ev["xaxis.range[0]"], b = ev["xaxis.range[1]"];
    if (ev["xaxis.range"]) [a, b] = ev["xaxis.range"];
    if (ev["xaxis.autorange"]) [a, b] = [0, endTick * tickS];
    if (a === undefined || b === undefined) return;
    const t0 = Math.max(0, Math.floor(a / tickS)), t1 = Math.min(endTick, Math.ceil(b / tickS));
    if (div.dataset.window === t0 + ":" + t1) return;
    draw(kind, div, t0, Math.max(t1, t0 + 2));
  });
  const views = {
    zoom: (kind, t0, t1) => draw(kind, kind === "timeline" ? timelineDiv : pulsesDiv, t0, t1),
  };
  return Promise.all([draw("timeline", timelineDiv, 0, endTick), draw("pulses", pulsesDiv, 0, endTick)]).then(() => {
    follow("timeline", timelineDiv);
    follow("pulses", pulsesDiv);
    return views;
  });
};

// A source computed in the page from arrays embedded in it (the HTML report).
RV.localSource = function (run) {
  const bisect = (a, x) => { let lo = 0, hi = a.length; while (lo < hi) { const m = (lo + hi) >> 1; if (a[m] <= x) lo = m + 1; else hi = m; } return lo; };
  return {
    timeline: async (t0, t1) => {               // each trace's points in the window (min/max kept)
      if (run.steps && (run.frames.shown === run.frames.total || t1 <= run.frames.ticks[run.frames.shown - 1]) &&
          RV.keptIn(run, t0, t1) < run.window_points)
        return RV.fullTimeline(run, t0, t1);    // zoomed in where the port frames are held: every step
      const out = {axes: {}, window_s: run.window_s}, a = t0 * run.tick_s, b = t1 * run.tick_s;
      for (const [name, ax] of Object.entries(run.timeline)) {
        out.axes[name] = {};
        for (const [k, s] of Object.entries(ax)) {
          const i0 = Math.max(bisect(s.t, a) - 1, 0), i1 = Math.min(bisect(s.t, b) + 1, s.t.length);
          out.axes[name][k] = {t: Array.from(s.t.subarray(i0, i1)), y: Array.from(s.y.subarray(i0, i1))};
        }
      }
      return out;
    },
    pulses: async (t0, t1) => {
      const f = run.frames, limit = 6000;
      const lo = Math.max(bisect(f.ticks, t0) - 1, 0), hi = bisect(f.ticks, t1 - 1);
      const out = {t0: t0, t1: t1, tick_us: run.tick_s * 1e6, lines: f.lines.map(l => l.name)};
      if (hi - lo <= limit) {
        out.ticks = Array.from(f.ticks.subarray(lo, hi), t => Math.max(t, t0));
        out.levels = f.lines.map(l => Array.from(f.values.subarray(lo, hi), v => ((v >> l.bit) & 1) ^ l.inv));
        return out;
      }
      const slots = limit / 2, edges = [], counts = f.lines.map(() => new Array(slots).fill(0));
      for (let k = 0; k <= slots; k++) edges.push(Math.round(t0 + (t1 - t0) * k / slots));
      for (let j = lo + 1; j < hi; j++) {
        const slot = Math.min(slots - 1, Math.floor((f.ticks[j] - t0) / (t1 - t0) * slots));
        const d = f.values[j] ^ f.values[j - 1];
        f.lines.forEach((l, i) => { if ((d >> l.bit) & 1) counts[i][slot]++; });
      }
      out.bands = {edges: edges, counts: counts};
      return out;
    },
  };
};

// A source that asks the console's server (with the headers the page sets in RV.headers: its token).
RV.headers = () => ({});
RV.serverSource = {
  timeline: (t0, t1) => fetch(`/api/timeline?t0=${t0}&t1=${t1}`, {headers: RV.headers()}).then(r => r.json()),
  pulses: (t0, t1) => fetch(`/api/pulses?t0=${t0}&t1=${t1}`, {headers: RV.headers()}).then(r => r.json()),
};
