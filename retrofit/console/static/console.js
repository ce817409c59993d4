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
  const r = await fetch(path, body === undefined ? {headers: headers(false)} :
    {method: "POST", headers: headers(true), body: JSON.stringify(body)});
  const data = await r.json();
  $("message").textContent = data.error || "";
  if (data.error) throw new Error(data.error);
  return data;
}

async function init() {
  if (!C.token) $("message").textContent = "open the address the console printed: it carries the console's token";
  C.machine = await api("/api/machine");
  $("machine-name").textContent = C.machine.name;
  $("machine-desc").textContent = C.machine.description;
  for (const name of [...C.machine.examples, ...C.machine.programs]) $("example").add(new Option(name, name));
  for (const a of C.machine.axes) $("jog-axis").add(new Option(a.name, a.name));
  $("dro").tBodies[0].innerHTML = C.machine.axes.map(a =>
    `<tr><td>${a.name}</td><td id="cmd-${a.name}">0.000</td><td id="car-${a.name}">0.000</td></tr>`).join("");
  const lathe = C.machine.examples.find(n => n.includes(C.machine.lathe ? "lathe" : "engrav"));
  if (lathe) $("example").value = lathe;
  bind();
  await claim(false).catch(() => {});
  poll();
}

async function claim(take) {
  const res = await api("/api/control", {take: take});
  C.control = res.control;
  sessionStorage.setItem("retrofit-control", res.control);
  return res;
}

function bind() {
  $("open").onclick = () => openProgram();
  $("file").onchange = async () => {
    const f = $("file").files[0];
    if (f) await openProgram({name: f.name, text: await f.text()});
  };
  $("run").onclick = async () => {
    delete document.body.dataset.views;
    window.retrofitReport = null;
    $("timeline").innerHTML = ""; $("pulses").innerHTML = ""; $("violations").innerHTML = "";
    if (C.preview) RV.drawPreview($("preview"), C.preview, $("program-name").textContent);
    const res = await api("/api/run", {speed: parseFloat($("speed").value)});
    C.runId = res.run_id;
    C.trail = 0;
  };
  $("speed").onchange = () => act("speed", {factor: parseFloat($("speed").value)}).catch(() => {});
  $("hold").onclick = () => act("hold");
  $("resume").onclick = () => act("resume");
  $("stop").onclick = async () => {            // a watching page takes control to STOP: it says so
    if (!C.you) await claim(true);
    await act("stop");
  };
  $("take").onclick = () => claim(true).catch(() => {});
  for (const k of ["feed", "rapid"]) {
    $(k).oninput = () => { $(k + "-val").textContent = $(k).value; };
    $(k).onchange = () => act(k, {pct: parseFloat($(k).value)});
  }
  const jog = (sign) => act("jog", {axis: $("jog-axis").value, step: sign * parseFloat($("jog-step").value)});
  $("jog-plus").onclick = () => jog(1);
  $("jog-minus").onclick = () => jog(-1);
  $("home").onclick = () => act("home");
  $("mdi-go").onclick = () => act("mdi", {text: $("mdi").value});
  $("dialog-ok").onclick = () => {
    const dlg = $("dialog");
    C.answered = dlg.dataset.key;
    dlg.dataset.key = "";
    dlg.close();
    act("answer");
  };
}

async function act(kind, args) {
  const res = await api("/api/action", Object.assign({kind: kind}, args || {}));
  if (res.run_id !== C.runId) { C.runId = res.run_id; C.trail = 0; }
  return res;
}

async function openProgram(body) {
  body = body || ($("path").value ? {path: $("path").value} : {name: $("example").value});
  const res = await api("/api/open", body);
  C.preview = res.preview;
  $("program-name").textContent = res.name;
  $("listing").innerHTML = res.listing.map((t, i) =>
    `<div id="L${i + 1}"><span class="n">${i + 1}</span>${t.replace(/&/g, "&amp;").replace(/</g, "&lt;")}</div>`).join("");
  const counts = RV.drawPreview($("preview"), C.preview, res.name + " on the " + C.machine.name);
  const info = $("preview-info");
  info.dataset.rapids = counts.rapids;
  info.dataset.cuts = counts.cuts;
  info.dataset.cutLines = res.preview.cut_lines;
  info.textContent = `${counts.cuts} cut segments (${res.preview.cut_lines} program lines), ${counts.rapids} rapids` +
    (res.preview.stock ? `; stock diameter ${2 * res.preview.stock.radius} mm` :
     (res.preview.lathe ? "; no stock drawn: name it in a comment, e.g. ; Stock: bar of 44 mm diameter" : ""));
}

async function poll() {
  try {
    const s = await api("/api/state?since=" + C.trail);
    if (C.runId === undefined) C.runId = s.run_id;
    if (s.run_id === C.runId) show(s);
  } catch (e) { /* shown in #message */ }
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
  if (s.fault) $("message").textContent = s.fault;
  $("state").textContent = s.state;
  document.body.dataset.state = s.state;
  if (s.commanded_mm) for (const a of C.machine.axes) {
    $("cmd-" + a.name).textContent = s.commanded_mm[a.name].toFixed(3);
    $("car-" + a.name).textContent = s.carriage_mm[a.name].toFixed(3);
  }
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
  if (s.dialog && !C.you) $("message").textContent = "waiting for the operator: " + s.dialog.text;
  if (s.dialog && C.you && key !== C.answered && dlg.dataset.key !== key) {
    $("dialog-text").textContent = s.dialog.text;
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

async function showRun() {
  const rep = await api("/api/report");
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
