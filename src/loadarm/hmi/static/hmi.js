// loadarm's operator screen: plain JS and SVG, nothing from outside. Frames come over one WebSocket (with a
// sequence number); commands go back on it, each with its own sequence number and the session's CSRF token,
// and the server's acknowledgement is shown. A watchdog greys the screen when frames stop.
"use strict";

const STALE_MS = 1000;          // no frame for this long: the view is greyed and says so
const JOG_EVERY_MS = 200;       // a held jog is renewed this often (the controller drops it after 0.5 s)
const SHELVE_S = 300;           // the shelving an operator asks for (the server allows up to 600 s)
const MODES = ["STORED", "APPROACH", "HOLD", "STANDOFF", "CONNECTED", "ALARM1", "ALARM2", "RELEASE",
               "RETURN", "DISCONNECT", "MANUAL", "ESTOP"];

const hmi = {session: null, geo: null, ws: null, lastFrameAt: 0, lastSeq: null, lastSeqAt: 0, frames: 0, cmdSeq: 0,
             history: [], seenAlarms: [], seenModes: [], modeArrivals: [], modeCycle: -1,
             pending: new Map(), acks: [], jog: null, jogTimer: null, frame: null, rate: 0, trend: [], page: "overview",
             rateCount: 0, rateSince: performance.now(),
             audio: {on: false, ctx: null, silenced: new Set(), playing: null, beeps: 0, next: 0}};
window.hmi = hmi;               // for the browser tests

const sessionPage = loginPage(hmi, {start, message: onMessage, beforeLogout: () => stopJog(), lost: () => {
  stopJog(false);
  $("link").textContent = "link to the controller lost: reconnecting";
}});

async function start(session) {          // logged in: common.js has shown the screen
  hmi.cmdSeq = Math.max(hmi.cmdSeq, session.last_seq || 0);   // a session's command numbers only increase
  $("title").textContent = `loadarm: ${session.name}`;
  document.title = `loadarm HMI: ${session.name}`;
  const g = await api("/api/geometry");
  hmi.geo = g.body;
  buildModes();
  for (const b of document.querySelectorAll("#controls button")) {
    const action = b.dataset.action || (b.dataset.jog ? "jog" : null);
    if (action) { b.disabled = !session.commands.includes(action); }
  }
  sessionPage.connect();
}

function onMessage(msg) {
  if (msg.type === "state") { onFrame(msg); }
  else if (msg.type === "trend") { onTrend(msg); }
  else if (msg.type === "ack") { onAck(msg); }
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
  $("replay-speed").blur();
});

function drawReplay(r) {
  $("replay-bar").hidden = false;
  const s = $("replay-slider");
  s.min = r.t0; s.max = r.t1;
  if (!hmi.dragging) { s.value = r.t; }
  $("replay-time").textContent = `${r.t.toFixed(1)} s of ${r.t0.toFixed(0)}-${r.t1.toFixed(0)} s` +
    (r.playing ? ` · playing ${r.speed}x` : " · paused") +
    (r.simulated ? " · simulated run: times of day from its start" : "");
  $("replay-play").textContent = r.playing ? "Pause" : "Play";
  // playing, the speed control shows the cursor's speed (found: it said 10 while the label said "playing 1x");
  // paused, it keeps the speed the operator chose for Play (found: reset to the last speed at the next frame)
  const sel = $("replay-speed"), want = String(r.speed);
  if (!r.playing) { $("replay-time").textContent += ` · Play plays at ${sel.value}x`; }
  else if (document.activeElement !== sel && sel.value !== want) {
    if (![...sel.options].some((o) => o.value === want)) { sel.add(new Option(`${want}x`, want)); }
    sel.value = want;
  }
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
  // what each command's acknowledgement said, with the controller's cycle when it was queued (the E-stop's
  // bound is held on it: the cycle after the next takes a command at the latest)
  hmi.acks.push({seq: msg.seq, action: p ? p.action : null, ok: msg.ok, cycle: msg.cycle ?? null});
  if (hmi.acks.length > 100) { hmi.acks.shift(); }
  // renewals, and a replay's cursor moves (its bar shows them): not news
  if (p && ["jog", "seek", "play", "pause"].includes(p.action) && msg.ok) { return; }
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
    ` · cycle ${f.seq} · t ${f.t.toFixed(1)} s` + (hmi.rate ? ` · ${hmi.rate.toFixed(0)} Hz` : "");   // none yet: not "0 Hz"
  document.body.dataset.mode = f.mode;
  if (f.replay) {
    drawReplay(f.replay);
    $("link").textContent = `replay · sample ${f.seq} · t ${f.t.toFixed(1)} s`;
  }
  for (const el of document.querySelectorAll("#modes span")) { el.classList.toggle("current", el.textContent === f.mode); }
  drawPrimary(f);
  drawAlarms(f);
  annunciate(f);
  if (hmi.page === "overview") { drawOverview(f); }
}

function drawOverview(f) {
  drawSide(f);
  drawTop(f);
  drawBars(f);
  drawTables(f);
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

// ------------------------------------------------------------------ pages
pageButtons(["overview", "trends", "journal"], (name) => {
  hmi.page = name;
  if (name === "overview" && hmi.frame) { drawOverview(hmi.frame); }
  if (name === "trends") { drawTrends(); }
  if (name === "journal") { loadJournal(); }
});

// ------------------------------------------------------------------ the primary state
function tile(id, text, cls) {
  const t = $(`tile-${id}`);
  t.querySelector(".v").textContent = text;
  t.className = "tile" + (t.id === "tile-ttl" ? " wide" : "") + (cls ? ` ${cls}` : "");
}

function drawPrimary(f) {
  const fc = f.forecast;
  const short = fc.state === "time" && f.time_to_limit < hmi.geo.sequence_time;
  tile("ttl", fc.text, fc.state === "none" || short ? "abnormal" : (fc.state === "off" ? "dim" : ""));
  // never cut (it wraps): the nearest face and the drift the forecast used (speed, direction); the prediction
  const face = fc.state === "time" ? `nearest: ${fc.face_words} · ` : "";
  const rule = fc.rule_words ? ` · raised by the ${fc.rule_words}` : "";
  // the mooring load monitoring (the prediction's second witness) after the prediction, marked when abnormal
  const pr = fc.prediction, detail = $("ttl-detail");
  if (fc.state === "off") {
    detail.replaceChildren();
  } else {
    const moorings = document.createElement("span");
    moorings.id = "moorings";
    moorings.textContent = pr.moorings;
    moorings.className = pr.moorings_abnormal ? "flag abnormal" : "flag";
    // why a claimed prediction is not used, marked when the ship is not the one it learned
    const why = document.createElement("span");
    why.id = "unused";
    why.textContent = pr.why ?? "";
    why.className = pr.why_abnormal ? "flag abnormal" : "flag";
    // a call for ESD-1 the prediction holds (ISA-18.2: suppressed by design, so shown), marked abnormal
    const held = document.createElement("span");
    held.id = "held";
    held.textContent = fc.held?.text ?? "";
    held.className = "flag abnormal";
    detail.replaceChildren(`${face}${fc.basis}\n${pr.text}`, ...(why.textContent ? ["; ", why] : []),
                           ...(pr.moorings ? ["; ", moorings] : []),
                           ...(held.textContent ? ["\n", held] : []), rule);
  }
  detail.title = detail.textContent;
  tile("esd", f.esd ? "ACTIVE" : "not active", f.esd ? "abnormal" : "dim");
  tile("ers", f.ers_valves_closed ? "CLOSED" : "open", f.ers_valves_closed && f.esd ? "" : (f.ers_valves_closed ? "abnormal" : ""));
  tile("coupler", f.coupler_open ? "OPEN" : (f.connected ? "on the flange" : "closed"), f.coupler_open ? "abnormal" : "");
  const estop = f.mode === "ESTOP";
  tile("estop", estop ? "ACTIVE" : "not active", estop ? "abnormal" : "dim");
  tile("estimate", f.estimate_healthy ? "healthy" : "UNHEALTHY", f.estimate_healthy ? "" : "abnormal");
}

// ------------------------------------------------------------------ drawing
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

// Labels never collide: each takes the first of its candidate places where its box meets no label placed
// before it and no drawn line it must keep clear of (the arm, the limits), inside the view; with no such
// place it is left out rather than drawn over something.
function boxHitsSegment(b, [x1, y1, x2, y2]) {
  const inside = (x, y) => x >= b.x && x <= b.x + b.width && y >= b.y && y <= b.y + b.height;
  if (inside(x1, y1) || inside(x2, y2)) { return true; }
  const edges = [[b.x, b.y, b.x + b.width, b.y], [b.x + b.width, b.y, b.x + b.width, b.y + b.height],
                 [b.x, b.y + b.height, b.x + b.width, b.y + b.height], [b.x, b.y, b.x, b.y + b.height]];
  return edges.some((e) => segmentsCross([x1, y1, x2, y2], e));
}

function segmentsCross([ax, ay, bx, by], [cx, cy, dx, dy]) {
  const o = (px, py, qx, qy, rx, ry) => Math.sign((qx - px) * (ry - py) - (qy - py) * (rx - px));
  return o(ax, ay, bx, by, cx, cy) !== o(ax, ay, bx, by, dx, dy) && o(cx, cy, dx, dy, ax, ay) !== o(cx, cy, dx, dy, bx, by);
}

function boxesMeet(a, b) {
  return a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;
}

function label(svg, text, candidates, scene) {
  const t = el("text", {class: "label"}, svg, text);
  for (const [x, y, anchor, at] of candidates) {
    t.setAttribute("x", x); t.setAttribute("y", y); t.setAttribute("text-anchor", anchor || "start");
    if (at !== undefined) { t.dataset.at = at; }
    const b = t.getBBox(), pad = {x: b.x - 2, y: b.y - 1, width: b.width + 4, height: b.height + 2};
    const inView = b.x >= 0 && b.y >= 0 && b.x + b.width <= 400 && b.y + b.height <= 300;
    if (inView && !scene.labels.some((o) => boxesMeet(o, pad)) && !scene.lines.some((s) => boxHitsSegment(pad, s))) {
      scene.labels.push(pad);
      return t;
    }
  }
  t.remove();
  return null;
}

function segments(points) {          // a polyline's points to its segments
  const out = [];
  for (let i = 1; i < points.length; i++) { out.push([...points[i - 1], ...points[i]]); }
  return out;
}

const ZONE_LEVEL = {2: 0, 3: 1, 4: 2};       // alarm level (ESD-1, second, release) to its band
const ZONE_PRIORITY = ["p3", "p2", "p1"];    // each band's alarm colour (the alarm's priority), when active

function drawSide(f) {
  const g = hmi.geo, svg = $("side");
  svg.textContent = "";
  const R = g.b + g.c;
  const P = fit(svg, -0.25 * R, 1.1 * R, Math.min(g.berth.y_low, 0) - 1, g.a + 0.9 * R);
  const rho = Math.hypot(f.coupler[0], f.coupler[1]);
  const pts = [[0, 0], [0, g.a], f.elbow, [rho, f.coupler[2]]].map(([x, y]) => P(x, y));
  const [gx0, gy] = P(-0.25 * R, 0), [gx1] = P(1.1 * R, 0);
  const [bx, by0] = P(g.berth.berthing_line, Math.min(g.berth.y_low, 0) - 1), [, by1] = P(g.berth.berthing_line, g.a);
  const scene = {labels: [], lines: [...segments(pts), [gx0, gy, gx1, gy], [bx, by0, bx, by1]]};
  el("line", {x1: gx0, y1: gy, x2: gx1, y2: gy, class: "ground"}, svg);
  el("line", {x1: bx, y1: by0, x2: bx, y2: by1, class: "berth"}, svg);
  const [ox] = P(0, g.a), px = P(1, g.a)[0] - ox;            // px per m
  let rOut = 0;
  g.zones.forEach((z, i) => {
    const r = 0.5 * (z.from_r + z.to_r), width = Math.max(2, (z.to_r - z.from_r) * px);
    const active = ZONE_LEVEL[f.level] === i;
    el("path", {d: arcPath(P, 0, g.a, r, ZONE_ARC[0], ZONE_ARC[1]),
                class: `zone zone${i}` + (active ? ` active ${ZONE_PRIORITY[i]}` : ""), "stroke-width": width}, svg);
    for (const edge of [r - width / 2 / px, r + width / 2 / px]) {       // a label keeps clear of the band
      scene.lines.push(...segments(arcPoints(P, g.a, edge)));
    }
    rOut = Math.max(rOut, r + width / 2 / px);
  });
  el("polyline", {points: pts.slice(0, 2).map((p) => p.join(",")).join(" "), class: "riser"}, svg);
  el("polyline", {points: pts.slice(1).map((p) => p.join(",")).join(" "), class: "arm"}, svg);
  for (const p of pts.slice(1, 3)) { el("circle", {cx: p[0], cy: p[1], r: 4, class: "joint"}, svg); }
  el("rect", {x: pts[3][0] - 4, y: pts[3][1] - 4, width: 8, height: 8, class: "coupler"}, svg);
  if (f.flange[0] !== null) {
    const [fx, fy] = P(Math.hypot(f.flange[0], f.flange[1]), f.flange[2]);
    el("circle", {cx: fx, cy: fy, r: 6, class: "flange" + (f.estimate_healthy ? "" : " unhealthy")}, svg);
    scene.labels.push({x: fx - 6, y: fy - 6, width: 12, height: 12});      // the flange itself stays clear
    label(svg, f.estimate_healthy ? "flange" : "flange (estimate unhealthy)",
          [[fx + 9, fy + 4], [fx - 9, fy + 4, "end"], [fx, fy + 18, "middle"], [fx, fy - 10, "middle"],
           [fx + 9, fy + 16], [fx - 9, fy - 8, "end"]], scene);
  }
  label(svg, "berthing line", [[bx + 3, by1], [bx - 3, by1, "end"], [bx + 3, by0 - 3], [bx - 3, by0 - 3, "end"],
                               [bx + 3, (by0 + by1) / 2], [bx - 3, (by0 + by1) / 2, "end"]], scene);
  label(svg, "jetty deck", [[gx0 + 2, gy + 12], [gx0 + 2, gy - 4], [gx1 - 2, gy + 12, "end"], [gx1 - 2, gy - 4, "end"]], scene);
  // each band's name outside the outermost band, a leader line to its own band (found: the names sat on the
  // bands, the release's red band through "ESD-1")
  g.zones.forEach((z) => {
    const r = 0.5 * (z.from_r + z.to_r), cand = [];
    for (const a of [0.25, 0.1, -0.05, 0.4, -0.2, 0.55, -0.35, 0.7, -0.5]) {
      const [lx, ly] = P((rOut + 6 / px) * Math.cos(a), g.a + (rOut + 6 / px) * Math.sin(a));
      cand.push([lx + 2, ly + 4, "start", a]);
    }
    const t = label(svg, z.name, cand, scene);
    if (t) {
      const a = Number(t.dataset.at), [x0, y0] = P(r * Math.cos(a), g.a + r * Math.sin(a));
      const [x1, y1] = [Number(t.getAttribute("x")) - 2, Number(t.getAttribute("y")) - 4];
      el("line", {x1: x0, y1: y0, x2: x1, y2: y1, class: "leader"}, svg);
      scene.lines.push([x0, y0, x1, y1]);
    }
  });
}

const ZONE_ARC = [-1.4, 0.9];        // the bands' arc in the side view, rad from the horizontal at the hinge

function arcPoints(P, cy, r, n = 24) {          // an arc of the bands as view points
  const out = [];
  for (let k = 0; k <= n; k++) {
    const a = ZONE_ARC[0] + (ZONE_ARC[1] - ZONE_ARC[0]) * k / n;
    out.push(P(r * Math.cos(a), cy + r * Math.sin(a)));
  }
  return out;
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
  const [, yTop] = P(0, 0.6 * R), [, yBot] = P(0, -0.6 * R);
  // the ship: the berth's hull at its moored position, moved as the flange estimate has moved
  const [dx, dy] = f.ship_offset || [0, 0];
  const hull = g.ship.outline.map(([x, y]) => P(x + dx, y + dy));
  el("polygon", {points: hull.map((p) => p.join(",")).join(" "), class: "ship"}, svg);
  const [cx, cy] = P(f.coupler[0], f.coupler[1]);
  const [bx] = P(g.berth.berthing_line, 0), [jx] = P(g.berth.jetty_face, 0);
  const scene = {labels: [], lines: [[ox, oy, cx, cy], [bx, yTop, bx, yBot], [jx, yTop, jx, yBot]]};
  for (const a of [g.slew.limit, -g.slew.limit]) {
    const [x, y] = P(R * Math.cos(a), R * Math.sin(a));
    el("line", {x1: ox, y1: oy, x2: x, y2: y, class: "slew-limit"}, svg);
    scene.lines.push([ox, oy, x, y]);
  }
  el("line", {x1: bx, y1: yTop, x2: bx, y2: yBot, class: "berth"}, svg);
  el("line", {x1: jx, y1: yTop, x2: jx, y2: yBot, class: "ground"}, svg);
  el("line", {x1: ox, y1: oy, x2: cx, y2: cy, class: "arm"}, svg);
  el("circle", {cx: ox, cy: oy, r: 5, class: "joint"}, svg);
  el("rect", {x: cx - 4, y: cy - 4, width: 8, height: 8, class: "coupler"}, svg);
  const pr = f.forecast.prediction;
  if (f.connected && pr.track.length) {           // the predicted track (mean) and its interval, grey: not an alarm
    for (const [x0, y0, x1, y1] of pr.band) {
      const [ax, ay] = P(x0, y1), [bx2, by2] = P(x1, y0);
      el("rect", {x: Math.min(ax, bx2), y: Math.min(ay, by2), width: Math.abs(bx2 - ax), height: Math.abs(by2 - ay),
                  class: "band"}, svg);
    }
    const pts = pr.track.map(([x, y]) => P(x, y));
    el("polyline", {points: pts.map((p) => p.join(",")).join(" "), class: "predicted"}, svg);
    scene.lines.push(...segments(pts));
  }
  let drift = null;
  const [fx0, fy0] = f.flange[0] === null ? [0, 0] : P(f.flange[0], f.flange[1]);
  const out = f.flange[0] !== null && !(fx0 >= 6 && fx0 <= 394 && fy0 >= 6 && fy0 <= 294);
  // the arrow: the drift the forecast extrapolates (the time to limit's detail says the same); none without a
  // drift fit (found in review: the flange's own motion, waves included, was drawn and named the drift)
  const fd = f.forecast.drift, rad = fd ? fd.direction_deg / DEG : 0;
  const v = fd ? [fd.speed * Math.cos(rad), fd.speed * Math.sin(rad)] : [0, 0];
  const speed = Math.hypot(v[0], v[1]), span = 60;       // the arrow's length, s
  if (out) {           // the ship has gone off the view (after a release): said at the edge, not drawn cut off
    drift = [`flange out of view (${Math.hypot(f.flange[0], f.flange[1]).toFixed(0)} m)` +
             (fd ? `, drift ${speed.toFixed(2)} m/s` : ""),
             Math.min(Math.max(fx0, 6), 394), Math.min(Math.max(fy0, 20), 294)];
  } else if (f.flange[0] !== null) {
    const [fx, fy] = [fx0, fy0];
    el("circle", {cx: fx, cy: fy, r: 6, class: "flange" + (f.estimate_healthy ? "" : " unhealthy")}, svg);
    scene.labels.push({x: fx - 6, y: fy - 6, width: 12, height: 12});      // the flange itself stays clear
    if (speed > 0.01) {
      // a minute of the drift, or less where that would leave the view (found: at 0.3 m/s the arrow and its
      // label were off the view's edge, the label left out)
      const [ex, ey] = P(f.flange[0] + span * v[0], f.flange[1] + span * v[1]);
      const k = Math.min(1, ...[[ex - fx, 30 - fx, 370 - fx], [ey - fy, 20 - fy, 280 - fy]].map(
        ([d, lo, hi]) => (d > 0 ? hi / d : (d < 0 ? lo / d : 1))).map((q) => Math.max(q, 0)));
      const [tx, ty] = [fx + k * (ex - fx), fy + k * (ey - fy)];
      el("line", {x1: fx, y1: fy, x2: tx, y2: ty, class: "drift"}, svg);
      scene.lines.push([fx, fy, tx, ty]);
      const shown = span * k === 60 ? "1 min" : `${(span * k).toFixed(0)} s`;
      drift = [`drift ${speed.toFixed(2)} m/s (${shown})`, tx, ty];
    }
  }
  if (drift) {
    const [text, tx, ty] = drift;
    label(svg, text, [[tx + 4, ty - 6], [tx - 4, ty - 6, "end"], [tx + 4, ty + 14], [tx - 4, ty + 14, "end"],
                      [tx, ty - 14, "middle"], [tx, ty + 22, "middle"], [tx + 10, ty - 18], [tx + 10, ty + 28],
                      [tx - 10, ty - 18, "end"], [tx - 10, ty + 28, "end"], [396, ty - 6, "end"], [396, ty + 14, "end"],
                      [396, 14, "end"], [396, 270, "end"]], scene);
  }
  label(svg, "jetty face", [[jx - 4, yTop + 12, "end"], [jx - 4, yBot - 4, "end"], [jx + 4, yTop + 12]], scene);
  label(svg, "berthing line", [[bx + 4, yTop + 12], [bx + 4, yBot - 4], [bx + 4, yTop + 26], [bx + 4, yBot - 18]], scene);
  const side = Math.max(...hull.map((p) => p[0]).filter((x) => x >= 0 && x <= 400).concat([0]));
  const near = Math.min(...hull.map((p) => p[0]));
  const sx = Math.max(near, 0) + 6;
  if (near < 400) {
    label(svg, `ship (${g.ship.length.toFixed(0)} x ${g.ship.beam.toFixed(1)} m)`,
          [[sx, yBot - 4], [sx, yTop + 12], [sx, yBot - 18], [sx, yTop + 26], [Math.min(side, 396), yBot - 4, "end"]], scene);
  }
  label(svg, "slew limit", (() => {
    const out = [];
    for (const a of [g.slew.limit, -g.slew.limit]) {
      for (const k of [0.55, 0.75, 0.35]) {
        const [x, y] = P(k * R * Math.cos(a), k * R * Math.sin(a));
        out.push([x + 4, y + (a > 0 ? -4 : 12)], [x - 4, y + (a > 0 ? -4 : 12), "end"]);
      }
    }
    return out;
  })(), scene);
}

function bar(label_, value, unit, lo, hi, normalLo, normalHi, digits = 1, none = "none") {
  const box = document.createElement("div");
  const ok = value === null ? true : value >= normalLo && value <= normalHi;
  box.className = "bar" + (ok ? "" : " abnormal");
  const pos = (v) => `${100 * Math.min(1, Math.max(0, (v - lo) / (hi - lo)))}%`;
  const shown = value === null ? none : `${value.toFixed(digits)} ${unit}`;
  box.innerHTML = `<div class="label"><span></span><span class="value"></span></div>` +
    `<div class="track"><div class="normal"></div><div class="needle"></div></div>`;
  box.querySelector(".label span").textContent = label_;
  box.querySelector(".label span").title = label_;
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
  const g = hmi.geo, box = $("bars"), fc = f.forecast;
  box.textContent = "";
  box.appendChild(bar("coupler to flange", f.distance, "m", 0, 20, 0, 20, 2));
  // no time: beyond the forecast's horizon ("> H s"), no forecast, or not connected: the forecast says which
  const none = fc.state === "time" ? `> ${(fc.horizon || g.horizon).toFixed(0)} s` : fc.text;
  const ttl = fc.state === "time" ? f.time_to_limit : null;
  box.appendChild(bar("time to limit", ttl, "s", 0, 120, g.sequence_time, 120, 1, fc.text));
  const normal = {beta_max: g.limits.beta[1] - g.alarm_beta.first, slew_pos: g.slew.limit - g.slew.first,
                  slew_neg: g.slew.limit - g.slew.first};
  for (const face of g.faces) {
    const v = f.margins[face], words = g.face_words[face];
    box.appendChild(bar(`margin: ${words}`, v === null ? null : v * DEG, "deg", 0, 180,
                        (normal[face] || 5 / DEG) * DEG, 180, 1));
    // none: not within the forecast's horizon; no forecast (or not connected): never a time left from before
    const t = fc.state === "time" && face in f.time_to_faces ? f.time_to_faces[face] : null;
    const b = bar(`time to it`, t, "s", 0, 120, g.sequence_time, 120, 0, none);
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
    ["cylinders (m)", f.cylinders.map((v) => fmt(v, 3)).join(", ")]]);
  // a replay's log keeps no pressure: said so, not "not measured" (the live run measured them)
  const bar_ = (v) => (v === null ? (f.replay ? "not in the log" : "not measured") : `${(v / 1e5).toFixed(1)} bar`);
  const p = f.pressures;
  if (f.replay && p.every((v) => v === null)) {
    rows(document.querySelector("#pressures tbody"), [["pressures", "not in the log"]]);
    return;
  }
  rows(document.querySelector("#pressures tbody"), [
    ["inboard cylinder A / B", `${bar_(p[0])} / ${bar_(p[1])}`],
    ["outboard cylinder A / B", `${bar_(p[2])} / ${bar_(p[3])}`], ["supply", bar_(p[4])]]);
}

function drawAlarms(f) {
  // Rebuilt only when the list changes: rows rebuilt at every frame would swallow a click whose press and
  // release fall on two different buttons (found: an acknowledge lost that way in the browser test).
  const key = JSON.stringify([f.alarms.map((a) => [a.tag, a.state, a.clock]), f.shelved.map((a) => [a.tag, a.state])]);
  if (key === hmi.alarmKey) { return; }
  hmi.alarmKey = key;
  const canAck = hmi.session.commands.includes("ack"), canShelve = hmi.session.commands.includes("shelve");
  const tbody = document.querySelector("#alarms tbody");
  tbody.textContent = "";
  for (const a of f.alarms) {
    // the time of day it was raised (the date too when not today); the run time when the clock is not known
    const tr = alarmRow(a, a.clock || `${a.raised_at.toFixed(1)} s`);
    tr.querySelector(".time").title = `run time ${a.raised_at.toFixed(1)} s`;
    const act = document.createElement("td");
    act.className = "act";
    tr.appendChild(act);
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
    tr.className = `shelved p${a.priority}`;
    tr.dataset.tag = a.tag;
    tr.innerHTML = "<td class=msg></td><td class=until></td><td class=act></td>";
    tr.querySelector(".msg").textContent = `${a.priority_name}: ${a.message} (${a.state})`;
    // until a time of day, as the list's times (the run time when the clock is not known)
    tr.querySelector(".until").textContent = `until ${a.until_clock || `${a.shelved_until.toFixed(0)} s`}`;
    const b = document.createElement("button");
    b.textContent = "Unshelve"; b.disabled = !canShelve;
    b.addEventListener("click", () => send("unshelve", {tag: a.tag}));
    tr.querySelector(".act").appendChild(b);
    sh.appendChild(tr);
  }
  $("shelved-box").hidden = f.shelved.length === 0;
}

// ------------------------------------------------------------------ audible annunciation (WebAudio, no file)
// Each priority its own pattern: [tone Hz, beeps, repeat every s]. It sounds while an unacknowledged alarm
// is not silenced; Silence quiets those sounding now, and a new alarm sounds again (ISA-18.2).
const SOUND = {1: [880, 3, 1.0], 2: [660, 2, 2.0], 3: [520, 1, 3.0], 4: [440, 1, 5.0]};

$("sound-on").addEventListener("change", () => {
  const au = hmi.audio;
  au.on = $("sound-on").checked;
  if (au.on && !au.ctx) { au.ctx = new AudioContext(); }       // created on the click: a user gesture
  if (au.on && au.ctx.state === "suspended") { au.ctx.resume(); }
  au.next = 0;
  if (hmi.frame) { annunciate(hmi.frame); }
});
$("silence").addEventListener("click", () => {
  const au = hmi.audio;
  for (const a of (hmi.frame ? hmi.frame.alarms : [])) { au.silenced.add(`${a.tag}@${a.raised_at}`); }
  au.playing = null;
  if (hmi.frame) { annunciate(hmi.frame); }
});

function annunciate(f) {
  const au = hmi.audio;
  const loud = f.alarms.filter((a) => a.state !== "acknowledged" && !au.silenced.has(`${a.tag}@${a.raised_at}`));
  const top = loud.length ? Math.min(...loud.map((a) => a.priority)) : null;
  au.playing = au.on ? top : null;
  $("sound-state").textContent = !au.on ? "sound off" :
    (top === null ? "quiet" : `sounding: ${loud.find((a) => a.priority === top).priority_name}`);
  if (au.playing === null || !au.ctx) { return; }
  const now = au.ctx.currentTime;
  if (now < au.next) { return; }
  const [hz, n, every] = SOUND[top];
  for (let i = 0; i < n; i++) { beep(au.ctx, hz, now + 0.2 * i, 0.12); }
  au.beeps += n;
  au.next = now + every;
}

function beep(ctx, hz, at, length) {
  const osc = ctx.createOscillator(), gain = ctx.createGain();
  osc.type = "square";
  osc.frequency.value = hz;
  gain.gain.setValueAtTime(0.0, at);
  gain.gain.linearRampToValueAtTime(0.15, at + 0.01);
  gain.gain.setValueAtTime(0.15, at + length - 0.02);
  gain.gain.linearRampToValueAtTime(0.0, at + length);
  osc.connect(gain).connect(ctx.destination);
  osc.start(at);
  osc.stop(at + length + 0.01);
}

// ------------------------------------------------------------------ trends (the last 10 minutes)
const TREND_S = 600;

function onTrend(msg) {
  hmi.trend = msg.reset ? msg.points.slice() : hmi.trend.concat(msg.points);
  const last = hmi.trend.length ? hmi.trend[hmi.trend.length - 1].t : 0;
  while (hmi.trend.length && hmi.trend[0].t <= last - TREND_S) { hmi.trend.shift(); }
  if (hmi.page === "trends") { drawTrends(); }
}

function chart(svg, series, lo, hi, limits = []) {
  svg.textContent = "";
  const pts = hmi.trend, t1 = pts.length ? pts[pts.length - 1].t : 0, t0 = t1 - TREND_S;
  const X = (t) => 600 * (t - t0) / TREND_S, Y = (v) => 150 - 140 * (Math.min(Math.max(v, lo), hi) - lo) / (hi - lo);
  for (let k = 0; k <= 10; k++) { el("line", {x1: 60 * k, y1: 10, x2: 60 * k, y2: 150, class: "grid"}, svg); }
  for (const v of [lo, (lo + hi) / 2, hi]) { el("line", {x1: 0, y1: Y(v), x2: 600, y2: Y(v), class: "grid"}, svg); }
  for (const v of limits) { el("line", {x1: 0, y1: Y(v), x2: 600, y2: Y(v), class: "limit"}, svg); }
  series.forEach(([get, cls]) => {
    let d = "", pen = false;
    for (const p of pts) {
      const v = get(p);
      if (v === null || v === undefined) { pen = false; continue; }
      d += `${pen ? "L" : "M"} ${X(p.t).toFixed(1)} ${Y(v).toFixed(1)} `;
      pen = true;
    }
    if (d) { el("path", {d, class: `trace ${cls}`}, svg); }
  });
}

// Each trend's scale and its latest values, in its caption (found in review: the charts had no value on them);
// a value that is not there is said as the trend's own words (found: "time to limit none", read as safe)
function legend(svg, lo, hi, unit, digits, now) {
  const cap = svg.parentElement.querySelector("figcaption");
  let span = cap.querySelector(".legend");
  if (!span) { span = document.createElement("span"); span.className = "legend"; cap.appendChild(span); }
  const last = hmi.trend.length ? hmi.trend[hmi.trend.length - 1] : null;
  const values = last ? now.map(([name, get, absent]) => {
    const v = get(last);
    return `${name} ${v === null || v === undefined ? absent() : v.toFixed(digits)}`;
  }).join(", ") : "no value yet";
  span.textContent = `scale ${lo.toFixed(digits)} to ${hi.toFixed(digits)} ${unit}, grid in the middle · now: ${values}`;
}

function drawTrends() {
  const g = hmi.geo, pts = hmi.trend;
  const deg = (v) => (v === null || v === undefined ? null : v * DEG);
  const angles = [["beta", (p) => deg(p.beta)], ["margin", (p) => deg(p.margin)]];
  chart($("trend-angles"), [[angles[0][1], ""], [angles[1][1], "second"]], 0, 180,
        [g.alarm_beta.first * DEG, g.limits.beta[1] * DEG]);
  legend($("trend-angles"), 0, 180, "deg", 1, angles.map(([name, get]) => [name, get, () => "not measured"]));
  chart($("trend-ttl"), [[(p) => p.ttl, ""]], 0, g.horizon, [g.sequence_time]);
  // no time: beyond the horizon, no forecast, or not connected: as the time to limit's tile says it
  const noTime = () => (hmi.frame && hmi.frame.forecast ? hmi.frame.forecast.text : "not connected");
  legend($("trend-ttl"), 0, g.horizon, "s", 0, [["time to limit", (p) => p.ttl, noTime]]);
  const top = Math.max(0.3, ...pts.map((p) => Math.max(p.drift || 0, p.speed || 0)));
  chart($("trend-drift"), [[(p) => p.drift, ""], [(p) => p.speed, "second thin"]], 0, top, [g.design_drift.speed]);
  legend($("trend-drift"), 0, top, "m/s", 2, [["drift", (p) => p.drift, () => "no fit"],
                                               ["flange speed", (p) => p.speed, () => "no estimate"]]);
  const t1 = pts.length ? pts[pts.length - 1].t : 0;
  $("trend-note").textContent = `run time ${Math.max(0, t1 - TREND_S).toFixed(0)}-${t1.toFixed(0)} s, a grid ` +
    `line a minute. Beta solid, the nearest face's margin dashed; the forecast's drift solid, the flange's ` +
    `speed with the waves dashed; dotted: the first alarm angle and beta's limit, the time the emergency ` +
    `sequence needs, the berth's design drift (${g.design_drift.speed} m/s). A gap in the time to limit: beyond ` +
    `the forecast's ${g.horizon.toFixed(0)} s horizon, or not connected; in the drift: no drift fit.`;
}

// ------------------------------------------------------------------ the alarm journal (the event log)
const loadJournal = journalPage(hmi, () => hmi.page === "journal");

sessionPage.boot();
