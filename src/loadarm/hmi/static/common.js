// What loadarm's two screens share (the operator's, hmi.js, and the bank's, bank.js), loaded before the page's own
// script: the API call, the login and logout, the session's WebSocket and its reconnect, the SVG element maker
// a line of the ISA-18.2 alarm list and the journal's page. Plain JS, nothing from outside.
"use strict";

const SVGNS = "http://www.w3.org/2000/svg";
const $ = (id) => document.getElementById(id);

async function api(path, options = {}) {
  const r = await fetch(path, Object.assign({credentials: "same-origin"}, options));
  let body = null;
  try { body = await r.json(); } catch (e) { body = null; }
  return {status: r.status, body};
}

function showLogin(message) {
  $("screen").hidden = true;
  $("login").hidden = false;
  $("login-message").textContent = message;
  $("login-user").focus();
}

// The page's login, logout and WebSocket. `state` is the page's own object (its `session` and `ws` are set here);
// `page` says what the page does: start(session) once logged in (the screen shown, the user named), message(msg)
// for each WebSocket message, lost() when the link drops (before the reconnect), and beforeLogout() if anything
// must stop first. Returns boot() (the session, if any, else the login) and connect() (the WebSocket, reconnected
// while the session lasts).
function loginPage(state, page) {
  async function enter(session) {
    state.session = session;
    $("login").hidden = true;
    $("screen").hidden = false;
    $("who").textContent = `${session.user} (${session.role})`;
    await page.start(session);
  }

  async function boot() {
    const r = await api("/api/session");
    if (r.status === 200 && r.body.user) { await enter(r.body); } else { showLogin(""); }
  }

  $("login-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const r = await api("/api/login", {method: "POST", headers: {"Content-Type": "application/json"},
      body: JSON.stringify({user: $("login-user").value, password: $("login-password").value})});
    $("login-password").value = "";
    if (r.status === 200) { await enter(r.body); }
    else { showLogin(r.body && r.body.detail ? r.body.detail : "login failed"); }
  });

  $("logout").addEventListener("click", async () => {
    if (page.beforeLogout) { page.beforeLogout(); }
    await api("/api/logout", {method: "POST", headers: {"X-CSRF-Token": state.session.csrf}});
    if (state.ws) { state.ws.onclose = null; state.ws.close(); }
    state.session = null;
    showLogin("logged out");
  });

  function connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(`${proto}//${location.host}/ws`);
    state.ws = ws;
    ws.onmessage = (ev) => page.message(JSON.parse(ev.data));
    ws.onclose = () => {
      page.lost();
      setTimeout(async () => {
        if (!state.session) { return; }
        const r = await api("/api/session");
        if (r.status === 200 && r.body.user) { connect(); } else { showLogin("session ended: log in again"); }
      }, 1000);
    };
  }

  return {boot, connect};
}

function el(name, attrs, parent, text) {     // an SVG element, appended to `parent` if given
  const e = document.createElementNS(SVGNS, name);
  for (const [k, v] of Object.entries(attrs)) { e.setAttribute(k, v); }
  if (text !== undefined) { e.textContent = text; }
  if (parent) { parent.appendChild(e); }
  return e;
}

// One line of an alarm list (ISA-18.2, both screens): its priority (colour, shape and name, the CSS's), the time it
// rose, its words and its state (an unacknowledged one's indicator blinking); `time` is the text of its time.
function alarmRow(a, time) {
  const tr = document.createElement("tr");
  tr.className = `alarm p${a.priority} ${a.state.startsWith("returned") ? "rtn unacknowledged" : a.state}`;
  tr.dataset.tag = a.tag;
  tr.innerHTML = "<td class=prio><span></span></td><td class=time></td><td class=msg></td>" +
                 "<td class=state><span class=ind></span><span class=text></span></td>";
  tr.querySelector(".prio span").textContent = a.priority_name;
  tr.querySelector(".time").textContent = time;
  tr.querySelector(".msg").textContent = a.message;
  tr.querySelector(".state .text").textContent = a.state;
  return tr;
}

// The journal's page (both screens): the server's /api/journal, newest first, filtered by kind and by words;
// reloaded as the filter changes and every 2 s while `shown()`. The rows keep the alarm list's priority classes.
function journalPage(state, shown) {
  let timer = null;
  async function load() {
    const q = new URLSearchParams({kind: $("journal-kind").value, q: $("journal-search").value});
    const r = await api(`/api/journal?${q}`);
    if (r.status !== 200) { return; }
    const tbody = document.querySelector("#journal tbody");
    tbody.textContent = "";
    for (const e of r.body.entries) {
      const tr = document.createElement("tr");
      tr.className = "entry" + (e.priority ? ` alarm p${e.priority}` : "");
      tr.dataset.kind = e.kind;
      tr.innerHTML = "<td class=time></td><td class=run></td><td class=kind></td><td class=prio><span></span></td><td class=msg></td>";
      tr.querySelector(".time").textContent = e.clock;
      tr.querySelector(".run").textContent = e.t === null ? "" : `${e.t.toFixed(1)} s`;
      tr.querySelector(".kind").textContent = e.kind.replace("_", " ");
      if (e.priority_name) { tr.querySelector(".prio span").textContent = e.priority_name; }
      tr.querySelector(".msg").textContent = e.text;
      tbody.appendChild(tr);
    }
    $("journal-count").textContent = `${r.body.entries.length} of ${r.body.total} shown, newest first`;
    state.journal = r.body;
  }
  $("journal-kind").addEventListener("change", () => load());
  $("journal-search").addEventListener("input", () => {
    clearTimeout(timer);
    timer = setTimeout(load, 200);
  });
  setInterval(() => { if (shown() && !$("screen").hidden) { load(); } }, 2000);
  return load;
}

// The pages of a screen: the header's #pages buttons show one `page-NAME` at a time; `onShow(name)` after.
function pageButtons(names, onShow) {
  function show(name) {
    for (const b of document.querySelectorAll("#pages button")) { b.classList.toggle("current", b.dataset.page === name); }
    for (const p of names) { $(`page-${p}`).hidden = p !== name; }
    onShow(name);
  }
  for (const b of document.querySelectorAll("#pages button")) { b.addEventListener("click", () => show(b.dataset.page)); }
  return show;
}
