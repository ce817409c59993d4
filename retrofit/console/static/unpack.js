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
  return run;
};
