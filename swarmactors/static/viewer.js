// swarmactors viewer: draws the frames the server sends over a WebSocket on a canvas.
// No build step: plain JavaScript. `window.swarm` exposes what is drawn (for tests and the console).
"use strict";

const PALETTE = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2", "#edc948", "#ff9da7", "#9c755f",
                 "#bab0ac", "#86bcb6"];
const ROBOT_PX = 7;
const $ = (id) => document.getElementById(id);

const S = {
  frame: null, ws: null, nextId: 1, selected: null, fieldChoice: "auto", extent: null,
  drawn: { t: null, robots: 0, count: 0 }, draws: [], ticks: [], dragging: null, robotFetch: 0,
  lastDraw: 0, pending: false, seekTimer: null,
};

// ------------------------------------------------------------------ connection
// The server's per-run token, from the address it printed (…/?token=…); sent with every request but the page.
const TOKEN = new URLSearchParams(location.search).get("token") || "";

function api(path) {
  return fetch(path, { headers: { "X-Swarmactors-Token": TOKEN } });
}

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/ws?token=${encodeURIComponent(TOKEN)}`);
  S.ws = ws;
  ws.onopen = () => banner(null);
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "frame") { S.frame = msg; schedule(); }
    else if (msg.type === "reply" && !msg.ok) banner(msg.error || "refused", true);
  };
  ws.onclose = async () => {
    let refused = null;  // a WebSocket does not tell why it was refused: ask over HTTP
    try {
      const r = await api("/api/frame");
      if (r.status === 403) refused = await r.text();
    } catch (e) { /* the server is gone: retry below */ }
    if (refused) { banner(refused, true); clearTimeout(bannerTimer); return; }
    banner("disconnected from the viewer server; retrying…", true);
    setTimeout(connect, 1000);
  };
}

function send(cmd) {
  if (!S.ws || S.ws.readyState !== WebSocket.OPEN) { banner("not connected", true); return; }
  S.ws.send(JSON.stringify({ id: S.nextId++, ...cmd }));
}

let bannerTimer = null;
function banner(text, error = false) {
  const b = $("banner");
  if (!text) { b.hidden = true; return; }
  b.textContent = text; b.hidden = false; b.className = "banner" + (error ? " error" : "");
  clearTimeout(bannerTimer);
  if (error) bannerTimer = setTimeout(() => { b.hidden = true; }, 6000);
}

function schedule() {
  if (S.pending) return;
  S.pending = true;
  requestAnimationFrame(() => { S.pending = false; render(); });
}

// ------------------------------------------------------------------ geometry
function canvasSize() {
  const c = $("canvas");
  const r = c.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  if (c.width !== Math.round(r.width * dpr) || c.height !== Math.round(r.height * dpr)) {
    c.width = Math.round(r.width * dpr); c.height = Math.round(r.height * dpr);
  }
  return { w: r.width, h: r.height, dpr };
}

function updateExtent(f) {
  let e;
  if (f.bounds) e = { x0: f.bounds[0][0], y0: f.bounds[0][1], x1: f.bounds[1][0], y1: f.bounds[1][1] };
  const pts = f.robots.map((r) => [r[1], r[2]]).concat(f.dead.map((d) => [d[1], d[2]]))
    .concat(Object.values(f.objects || {}).map((p) => [p[0], p[1]]));
  const sp = S.space;
  if (sp) {  // obstacles and the map are in the picture too
    for (const ob of sp.obstacles || []) pts.push(...ob.xy);
    if (sp.map) {
      const m = sp.map;
      pts.push([m.origin[0], m.origin[1]], [m.origin[0] + m.rows[0].length * m.cell, m.origin[1] + m.rows.length * m.cell]);
    }
  }
  for (const [x, y] of pts) {
    if (!e) e = { x0: x, y0: y, x1: x, y1: y };
    e.x0 = Math.min(e.x0, x); e.y0 = Math.min(e.y0, y); e.x1 = Math.max(e.x1, x); e.y1 = Math.max(e.y1, y);
  }
  if (!e) e = { x0: 0, y0: 0, x1: 1, y1: 1 };
  if (S.extent) {  // only grows: the picture does not jump around as robots move
    e = { x0: Math.min(e.x0, S.extent.x0), y0: Math.min(e.y0, S.extent.y0),
          x1: Math.max(e.x1, S.extent.x1), y1: Math.max(e.y1, S.extent.y1) };
  }
  S.extent = e;
}

function transform() {
  const { w, h } = canvasSize();
  const e = S.extent || { x0: 0, y0: 0, x1: 1, y1: 1 };
  const margin = 24;
  const spanX = Math.max(e.x1 - e.x0, 1e-9), spanY = Math.max(e.y1 - e.y0, 1e-9);
  const k = Math.min((w - 2 * margin) / spanX, (h - 2 * margin) / spanY);
  const ox = (w - k * spanX) / 2, oy = (h - k * spanY) / 2;
  return {
    k,
    toScreen: (x, y) => [ox + (x - e.x0) * k, h - (oy + (y - e.y0) * k)],
    toWorld: (px, py) => [e.x0 + (px - ox) / k, e.y0 + (h - py - oy) / k],
  };
}

// ------------------------------------------------------------------ colours
function chosenField(f) {
  if (S.fieldChoice !== "auto") return S.fieldChoice || null;
  const st = Object.values(f.status);
  if (st.some((s) => s.role !== undefined && s.role !== null)) return "role";
  if (f.field) return f.field;
  return null;
}

function colourer(f, field) {
  const values = f.robots.map((r) => ((f.status[r[0]] || {})[field]));
  const nums = values.filter((v) => typeof v === "number");
  const categorical = !field || values.some((v) => v !== undefined && v !== null && typeof v !== "number");
  if (!field) return { colour: () => "#9ecae1", legend: [] };
  if (!categorical && nums.length) {
    const lo = Math.min(...nums), hi = Math.max(...nums);
    const colour = (v) => (typeof v !== "number" ? "#ffffff" : viridis(hi === lo ? 0.5 : (v - lo) / (hi - lo)));
    return { colour, legend: [[`${field} ${fmt(lo)}`, colour(lo)], [`${field} ${fmt(hi)}`, colour(hi)]] };
  }
  const names = [...new Set(values.filter((v) => v !== undefined && v !== null).map(String))].sort();
  const colour = (v) => (v === undefined || v === null ? "#ffffff" : PALETTE[names.indexOf(String(v)) % PALETTE.length]);
  return { colour, legend: names.slice(0, 12).map((n) => [`${field} = ${n}`, colour(n)]) };
}

function viridis(t) {
  const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const x = Math.max(0, Math.min(1, t)) * (stops.length - 1);
  const i = Math.min(Math.floor(x), stops.length - 2), u = x - i;
  const c = stops[i].map((a, j) => Math.round(a + (stops[i + 1][j] - a) * u));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function fmt(v) {
  if (typeof v === "number") return Number.isInteger(v) ? String(v) : v.toPrecision(3);
  if (v === null || v === undefined) return "–";
  return typeof v === "object" ? JSON.stringify(v) : String(v);
}

// ------------------------------------------------------------------ drawing
function render() {
  const f = S.frame;
  if (!f) return;
  updateExtent(f);
  const c = $("canvas");
  const ctx = c.getContext("2d");
  const { w, h, dpr } = canvasSize();
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const T = transform();
  const field = chosenField(f);
  const col = colourer(f, field);
  const byId = new Map(f.robots.map((r) => [r[0], r]));

  if (f.bounds) {
    const [ax, ay] = T.toScreen(f.bounds[0][0], f.bounds[0][1]);
    const [bx, by] = T.toScreen(f.bounds[1][0], f.bounds[1][1]);
    ctx.strokeStyle = "#ccc"; ctx.setLineDash([4, 4]); ctx.strokeRect(ax, by, bx - ax, ay - by); ctx.setLineDash([]);
  }
  drawSpace(ctx, T, f);
  if ($("show-ranges").checked || S.selected !== null) {
    ctx.strokeStyle = "rgba(80,120,200,0.25)"; ctx.fillStyle = "rgba(80,120,200,0.04)";
    for (const r of f.robots) {
      if (!$("show-ranges").checked && r[0] !== S.selected) continue;
      const [x, y] = T.toScreen(r[1], r[2]);
      ctx.beginPath(); ctx.arc(x, y, r[3] * T.k, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    }
  }
  if ($("show-links").checked && f.robots.length <= 2000) drawLinks(ctx, T, f);
  drawStructure(ctx, T, f, byId);
  const talking = $("show-activity").checked ? f.activity || {} : {};
  for (const r of f.robots) {
    const [x, y] = T.toScreen(r[1], r[2]);
    const n = talking[r[0]] || 0;
    if (n) {
      ctx.strokeStyle = "rgba(225,87,89,0.8)"; ctx.lineWidth = Math.min(1 + n, 4);
      ctx.beginPath(); ctx.arc(x, y, ROBOT_PX + 4, 0, 2 * Math.PI); ctx.stroke();
    }
    ctx.fillStyle = col.colour(((f.status[r[0]] || {})[field]));
    ctx.strokeStyle = r[0] === S.selected ? "#000" : "#444"; ctx.lineWidth = r[0] === S.selected ? 3 : 1;
    ctx.beginPath(); ctx.arc(x, y, ROBOT_PX, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
  }
  ctx.lineWidth = 1;
  drawBodies(ctx, T, f);
  if (f.robots.length <= 300) {
    ctx.fillStyle = "#222"; ctx.font = "9px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "middle";
    for (const r of f.robots) { const [x, y] = T.toScreen(r[1], r[2]); ctx.fillText(String(r[0]), x, y - ROBOT_PX - 6); }
  }
  ctx.strokeStyle = "#d62728"; ctx.lineWidth = 2.5;
  for (const d of f.dead) {
    const [x, y] = T.toScreen(d[1], d[2]);
    ctx.beginPath(); ctx.moveTo(x - 6, y - 6); ctx.lineTo(x + 6, y + 6); ctx.moveTo(x + 6, y - 6); ctx.lineTo(x - 6, y + 6); ctx.stroke();
  }
  ctx.lineWidth = 1;
  for (const [name, p0] of Object.entries(f.objects || {})) {
    const p = S.dragging && S.dragging.name === name ? S.dragging.pos : p0;
    const [x, y] = T.toScreen(p[0], p[1]);
    ctx.fillStyle = "#f1a340"; ctx.strokeStyle = "#333";
    ctx.beginPath(); ctx.moveTo(x, y - 9); ctx.lineTo(x + 9, y); ctx.lineTo(x, y + 9); ctx.lineTo(x - 9, y); ctx.closePath();
    ctx.fill(); ctx.stroke();
    ctx.fillStyle = "#333"; ctx.textAlign = "left"; ctx.font = "11px sans-serif"; ctx.fillText(name, x + 11, y - 8);
  }
  S.drawn = { t: f.t, robots: f.robots.length, dead: f.dead.length, count: S.drawn.count + 1 };
  const now = performance.now();
  S.draws.push(now); S.ticks.push([now, f.t]);
  while (S.draws.length && S.draws[0] < now - 1000) S.draws.shift();
  while (S.ticks.length && S.ticks[0][0] < now - 2000) S.ticks.shift();
  panel(f, field, col);
}

// The world's space: fetched once from /api/space, drawn under the robots.
function drawSpace(ctx, T, f) {
  if (!f.space) return;
  if (S.space === undefined) {
    S.space = null;
    api("/api/space").then((r) => r.json()).then((sp) => { S.space = sp; render(); });
    return;
  }
  const sp = S.space;
  if (!sp) return;
  for (const ob of sp.obstacles || []) {
    const lifted = ob.z && ob.z[0] !== null && ob.z[0] > 0;
    ctx.beginPath();
    ob.xy.forEach(([x, y], i) => { const [sx, sy] = T.toScreen(x, y); if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy); });
    ctx.closePath();
    ctx.fillStyle = lifted ? "rgba(90,90,90,0.25)" : "rgba(90,90,90,0.7)";
    ctx.strokeStyle = "#333"; ctx.fill(); ctx.stroke();
  }
  const m = sp.map;
  if (m) {
    if (!S.mapImage) {  // one pixel per cell, drawn scaled
      const h = m.rows.length, w = m.rows[0].length;
      const img = document.createElement("canvas"); img.width = w; img.height = h;
      const g = img.getContext("2d"); const data = g.createImageData(w, h);
      const colour = { "@": [70, 70, 70, 200], "+": [70, 70, 70, 90], "W": [70, 120, 220, 120], ".": [0, 0, 0, 0] };
      m.rows.forEach((row, r) => { for (let c = 0; c < w; c++) data.data.set(colour[row[c]] || colour["."], (r * w + c) * 4); });
      g.putImageData(data, 0, 0); S.mapImage = img;
    }
    const h = m.rows.length, w = m.rows[0].length;
    const [ax, ay] = T.toScreen(m.origin[0], m.origin[1] + h * m.cell);
    const [bx, by] = T.toScreen(m.origin[0] + w * m.cell, m.origin[1]);
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(S.mapImage, ax, ay, bx - ax, by - ay);
  }
}

function drawBodies(ctx, T, f) {
  const sp = S.space;
  if (!sp) return;
  const flying = new Set(sp.flying || []);
  for (const r of f.robots) {
    const [x, y] = T.toScreen(r[1], r[2]);
    const rad = (sp.radius || {})[r[0]];
    if (rad) { ctx.strokeStyle = "#555"; ctx.beginPath(); ctx.arc(x, y, rad * T.k, 0, 2 * Math.PI); ctx.stroke(); }
    if (flying.has(r[0])) {  // a triangle over the disc, the altitude beside it
      ctx.strokeStyle = "#1f77b4"; ctx.lineWidth = 1.5; ctx.beginPath();
      ctx.moveTo(x, y - ROBOT_PX - 3); ctx.lineTo(x + ROBOT_PX + 2, y + ROBOT_PX); ctx.lineTo(x - ROBOT_PX - 2, y + ROBOT_PX);
      ctx.closePath(); ctx.stroke(); ctx.lineWidth = 1;
      if (r.length > 4 && f.robots.length <= 300) {
        ctx.fillStyle = "#1f77b4"; ctx.font = "9px sans-serif"; ctx.textAlign = "left";
        ctx.fillText("z=" + r[4].toFixed(1), x + ROBOT_PX + 3, y + ROBOT_PX + 3);
      }
    }
  }
}

function drawLinks(ctx, T, f) {
  const rs = f.robots;
  ctx.lineWidth = 1;
  for (let i = 0; i < rs.length; i++) {
    for (let j = i + 1; j < rs.length; j++) {
      const dx = rs[i][1] - rs[j][1], dy = rs[i][2] - rs[j][2];
      const d = Math.hypot(dx, dy);
      const ij = d <= rs[i][3], ji = d <= rs[j][3];
      if (!ij && !ji) continue;
      const [ax, ay] = T.toScreen(rs[i][1], rs[i][2]);
      const [bx, by] = T.toScreen(rs[j][1], rs[j][2]);
      ctx.strokeStyle = ij && ji ? "#c9c9c9" : "#e4e4e4";
      ctx.setLineDash(ij && ji ? [] : [3, 3]);
      ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
    }
  }
  ctx.setLineDash([]);
}

// A protocol shows its structure with status fields: `parent` / `child` (robot ids: a tree or a chain, thick
// blue) and `links` / `conn` (lists of ids: the links the protocol formed, thinner teal).
function drawStructure(ctx, T, f, byId) {
  let n = 0;
  const edge = (r, tid, colour, width) => {
    const o = byId.get(tid);
    if (!o || o === r) return;
    const [ax, ay] = T.toScreen(r[1], r[2]);
    const [bx, by] = T.toScreen(o[1], o[2]);
    ctx.strokeStyle = colour; ctx.lineWidth = width;
    ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
    n++;
  };
  for (const r of f.robots) {
    const st = f.status[r[0]] || {};
    for (const key of ["links", "conn"]) {
      if (Array.isArray(st[key])) for (const x of st[key]) if (Number.isInteger(x)) edge(r, x, "#2a9d8f", 2);
    }
  }
  for (const r of f.robots) {
    const st = f.status[r[0]] || {};
    for (const key of ["parent", "child"]) if (Number.isInteger(st[key])) edge(r, st[key], "#1f5fa8", 3.5);
  }
  ctx.lineWidth = 1;
  S.structureEdges = n;
}

// ------------------------------------------------------------------ side panel
function panel(f, field, col) {
  $("run-id").textContent = `${f.run_id || ""} · ${f.clock || ""}${f.mode === "replay" ? " · replay" : ""}`;
  $("tick").textContent = f.t === null ? "–" : `${f.t}${f.ticks ? " / " + (f.ticks - 1) : ""}`;
  let state = f.mode === "replay" ? (f.playing ? "replaying" : "replay") :
    f.finished ? "finished" : f.gone ? "world gone" : f.playing ? "running" : f.paused ? "paused" : "running";
  if (f.message) state += ` — ${f.message}`;
  $("state").textContent = state;
  $("robots").textContent = `${f.robots.length} alive, ${f.dead.length} failed`;
  $("fps").textContent = String(S.draws.length);
  const tk = S.ticks.filter((x) => x[1] !== null);
  const span = tk.length > 1 ? (tk[tk.length - 1][0] - tk[0][0]) / 1000 : 0;
  $("tps").textContent = span > 0 ? fmt((tk[tk.length - 1][1] - tk[0][1]) / span) : "–";
  $("sent").textContent = fmt(f.sent);
  $("deliveries").textContent = f.deliveries === null ? "not in the state stream" : fmt(f.deliveries);
  $("drops").innerHTML = Object.entries(f.dropped || {})
    .map(([k, v]) => `<tr><th>${esc(k)}</th><td class="${v ? "drop-bad" : ""}">${v}</td></tr>`).join("");
  $("metrics").innerHTML = metrics(f);
  $("legend").innerHTML = col.legend.map(([name, c]) => `<span class="swatch" style="background:${c}"></span>${esc(name)}`)
    .join("<br>") + (f.dead.length ? `<br><span style="color:#d62728">✕</span> failed` : "");
  $("events").innerHTML = (f.events || []).slice().reverse().map((e) => `<li>${esc(describeEvent(e))}</li>`).join("");
  syncControls(f, field);
  if (S.selected !== null && performance.now() - S.robotFetch > 500) loadRobot(S.selected);
}

function metrics(f) {
  const fields = new Map();
  for (const st of Object.values(f.status)) {
    for (const [k, v] of Object.entries(st)) {
      if (!fields.has(k)) fields.set(k, []);
      fields.get(k).push(v);
    }
  }
  const n = f.robots.length;
  const rows = [];
  for (const [k, vs] of [...fields.entries()].slice(0, 10)) {
    const set = vs.filter((v) => v !== null && v !== undefined);
    if (set.length && set.every((v) => typeof v === "number")) {
      const lo = Math.min(...set), hi = Math.max(...set), mean = set.reduce((a, b) => a + b, 0) / set.length;
      rows.push(`<b>${esc(k)}</b>: ${set.length}/${n} set, min ${fmt(lo)}, mean ${fmt(mean)}, max ${fmt(hi)}`);
    } else {
      const counts = new Map();
      for (const v of set) counts.set(fmt(v), (counts.get(fmt(v)) || 0) + 1);
      const top = [...counts.entries()].sort((a, b) => b[1] - a[1]).slice(0, 6);
      rows.push(`<b>${esc(k)}</b>: ${top.map(([v, c]) => `${esc(v)} ×${c}`).join(", ")}${set.length < n ? `; unset ×${n - set.length}` : ""}`);
    }
  }
  return rows.join("<br>") || '<span class="muted">no status fields yet</span>';
}

function describeEvent(e) {
  const { t, source, ...rest } = e;
  const body = Object.entries(rest).map(([k, v]) => `${k} ${typeof v === "object" ? JSON.stringify(v) : v}`).join(" ");
  return `t=${t} ${body}${source ? ` (${source})` : ""}`;
}

function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
}

function syncControls(f, field) {
  const replay = f.mode === "replay";
  const live = !replay && f.controls && f.clock === "lockstep";
  $("play").disabled = !(replay || live);
  $("step").disabled = !(replay || live);
  $("speed").disabled = !(replay || live);
  $("play").textContent = f.playing ? "⏸" : "▶";
  $("tools").style.opacity = !replay && f.controls ? 1 : 0.4;
  $("tool-kill").disabled = replay || !f.controls;
  const rate = f.rate === null || f.rate === undefined ? "" : String(Math.round(f.rate));
  if (document.activeElement !== $("speed") && [...$("speed").options].some((o) => o.value === rate)) $("speed").value = rate;
  $("replay-bar").hidden = !replay;
  if (replay && f.replay) {
    const s = $("slider");
    s.min = f.replay.first; s.max = f.replay.last;
    if (document.activeElement !== s) s.value = f.t;
    $("slider-label").textContent = `tick ${f.t} of ${f.replay.first}–${f.replay.last}`;
  }
  const names = new Set();
  for (const st of Object.values(f.status)) for (const k of Object.keys(st)) names.add(k);
  const sel = $("field");
  const want = ["auto", "", ...[...names].sort()];
  const have = [...sel.options].map((o) => o.value);
  if (want.join("\u0000") !== have.join("\u0000")) {
    sel.innerHTML = want.map((v) => `<option value="${esc(v)}">${v === "auto" ? `auto (${esc(field || "none")})` : v === "" ? "none" : esc(v)}</option>`).join("");
    sel.value = want.includes(S.fieldChoice) ? S.fieldChoice : "auto";
  } else if (sel.options[0]) {
    sel.options[0].textContent = `auto (${field || "none"})`;
  }
}

// ------------------------------------------------------------------ robot details
async function loadRobot(rid) {
  S.robotFetch = performance.now();
  let d;
  try {
    d = await (await api(`/api/robot/${rid}`)).json();
  } catch (e) { return; }
  if (S.selected !== rid) return;
  const status = Object.entries(d.status || {}).map(([k, v]) => `<tr><th>${esc(k)}</th><td>${esc(fmt(v))}</td></tr>`).join("");
  let html = `<b>robot ${rid}</b> ${d.alive ? "alive" : d.failed ? `<span style="color:#d62728">failed: ${esc(d.failed.cause)} at tick ${fmt(d.failed.t)}</span>` : "(unknown)"}`;
  if (d.pos) html += `<br>at (${d.pos.slice(0, 2).map((v) => v.toFixed(3)).join(", ")}), range ${fmt(d.range)}`;
  html += `<table>${status || '<tr><td class="muted">no status fields</td></tr>'}</table>`;
  if (d.frames_available) {
    html += `<div><b>frames sent</b> (ticks ${fmt(d.window[0])}–${fmt(d.window[1])})</div>`;
    html += (d.sent || []).slice(-12).reverse().map((s) => {
      const fate = `delivered to ${s.delivered.length}` + (s.dropped.length ? "; dropped: " +
        s.dropped.map((x) => `→${x[0]} ${x[1]}`).join(", ") : "");
      return `<div>t=${s.t} #${s.seq} ${esc(s.kind)} → ${s.dst === null ? "all" : s.dst}, ${s.size} B: ${fate}</div>`;
    }).join("") || '<div class="muted">none</div>';
    html += "<div><b>frames to it</b></div>";
    html += (d.received || []).slice(-12).reverse().map((r) =>
      `<div>t=${r.t} from ${r.src} #${r.seq} ${esc(r.kind || "")}: ${esc(r.fate)}</div>`).join("") || '<div class="muted">none</div>';
  } else {
    html += `<div class="muted">${esc(d.frames_note)}</div>`;
  }
  html += "<div><b>log</b></div>";
  html += d.log && d.log.length ? `<pre>${esc(d.log.slice(-15).join("\n"))}</pre>` : `<div class="muted">${esc(d.log_note || "no log lines")}</div>`;
  $("robot").innerHTML = html;
  $("robot").classList.remove("muted");
}

// ------------------------------------------------------------------ input
function robotAt(px, py) {
  const f = S.frame;
  if (!f) return null;
  const T = transform();
  let best = null, bestD = ROBOT_PX + 4;
  for (const r of f.robots) {
    const [x, y] = T.toScreen(r[1], r[2]);
    const d = Math.hypot(x - px, y - py);
    if (d <= bestD) { best = r[0]; bestD = d; }
  }
  if (best === null) {
    for (const dd of f.dead) {
      const [x, y] = T.toScreen(dd[1], dd[2]);
      if (Math.hypot(x - px, y - py) <= ROBOT_PX) best = dd[0];
    }
  }
  return best;
}

function objectAt(px, py) {
  const f = S.frame;
  if (!f) return null;
  const T = transform();
  for (const [name, p] of Object.entries(f.objects || {})) {
    const [x, y] = T.toScreen(p[0], p[1]);
    if (Math.hypot(x - px, y - py) <= 11) return name;
  }
  return null;
}

function pointer(ev) {
  const r = $("canvas").getBoundingClientRect();
  return [ev.clientX - r.left, ev.clientY - r.top];
}

function setup() {
  const c = $("canvas");
  c.addEventListener("mousedown", (ev) => {
    const [px, py] = pointer(ev);
    const f = S.frame;
    const name = objectAt(px, py);
    if (name && f && f.controls && f.mode !== "replay") {
      S.dragging = { name, pos: f.objects[name].slice() };
      return;
    }
    const rid = robotAt(px, py);
    if (rid === null) { S.selected = null; $("robot").textContent = "click a robot"; $("robot").classList.add("muted"); schedule(); return; }
    if (S.selected !== rid) { $("robot").textContent = `robot ${rid}…`; $("robot").classList.add("muted"); }
    S.selected = rid;
    if (document.querySelector('input[name="tool"]:checked').value === "kill" && f && f.controls && f.mode !== "replay") {
      send({ cmd: "kill", id: rid });
    }
    loadRobot(rid);
    schedule();
  });
  c.addEventListener("mousemove", (ev) => {
    if (!S.dragging) return;
    const [px, py] = pointer(ev);
    S.dragging.pos = transform().toWorld(px, py);
    schedule();
  });
  window.addEventListener("mouseup", () => {
    if (!S.dragging) return;
    const { name, pos } = S.dragging;
    S.dragging = null;
    send({ cmd: "move", object: name, pos });
  });
  $("play").onclick = () => send({ cmd: S.frame && S.frame.playing ? "pause" : "play" });
  $("step").onclick = () => send({ cmd: "step" });
  $("speed").onchange = () => send({ cmd: "speed", rate: $("speed").value === "" ? null : Number($("speed").value) });
  $("field").onchange = () => { S.fieldChoice = $("field").value; schedule(); };
  for (const id of ["show-links", "show-ranges", "show-activity"]) $(id).onchange = schedule;
  $("slider").oninput = () => {
    clearTimeout(S.seekTimer);
    S.seekTimer = setTimeout(() => send({ cmd: "seek", t: Number($("slider").value) }), 30);
  };
  $("export").onclick = async () => {
    const text = await (await api("/api/events.toml")).text();
    $("export-text").value = text;
    $("export-box").hidden = false;
    $("export-text").scrollIntoView();
  };
  window.addEventListener("resize", schedule);
  connect();
}

window.swarm = {
  get frame() { return S.frame; },
  get drawn() { return S.drawn; },
  get structureEdges() { return S.structureEdges; },
  get space() { return S.space; },
  // A world point on the page (CSS pixels, relative to the viewport).
  screenOfPoint(x, y) {
    const [sx, sy] = transform().toScreen(x, y);
    const box = $("canvas").getBoundingClientRect();
    return [box.left + sx, box.top + sy];
  },
  // The robot's position on the page (CSS pixels, relative to the viewport), for clicks in tests.
  screenOf(rid) {
    const r = S.frame && S.frame.robots.find((x) => x[0] === rid);
    if (!r) return null;
    const [x, y] = transform().toScreen(r[1], r[2]);
    const box = $("canvas").getBoundingClientRect();
    return [box.left + x, box.top + y];
  },
  screenOfObject(name) {
    const p = S.frame && (S.frame.objects || {})[name];
    if (!p) return null;
    const [x, y] = transform().toScreen(p[0], p[1]);
    const box = $("canvas").getBoundingClientRect();
    return [box.left + x, box.top + y];
  },
  robotAt,
  send,
};

setup();
