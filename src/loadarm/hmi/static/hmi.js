// loadarm's operator screen: plain JS and SVG, nothing from outside. Frames come over one WebSocket (with a
// sequence number); commands go back on it, each with its own sequence number and the session's CSRF token,
// and the server's acknowledgement is shown. A watchdog greys the screen when frames stop.
"use strict";

const STALE_MS = 1000;          // no frame for this long: the view is greyed and says so
const JOG_EVERY_MS = 200;       // a held jog is renewed this often (the controller drops it after 0.5 s)
const SHELVE_S = 300;           // the shelving an operator asks for (the server allows up to 600 s)
const MODES = ["STORED", "APPROACH", "HOLD", "STANDOFF", "CONNECTED", "ALARM1", "ALARM2", "RELEASE",
               "RETURN", "DISCONNECT", "MANUAL", "ESTOP"];
const SVGNS = "http://www.w3.org/2000/svg";
const $ = (id) => document.getElementById(id);

const hmi = {session: null, geo: null, ws: null, lastFrameAt: 0, lastSeq: null, lastSeqAt: 0, frames: 0, cmdSeq: 0,
             history: [], seenAlarms: [], seenModes: [], modeArrivals: [], modeCycle: -1,
             pending: new Map(), jog: null, jogTimer: null, flange0: null, frame: null, rate: 0,
             rateCount: 0, rateSince: performance.now()};
window.hmi = hmi;               // for the browser tests

async function api(path, options = {}) {
  const r = await fetch(path, Object.assign({credentials: "same-origin"}, options));
  let body = null;
  try { body = await r.json(); } catch (e) { body = null; }
  return {status: r.status, body};
}

async function boot() {
  const r = await api("/api/session");
  if (r.status === 200 && r.body.user) { await start(r.body); } else { showLogin(""); }
}

function showLogin(message) {
  $("screen").hidden = true;
  $("login").hidden = false;
  $("login-message").textContent = message;
  $("login-user").focus();
}

$("login-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const r = await api("/api/login", {method: "POST", headers: {"Content-Type": "application/json"},
    body: JSON.stringify({user: $("login-user").value, password: $("login-password").value})});
  $("login-password").value = "";
  if (r.status === 200) { await start(r.body); }
  else { showLogin(r.body && r.body.detail ? r.body.detail : "login failed"); }
});

$("logout").addEventListener("click", async () => {
  stopJog();
  await api("/api/logout", {method: "POST", headers: {"X-CSRF-Token": hmi.session.csrf}});
  if (hmi.ws) { hmi.ws.onclose = null; hmi.ws.close(); }
  hmi.session = null;
  showLogin("logged out");
});

async function start(session) {
  hmi.session = session;
  hmi.cmdSeq = Math.max(hmi.cmdSeq, session.last_seq || 0);   // a session's command numbers only increase
  $("login").hidden = true;
  $("screen").hidden = false;
  $("who").textContent = `${session.user} (${session.role})`;
  $("title").textContent = `loadarm: ${session.name}`;
  document.title = `loadarm HMI: ${session.name}`;
  const g = await api("/api/geometry");
  hmi.geo = g.body;
  buildModes();
  for (const b of document.querySelectorAll("#controls button")) {
    const action = b.dataset.action || (b.dataset.jog ? "jog" : null);
    if (action) { b.disabled = !session.commands.includes(action); }
  }
  connect();
}

function connect() {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  const ws = new WebSocket(`${proto}//${location.host}/ws`);
  hmi.ws = ws;
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "state") { onFrame(msg); }
    else if (msg.type === "ack") { onAck(msg); }
  };
  ws.onclose = () => {
    stopJog(false);
    $("link").textContent = "link to the controller lost: reconnecting";
    setTimeout(async () => {
      if (!hmi.session) { return; }
      const r = await api("/api/session");
      if (r.status === 200 && r.body.user) { connect(); } else { showLogin("session ended: log in again"); }
    }, 1000);
  };
}

function control(type, extra = {}) {          // a replay's cursor: seek, play, pause
  if (!hmi.ws || hmi.ws.readyState !== WebSocket.OPEN) { return; }
  const seq = ++hmi.cmdSeq;
  hmi.pending.set(seq, {action: type, at: performance.now()});
  hmi.ws.send(JSON.stringify(Object.assign({type, seq}, extra)));
}

$("replay-slider").addEventListener("input", () => { hmi.dragging = true; });
$("replay-slider").addEventListener("change", () => {
  hmi.dragging = false;
  control("seek", {t: Number($("replay-slider").value)});
});
$("replay-play").addEventListener("click", () => {
  if (hmi.frame && hmi.frame.replay && hmi.frame.replay.playing) { control("pause"); }
  else { control("play", {speed: Number($("replay-speed").value)}); }
});
$("replay-speed").addEventListener("change", () => {
  if (hmi.frame && hmi.frame.replay && hmi.frame.replay.playing) { control("play", {speed: Number($("replay-speed").value)}); }
});

function drawReplay(r) {
  $("replay-bar").hidden = false;
  const s = $("replay-slider");
  s.min = r.t0; s.max = r.t1;
  if (!hmi.dragging) { s.value = r.t; }
  $("replay-time").textContent = `${r.t.toFixed(1)} s of ${r.t0.toFixed(0)}-${r.t1.toFixed(0)} s` +
    (r.playing ? ` · playing ${r.speed}x` : " · paused");
  $("replay-play").textContent = r.playing ? "Pause" : "Play";
}

function send(action, extra = {}) {
  if (!hmi.ws || hmi.ws.readyState !== WebSocket.OPEN) { showAck(null, false, `${action}: not connected`); return; }
  const seq = ++hmi.cmdSeq;
  hmi.pending.set(seq, {action, at: performance.now()});
  hmi.ws.send(JSON.stringify(Object.assign({type: "cmd", seq, action, csrf: hmi.session.csrf}, extra)));
  return seq;
}

function onAck(msg) {
  // the session's commands are numbered across its screens: another tab's may have gone first
  if (typeof msg.last_seq === "number") { hmi.cmdSeq = Math.max(hmi.cmdSeq, msg.last_seq); }
  const p = hmi.pending.get(msg.seq);
  hmi.pending.delete(msg.seq);
  if (p && (p.action === "jog" || p.action === "seek") && msg.ok) { return; }   // renewals and drags: not news
  showAck(msg.seq, msg.ok, msg.message);
}

function showAck(seq, ok, text) {
  const el = $("ack");
  el.textContent = (seq === null ? "" : `#${seq} `) + text;
  el.className = ok ? "ok" : "refused";
  el.dataset.seq = seq === null ? "" : String(seq);
}

// ------------------------------------------------------------------ commands
for (const b of document.querySelectorAll("#controls button[data-action]")) {
  if (b.id === "ers") { continue; }
  b.addEventListener("click", () => {
    if (b.dataset.action === "estop" || b.dataset.action === "stop") { stopJog(false); }   // no renewal after
    send(b.dataset.action);
  });
}
$("ers").addEventListener("click", () => { send("ers"); $("ers-dialog").showModal(); });
$("ers-dialog").addEventListener("close", () => {
  if ($("ers-dialog").returnValue === "confirm") { send("ers_confirm"); }
});

// the controller's jog speed (the session says it): a faster request is refused, never clamped
function jogVector(spec) { return spec.split(",").map((v) => hmi.session.jog_speed * Number(v)); }

function startJog(vec, button) {
  if (!hmi.session.commands.includes("jog")) { return; }
  stopJog(false);
  hmi.jog = {vec, button};
  if (button) { button.classList.add("held"); }
  send("jog", {jog: vec});
  hmi.jogTimer = setInterval(() => send("jog", {jog: vec}), JOG_EVERY_MS);
}

function stopJog(sendStop = true) {
  if (!hmi.jog) { return; }
  clearInterval(hmi.jogTimer);
  if (hmi.jog.button) { hmi.jog.button.classList.remove("held"); }
  hmi.jog = null;
  if (sendStop) { send("stop"); }
}

for (const b of document.querySelectorAll(".jogbtn")) {
  b.addEventListener("pointerdown", (ev) => { ev.preventDefault(); startJog(jogVector(b.dataset.jog), b); });
  for (const ev of ["pointerup", "pointerleave", "pointercancel"]) { b.addEventListener(ev, () => stopJog()); }
}
const KEYS = {ArrowRight: "1,0,0", ArrowLeft: "-1,0,0", ArrowUp: "0,1,0", ArrowDown: "0,-1,0",
              PageUp: "0,0,1", PageDown: "0,0,-1"};
document.addEventListener("keydown", (ev) => {
  if ($("screen").hidden || !(ev.key in KEYS)) { return; }
  ev.preventDefault();
  if (!ev.repeat && !(hmi.jog && hmi.jog.key === ev.key)) {
    startJog(jogVector(KEYS[ev.key]), null);
    if (hmi.jog) { hmi.jog.key = ev.key; }
  }
});
document.addEventListener("keyup", (ev) => { if (hmi.jog && hmi.jog.key === ev.key) { stopJog(); } });
window.addEventListener("blur", () => stopJog());

// ------------------------------------------------------------------ frames
function noteMode(m) {
  if (hmi.seenModes[hmi.seenModes.length - 1] !== m) {
    hmi.seenModes.push(m);
    hmi.modeArrivals.push([m, Date.now() / 1000]);             // when each mode change reached the screen
  }
}

function onFrame(f) {
  hmi.lastFrameAt = performance.now();
  if (f.seq !== hmi.lastSeq || f.replay) { hmi.lastSeqAt = hmi.lastFrameAt; }   // a replay: frames are the life
  else if (hmi.lastFrameAt - hmi.lastSeqAt > STALE_MS) { return; }   // the controller stalled: keep the greying
  hmi.lastSeq = f.seq;
  // end to end: the controller's publication of the cycle to this frame's arrival (one clock on one machine;
  // across machines it needs their clocks synchronised)
  const latency = f.published_at === null ? null : Date.now() / 1000 - f.published_at;
  hmi.history.push({seq: f.seq, at: hmi.lastFrameAt, mode: f.mode, coupler: f.coupler, latency,
                    open: f.coupler_open, valves: f.ers_valves_closed});
  if (hmi.history.length > 600) { hmi.history.shift(); }
  // in the order raised; alarms raised in one cycle in escalation order (the less urgent first), not the list's
  const raised = [...f.alarms].sort((x, y) => (x.raised_at - y.raised_at) || (y.priority - x.priority));
  for (const a of raised) { if (!hmi.seenAlarms.includes(a.tag)) { hmi.seenAlarms.push(a.tag); } }
  // every mode the controller passed through, in order, even one held for less than a frame (f.modes: its
  // last changes by cycle); then the frame's own (a replay carries no changes)
  for (const [k, m] of (f.modes || [])) {
    if (k > hmi.modeCycle) { hmi.modeCycle = k; noteMode(m); }
  }
  noteMode(f.mode);
  hmi.frames += 1;
  hmi.frame = f;
  hmi.rateCount += 1;
  const since = hmi.lastFrameAt - hmi.rateSince;
  if (since >= 1000) { hmi.rate = 1000 * hmi.rateCount / since; hmi.rateCount = 0; hmi.rateSince = hmi.lastFrameAt; }
  document.body.classList.remove("stale");
  $("stale-banner").hidden = true;
  $("link").textContent = (f.plant_ok ? "live" : "PLC LINK LOST: plant values bad") +
    ` · cycle ${f.seq} · t ${f.t.toFixed(1)} s · ${hmi.rate.toFixed(0)} Hz`;
  document.body.dataset.mode = f.mode;
  if (f.replay) {
    drawReplay(f.replay);
    $("link").textContent = `replay · sample ${f.seq} · t ${f.t.toFixed(1)} s`;
  }
  for (const el of document.querySelectorAll("#modes span")) { el.classList.toggle("current", el.textContent === f.mode); }
  drawSide(f);
  drawTop(f);
  drawBars(f);
  drawTables(f);
  drawAlarms(f);
}

setInterval(() => {          // the stale-data watchdog: no frame, or frames with no new controller cycle
  if ($("screen").hidden || hmi.lastFrameAt === 0) { return; }
  const now = performance.now(), age = now - hmi.lastSeqAt;
  if (age > STALE_MS) {
    document.body.classList.add("stale");
    const b = $("stale-banner");
    b.hidden = false;
    const why = now - hmi.lastFrameAt > STALE_MS ? "no frame from the server" : "the controller has not cycled";
    b.textContent = `NO LIVE DATA: ${why} for ${(age / 1000).toFixed(1)} s (last cycle ${hmi.lastSeq}); ` +
                    "the values shown are not the plant's now";
  }
}, 200);

function buildModes() {
  const box = $("modes");
  box.textContent = "";
  for (const m of MODES) { const s = document.createElement("span"); s.textContent = m; box.appendChild(s); }
}

function el(name, attrs, parent, text) {
  const e = document.createElementNS(SVGNS, name);
  for (const [k, v] of Object.entries(attrs)) { e.setAttribute(k, v); }
  if (text !== undefined) { e.textContent = text; }
  if (parent) { parent.appendChild(e); }
  return e;
}

function fit(svg, x0, x1, y0, y1) {          // world (m, y up) to the 400 x 300 view box
  const s = Math.min(380 / (x1 - x0), 280 / (y1 - y0));
  return (x, y) => [10 + (x - x0) * s, 290 - (y - y0) * s];
}

function arcPath(P, cx, cy, r, a0, a1) {
  const [x0, y0] = P(cx + r * Math.cos(a0), cy + r * Math.sin(a0));
  const [x1, y1] = P(cx + r * Math.cos(a1), cy + r * Math.sin(a1));
  const [ox] = P(cx, cy), [rx] = P(cx + r, cy);
  const rr = rx - ox;
  return `M ${x0} ${y0} A ${rr} ${rr} 0 0 0 ${x1} ${y1}`;
}

const ZONE_LEVEL = {2: 0, 3: 1, 4: 2};       // alarm level (ESD-1, second, release) to its band
const ZONE_PRIORITY = ["p3", "p2", "p1"];    // each band's alarm colour (the alarm's priority), when active

function drawSide(f) {
  const g = hmi.geo, svg = $("side");
  svg.textContent = "";
  const R = g.b + g.c;
  const P = fit(svg, -0.25 * R, 1.1 * R, Math.min(g.berth.y_low, 0) - 1, g.a + 0.9 * R);
  const [gx0, gy] = P(-0.25 * R, 0), [gx1] = P(1.1 * R, 0);
  el("line", {x1: gx0, y1: gy, x2: gx1, y2: gy, class: "ground"}, svg);
  el("text", {x: gx0 + 2, y: gy + 12}, svg, "jetty deck");
  const [bx, by0] = P(g.berth.berthing_line, Math.min(g.berth.y_low, 0) - 1), [, by1] = P(g.berth.berthing_line, g.a);
  el("line", {x1: bx, y1: by0, x2: bx, y2: by1, class: "berth"}, svg);
  el("text", {x: bx + 3, y: by1}, svg, "berthing line");
  g.zones.forEach((z, i) => {
    const r = 0.5 * (z.from_r + z.to_r);
    const [ox] = P(0, g.a), [wx] = P(z.to_r - z.from_r, g.a);
    const active = ZONE_LEVEL[f.level] === i;
    el("path", {d: arcPath(P, 0, g.a, r, -1.4, 0.9), class: `zone zone${i}` + (active ? ` active ${ZONE_PRIORITY[i]}` : ""),
                "stroke-width": Math.max(2, wx - ox)}, svg);
    const [lx, ly] = P(r * Math.cos(-1.4), g.a + r * Math.sin(-1.4));
    el("text", {x: lx + 3, y: ly}, svg, z.name);
  });
  const rho = Math.hypot(f.coupler[0], f.coupler[1]);
  const pts = [[0, 0], [0, g.a], f.elbow, [rho, f.coupler[2]]].map(([x, y]) => P(x, y));
  el("polyline", {points: pts.slice(0, 2).map((p) => p.join(",")).join(" "), class: "riser"}, svg);
  el("polyline", {points: pts.slice(1).map((p) => p.join(",")).join(" "), class: "arm"}, svg);
  for (const p of pts.slice(1, 3)) { el("circle", {cx: p[0], cy: p[1], r: 4, class: "joint"}, svg); }
  el("rect", {x: pts[3][0] - 4, y: pts[3][1] - 4, width: 8, height: 8, class: "coupler"}, svg);
  if (f.flange[0] !== null) {
    const [fx, fy] = P(Math.hypot(f.flange[0], f.flange[1]), f.flange[2]);
    el("circle", {cx: fx, cy: fy, r: 6, class: "flange" + (f.estimate_healthy ? "" : " unhealthy")}, svg);
    el("text", {x: fx + 8, y: fy + 4}, svg, f.estimate_healthy ? "flange" : "flange (estimate unhealthy)");
  }
}

function drawTop(f) {
  const g = hmi.geo, svg = $("top");
  svg.textContent = "";
  const defs = el("defs", {}, svg);
  const m = el("marker", {id: "arrow", viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 6, markerHeight: 6,
                          orient: "auto"}, defs);
  el("path", {d: "M 0 0 L 10 5 L 0 10 z", fill: "#303030"}, m);
  const R = g.b + g.c;
  const P = fit(svg, -0.2 * R, 1.3 * R, -0.6 * R, 0.6 * R);
  const [ox, oy] = P(0, 0);
  for (const a of [g.slew.limit, -g.slew.limit]) {
    const [x, y] = P(R * Math.cos(a), R * Math.sin(a));
    el("line", {x1: ox, y1: oy, x2: x, y2: y, class: "slew-limit"}, svg);
  }
  const [, yTop] = P(0, 0.6 * R), [, yBot] = P(0, -0.6 * R);
  if (f.flange[0] !== null && f.estimate_healthy && hmi.flange0 === null) { hmi.flange0 = f.flange.slice(); }
  const dx = hmi.flange0 && f.flange[0] !== null ? f.flange[0] - hmi.flange0[0] : 0;
  const dy = hmi.flange0 && f.flange[1] !== null ? f.flange[1] - hmi.flange0[1] : 0;
  const [sx, sy0] = P(g.berth.berthing_line + dx, 0.6 * R + dy), [sx1, sy1] = P(g.berth.berthing_line + dx + 40, -0.6 * R + dy);
  el("rect", {x: sx, y: sy0, width: Math.max(0, sx1 - sx), height: Math.max(0, sy1 - sy0), class: "ship"}, svg);
  el("text", {x: sx + 4, y: yBot - 4}, svg, "ship (schematic)");
  const [bx] = P(g.berth.berthing_line, 0), [jx] = P(g.berth.jetty_face, 0);
  el("line", {x1: bx, y1: yTop, x2: bx, y2: yBot, class: "berth"}, svg);
  el("line", {x1: jx, y1: yTop, x2: jx, y2: yBot, class: "ground"}, svg);
  el("text", {x: jx - 52, y: yTop + 12}, svg, "jetty face");
  const [cx, cy] = P(f.coupler[0], f.coupler[1]);
  el("line", {x1: ox, y1: oy, x2: cx, y2: cy, class: "arm"}, svg);
  el("circle", {cx: ox, cy: oy, r: 5, class: "joint"}, svg);
  el("rect", {x: cx - 4, y: cy - 4, width: 8, height: 8, class: "coupler"}, svg);
  if (f.flange[0] !== null) {
    const [fx, fy] = P(f.flange[0], f.flange[1]);
    el("circle", {cx: fx, cy: fy, r: 6, class: "flange" + (f.estimate_healthy ? "" : " unhealthy")}, svg);
    const v = f.flange_velocity, speed = Math.hypot(v[0] || 0, v[1] || 0);
    if (speed > 0.01) {
      const [tx, ty] = P(f.flange[0] + 60 * v[0], f.flange[1] + 60 * v[1]);
      el("line", {x1: fx, y1: fy, x2: tx, y2: ty, class: "drift"}, svg);
      el("text", {x: tx > 240 ? tx - 4 : tx + 4, y: ty - 6, "text-anchor": tx > 240 ? "end" : "start"}, svg,
         `drift ${speed.toFixed(2)} m/s (1 min)`);
    }
  }
}

function bar(label, value, unit, lo, hi, normalLo, normalHi, digits = 1) {
  const box = document.createElement("div");
  const ok = value === null ? true : value >= normalLo && value <= normalHi;
  box.className = "bar" + (ok ? "" : " abnormal");
  const pos = (v) => `${100 * Math.min(1, Math.max(0, (v - lo) / (hi - lo)))}%`;
  const shown = value === null ? "none" : `${value.toFixed(digits)} ${unit}`;
  box.innerHTML = `<div class="label"><span></span><span class="value"></span></div>` +
    `<div class="track"><div class="normal"></div><div class="needle"></div></div>`;
  box.querySelector(".label span").textContent = label;
  box.querySelector(".value").textContent = shown;
  const n = box.querySelector(".normal");
  n.style.left = pos(normalLo);
  n.style.width = `calc(${pos(normalHi)} - ${pos(normalLo)})`;
  const needle = box.querySelector(".needle");
  if (value === null) { needle.hidden = true; } else { needle.style.left = `calc(${pos(value)} - 1px)`; }
  return box;
}

const DEG = 180 / Math.PI;

function drawBars(f) {
  const g = hmi.geo, box = $("bars");
  box.textContent = "";
  box.appendChild(bar("coupler to flange", f.distance, "m", 0, 20, 0, 20, 2));
  const ttl = f.time_to_limit;
  box.appendChild(bar("time to limit", ttl === null ? null : Math.min(ttl, 600), "s", 0, 600, g.sequence_time, 600, 0));
  const normal = {beta_max: g.limits.beta[1] - g.alarm_beta.first, slew_pos: g.slew.limit - g.slew.first,
                  slew_neg: g.slew.limit - g.slew.first};
  for (const face of g.faces) {
    const v = f.margins[face];
    box.appendChild(bar(`margin ${face}`, v === null ? null : v * DEG, "deg", 0, 180,
                        (normal[face] || 5 / DEG) * DEG, 180, 1));
    const t = face in f.time_to_faces ? f.time_to_faces[face] : null;   // none: not within the forecast's horizon
    const b = bar(`time to ${face}`, t, "s", 0, 120, g.sequence_time, 120, 0);
    b.classList.add("face-time");
    box.appendChild(b);
  }
}

function rows(tbody, data) {
  tbody.textContent = "";
  for (const [k, v] of data) {
    const tr = document.createElement("tr");
    const a = document.createElement("td"), b = document.createElement("td");
    a.textContent = k; b.textContent = v;
    tr.append(a, b); tbody.appendChild(tr);
  }
}

function drawTables(f) {
  const fmt = (v, d = 2) => (v === null ? "none" : v.toFixed(d));
  rows(document.querySelector("#flange tbody"), [
    ["position (m)", f.flange.map((v) => fmt(v)).join(", ")],
    ["velocity (m/s)", f.flange_velocity.map((v) => fmt(v, 3)).join(", ")],
    ["health", f.estimate_healthy ? "healthy" : "UNHEALTHY"],
    ["coupler (m)", f.coupler.map((v) => fmt(v)).join(", ")],
    ["cylinders (m)", f.cylinders.map((v) => fmt(v, 3)).join(", ")],
    ["ERS valves", f.ers_valves_closed ? "closed" : "open"],
    ["coupler", f.coupler_open ? "open" : "closed"]]);
  const bar_ = (v) => (v === null ? "not measured" : `${(v / 1e5).toFixed(1)} bar`);
  const p = f.pressures;
  rows(document.querySelector("#pressures tbody"), [
    ["inboard cylinder A / B", `${bar_(p[0])} / ${bar_(p[1])}`],
    ["outboard cylinder A / B", `${bar_(p[2])} / ${bar_(p[3])}`], ["supply", bar_(p[4])]]);
}

function drawAlarms(f) {
  // Rebuilt only when the list changes: rows rebuilt at every frame would swallow a click whose press and
  // release fall on two different buttons (found: an acknowledge lost that way in the browser test).
  const key = JSON.stringify([f.alarms.map((a) => [a.tag, a.state]), f.shelved.map((a) => [a.tag, a.state])]);
  if (key === hmi.alarmKey) { return; }
  hmi.alarmKey = key;
  const canAck = hmi.session.commands.includes("ack"), canShelve = hmi.session.commands.includes("shelve");
  const tbody = document.querySelector("#alarms tbody");
  tbody.textContent = "";
  for (const a of f.alarms) {
    const tr = document.createElement("tr");
    tr.className = `alarm p${a.priority} ${a.state.startsWith("returned") ? "rtn" : a.state}`;
    tr.dataset.tag = a.tag;
    tr.innerHTML = "<td class=prio><span></span></td><td class=time></td><td class=msg></td><td class=state></td><td class=act></td>";
    tr.querySelector(".prio span").textContent = a.priority_name;
    tr.querySelector(".time").textContent = `${a.raised_at.toFixed(1)} s`;
    tr.querySelector(".msg").textContent = a.message;
    tr.querySelector(".state").textContent = a.state;
    const act = tr.querySelector(".act");
    if (a.state !== "acknowledged") {
      const b = document.createElement("button");
      b.textContent = "Acknowledge"; b.className = "ackbtn"; b.disabled = !canAck;
      b.addEventListener("click", () => send("ack", {tag: a.tag}));
      act.appendChild(b);
    }
    const s = document.createElement("button");
    s.textContent = `Shelve ${SHELVE_S / 60} min`; s.className = "shelvebtn"; s.disabled = !canShelve;
    s.addEventListener("click", () => send("shelve", {tag: a.tag, seconds: SHELVE_S}));
    act.appendChild(s);
    tbody.appendChild(tr);
  }
  const sh = document.querySelector("#shelved tbody");
  sh.textContent = "";
  for (const a of f.shelved) {
    const tr = document.createElement("tr");
    tr.innerHTML = "<td class=msg></td><td class=until></td><td class=act></td>";
    tr.querySelector(".msg").textContent = `${a.tag}: ${a.message} (${a.state})`;
    tr.querySelector(".until").textContent = `until ${a.shelved_until.toFixed(0)} s`;
    const b = document.createElement("button");
    b.textContent = "Unshelve"; b.disabled = !canShelve;
    b.addEventListener("click", () => send("unshelve", {tag: a.tag}));
    tr.querySelector(".act").appendChild(b);
    sh.appendChild(tr);
  }
}

boot();
