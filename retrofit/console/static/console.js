// The console page: open a program, run it, watch it (polled ten times a second), steer it.
// The token comes in the address the console printed (?token=...): the page keeps it in this tab's
// sessionStorage, takes it out of the address bar, and sends it with every call; the control id
// (this tab holds control) likewise.
"use strict";

const $ = (id) => document.getElementById(id);
const C = {machine: null, preview: null, trail: 0, polling: null, lastLine: null, runId: undefined, shownId: null,
           token: keepToken(), control: sessionStorage.getItem("retrofit-control"), you: false};

function keepToken() {
  const url = new URL(location.href);
  const given = url.searchParams.get("token");
  if (given) {
    sessionStorage.setItem("retrofit-token", given);
    url.searchParams.delete("token");
    history.replaceState(null, "", url.pathname + url.search + url.hash);
  }
  return sessionStorage.getItem("retrofit-token") || "";
}

function headers(json) {
  const h = {"X-Retrofit-Token": C.token};
  if (C.control) h["X-Retrofit-Control"] = C.control;
  if (json) h["Content-Type"] = "application/json";
  return h;
}
RV.headers = () => headers(false);

async function api(path, body) {
  let r;
  try {
    r = await fetch(path, body === undefined ? {headers: headers(false)} :
      {method: "POST", headers: headers(true), body: JSON.stringify(body)});
  } catch (e) {
    throw new Error("the console does not answer (" + e.message + "); is retrofit console still running?");
  }
  let data;
  try { data = await r.json(); } catch (e) { data = {error: `${path}: the console answered ${r.status} without JSON`}; }
  if (data.error) throw new Error(data.error);
  return data;
}

// The message line under the header: an error, a warning or a note, in words. It stays until the
// next successful action or a click on it (or on its x); the polls never clear it.
const M = {kind: null, key: null, dismissed: null, faults: new Set()};

function say(kind, text, key) {
  M.kind = kind; M.key = key || kind + ":" + text;
  $("message-text").textContent = text;
  $("message").className = kind;
  $("message").hidden = false;
}

function unsay() {
  if (M.kind) M.dismissed = M.key;
  M.kind = M.key = null;
  $("message").hidden = true;
  $("message-text").textContent = "";
}

// An operator's action: a success clears the message line, a refusal is shown there and thrown.
async function doing(what, call) {
  try {
    const res = await call();
    unsay();
    M.dismissed = null;
    return res;
  } catch (e) {
    say("error", what ? `${what}: ${e.message}` : e.message);
    throw e;
  }
}

async function init() {
  if (!C.token) say("error", "open the address the console printed: it carries the console's token");
  C.machine = await api("/api/machine");
  $("machine-name").textContent = C.machine.name;
  $("machine-desc").textContent = C.machine.description;
  for (const name of [...C.machine.examples, ...C.machine.programs]) $("example").add(new Option(name, name));
  for (const a of C.machine.axes) $("jog-axis").add(new Option(a.name, a.name));
  $("dro").tBodies[0].innerHTML = C.machine.axes.map(a =>
    `<tr><td>${a.name}</td><td id="cmd-${a.name}">0.000</td><td id="car-${a.name}">0.000</td></tr>`).join("");
  const lathe = C.machine.examples.find(n => n.includes(C.machine.lathe ? "lathe" : "engrav"));
  if (lathe) $("example").value = lathe;
  keepChoices();
  bind();
  const fit = new ResizeObserver(seen => {     // a plot follows its box (a scroll bar, a narrower window)
    for (const e of seen) if (e.target.data) Plotly.Plots.resize(e.target);
  });
  for (const id of ["preview", "timeline", "pulses"]) fit.observe($(id));
  await claim(false).catch(() => {});
  const open = await api("/api/program").catch(() => ({}));      // what the console has open survives a reload
  if (open.name) showProgram(open); else drawEmpty();
  poll();
}

// The page's own choices (program list, pace, jog axis and step) kept in this tab across a reload.
function keepChoices() {
  for (const id of ["example", "speed", "jog-axis", "jog-step", "path"]) {
    const key = "retrofit-choice-" + id, kept = sessionStorage.getItem(key);
    if (kept !== null && (id === "path" || [...$(id).options].some(o => o.value === kept))) $(id).value = kept;
    $(id).addEventListener("change", () => sessionStorage.setItem(key, $(id).value));
  }
}

async function claim(take) {
  const res = await api("/api/control", {take: take});
  C.control = res.control;
  sessionStorage.setItem("retrofit-control", res.control);
  return res;
}

function bind() {
  $("open").onclick = () => openProgram().catch(() => {});
  $("file").onchange = async () => {
    const f = $("file").files[0];
    if (f) await openProgram({name: f.name, text: await f.text()}).catch(() => {});
  };
  $("run").onclick = async () => {
    const res = await doing("Run", () => api("/api/run", {speed: parseFloat($("speed").value)})).catch(() => null);
    if (res) adopt(res.run_id);
  };
  $("speed").onchange = () => act("speed", {factor: parseFloat($("speed").value)}).catch(() => {});
  $("hold").onclick = () => act("hold").catch(() => {});
  $("resume").onclick = () => act("resume").catch(() => {});
  $("stop").onclick = async () => {            // a watching page takes control to STOP: it says so
    if (!C.you) await doing("Take control", () => claim(true));
    await act("stop");
  };
  $("take").onclick = () => doing("Take control", () => claim(true)).catch(() => {});
  for (const k of ["feed", "rapid"]) {
    $(k).oninput = () => { $(k + "-val").textContent = $(k).value; };
    $(k).onchange = () => act(k, {pct: parseFloat($(k).value)}).catch(() => {});
  }
  const jog = (sign) => act("jog", {axis: $("jog-axis").value, step: sign * parseFloat($("jog-step").value)}).catch(() => {});
  $("jog-plus").onclick = () => jog(1);
  $("jog-minus").onclick = () => jog(-1);
  $("home").onclick = () => act("home").catch(() => {});
  $("mdi-go").onclick = () => act("mdi", {text: $("mdi").value}).catch(() => {});
  $("mdi").onkeydown = (ev) => { if (ev.key === "Enter") $("mdi-go").click(); };
  $("message").onclick = () => unsay();
  $("dialog-ok").onclick = () => {
    const dlg = $("dialog");
    C.answered = dlg.dataset.key;
    dlg.dataset.key = "";
    dlg.close();
    act("answer").catch(() => {});
  };
}

async function act(kind, args) {               // the console's refusals name the action themselves
  const res = await doing(null, () => api("/api/action", Object.assign({kind: kind}, args || {})));
  adopt(res.run_id);
  return res;
}

// A new run (started here, by another page, or a jog after STOP): its backplot and views start empty.
function adopt(runId) {
  if (runId === undefined || runId === C.runId) return;
  const first = C.runId === undefined;
  C.runId = runId;
  C.trail = 0;
  if (first) return;
  delete document.body.dataset.views;
  window.retrofitReport = null;
  for (const id of ["timeline", "pulses"]) Plotly.purge($(id));
  $("violations").innerHTML = "";
  if (C.preview) RV.drawPreview($("preview"), C.preview, C.title); else drawEmpty();
}

async function openProgram(body) {
  body = body || ($("path").value ? {path: $("path").value} : {name: $("example").value});
  const name = body.path || body.name;
  showProgram(await doing(`Open "${name}"`, () => api("/api/open", body)));
}

function showProgram(res) {
  C.preview = res.preview;
  C.title = res.name + " on the " + C.machine.name;
  $("program-name").textContent = res.name;
  $("listing").innerHTML = res.listing.map((t, i) =>
    `<div id="L${i + 1}"><span class="n">${i + 1}</span>${t.replace(/&/g, "&amp;").replace(/</g, "&lt;")}</div>`).join("");
  C.lastLine = null;
  const counts = RV.drawPreview($("preview"), C.preview, C.title);
  const info = $("preview-info");
  info.dataset.rapids = counts.rapids;
  info.dataset.cuts = counts.cuts;
  info.dataset.cutLines = res.preview.cut_lines;
  info.textContent = `${counts.cuts} cut segments (${res.preview.cut_lines} program lines), ${counts.rapids} rapids` +
    (res.preview.stock ? `; stock diameter ${2 * res.preview.stock.radius} mm` :
     (res.preview.lathe ? "; no stock drawn: name it in a comment, e.g. ; Stock: bar of 44 mm diameter" : ""));
  (res.warnings || []).forEach(w => say("warning", w));
}

// Before a program is open: the machine's envelope (its soft limits) and where it stands.
function drawEmpty() {
  const pv = {lathe: C.machine.lathe, axes: C.machine.axes, segments: [], rapids: 0, cuts: 0};
  RV.drawPreview($("preview"), pv, `${C.machine.name}: no program open; the work envelope and where the machine stands`);
  C.empty = pv;
  $("preview-info").textContent = "open a program to preview it";
}

async function poll() {
  try {
    let s = await api("/api/state?since=" + C.trail);
    if (s.run_id !== C.runId) {                 // a new run: its backplot from its first point
      adopt(s.run_id);
      s = Object.assign({}, s, {trail: [], trail_len: 0});
    }
    if (M.kind === "warning" && M.key === "contact") unsay();
    show(s);
    document.body.dataset.polls = (+document.body.dataset.polls || 0) + 1;   // answers taken (tests wait on them)
  } catch (e) {
    if (!M.kind || M.key === "contact") say("warning", e.message, "contact");
  }
  C.polling = setTimeout(poll, 100);
}

function showControl(c) {
  C.you = c.you;
  document.body.dataset.control = c.you ? "yours" : "watching";
  const h = c.holder;
  $("control").textContent = c.you ? "you hold control" :
    (h ? `watching: ${h.name} (${h.address}) holds control since ${h.since}` : "watching: no one holds control");
  $("take").hidden = c.you;
  $("stop").textContent = c.you ? "STOP" : "Take control + STOP";
}

function show(s) {
  if (s.control) showControl(s.control);
  if (s.fault) {                               // a run that stopped on an error says why, until dismissed
    const key = "fault:" + s.run_id + ":" + s.fault;
    if (!M.faults.has(key) || (!M.kind && M.dismissed !== key)) say("error", s.fault, key);
    M.faults.add(key);
  }
  $("state").textContent = s.state;
  document.body.dataset.state = s.state;
  if (s.commanded_mm) for (const a of C.machine.axes) {
    $("cmd-" + a.name).textContent = mm(s.commanded_mm[a.name]);
    $("car-" + a.name).textContent = mm(s.carriage_mm[a.name]);
  }
  RV.showPosition($("preview"), C.preview || C.empty, s.commanded_mm || zeros());
  if (s.time_s !== undefined) $("time").textContent = s.time_s.toFixed(2);
  $("line").textContent = s.line ?? "-";
  if (s.line !== C.lastLine) {
    if (C.lastLine) $("L" + C.lastLine)?.classList.remove("current");
    const el = s.line ? $("L" + s.line) : null;
    if (el) { el.classList.add("current"); el.scrollIntoView({block: "nearest"}); }
    C.lastLine = s.line;
  }
  if (s.spindle) $("spindle").textContent = s.spindle[1] ? `${s.spindle[1] > 0 ? "forward" : "reverse"} ${s.spindle[0]} rpm` : "off";
  if (s.coolant !== undefined) $("coolant").textContent = {7: "mist", 8: "flood"}[s.coolant] || "off";
  if (s.tool !== undefined) $("tool").textContent = s.tool;
  $("flags").innerHTML = (s.flags || []).map(f => `<span>${f}</span>`).join("");
  if (C.preview && s.trail && s.trail.length) RV.extendBackplot($("preview"), C.preview, s.trail);
  C.trail = s.trail_len || 0;
  const dlg = $("dialog");
  const key = s.dialog ? s.dialog.kind + ":" + s.dialog.line + ":" + s.events : null;
  if (s.dialog && !C.you && M.kind !== "error") say("info", "waiting for the operator: " + s.dialog.text, "wait:" + key);
  if (!s.dialog && M.key && M.key.startsWith("wait:")) unsay();
  if (s.dialog && C.you && key !== C.answered && dlg.dataset.key !== key) {
    $("dialog-text").textContent = s.dialog.text;
    say("warning", `line ${s.dialog.line}: ${s.dialog.text}`, "dialog:" + key);
    dlg.dataset.kind = s.dialog.kind;
    dlg.dataset.key = key;
    if (!dlg.open) dlg.showModal();
  }
  if ((!s.dialog || !C.you) && dlg.open) { dlg.close(); dlg.dataset.key = ""; }
  if (["done", "stopped", "error"].includes(s.state) && C.shownId !== s.run_id) {
    C.shownId = s.run_id;
    showRun().catch(() => { C.shownId = null; });
  }
}

// A position in mm as the DRO shows it: three decimals, never -0.000.
function mm(v) {
  const t = v.toFixed(3);
  return /^-0\.0+$/.test(t) ? t.slice(1) : t;
}

function zeros() {
  return Object.fromEntries(C.machine.axes.map(a => [a.name, 0]));
}

async function showRun() {
  let rep;
  try { rep = await api("/api/report"); } catch (e) { say("error", "After the run: " + e.message); throw e; }
  window.retrofitReport = rep;
  const v = rep.violations;
  $("violations").innerHTML = v.length ? "<b>violations</b>: " + v.slice(0, 50).map(x =>
    `<a href="#L${x.line}" data-line="${x.line}">${x.kind} ${x.axis} at ${(x.tick * rep.tick_us * 1e-6).toFixed(4)} s (line ${x.line ?? "-"})</a>`).join(", ")
    : "no violations";
  for (const x of v) if (x.line) $("L" + x.line)?.classList.add("flag");
  window.retrofitViews = await RV.attachRunViews($("timeline"), $("pulses"), RV.serverSource, rep.ticks,
    rep.tick_us * 1e-6, v);
  document.body.dataset.views = "ready";
}

init();
