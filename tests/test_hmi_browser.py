"""The operator's screen in a real browser (issue 15): Debian's Chromium driven by Playwright against
``loadarm serve``'s HMI on an ephemeral loopback port, over the real guidance service (the drift-off scenario,
kinematic plant). Skipped with the reason when no Chromium is installed (`apt-get install chromium`); CI
installs it (.ci/run). All are in the slow suite (`make test SLOW=1`, CI): Chromium's start alone costs 13 s of
`make test`'s two minutes on two cores."""

from __future__ import annotations

import math
import re
import time

import pytest

from loadarm.opcua.security import Role, StateDir
from loadarm.testing.browser import CHROMIUM_HINT, find_chromium, log_in, wait_for

SCENARIO = "examples/scenarios/driftoff.toml"

pytestmark = pytest.mark.skipif(find_chromium() is None, reason=CHROMIUM_HINT)


@pytest.fixture(scope="module")
def state(tmp_path_factory):
    st = StateDir(tmp_path_factory.mktemp("hmi") / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    st.users().add("victor", Role.VIEWER, "pw-victor")
    return st


class Screen:
    """The guidance service (its own thread) and the HMI server (uvicorn in its own) over the drift-off."""

    def __init__(self, state, *, scripted=False, speedup=1.0):
        from contextlib import ExitStack

        from loadarm.testing.browser import scenario_screen

        self._stack = ExitStack()
        self.service, self.server = self._stack.enter_context(
            scenario_screen(SCENARIO, state.path, speedup=speedup, scripted=scripted, plant="kinematic",
                            name="drift-off"))
        self.loop, self.url = self.service.loop, self.server.url

    def close(self):
        self._stack.close()


@pytest.fixture
def screen(state):
    made = []

    def make(**kw):
        s = Screen(state, **kw)
        made.append(s)
        return s

    yield make
    for s in made:
        s.close()


@pytest.fixture
def page(browser):
    ctx = browser.new_context(viewport={"width": 1400, "height": 900})
    pg = ctx.new_page()
    pg.errors, pg.requests = [], []
    pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: pg.errors.append(str(e)))
    pg.on("request", lambda r: pg.requests.append(r.url))
    yield pg
    ctx.close()


@pytest.mark.slow           # 13 s: Chromium's start (make test's budget; CI runs it)
def test_the_page_loads_with_no_console_error_and_no_request_outside_and_updates_at_10_hz(screen, page):
    s = screen()
    log_in(page, s.url, "alice", "pw-alice")
    wait_for(page, "hmi.frames >= 30", what="30 frames")
    hist = page.evaluate("hmi.history.slice(-25).map(h => [h.seq, h.at])")
    rate = (len(hist) - 1) / ((hist[-1][1] - hist[0][1]) / 1000)
    assert rate >= 10, rate                              # measured here: 19-20 Hz (FRAME_RATE 20)
    assert all(b[0] > a[0] for a, b in zip(hist, hist[1:]))
    assert page.errors == []
    outside = [u for u in page.requests if not (u.startswith(s.url) or u.startswith("ws://127.0.0.1")
                                                 or u.startswith("data:"))]
    assert outside == [], outside
    assert page.inner_text("#who") == "alice (operator)" and page.is_visible("#estop")


def _until(pred, what, timeout=5.0):
    """The controller takes a request at its next cycle (the screen's acknowledgement says it was queued)."""
    t0 = time.monotonic()
    while not pred():
        assert time.monotonic() - t0 < timeout, f"timed out waiting for {what}"
        time.sleep(0.02)


def _logged(screen, user, action, tag=None):
    """Wait until the controller's log has ``user``'s operator ``action`` (on alarm ``tag``)."""
    def found():
        return any(e[2] == "operator" and e[4].get("user") == user and e[4].get("action") == action
                   and (tag is None or e[4].get("tag") == tag) for e in list(screen.loop.events))

    _until(found, f"{user}'s {action} in the log")


def _coupler_z(page):
    return page.evaluate("hmi.frame.coupler[2]")


@pytest.mark.slow
def test_the_jog_pad_moves_the_coupler_and_the_dead_man_stops_it(screen, page):
    """Held, the z+ button (and the PageUp key) raises the coupler; released, it stops within the next
    updates (the page sends a stop; the controller would drop the jog after 0.5 s anyway)."""
    s = screen()
    log_in(page, s.url, "alice", "pw-alice")
    z0 = _coupler_z(page)
    btn = page.locator(".jogbtn[data-jog='0,0,1']")
    btn.hover()
    page.mouse.down()
    time.sleep(1.0)
    z1 = _coupler_z(page)
    page.mouse.up()
    time.sleep(0.3)
    z2 = _coupler_z(page)
    time.sleep(0.4)
    z3 = _coupler_z(page)
    assert z1 - z0 > 0.03, (z0, z1)                      # 0.15 m/s asked; the joint rate limits give ~0.07
    assert abs(z3 - z2) < 1e-3, (z2, z3)
    page.keyboard.down("PageUp")
    time.sleep(0.8)
    z4 = _coupler_z(page)
    page.keyboard.up("PageUp")
    time.sleep(0.3)
    z5 = _coupler_z(page)
    time.sleep(0.4)
    assert z4 - z3 > 0.03 and abs(_coupler_z(page) - z5) < 1e-3
    ops = [e[4] for e in s.loop.events if e[2] == "operator" and "action" in e[4]]
    assert {o["user"] for o in ops} == {"alice"} and [o["action"] for o in ops].count("jog") == 2   # held: once


@pytest.mark.slow           # 3 s (make test's budget; CI runs it)
def test_e_stop_stops_the_arm_within_one_update(screen, page):
    """The coupler jogging, one click on E-STOP: every frame of the cycle after the next from the one published
    when the E-stop was queued (the acknowledgement names it; the cycle under way then may finish without it)
    shows ESTOP, and the coupler stands still from then on.

    Held on the controller's cycles, not on frames after the click: on a loaded machine more than one frame
    can arrive between the click and the server's reading of it (found in CI: two MANUAL frames, the coupler
    already still on the second, the suite taking 35 min).
    """
    s = screen()
    log_in(page, s.url, "alice", "pw-alice")
    page.keyboard.down("PageUp")
    time.sleep(1.0)
    page.click("#estop")
    wait_for(page, "hmi.frame.mode === 'ESTOP'", timeout=3.0, what="ESTOP on the screen")
    wait_for(page, "hmi.acks.some(a => a.action === 'estop')", timeout=3.0, what="the E-stop's acknowledgement")
    page.keyboard.up("PageUp")
    time.sleep(0.5)
    queued = page.evaluate("hmi.acks.filter(a => a.action === 'estop')[0]")
    assert queued["ok"] and isinstance(queued["cycle"], int), queued
    hist = page.evaluate("hmi.history.map(h => [h.seq, h.mode, h.coupler[2]])")
    moving = [(q, m, z) for q, m, z in hist if q <= queued["cycle"]]
    assert moving and moving[-1][1] == "MANUAL", moving[-3:]     # jogging when it was queued
    stopped = [(q, m, z) for q, m, z in hist if q >= queued["cycle"] + 2]
    assert len(stopped) >= 5 and {m for _, m, _ in stopped} == {"ESTOP"}, stopped[:5]
    zs = [z for _, _, z in stopped]
    assert max(zs) - min(zs) < 1e-3, zs[:5]
    assert page.evaluate("hmi.frame.mode") == "ESTOP"          # the key's release (a stop) does not clear it
    _logged(s, "alice", "estop")


@pytest.mark.slow
def test_a_viewer_sees_everything_and_can_press_only_esd_1(screen, page):
    s = screen()
    log_in(page, s.url, "victor", "pw-victor")
    enabled = page.evaluate("[...document.querySelectorAll('#controls button')].filter(b => !b.disabled)"
                            ".map(b => b.id || b.textContent)")
    assert enabled == ["esd"], enabled
    page.evaluate("send('estop')")                      # forced past the disabled button: the server refuses
    wait_for(page, "document.getElementById('ack').className === 'refused'", what="the refusal")
    assert "needs the operator role" in page.inner_text("#ack")
    time.sleep(0.2)
    assert page.evaluate("hmi.frame.mode") != "ESTOP"
    page.click("#esd")
    wait_for(page, "document.getElementById('ack').textContent.includes('esd sent')", what="esd acknowledged")
    _logged(s, "victor", "esd")


@pytest.mark.slow
def test_a_stale_controller_or_a_lost_server_greys_the_view_and_says_so(screen, page):
    s = screen()
    log_in(page, s.url, "alice", "pw-alice")
    assert not page.evaluate("document.body.classList.contains('stale')")
    s.service.stop()                                    # the controller stops cycling; the server still sends
    wait_for(page, "document.body.classList.contains('stale')", timeout=3.0, what="the greying")
    assert "the controller has not cycled" in page.inner_text("#stale-banner")
    s.server.stop()                                     # and now the server is gone too
    wait_for(page, "document.getElementById('stale-banner').textContent.includes('no frame from the server')",
             timeout=3.0)
    assert "reconnecting" in page.inner_text("#link")


ORDER = ("STORED", "APPROACH", "STANDOFF", "CONNECTED", "ALARM1", "ALARM2", "RELEASE", "RETURN")


def _in_order(modes):
    """The modes the screen showed come in the sequence's order, from the connection through ESD-1 and the
    release to the return. ALARM2 may be skipped: the release lead counts the ERS valves at their worst until
    they confirm (issue 25), so a break-out seen late raises the second alarm and the release in one cycle
    (found in CI: the stock drift-off now goes ALARM1 -> RELEASE)."""
    idx = [ORDER.index(m) for m in modes]
    assert idx == sorted(set(idx)), modes
    assert {"CONNECTED", "ALARM1", "RELEASE", "RETURN"} <= set(modes), modes


@pytest.mark.slow
def test_the_drift_off_on_the_screen_alarms_in_order_acknowledged_and_a_screenshot_of_each_mode(
        screen, page, tmp_path):
    """The scripted drift-off at 8x: the screen shows the modes in the run's order and the alarms ESD-1,
    second and release in that order; the operator acknowledges the release alarm from the list (found: the
    list rebuilt at every frame lost that click); a screenshot of each mode polled is saved (make docs takes
    those of docs/hmi.md)."""
    from loadarm.testing.browser import tour

    s = screen(scripted=True, speedup=8.0)
    got = tour(page, s.url, "alice", "pw-alice", tmp_path)
    _in_order(got["modes"])
    assert [a for a in got["alarms"] if a in ("ESD1", "SECOND", "RELEASE")] == ["ESD1", "SECOND", "RELEASE"]
    assert len(got["shots"]) >= 4 and all(p.stat().st_size > 10_000 for p in got["shots"])
    assert page.evaluate("hmi.frame.alarms.find(a => a.tag === 'RELEASE').state").endswith("unacknowledged")
    page.locator("tr.alarm[data-tag='RELEASE'] .ackbtn").click()
    # acknowledged: kept in the list while active, gone if it had returned to normal meanwhile
    wait_for(page, "(hmi.frame.alarms.find(a => a.tag === 'RELEASE') || {state: 'acknowledged'}).state"
                   " === 'acknowledged'", what="RELEASE acknowledged")
    _logged(s, "alice", "ack", tag="RELEASE")
    assert page.errors == []


@pytest.mark.slow
def test_the_replay_s_time_slider_moves_the_screen_through_the_logged_run(state, page, tmp_path):
    """``serve --replay``'s screen over the drift-off's event log: the replay bar shows, every command is
    disabled, and moving the slider into the release shows it with its alarms as logged."""
    from loadarm.eventlog import EventLog
    from loadarm.hmi.app import HmiServer, create_app
    from loadarm.hmi.replay import ReplayService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCENARIO)
    with EventLog(tmp_path / "events.db", run="r") as log:
        res = run_scenario(sc, model, log=log, plant="kinematic")
    # a whole second inside the release, before the return (found: a fixed 238 s fell in RETURN once the lead
    # counted the ERS valves' timeout and the release came earlier)
    t_rel, t_ret = res.first("alarm", "RELEASE"), res.first("mode", "-> RETURN")
    t = math.ceil(t_rel + 1.0)
    assert t + 1.0 < t_ret, (t_rel, t_ret)
    with EventLog.open_existing(tmp_path / "events.db") as log:
        service = ReplayService(log.query(run="r"), model)
    server = HmiServer(create_app(service, state.path, model, name="replay"), "127.0.0.1", 0)
    server.start()
    try:
        log_in(page, server.url, "alice", "pw-alice")
        assert page.is_visible("#replay-bar")
        assert page.evaluate("[...document.querySelectorAll('#controls button')].every(b => b.disabled)")
        page.evaluate(f"const s = document.getElementById('replay-slider'); s.value = {t}; "
                      "s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'))")
        wait_for(page, f"hmi.frame.t >= {t} && hmi.frame.t < {t + 1}", what=f"the frame at {t} s")
        assert page.evaluate("hmi.frame.mode") == "RELEASE"
        assert page.evaluate("hmi.frame.alarms.map(a => a.tag)") == ["RELEASE", "SECOND", "ESD1", "PRE_ALARM"]
        assert not page.evaluate("document.body.classList.contains('stale')") and page.errors == []
    finally:
        server.stop()


@pytest.mark.slow
def test_a_manual_ers_from_the_screen_asks_for_a_confirmation_and_releases_only_after_the_valves(screen, page):
    """Connected (the scripted drift-off at 8x, before its drift): the ERS button opens a confirmation; Cancel
    sends nothing more; Confirm releases the coupler. On every frame the screen showed, the coupler was open
    only with the ERS valves confirmed closed."""
    s = screen(scripted=True, speedup=8.0)
    log_in(page, s.url, "alice", "pw-alice")
    wait_for(page, "hmi.frame.mode === 'CONNECTED'", timeout=60.0, what="the connection")
    page.click("#ers")
    assert page.is_visible("#ers-dialog")
    page.click("#ers-cancel")
    time.sleep(0.3)
    assert page.evaluate("hmi.frame.mode") == "CONNECTED"
    page.click("#ers")
    page.click("#ers-confirm")
    wait_for(page, "['ALARM1', 'RELEASE', 'RETURN'].includes(hmi.frame.mode)", timeout=10.0, what="the release")
    wait_for(page, "hmi.frame.coupler_open || hmi.frame.mode === 'RETURN'", timeout=30.0, what="the coupler open")
    hist = page.evaluate("hmi.history.map(h => [h.open, h.valves])")
    assert all(valves for open_, valves in hist if open_)
    _logged(s, "alice", "ers_confirm")
    assert page.errors == []


@pytest.mark.slow
def test_a_new_operator_approaches_connects_and_sees_the_drift_off_from_the_buttons(screen, page):
    """The issue's user (at 8x): the drift-off without its script; the operator presses Start approach, waits
    for the standoff, presses Connect, and sees ESD-1, the second alarm and the release arrive, in order,
    ending in RETURN."""
    s = screen(speedup=8.0)
    log_in(page, s.url, "alice", "pw-alice")
    page.click("button[data-action='start']")
    wait_for(page, "hmi.frame.mode === 'STANDOFF'", timeout=60.0, what="the standoff")
    page.click("button[data-action='connect']")
    wait_for(page, "hmi.frame.mode === 'CONNECTED'", timeout=10.0, what="the connection")
    wait_for(page, "hmi.frame.mode === 'RETURN'", timeout=60.0, what="the release and the return")
    modes = page.evaluate("hmi.seenModes")
    _in_order(modes)
    assert [a for a in page.evaluate("hmi.seenAlarms") if a in ("ESD1", "SECOND", "RELEASE")] == [
        "ESD1", "SECOND", "RELEASE"]
    assert page.errors == []


# --------------------------------------------------------------------------- issue 29: the screen that fits

SIZES = ((1920, 1080), (1366, 768))
#: The primary state: always inside the window, never below the fold (issue 29, item 1).
PRIMARY = ("#modes span.current", "#tile-ttl", "#tile-esd", "#tile-ers", "#tile-coupler", "#tile-estop", "#estop",
           "#alarm-panel", "tr.alarm")


def _replay_screen(state, db, scenario, seed=None):
    """A scenario run (kinematic plant; ``seed``: the scenario's own when None) logged to ``db``, and ``serve
    --replay``'s screen on it, started: the server and the run's result."""
    from loadarm.eventlog import EventLog
    from loadarm.hmi.app import HmiServer, create_app
    from loadarm.hmi.replay import ReplayService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(scenario)
    if seed is not None:
        sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": seed})})
    with EventLog(db, run="r") as log:
        res = run_scenario(sc, model, log=log, plant="kinematic")
    with EventLog.open_existing(db) as log:
        service = ReplayService(log.query(run="r"), model)
    server = HmiServer(create_app(service, state.path, model, name="replay"), "127.0.0.1", 0)
    server.start()
    return server, res


@pytest.fixture(scope="module")
def replay_server(state, tmp_path_factory):
    """The drift-off (kinematic plant) logged, and ``serve --replay``'s screen on it; the release's time."""
    server, res = _replay_screen(state, tmp_path_factory.mktemp("replay29") / "events.db", SCENARIO)
    yield {"url": server.url, "release": res.first("alarm", "RELEASE"), "connect": res.first("mode", "-> CONNECTED")}
    server.stop()


def _seek(page, t):
    page.evaluate(f"control('pause'); control('seek', {{t: {t}}})")
    wait_for(page, f"hmi.frame.t === {t}", what=f"the frame at {t} s")
    time.sleep(0.15)                                    # the frame drawn


def _sized(browser, w, h):
    ctx = browser.new_context(viewport={"width": w, "height": h})
    pg = ctx.new_page()
    pg.errors = []
    pg.on("pageerror", lambda e: pg.errors.append(str(e)))
    pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
    return ctx, pg


def _outside(page, selectors):
    """The primary elements whose box is not wholly inside the window (or that are missing)."""
    return page.evaluate("""(sels) => sels.flatMap((s) => {
        const els = [...document.querySelectorAll(s)];
        if (!els.length) { return [s + ': missing']; }
        return els.flatMap((e) => { const r = e.getBoundingClientRect();
          return r.width > 0 && r.height > 0 && r.left >= 0 && r.top >= 0 && r.right <= innerWidth
            && r.bottom <= innerHeight ? [] : [`${s}: ${JSON.stringify(r)}`]; }); })""", list(selectors))


@pytest.mark.slow
@pytest.mark.parametrize("w, h", SIZES)
def test_the_primary_state_fits_without_scrolling(browser, replay_server, w, h):
    """Issue 29 item 1: at a 1920x1080 console and a 1366x768 laptop, with the release's four alarms in the
    list, the mode, the time to limit, ESD-1, the ERS valves, the coupler, the E-stop (state and button) and
    every active alarm's row lie inside the window, and the page does not scroll."""
    ctx, page = _sized(browser, w, h)
    try:
        log_in(page, replay_server["url"], "alice", "pw-alice")
        _seek(page, 60)                                   # the approach: not connected, no detail to the time
        row = page.evaluate("document.getElementById('primary').getBoundingClientRect().height")
        _seek(page, math.ceil(replay_server["release"] + 1.0))
        assert page.evaluate("hmi.frame.alarms.length") == 4
        if w >= 1920:           # the tiles' row keeps its height as the arm connects (its two lines kept)
            assert page.evaluate("document.getElementById('primary').getBoundingClientRect().height") == row
        assert _outside(page, PRIMARY) == []
        assert page.evaluate("document.scrollingElement.scrollHeight <= innerHeight"
                             " && document.scrollingElement.scrollWidth <= innerWidth")
        # nothing of it cut: the forecast's detail whole, with the drift's speed and direction (item 2)
        assert page.evaluate(_CUT) == []
        detail = page.inner_text("#ttl-detail")
        assert re.search(r"\d\.\d\d m/s .*\(-?\d+ deg\)", detail), detail
        # and every alarm the controller can raise, all at once, in view (found: four rows fitted, the list
        # scrolled from the fifth)
        from loadarm.vocab import ANNUNCIATED

        assert page.evaluate(_ALL_ALARMS, list(ANNUNCIATED)) == [len(ANNUNCIATED), 0, True]
        assert page.errors == []
    finally:
        ctx.close()


#: Text the primary state shows that is cut off: wider or taller than its box (an ellipsis, or text running
#: over the next tile: found in review, "on the flang" into the E-stop tile on a tablet, and the forecast's drift
#: direction cut at 1366x768).
_CUT = """() => [...document.querySelectorAll('#primary .tile .v, #primary .tile .d, #primary .tile .k, #modes span')]
  .filter((e) => e.scrollWidth > e.clientWidth + 1 || e.scrollHeight > e.clientHeight + 1
          || e.getBoundingClientRect().right > e.closest('.tile, #modes').getBoundingClientRect().right + 1)
  .map((e) => `${e.id || e.className}: ${e.textContent}`)"""

#: Every alarm the controller annunciates, active at once, drawn into the list (the next frame redraws it): the
#: rows' boxes measured before that.
_ALL_ALARMS = """(tags) => {
  const f = JSON.parse(JSON.stringify(hmi.frame));
  f.alarms = tags.map((tag, i) => ({tag, message: `alarm ${tag} with a message as long as the longest we have`,
    priority: 1 + (i % 4), priority_name: ['critical', 'high', 'medium', 'low'][i % 4], state: 'unacknowledged',
    raised_at: 10 + i, shelved_until: null, raised_wall: null, clock: '14:03:27'}));
  hmi.alarmKey = null;
  drawAlarms(f);
  const rows = [...document.querySelectorAll('tr.alarm')];
  return [rows.length, rows.filter((e) => { const r = e.getBoundingClientRect();
    return !(r.top >= 0 && r.bottom <= innerHeight && r.left >= 0 && r.right <= innerWidth); }).length,
    document.scrollingElement.scrollHeight <= innerHeight];
}"""


_OVERLAPS = """() => {
  // every text box of the two views against every other, every drawn line (sampled along its length, widened
  // by half its stroke: the arm, the riser, the deck, the berthing line, the alarm bands, the slew limits, the
  // drift, the predicted track; leaders only against the labels they do not name) and every joint and flange
  const hits = [];
  for (const id of ['side', 'top']) {
    const svg = document.getElementById(id);
    const texts = [...svg.querySelectorAll('text')].map((t) => [t.textContent, t.getBBox()]);
    const near = (b, x, y, d) => x >= b.x - d && x <= b.x + b.width + d && y >= b.y - d && y <= b.y + b.height + d;
    texts.forEach(([a, b], i) => {
      texts.slice(i + 1).forEach(([c, d]) => { if (boxesMeet(b, d)) { hits.push(`${id}: ${a} / ${c}`); } });
      for (const g of svg.querySelectorAll('line, polyline, path.zone')) {
        if (g.closest('marker') || (g.classList.contains('leader') && near(b, +g.getAttribute('x2'),
                                                                          +g.getAttribute('y2'), 3))) { continue; }
        const half = parseFloat(getComputedStyle(g).strokeWidth) / 2, n = g.getTotalLength();
        for (let s = 0; s <= n; s += 1) {
          const p = g.getPointAtLength(s);
          if (near(b, p.x, p.y, half)) { hits.push(`${id}: ${a} / ${g.getAttribute('class')}`); break; }
        }
      }
      for (const g of svg.querySelectorAll('circle')) {
        if (boxesMeet(b, g.getBBox())) { hits.push(`${id}: ${a} / ${g.getAttribute('class')}`); }
      }
    });
  }
  return hits;
}"""

#: The labels each view must show (none left out for want of room): the side view's, the top view's.
_SIDE = {"berthing line", "jetty deck", "ESD-1", "second alarm", "release"}
_TOP = {"jetty face", "berthing line", "slew limit"}


def _labels(page, view):
    return set(page.evaluate(f"[...document.querySelectorAll('#{view} text')].map((e) => e.textContent)"))


@pytest.mark.slow
@pytest.mark.parametrize("w, h", SIZES)
def test_no_label_collides_with_another_or_the_arm(browser, replay_server, w, h):
    """Issue 29 item 4: through the drift-off (stored, approach, connected, the drift, ESD-1, the release, the
    return), no text box of the side or top view meets another, any drawn line (the arm, the alarm bands, the
    limits, the drift...) or a joint; and none is left out: in every state each view has its labels, the flange's
    and the drift's when there are, the ship's (drawn from the berth's hull). Found in review: the bands' names sat
    on the bands (the release's red band through "ESD-1"); the old check looked at the arm only."""
    ctx, page = _sized(browser, w, h)
    try:
        log_in(page, replay_server["url"], "alice", "pw-alice")
        rel = math.ceil(replay_server["release"])
        for t in (0, 60, math.ceil(replay_server["connect"] + 2), 205, rel - 1, rel + 1, rel + 8, 260, 320):
            _seek(page, t)
            assert page.evaluate(_OVERLAPS) == [], t
            side, top = _labels(page, "side"), _labels(page, "top")
            assert _SIDE <= side and _TOP <= top, (t, side, top)
            assert any(x.startswith("ship (278 x 43.4 m)") for x in top), (t, top)
            if page.evaluate("hmi.frame.flange[0] !== null"):
                assert "flange" in side, (t, side)
            # the forecast's drift beside its arrow (or at the edge); without a drift fit no arrow, never the
            # flange's own motion (waves included) called the drift
            drift = page.evaluate("hmi.frame.forecast.drift && hmi.frame.forecast.drift.speed")
            if drift is not None and drift > 0.01:
                assert any(f"drift {drift:.2f} m/s" in x for x in top), (t, top)
            else:
                assert not any("drift" in x for x in top) and not page.evaluate(
                    "document.querySelectorAll('#top line.drift').length"), (t, top)
        assert page.evaluate("document.querySelectorAll('#top polygon.ship').length") == 1
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.slow
def test_the_screen_says_what_the_forecast_says_in_the_operator_s_words(browser, replay_server):
    """Issue 29 items 2, 3, 4: connected before the drift, the time to limit is a time or "> H s" (H the
    forecast's own horizon), never "none", with the drift it used; in the release the alarm list times are
    times of day, the priorities never blink (only the state's indicator does), and no face is named by its
    code anywhere on the page."""
    from loadarm.vocab import FACES

    ctx, page = _sized(browser, 1920, 1080)
    try:
        log_in(page, replay_server["url"], "alice", "pw-alice")
        _seek(page, 150)
        ttl = page.inner_text("#ttl-value")
        horizon = page.evaluate("hmi.frame.forecast.horizon")
        assert re.fullmatch(r"\d+\.\d s", ttl) or ttl == f"> {horizon:.0f} s", ttl
        assert "drift" in page.inner_text("#ttl-detail") and "none" not in page.inner_text("#values")
        # no forecast is a state of its own: the tile inverted, and every time in the bars says so
        got = page.evaluate("""() => { const f = JSON.parse(JSON.stringify(hmi.frame));
            f.forecast = Object.assign(f.forecast, {state: 'none', text: 'NO FORECAST: no healthy estimate'});
            f.time_to_limit = null; drawPrimary(f); drawBars(f);
            return [document.getElementById('tile-ttl').className, document.getElementById('ttl-value').textContent,
                    [...document.querySelectorAll('#bars .bar .value')].map((e) => e.textContent)]; }""")
        assert got[0] == "tile wide abnormal" and got[1] == "NO FORECAST: no healthy estimate", got
        assert got[2].count("NO FORECAST: no healthy estimate") == 7, got          # the time to limit, 6 faces
        _seek(page, math.ceil(replay_server["release"] + 1.0))
        times = page.evaluate("[...document.querySelectorAll('tr.alarm td.time')].map((e) => e.textContent)")
        assert times and all(re.fullmatch(r"(\d{4}-\d\d-\d\d )?\d\d:\d\d:\d\d", x) for x in times), times
        blink = page.evaluate("""() => [...document.querySelectorAll('tr.alarm.unacknowledged')].map((tr) => [
            tr.querySelector('td.prio').getAnimations({subtree: true}).length,
            tr.querySelector('td.state .ind').getAnimations().length])""")
        assert blink and all(p == 0 and s == 1 for p, s in blink), blink
        shown = page.inner_text("body")
        assert not [f for f in FACES if f in shown], shown
        # a replay's log keeps no pressure: said so, once (found: "not measured / not measured" on every row)
        assert page.inner_text("#pressures").split() == ["pressures", "not", "in", "the", "log"]
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.slow
def test_trends_journal_and_the_replay_s_speed(browser, replay_server):
    """Issue 29 items 5, 6: the trends page draws the last 10 minutes (beta, the margin, the time to limit, the
    drift speed) from the frames' points, the journal lists the alarms from the log and its filter and search
    narrow it, and the replay's speed control shows the speed its label says it plays at."""
    ctx, page = _sized(browser, 1366, 768)
    try:
        log_in(page, replay_server["url"], "alice", "pw-alice")
        assert page.input_value("#replay-speed") == "1" and "playing 1x" in page.inner_text("#replay-time")
        page.select_option("#replay-speed", "4")
        wait_for(page, "document.getElementById('replay-time').textContent.includes('playing 4x')",
                 what="playing 4x")
        # paused, the speed chosen stays for Play, and says so (found in review: the next frame reset it to the
        # last speed, and Play played at 4x under a control that had said 10x)
        page.click("#replay-play")
        wait_for(page, "document.getElementById('replay-time').textContent.includes('paused')", what="paused")
        page.select_option("#replay-speed", "10")
        time.sleep(0.6)                                   # a dozen frames
        assert page.input_value("#replay-speed") == "10" and "Play plays at 10x" in page.inner_text("#replay-time")
        page.click("#replay-play")
        wait_for(page, "document.getElementById('replay-time').textContent.includes('playing 10x')",
                 what="playing 10x")
        assert page.input_value("#replay-speed") == "10" and page.evaluate("hmi.frame.replay.speed") == 10
        rel = math.ceil(replay_server["release"] + 1.0)
        _seek(page, rel)
        page.click("#pages button[data-page='trends']")
        wait_for(page, f"hmi.trend.length > 0 && hmi.trend[hmi.trend.length - 1].t === {rel}")
        assert page.evaluate("hmi.trend.length") == rel + 1                  # 1 Hz from 0 s: within 10 minutes
        for svg in ("trend-angles", "trend-ttl", "trend-drift"):
            assert page.evaluate(f"document.querySelectorAll('#{svg} path.trace').length") >= 1, svg
        # each with its scale and its latest values (found in review: no value anywhere on the charts), and the
        # drift is the forecast's, the flange's speed with the waves beside it (found: that speed was the drift)
        caps = page.evaluate("[...document.querySelectorAll('#page-trends figcaption')].map((e) => e.textContent)")
        assert all(re.search(r"scale [\d.]+ to [\d.]+ .*now: ", c) for c in caps), caps
        last = page.evaluate("hmi.trend[hmi.trend.length - 1]")
        assert f"drift {last['drift']:.2f}, flange speed {last['speed']:.2f}" in caps[2], (caps[2], last)
        assert page.evaluate("document.querySelectorAll('#trend-drift path.trace').length") == 2
        # no time to limit is said as the forecast says it, never "none" (found in the second trial: the caption
        # read "now: time to limit none" before the connection and beyond the horizon: item 2's "none")
        said = page.evaluate("""() => { const out = {};
            const n = hmi.trend.length - 1;
            hmi.trend[n] = Object.assign({}, hmi.trend[n], {ttl: null, drift: null});
            for (const [state, text] of [['off', 'not connected'], ['beyond', '> 65 s'],
                                         ['none', 'NO FORECAST: no healthy estimate']]) {
              hmi.frame.forecast = Object.assign({}, hmi.frame.forecast, {state, text}); drawTrends();
              out[state] = [...document.querySelectorAll('#page-trends figcaption')].map((e) => e.textContent); }
            return out; }""")
        for state, text in (("off", "not connected"), ("beyond", "> 65 s"),
                            ("none", "NO FORECAST: no healthy estimate")):
            assert said[state][1].endswith(f"now: time to limit {text}"), said[state]
            assert "now: drift no fit," in said[state][2] and "none" not in " ".join(said[state]), said[state]
        assert _outside(page, PRIMARY) == []
        page.click("#pages button[data-page='journal']")
        wait_for(page, "document.querySelectorAll('#journal tbody tr').length > 0", what="the journal")
        kinds = set(page.evaluate("[...document.querySelectorAll('#journal tbody tr')].map((r) => r.dataset.kind)"))
        assert kinds <= {"alarm", "alarm_state"} and "alarm_state" in kinds
        page.fill("#journal-search", "ERS-2")
        wait_for(page, "document.querySelectorAll('#journal tbody tr').length > 0 && [...document.querySelectorAll("
                       "'#journal tbody tr')].every((r) => r.textContent.includes('ERS-2'))", what="the search")
        page.select_option("#journal-kind", "modes")
        page.fill("#journal-search", "")
        wait_for(page, "[...document.querySelectorAll('#journal tbody tr')].some((r) => r.dataset.kind === 'mode')",
                 what="the modes")
        # everything the log has, every face in the operator's words (found in review: the ESD-1 command's
        # message "velocity step: beta_max face in 27.9 s")
        from loadarm.vocab import FACES

        page.select_option("#journal-kind", "all")
        wait_for(page, "[...document.querySelectorAll('#journal tbody tr')].some((r) => r.dataset.kind === 'command')",
                 what="the commands")
        shown = page.inner_text("#journal")
        assert not [f for f in FACES if f in shown], shown
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.slow
def test_audible_annunciation_per_priority_with_silence(browser, replay_server):
    """Issue 29 item 5: off until the operator turns it on (WebAudio, no file); on, the most urgent
    unacknowledged alarm sounds its priority's pattern, Silence quiets it, and a new alarm sounds again."""
    ctx, page = _sized(browser, 1366, 768)
    try:
        log_in(page, replay_server["url"], "alice", "pw-alice")
        _seek(page, math.ceil(replay_server["release"] + 1.0))
        assert page.evaluate("hmi.audio.playing") is None
        page.check("#sound-on")
        wait_for(page, "hmi.audio.playing === 1 && hmi.audio.beeps >= 3", what="the critical pattern")
        page.click("#silence")
        assert page.evaluate("hmi.audio.playing") is None and "quiet" in page.inner_text("#sound-state")
        _seek(page, 150)                                  # before the drift: no alarm
        _seek(page, math.ceil(replay_server["release"] + 1.0))
        assert page.evaluate("hmi.audio.playing") is None  # the same activation: still silenced
        # a new alarm sounds again, at its own priority's pattern, in the page's own audio
        got = page.evaluate("""() => { const f = JSON.parse(JSON.stringify(hmi.frame)), n = hmi.audio.beeps;
            f.alarms.push({tag: 'SENSOR_FAULT', priority: 2, priority_name: 'high', state: 'unacknowledged',
                           raised_at: f.t, message: 'x'});
            hmi.audio.next = 0; annunciate(f);
            return [hmi.audio.playing, hmi.audio.beeps - n, hmi.audio.ctx instanceof AudioContext]; }""")
        assert got == [2, 2, True], got                   # high: two beeps
        requests = page.evaluate("performance.getEntriesByType('resource').map((e) => e.name)")
        assert not [u for u in requests if re.search(r"\.(wav|mp3|ogg)$", u)]
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.slow
def test_the_ship_s_view_a_viewer_on_a_tablet(screen, browser, state, replay_server):
    """Issue 29 item 5: the viewer role on a 1024x768 tablet: only ESD-1 can be pressed; in the release (its
    four alarms, the coupler "on the flange", ESD-1 active) the primary state is in view without scrolling, no
    text of it cut, and the two views at a readable scale."""
    s = screen()
    ctx, page = _sized(browser, 1024, 768)
    try:
        log_in(page, s.url, "victor", "pw-victor")
        enabled = page.evaluate("[...document.querySelectorAll('#controls button')].filter(b => !b.disabled)"
                                ".map(b => b.id)")
        assert enabled == ["esd"] and page.errors == []
        log_in(page, replay_server["url"], "victor", "pw-victor")
        _seek(page, math.ceil(replay_server["release"] + 1.0))
        assert page.inner_text("#coupler-value") == "on the flange" and page.evaluate("hmi.frame.alarms.length") == 4
        assert _outside(page, PRIMARY) == []
        assert page.evaluate(_CUT) == []                 # found in review: "on the flang" over the E-stop tile
        # the views at a readable scale (found: 150 px high, their 10 px labels drawn at 5 px)
        assert page.evaluate("Math.min(...['side', 'top'].map((id) => document.getElementById(id)"
                             ".getBoundingClientRect().height))") >= 220
        assert page.evaluate("document.scrollingElement.scrollHeight <= innerHeight"
                             " && document.scrollingElement.scrollWidth <= innerWidth")
        assert page.errors == []
    finally:
        ctx.close()


@pytest.fixture(scope="module")
def breakout_replay(state, tmp_path_factory):
    """The break-out on a tracked ship (every line parts at 400 s) logged, and a replay screen on it."""
    server, res = _replay_screen(state, tmp_path_factory.mktemp("replay30b") / "events.db",
                                 "examples/scenarios/breakout_tracked.toml")
    lost = res.first_code("info.moorings_lost")
    yield {"url": server.url, "connect": res.first("mode", "-> CONNECTED"), "lost": lost}
    server.stop()


@pytest.fixture(scope="module")
def held_replay(state, tmp_path_factory):
    """Hs 1.5 m on a tracked ship, seed 0 (the break-out test's wave call at 208.04 s held by the prediction,
    docs/guidance.md section 13) logged, and a replay screen on it."""
    server, res = _replay_screen(state, tmp_path_factory.mktemp("replay30h") / "events.db",
                                 "examples/scenarios/hs15_tracked.toml", seed=0)
    yield {"url": server.url, "calls": res.held_calls(), "esd1": res.first_code("stage.esd1")}
    server.stop()


@pytest.mark.slow
def test_a_held_call_is_said_on_the_screen_marked_abnormal(browser, held_replay, tmp_path):
    """ISA-18.2's suppressed by design is shown: while the prediction holds the measured drift's call for ESD-1
    (seed 0 at 208.04 s), the time to limit's detail says so, marked abnormal (ISA-101: the inverted style, no
    alarm colour); before the call nothing is said; once ESD-1 is raised the line is gone."""
    ctx, page = _sized(browser, *SIZES[0])
    try:
        onset = held_replay["calls"][0][0]
        log_in(page, held_replay["url"], "alice", "pw-alice")
        _seek(page, math.floor(onset) - 5)
        assert page.query_selector("#held") is None
        _seek(page, math.ceil(onset) + 1)
        assert page.inner_text("#held").startswith("MEASURED DRIFT CALLS ESD-1, held by the prediction for ")
        assert page.evaluate("document.getElementById('held').className") == "flag abnormal"
        colour = page.evaluate("getComputedStyle(document.getElementById('held')).backgroundColor")
        assert colour == "rgb(48, 48, 48)", colour
        page.screenshot(path=str(tmp_path / "held.png"))
        assert page.evaluate(_OVERLAPS) == []
        _seek(page, math.ceil(held_replay["esd1"]) + 2)
        assert page.query_selector("#held") is None
        assert page.errors == []
    finally:
        ctx.close()


@pytest.mark.slow
def test_the_moorings_lost_are_marked_abnormal_on_the_screen(browser, breakout_replay, tmp_path):
    """Issue 30 (the second witness): connected, the time to limit's detail says "moorings holding" in the
    normal style; once more than a third of the lines are slack (the break-out) it says "MOORINGS LOST" marked abnormal (ISA-101:
    the inverted style with a pointer, never an alarm colour). Found: the state was text only."""
    ctx, page = _sized(browser, *SIZES[0])
    try:
        log_in(page, breakout_replay["url"], "alice", "pw-alice")
        _seek(page, math.ceil(breakout_replay["connect"] + 20))
        assert page.inner_text("#moorings") == "moorings holding"
        assert page.evaluate("document.getElementById('moorings').className") == "flag"
        assert breakout_replay["lost"] is not None
        _seek(page, math.ceil(breakout_replay["lost"] + 1))
        assert page.inner_text("#moorings").endswith("MOORINGS LOST: lines slack")
        assert page.evaluate("document.getElementById('moorings').className") == "flag abnormal"
        colour = page.evaluate("getComputedStyle(document.getElementById('moorings')).backgroundColor")
        assert colour == "rgb(48, 48, 48)", colour             # --arm, the abnormal tile's: no alarm colour
        assert "MOORINGS LOST" in page.evaluate("document.getElementById('ttl-detail').title")
        why = page.inner_text("#unused")                     # the prediction's reason, after ESD-1 or the moorings
        assert why in ("ESD-1 raised: every route acts", "the moorings are lost"), why
        assert page.evaluate("document.getElementById('unused').className") == (
            "flag abnormal" if why == "the moorings are lost" else "flag")
        page.screenshot(path=str(tmp_path / "moorings-lost.png"))
        assert page.evaluate(_OVERLAPS) == []
        assert page.errors == []
    finally:
        ctx.close()


@pytest.fixture(scope="module")
def tracked_replay(state, tmp_path_factory):
    """The drift-off on a tracked ship (35 minutes of track before the run: the prediction trusted from the
    connection) logged, and a replay screen on it."""
    server, res = _replay_screen(state, tmp_path_factory.mktemp("replay30") / "events.db",
                                 "examples/scenarios/driftoff_tracked.toml")
    yield {"url": server.url, "connect": res.first("mode", "-> CONNECTED"), "esd1": res.first("alarm", "ALARM1")}
    server.stop()


@pytest.mark.slow
@pytest.mark.parametrize("w, h", SIZES)
def test_the_predicted_track_and_its_band_are_drawn_and_the_time_to_limit_has_its_interval(browser, tracked_replay,
                                                                                         w, h, tmp_path):
    """Issue 30 item 5: connected to a tracked ship before the drift, the top view draws the predicted track
    (a grey dashed line) and its interval (a grey band per 5 s of the 120 s claim), the time to limit's detail
    says the prediction's ("prediction: no face within 120 s" or "face in A s at the earliest, B s on the mean
    track"), nothing collides with a
    label, and the primary state still fits; after ESD-1 the rule that raised it is named."""
    ctx, page = _sized(browser, w, h)
    try:
        log_in(page, tracked_replay["url"], "alice", "pw-alice")
        _seek(page, math.ceil(tracked_replay["connect"] + 20))
        assert page.evaluate("document.querySelectorAll('#top polyline.predicted').length") == 1
        assert page.evaluate("document.querySelectorAll('#top rect.band').length") == 24
        detail = page.evaluate("document.getElementById('ttl-detail').textContent")
        assert re.search(r"prediction: (no face within 120 s|face in \d+ s at the earliest(, \d+ s on the mean track| \(mean track))", detail), detail
        assert page.evaluate(_OVERLAPS) == []
        assert _outside(page, [s for s in PRIMARY if s != "tr.alarm"]) == []           # no alarm active yet
        page.screenshot(path=str(tmp_path / f"prediction-{w}.png"))
        _seek(page, math.ceil(tracked_replay["esd1"] + 1))
        detail = page.evaluate("document.getElementById('ttl-detail').textContent")
        assert "raised by the measured drift" in detail or "raised by the design-drift floor" in detail, detail
        assert "prediction (not used)" in detail, detail
        assert page.errors == []
    finally:
        ctx.close()
