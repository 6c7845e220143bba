// flexlift live dashboard: draws each snapshot received on the websocket /ws.
// No framework, no build step, nothing fetched from outside this server.
"use strict";
const DEG = 180 / Math.PI;
const STALE_MS = 3000;          // no snapshot for this long: the link is shown as lost
const SVGNS = "http://www.w3.org/2000/svg";
let lastAt = 0;
let rows = {};                  // bag name -> its table cells
let rowOrder = "";

function $(id) { return document.getElementById(id); }
function fmt(v, digits) { return (v === null || v === undefined) ? "—" : v.toFixed(digits); }
function level(ratio) { return ratio === null ? "" : ratio >= 1 ? "bad" : ratio >= 0.8 ? "warn" : "ok"; }
function clock(t) {
  const s = Math.max(0, Math.floor(t)), h = Math.floor(s / 3600), m = Math.floor(s / 60) % 60;
  return h + ":" + String(m).padStart(2, "0") + ":" + String(s % 60).padStart(2, "0");
}

function meterHtml(centred) {
  return '<span class="val"></span><span class="meter' + (centred ? " centred" : "") +
         '"><span class="fill"></span><span class="tick lo"></span><span class="tick hi"></span></span>';
}

// one cell: its text, bar (from `from` to `to` as fractions of the bar) and limit ticks
function setCell(td, text, from, to, ticks, cls) {
  td.className = cls;
  td.querySelector(".val").textContent = text;
  const bar = td.querySelector(".fill");
  const a = Math.max(0, Math.min(from, to)), b = Math.min(1, Math.max(from, to));
  bar.style.left = (100 * a) + "%"; bar.style.width = (100 * Math.max(0, b - a)) + "%";
  const tks = td.querySelectorAll(".tick");
  tks.forEach((tk, i) => {
    if (i < ticks.length) { tk.style.display = ""; tk.style.left = (100 * ticks[i]) + "%"; }
    else { tk.style.display = "none"; }
  });
}

function buildRows(bags) {
  const body = document.querySelector("#bags tbody");
  body.innerHTML = ""; rows = {};
  for (const b of bags) {
    const tr = document.createElement("tr");
    tr.id = "bag-" + b.name; tr.dataset.testid = "bag";
    const name = document.createElement("td"); name.className = "name"; name.textContent = b.name;
    tr.appendChild(name);
    const cells = {};
    for (const q of ["depth", "speed", "pitch", "fill", "purge"]) {
      const td = document.createElement("td");
      td.dataset.q = q; td.innerHTML = meterHtml(q === "pitch");
      tr.appendChild(td); cells[q] = td;
    }
    body.appendChild(tr); rows[b.name] = { tr, cells };
  }
  rowOrder = bags.map(b => b.name).join(",");
}

function drawBag(b, lim, alarmed) {
  const r = rows[b.name], c = r.cells;
  r.tr.classList.toggle("alarmed", alarmed);
  const d = b.depth_m;
  setCell(c.depth, fmt(d, 1), 0, d === null ? 0 : d / lim.water_depth_m, [], d === null ? "" : "depth");
  const v = b.speed_m_s, vs = 1.25 * lim.speed_m_s;        // the bar runs to 125 % of the limit
  setCell(c.speed, fmt(v, 2), 0, v === null ? 0 : Math.abs(v) / vs, [0.8],
          level(v === null ? null : Math.abs(v) / lim.speed_m_s));
  const p = b.pitch_rad, ps = 1.25 * lim.pitch_rad;
  setCell(c.pitch, p === null ? "—" : (p * DEG).toFixed(1), 0.5, p === null ? 0.5 : 0.5 + 0.5 * p / ps,
          [0.1, 0.9], level(p === null ? null : Math.abs(p) / lim.pitch_rad));
  for (const q of ["fill", "purge"]) {
    const x = b[q], out = x !== null && (x < -0.005 || x > 1.005);   // a reading out of its range
    setCell(c[q], x === null ? "—" : (100 * x).toFixed(0), 0, x === null ? 0 : x, [],
            x === null ? "" : out ? "bad" : "ok");
  }
}

function svg(tag, attrs, parent, text) {
  const el = document.createElementNS(SVGNS, tag);
  for (const k in attrs) el.setAttribute(k, attrs[k]);
  if (text !== undefined) el.textContent = text;
  parent.appendChild(el); return el;
}

function niceStep(span) {
  const raw = span / 5, p = Math.pow(10, Math.floor(Math.log10(raw)));
  return [1, 2, 5, 10].map(k => k * p).find(s => s >= raw);
}

function drawProfile(s) {
  const g = $("profile"); g.innerHTML = "";
  const W = 760, H = 260, L = 56, R = 20, T = 22, B = 30;
  const known = s.bags.filter(b => b.depth_m !== null);
  if (!known.length) { svg("text", { x: W / 2, y: H / 2, "text-anchor": "middle" }, g, "no depth readings"); return; }
  const ds = known.map(b => b.depth_m), lo = Math.min(...ds), hi = Math.max(...ds);
  const span = Math.max(10, 1.5 * (hi - lo)), mid = (lo + hi) / 2;
  const top = mid - span / 2, bot = mid + span / 2;
  const y = d => T + (H - T - B) * (d - top) / (bot - top);
  const n = s.bags.length, x = i => L + (W - L - R) * (n === 1 ? 0.5 : i / (n - 1));
  const step = niceStep(span);
  for (let d = Math.ceil(top / step) * step; d <= bot; d += step) {
    svg("line", { x1: L, x2: W - R, y1: y(d), y2: y(d), stroke: "#e3e9ef" }, g);
    svg("text", { x: L - 6, y: y(d) + 4, "text-anchor": "end" }, g, d.toFixed(step < 1 ? 1 : 0));
  }
  if (top < 0) svg("line", { x1: L, x2: W - R, y1: y(0), y2: y(0), stroke: "#2f6fb5", "stroke-width": 2 }, g);
  svg("text", { x: L, y: H - 8 }, g, "stern");
  svg("text", { x: W - R, y: H - 8, "text-anchor": "end" }, g, "bow");
  const pts = s.bags.map((b, i) => b.depth_m === null ? null : x(i) + "," + y(b.depth_m)).filter(Boolean);
  svg("polyline", { points: pts.join(" "), fill: "none", stroke: "#10263f", "stroke-width": 3 }, g);
  const alarmed = new Set(s.alarms.map(a => a.bag));
  s.bags.forEach((b, i) => {
    if (b.depth_m === null) return;
    const lv = level(b.speed_m_s === null ? null : Math.abs(b.speed_m_s) / s.limits.speed_m_s);
    const col = alarmed.has(b.name) || lv === "bad" ? "#d62d20" : lv === "warn" ? "#e0a100" : "#2e9d6b";
    svg("circle", { cx: x(i), cy: y(b.depth_m), r: 8, fill: col, stroke: "#fff", "stroke-width": 2 }, g);
    svg("text", { x: x(i), y: y(b.depth_m) - 13, "text-anchor": "middle", class: "bagname" }, g, b.name);
    svg("text", { x: x(i), y: y(b.depth_m) + 22, "text-anchor": "middle" }, g, b.depth_m.toFixed(1) + " m");
  });
}

function drawColumn(s) {
  const g = $("column"); g.innerHTML = "";
  const wd = s.limits.water_depth_m, T = 10, H = 96, y = d => T + H * d / wd;
  svg("rect", { x: 50, y: T, width: 100, height: H, fill: "#d7e7f5" }, g);
  svg("line", { x1: 45, x2: 155, y1: T, y2: T, stroke: "#2f6fb5", "stroke-width": 2 }, g);
  svg("rect", { x: 45, y: T + H, width: 110, height: 6, fill: "#9c7a4f" }, g);
  svg("text", { x: 42, y: T + 4, "text-anchor": "end" }, g, "0");
  svg("text", { x: 42, y: T + H + 4, "text-anchor": "end" }, g, wd.toFixed(0));
  const ds = s.bags.map(b => b.depth_m).filter(d => d !== null);
  if (!ds.length) return;
  const mean = ds.reduce((a, b) => a + b, 0) / ds.length;
  svg("rect", { x: 62, y: y(mean) - 3, width: 76, height: 6, rx: 3, fill: "#10263f" }, g);
  svg("text", { x: 158, y: y(mean) + 4 }, g, mean.toFixed(0) + " m");
}

function drawAlarms(s) {
  const list = $("alarms"); list.innerHTML = "";
  const n = s.alarms.length;
  $("alarm-count").textContent = n === 0 ? "No" : n;
  $("alarm-word").textContent = n === 1 ? "alarm" : "alarms";
  $("alarm-panel").className = "alarms " + (n ? "alarms-on" : "alarms-clear");
  for (const a of s.alarms.slice().reverse()) {            // newest first
    const li = document.createElement("li"); li.dataset.testid = "alarm";
    for (const [cls, text] of [["t", a.time_s === null ? "" : clock(a.time_s)], ["k", a.kind],
                               ["b", a.bag || "hull"], ["m", a.message]]) {
      const sp = document.createElement("span"); sp.className = cls; sp.textContent = text; li.appendChild(sp);
    }
    list.appendChild(li);
  }
}

function draw(s) {
  if (!s) return;
  lastAt = Date.now();
  const lim = s.limits;
  $("lift").textContent = s.lift || "";
  document.title = "flexlift · " + (s.lift || "lift") + " · " + s.state;
  const st = $("state"); st.textContent = s.state;
  st.className = "state state-" + s.state.replace(/ /g, "-");
  $("time").textContent = clock(s.time_s);
  $("mode").textContent = s.mode || "—";
  $("speed-limit").textContent = lim.speed_m_s.toFixed(2);
  $("pitch-limit").textContent = $("pitch-limit-2").textContent = (lim.pitch_rad * DEG).toFixed(1);
  const hp = s.hull_pitch_rad, hl = level(hp === null ? null : Math.abs(hp) / lim.pitch_rad);
  const hpEl = $("hull-pitch"); hpEl.textContent = hp === null ? "—" : (hp * DEG).toFixed(2) + "°";
  hpEl.className = "big " + hl;
  const meter = $("hull-bar").parentNode; meter.className = "meter centred " + hl;
  const frac = hp === null ? 0.5 : 0.5 + 0.5 * hp / (1.25 * lim.pitch_rad);
  const bar = $("hull-bar"), a = Math.max(0, Math.min(0.5, frac)), b = Math.min(1, Math.max(0.5, frac));
  bar.style.left = (100 * a) + "%"; bar.style.width = (100 * (b - a)) + "%";
  meter.querySelector(".lo").style.left = "10%"; meter.querySelector(".hi").style.left = "90%";
  if (s.bags.map(b => b.name).join(",") !== rowOrder) buildRows(s.bags);
  const alarmed = new Set(s.alarms.map(x => x.bag));
  for (const bag of s.bags) drawBag(bag, lim, alarmed.has(bag.name));
  drawProfile(s); drawColumn(s); drawAlarms(s);
}

function connect() {
  const ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws");
  ws.onmessage = ev => draw(JSON.parse(ev.data));
  ws.onclose = () => setTimeout(connect, 1000);
}

setInterval(() => {
  const link = $("link"), age = Date.now() - lastAt;
  if (lastAt && age < STALE_MS) { link.className = "link link-up"; link.textContent = "live"; }
  else { link.className = "link link-down"; link.textContent = lastAt ? "no data for " + Math.round(age / 1000) + " s" : "no data"; }
}, 500);
connect();
