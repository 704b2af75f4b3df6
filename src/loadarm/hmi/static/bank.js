// loadarm's bank screen (issue 31): plain JS and SVG, nothing from outside. Frames come over one WebSocket; the
// page sends one command, the acknowledgement of the alarms (the bank's world has no controller); its journal page
// lists the service's notes. Every arm is drawn from its capsules (the segments
// and radii the clearance is computed on): a top view (y along the jetty across, x towards the ship up) and a side
// view from the ship (y across, z up), on one scale each, fixed at the first frame. The nearest clash is grey
// while it keeps the required clearance, emphasised below it (ISA-101).
"use strict";

const STALE_MS = 1000;          // no frame for this long: the view is greyed and says so
const W = 400, H = 300, PAD = 8, LABEL_ROOM = 18;   // the views' viewBox and the room kept for the arms' names
const bank = {session: null, geo: null, ws: null, frames: 0, frame: null, lastFrameAt: 0, views: null, cmdSeq: 0};
window.hmi = bank;              // for the browser tests (the same name as the single arm's screen)

const sessionPage = loginPage(bank, {start, message: (msg) => {
                                       if (msg.type === "state") { onFrame(msg); } else if (msg.type === "ack") { onAck(msg); } },
                                     lost: () => { $("link").textContent = "link to the server lost: reconnecting"; }});

function acknowledge() {             // the operator acknowledges every alarm (the server checks the role again)
  if (!bank.ws || bank.ws.readyState !== WebSocket.OPEN) { $("ack-result").textContent = "not connected"; return; }
  bank.cmdSeq += 1;
  bank.ws.send(JSON.stringify({type: "cmd", seq: bank.cmdSeq, action: "ack", csrf: bank.session.csrf}));
}

function onAck(msg) {
  if (typeof msg.last_seq === "number") { bank.cmdSeq = Math.max(bank.cmdSeq, msg.last_seq); }
  $("ack-result").textContent = msg.message;
}

$("ack-loads").addEventListener("click", acknowledge);

// the pages: the bank, and the journal of the service's notes (alarms risen and cleared, acknowledgements, refusals)
bank.page = "bank";
const loadJournal = journalPage(bank, () => bank.page === "journal");
pageButtons(["bank", "journal"], (name) => {
  bank.page = name;
  if (name === "journal") { loadJournal(); }
});

async function start(session) {          // logged in: common.js has shown the screen
  bank.cmdSeq = session.last_seq || 0;
  $("title").textContent = `loadarm bank: ${session.name}`;
  document.title = `loadarm bank: ${session.name}`;
  bank.geo = (await api("/api/bank")).body;
  sessionPage.connect();
}

setInterval(() => {
  const stale = bank.session !== null && performance.now() - bank.lastFrameAt > STALE_MS;
  $("stale-banner").hidden = !stale;
  document.body.classList.toggle("stale", stale);
}, 250);

function onFrame(f) {
  bank.frame = f;
  bank.frames += 1;
  bank.lastFrameAt = performance.now();
  $("link").textContent = "live";
  if (!bank.views) { bank.views = scales(f); }
  drawTiles(f);
  drawTables(f);
  drawAlarms(f);
  drawTop(f);
  drawSide(f);
}

// ------------------------------------------------------------------ scales, fixed at the first frame

function extent(points) {
  const lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
  for (const [a, b, r] of points) {
    lo[0] = Math.min(lo[0], a - r); hi[0] = Math.max(hi[0], a + r);
    lo[1] = Math.min(lo[1], b - r); hi[1] = Math.max(hi[1], b + r);
  }
  return {lo, hi};
}

function fit(box, margin) {        // across (horizontal, m) and up (vertical, m) into the viewBox, bottom room kept
  const across = box.hi[0] - box.lo[0] + 2 * margin, up = box.hi[1] - box.lo[1] + 2 * margin;
  const k = Math.min((W - 2 * PAD) / across, (H - 2 * PAD - LABEL_ROOM) / up);
  const u0 = (W - k * across) / 2 - k * (box.lo[0] - margin);
  const v0 = PAD + (H - 2 * PAD - LABEL_ROOM - k * up) / 2 + k * (box.hi[1] + margin);
  return {k, u: (a) => u0 + k * a, v: (b) => v0 - k * b, bottom: H - PAD};
}

function scales(f) {
  const top = [], side = [];
  f.arms.forEach((arm, i) => {
    const radii = bank.geo.arms[i].radii;
    arm.capsules.forEach((part, j) => {
      for (const p of part) { top.push([p[1], p[0], radii[j]]); side.push([p[1], p[2], radii[j]]); }
    });
  });
  return {top: fit(extent(top), 1.5), side: fit(extent(side), 1.0)};
}

// ------------------------------------------------------------------ drawing

function boxesMeet(a, b) {
  return a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;
}

function segmentHitsBox(s, b) {     // a thick segment against a box, sampled along its length
  const n = Math.max(2, Math.ceil(Math.hypot(s[2] - s[0], s[3] - s[1])));
  for (let i = 0; i <= n; i++) {
    const x = s[0] + (s[2] - s[0]) * i / n, y = s[1] + (s[3] - s[1]) * i / n;
    if (x >= b.x - s[4] && x <= b.x + b.width + s[4] && y >= b.y - s[4] && y <= b.y + b.height + s[4]) { return true; }
  }
  return false;
}

function label(svg, text, candidates, scene, cls) {   // the first candidate that meets nothing drawn, else none
  const t = el("text", {class: cls || "label"}, svg, text);
  for (const [x, y, anchor] of candidates) {
    t.setAttribute("x", x); t.setAttribute("y", y); t.setAttribute("text-anchor", anchor || "middle");
    const b = t.getBBox();
    const pad = {x: b.x - 1, y: b.y - 1, width: b.width + 2, height: b.height + 2};
    const inView = pad.x >= 0 && pad.y >= 0 && pad.x + pad.width <= W && pad.y + pad.height <= H;
    if (inView && !scene.labels.some((o) => boxesMeet(o, pad)) && !scene.lines.some((s) => segmentHitsBox(s, pad))) {
      scene.labels.push(pad);
      return t;
    }
  }
  t.remove();
  return null;
}

function line(svg, scene, a, b, attrs) {
  const e = el("line", Object.assign({x1: a[0], y1: a[1], x2: b[0], y2: b[1]}, attrs), svg);
  const half = parseFloat(attrs["stroke-width"] || getComputedStyle(e).strokeWidth) / 2;
  scene.lines.push([a[0], a[1], b[0], b[1], half]);
  return e;
}

function circle(svg, scene, c, r, attrs) {
  el("circle", Object.assign({cx: c[0], cy: c[1], r}, attrs), svg);
  scene.lines.push([c[0], c[1], c[0], c[1], r]);
}

const PART_CLASS = ["pipe riser", "pipe", "pipe", "swivel", "pipe cw", "pipe cw"];

function drawArm(svg, scene, view, arm, radii, project) {    // each capsule to scale, tagged with its arm and part
  arm.capsules.forEach((part, j) => {
    const a = project(part[0]), b = project(part[1]);
    const r = Math.max(radii[j] * view.k, 1);
    const tag = {"data-arm": arm.name, "data-part": j};
    if (j === 3 || Math.hypot(a[0] - b[0], a[1] - b[1]) < 0.5) {       // the swivel, or a capsule seen end on
      circle(svg, scene, a, r, Object.assign({class: j === 3 ? "swivel" : `${PART_CLASS[j]} end-on`}, tag));
      return;
    }
    line(svg, scene, a, b, Object.assign({class: PART_CLASS[j], "stroke-width": 2 * r}, tag));
  });
}

function drawClash(svg, scene, f, project) {
  const c = f.clash, cls = c.abnormal ? "clash abnormal" : "clash";
  const a = project(c.points[0]), b = project(c.points[1]);
  line(svg, scene, a, b, {class: cls, "data-arms": c.arms.join("/")});
  for (const p of [a, b]) { el("circle", {cx: p[0], cy: p[1], r: 2.5, class: `clash-end${c.abnormal ? " abnormal" : ""}`}, svg); }
  return [a, b];
}

function clashLabel(svg, scene, f, ends) {
  const mx = (ends[0][0] + ends[1][0]) / 2, my = (ends[0][1] + ends[1][1]) / 2;
  const text = `${f.clash.clearance.toFixed(2)} m`;
  label(svg, text, [[mx, my - 12], [mx, my + 18], [mx + 8, my - 24, "start"], [mx - 8, my - 24, "end"],
                    [mx, my - 36], [mx, my + 30], [mx, my - 48], [mx, my + 42]], scene, "clash-label");
}

function drawTop(f) {
  const svg = $("bank-top"), view = bank.views.top, g = bank.geo;
  svg.replaceChildren();
  const scene = {labels: [], lines: []};
  const project = (p) => [view.u(p[1]), view.v(p[0])];
  const dx = f.manifold[0] - g.manifold[0], dy = f.manifold[1] - g.manifold[1];
  const pts = g.ship.outline.map(([x, y]) => `${view.u(y + dy).toFixed(1)},${view.v(x + dx).toFixed(1)}`).join(" ");
  el("polygon", {points: pts, class: "ship"}, svg);
  const bl = view.v(g.berthing_line);
  line(svg, scene, [0, bl], [W, bl], {class: "berth"});
  f.arms.forEach((arm, i) => drawArm(svg, scene, view, arm, g.arms[i].radii, project));
  f.arms.forEach((arm) => {
    const p = project(arm.flange);
    el("rect", {x: p[0] - 2.5, y: p[1] - 2.5, width: 5, height: 5, class: "bank-flange"}, svg);
  });
  const ends = drawClash(svg, scene, f, project);
  f.arms.forEach((arm, i) => {
    const u = view.u(g.arms[i].base[1]);
    label(svg, arm.name, [[u, view.bottom], [u, view.bottom - 12]], scene, "arm-name");
  });
  f.arms.forEach((arm, i) => {
    const p = project(arm.flange), name = g.arms[i].flange;
    label(svg, name, [[p[0], p[1] - 14], [p[0], p[1] - 26], [p[0] + 10, p[1] - 8, "start"]], scene);
  });
  clashLabel(svg, scene, f, ends);
  const sx = view.u(g.manifold[1] + dy);
  label(svg, `ship (${g.ship.length.toFixed(0)} x ${g.ship.beam.toFixed(1)} m)`,
        [[sx, PAD + 10], [sx, PAD + 22], [PAD, PAD + 10, "start"]], scene);
  label(svg, "berthing line", [[W - PAD, bl - 4, "end"], [W - PAD, bl + 12, "end"], [PAD, bl - 4, "start"],
                               [PAD, bl + 12, "start"]], scene);
}

function drawSide(f) {
  const svg = $("bank-side"), view = bank.views.side, g = bank.geo;
  svg.replaceChildren();
  const scene = {labels: [], lines: []};
  const project = (p) => [view.u(p[1]), view.v(p[2])];
  const deck = view.v(0);
  line(svg, scene, [0, deck], [W, deck], {class: "deck"});
  f.arms.forEach((arm, i) => drawArm(svg, scene, view, arm, g.arms[i].radii, project));
  f.arms.forEach((arm) => {
    const p = project(arm.flange);
    el("rect", {x: p[0] - 2.5, y: p[1] - 2.5, width: 5, height: 5, class: "bank-flange"}, svg);
  });
  const ends = drawClash(svg, scene, f, project);
  f.arms.forEach((arm, i) => {
    const u = view.u(g.arms[i].base[1]);
    label(svg, arm.name, [[u, deck + 14], [u, view.bottom]], scene, "arm-name");
  });
  clashLabel(svg, scene, f, ends);
  label(svg, "jetty deck", [[PAD, deck + 14, "start"], [W - PAD, deck + 14, "end"], [PAD, deck - 4, "start"]], scene);
}

// ------------------------------------------------------------------ tiles and tables

function drawTiles(f) {
  const c = f.clash;
  $("clash-value").textContent = `${c.arms[0]} / ${c.arms[1]}: ${c.clearance.toFixed(2)} m`;
  $("clash-value").classList.toggle("abnormal", c.abnormal);
  $("tile-clash").classList.toggle("abnormal", c.abnormal);
  $("clash-detail").textContent = (c.abnormal ? `below the required ${f.required.toFixed(2)} m: ` : "")
    + `${c.parts[0]} of ${c.arms[0]} to ${c.parts[1]} of ${c.arms[1]}`;
  const worst = f.arms.reduce((a, b) => (b.stage > a.stage ? b : a));
  $("stage-value").textContent = worst.stage > 0 ? worst.stage_text : "none";
  $("stage-detail").textContent = f.arms.filter((a) => a.stage > 0 && a.stage === worst.stage).map((a) => a.name).join(", ");
  $("tile-stage").classList.toggle("abnormal", worst.stage > 0);
  const fc = f.forecast;
  $("ttl-value").textContent = fc.time === null ? "none forecast" : `${fc.time.toFixed(0)} s`;
  $("ttl-detail").textContent = fc.time === null ? "" : `${fc.words} (${fc.arms.join(" / ")})`;
  $("tile-ttl").classList.toggle("abnormal", worst.stage > 0);
  $("required-value").textContent = `${f.required.toFixed(2)} m`;
  $("ship-value").textContent = f.ship_deg.map((v) => v.toFixed(2)).join(" / ");
  $("time-value").textContent = `${f.t.toFixed(1)} s`;
}

function row(body, cells, abnormal) {
  const tr = document.createElement("tr");
  body.appendChild(tr);
  tr.className = abnormal ? "abnormal" : "";
  for (const c of cells) {
    const td = document.createElement("td");
    td.textContent = c;
    tr.appendChild(td);
  }
}

// The manifold load: its share of the allowable and which load (the label's first word), prefixed by the alarm's
// ISA-18.2 state while it is not normal (UNACK, ACK, RTN: returned to normal, unacknowledged).
const LOAD_STATE = {unacknowledged: "UNACK", acknowledged: "ACK"};
function loadText(l) {
  if (l.utilisation === null) return "-";
  const share = `${(100 * l.utilisation).toFixed(0)} % ${l.governing.split(" ")[0]}`;
  if (l.state === "normal") return share;
  return `${LOAD_STATE[l.state] || "RTN"} ${share}`;
}

// ISA-18.2's list, as the arm's screen: each arm's stage alarms and manifold-load alarm not normal, the most urgent
// first, then the oldest; the priority's colour with its shape and name, an unacknowledged one's indicator blinking
function drawAlarms(f) {
  const key = JSON.stringify(f.alarms.map((a) => [a.tag, a.state]));
  if (key === bank.alarmKey) { return; }
  bank.alarmKey = key;
  const tbody = document.querySelector("#alarms tbody");
  tbody.replaceChildren();
  for (const a of f.alarms) {
    tbody.appendChild(alarmRow(a, a.raised_at === null ? "-" : `${a.raised_at.toFixed(1)} s`));
  }
}

function drawTables(f) {
  const unacked = f.alarms.some((a) => a.state === "unacknowledged" || a.state.startsWith("returned"));
  $("ack-loads").hidden = !(unacked && bank.session.commands.includes("ack"));
  const arms = document.querySelector("#arms tbody"), margins = document.querySelector("#margins tbody");
  arms.replaceChildren();
  margins.replaceChildren();
  const g = bank.geo;
  for (const a of f.arms) {
    const close = a.nearest.clearance === null || a.nearest.clearance < f.required;
    row(arms, [a.name, a.stage > 0 ? a.stage_text : "none", a.nearest.arm,
               a.nearest.clearance === null ? "-" : `${a.nearest.clearance.toFixed(2)} m`, loadText(a.load)],
        close || a.stage > 0 || a.load.active || a.load.state !== "normal");
    const face = a.face.margin_deg === null ? "out of reach" : `${a.face.margin_deg.toFixed(1)} deg`;
    const sw = a.swivel.margin_deg === null ? "-" : `${a.swivel.margin_deg.toFixed(1)} deg`;
    row(margins, [a.name, a.ttl === null ? "none" : `${a.ttl.toFixed(0)} s`, `${face}: ${g.face_words[a.face.name]}`, `${sw}: ${g.swivel_words[a.swivel.name]}`],
        a.face.margin_deg === null || a.face.margin_deg < 0 || (a.swivel.margin_deg !== null && a.swivel.margin_deg < 0));
  }
}

sessionPage.boot();
