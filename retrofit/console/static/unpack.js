// The HTML report's binary store (retrofit/console/packing.py) back as typed arrays and texts:
// the page is windows-1252, so each character of the store is one byte ("=" and the byte plus 64
// for the four it escapes); each block is gzip, unpacked by the browser's own DecompressionStream.
"use strict";

// windows-1252's characters for the bytes 0x80..0x9f (the rest are their own code points)
RV.W1252 = "\u20ac\x81\u201a\u0192\u201e\u2026\u2020\u2021\u02c6\u2030\u0160\u2039\u0152\x8d\u017d\x8f" +
           "\x90\u2018\u2019\u201c\u201d\u2022\u2013\u2014\u02dc\u2122\u0161\u203a\u0153\x9d\u017e\u0178";

RV.bytes = function (text) {
  const back = new Map();
  for (let i = 0; i < 32; i++) back.set(RV.W1252.charCodeAt(i), 0x80 + i);
  const out = new Uint8Array(text.length);
  let n = 0;
  for (let i = 0; i < text.length; i++) {
    let c = text.charCodeAt(i);
    if (c === 61) c = text.charCodeAt(++i) - 64;
    else if (c > 255) c = back.get(c);
    out[n++] = c;
  }
  return out.subarray(0, n);
};

RV.gunzip = async function (bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
};

RV.TYPES = {u1: Uint8Array, u4: Uint32Array, i4: Int32Array, f4: Float32Array, f8: Float64Array};

// One block of the store (its reference from packing.Store): a typed array, or a string.
RV.unpack = async function (store, ref) {
  const raw = await RV.gunzip(store.subarray(ref.at, ref.at + ref.len));
  if (ref.type === "text") return new TextDecoder().decode(raw);
  const Type = ref.type === "steps" ? Uint32Array : RV.TYPES[ref.type];
  const size = Type.BYTES_PER_ELEMENT, n = raw.length / size, out = new Uint8Array(raw.length);
  for (let b = 0; b < size; b++) for (let i = 0; i < n; i++) out[i * size + b] = raw[b * n + i];
  const values = new Type(out.buffer);
  if (ref.type !== "steps") return values;
  const cols = ref.cols, rows = n / cols, mm = new Float64Array(n);   // zigzag differences -> mm
  for (let c = 0; c < cols; c++) {
    for (let r = 0, s = 0; r < rows; r++) {
      const z = values[c * rows + r];
      s += (z & 1) ? -((z + 1) / 2) : z / 2;
      mm[r * cols + c] = s / ref.per_mm[c];
    }
  }
  return mm;
};

// The run's data as views.js draws it (see report_html.run_data).
RV.unpackRun = async function (run, store) {
  const get = (ref) => RV.unpack(store, ref), round = (v) => Math.round(v * 1e4) / 1e4;
  const mm = await get(run.backplot.mm), n = run.backplot.axes, rows = [];
  for (let i = 0; i + n <= mm.length; i += n) {            // rows as the console's state sends them
    const at = Array.from(mm.subarray(i, i + n), round);
    rows.push([0].concat(at, at));
  }
  run.backplot = rows;
  const f = run.frames, ticks = new Float64Array(f.shown), values = new Uint8Array(f.shown);
  let k = 0, t = 0;
  for (const chunk of f.chunks) {                          // rises and falls apart: each packs better
    const even = await get(chunk.even), odd = await get(chunk.odd), v = await get(chunk.values);
    for (let i = 0; i < v.length; i++, k++) {
      t += (i & 1) ? odd[i >> 1] : even[i >> 1];
      ticks[k] = t;
      values[k] = v[i];
    }
  }
  f.ticks = ticks;
  f.values = values;
  const tl = run.timeline, grid = await get(tl.ticks), at = new Float64Array(grid.length);
  for (let i = 0, s = 0; i < grid.length; i++) { s += grid[i]; at[i] = s * run.tick_s; }
  run.timeline = {};
  run.window_s = tl.window_s;
  for (const [name, ax] of Object.entries(tl.axes)) {
    run.timeline[name] = {};
    for (const [key, s] of Object.entries(ax)) {
      const steps = await get(s.i), y = await get(s.y), t = new Float64Array(steps.length);
      for (let i = 0, k = 0; i < steps.length; i++) { k += steps[i]; t[i] = at[k]; }
      run.timeline[name][key] = {t: t, y: y};
    }
  }
  const sg = run.preview.segments;
  if (sg && sg.count !== undefined) {
    const cut = await get(sg.cut), line = await get(sg.line), ends = await get(sg.mm), a = sg.axes;
    run.preview.segments = Array.from(cut, (c, i) => ({kind: c ? "cut" : "rapid", line: line[i] || null,
      start: Array.from(ends.subarray(2 * a * i, 2 * a * i + a), round),
      end: Array.from(ends.subarray(2 * a * i + a, 2 * a * (i + 1)), round)}));
  }
  run.source = await get(run.source);
  run.steps = RV.axisSteps(run.frames, run.start_steps);
  return run;
};

// Every step of each axis in the port frames held, decoded as a driver decodes them (a rising step
// edge, the direction line sampled at it): the tick of each and the position after it (steps).
RV.axisSteps = function (f, starts) {
  const out = [];
  for (let k = 0; k + 1 < f.lines.length; k += 2) {
    const st = f.lines[k], dr = f.lines[k + 1], ticks = [], position = [];
    let before = 0, p = starts[k / 2];
    for (let i = 0; i < f.values.length; i++) {
      const v = f.values[i], level = ((v >> st.bit) & 1) ^ st.inv;
      if (level && !before) {
        p += (((v >> dr.bit) & 1) ^ dr.inv) ? 1 : -1;
        ticks.push(f.ticks[i]);
        position.push(p);
      }
      before = level;
    }
    out.push({ticks: Float64Array.from(ticks), position: Float64Array.from(position), start: starts[k / 2]});
  }
  return out;
};

RV.bisect = (a, x, right) => {                 // the first index whose value is > x (>= x when !right)
  let lo = 0, hi = a.length;
  while (lo < hi) { const m = (lo + hi) >> 1; if (right ? a[m] <= x : a[m] < x) lo = m + 1; else hi = m; }
  return lo;
};

// How many points of the kept (downsampled) position trace of the first axis fall in [t0, t1).
RV.keptIn = function (run, t0, t1) {
  const s = Object.values(run.timeline)[0].position_mm;
  return RV.bisect(s.t, t1 * run.tick_s, false) - RV.bisect(s.t, t0 * run.tick_s, false);
};

// A window of the timeline computed from every step, as the console's server computes it
// (views.timeline): position, velocity and acceleration averaged over the stated window; the
// carriage error is the kept trace's (the report holds no carriage per step).
RV.fullTimeline = function (run, t0, t1) {
  const n = run.window_points, ticks = [];
  for (let i = 0; i < n; i++) {
    const t = Math.round(t0 + (t1 - 1 - t0) * i / (n - 1));
    if (!ticks.length || t !== ticks[ticks.length - 1]) ticks.push(t);
  }
  const spacing = ticks.length > 1 ? ticks[1] - ticks[0] : 1;
  const half = Math.max(Math.floor(run.average_s / run.tick_s / 2), spacing, 1);
  const out = {axes: {}, window_s: 2 * half * run.tick_s}, names = Object.keys(run.timeline);
  const at = (s, t) => { const k = RV.bisect(s.ticks, t, true); return k ? s.position[k - 1] : s.start; };
  const rate = (s, t) => {
    const first = RV.bisect(s.ticks, t - half, false), last = RV.bisect(s.ticks, t + half, true) - 1;
    if (last > first) return (s.position[last] - s.position[first]) / (s.ticks[last] - s.ticks[first]);
    if (last === first) return (s.position[first] - (first ? s.position[first - 1] : s.start)) / (2 * half);
    return 0;
  };
  names.forEach((name, i) => {
    const s = run.steps[i], mm = run.per_mm[i], scale = 60 / (mm * run.tick_s), t = ticks.map(k => k * run.tick_s);
    const error = run.timeline[name].error_mm, e0 = RV.bisect(error.t, t0 * run.tick_s, false) - 1;
    const e1 = RV.bisect(error.t, t1 * run.tick_s, false) + 1;
    out.axes[name] = {
      position_mm: {t: t, y: ticks.map(k => at(s, k) / mm)},
      velocity_mm_min: {t: t, y: ticks.map(k => rate(s, k) * scale)},
      accel_mm_s2: {t: t, y: ticks.map(k => (rate(s, k + half) - rate(s, k - half)) * scale / 60 / (2 * half * run.tick_s))},
      error_mm: {t: Array.from(error.t.subarray(Math.max(e0, 0), e1)), y: Array.from(error.y.subarray(Math.max(e0, 0), e1))},
    };
  });
  return out;
};
