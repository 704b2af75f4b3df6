"""The operator's screen in a real browser (issue 15): Debian's Chromium driven by Playwright against
``loadarm serve``'s HMI on an ephemeral loopback port, over the real guidance service (the drift-off scenario,
kinematic plant). Skipped with the reason when no Chromium is installed (`apt-get install chromium`); CI
installs it (.ci/run). `make test` runs the page load and the E-stop; the rest, seconds each, are in the slow
suite (`make test SLOW=1`, CI) to keep it within two minutes on two cores."""

from __future__ import annotations

import math
import time

import pytest

from loadarm.opcua.security import Role, StateDir
from loadarm.testing.browser import CHROMIUM_HINT, find_chromium, launch, log_in, wait_for

SCENARIO = "examples/scenarios/driftoff.toml"

pytestmark = pytest.mark.skipif(find_chromium() is None, reason=CHROMIUM_HINT)


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = launch(p)
        yield b
        b.close()


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


def test_e_stop_stops_the_arm_within_one_update(screen, page):
    """The coupler jogging, one click on E-STOP: the first or second frame after the click (one may have been
    on its way) shows ESTOP, and the coupler stands still from then on."""
    s = screen()
    log_in(page, s.url, "alice", "pw-alice")
    page.keyboard.down("PageUp")
    time.sleep(1.0)
    page.evaluate("document.getElementById('estop').addEventListener('click', "
                  "() => { hmi.clickAt = performance.now(); }, {capture: true})")
    page.click("#estop")
    wait_for(page, "hmi.frame.mode === 'ESTOP'", timeout=3.0, what="ESTOP on the screen")
    page.keyboard.up("PageUp")
    time.sleep(0.5)
    hist = page.evaluate("hmi.history.filter(h => h.at >= hmi.clickAt).map(h => [h.mode, h.coupler[2]])")
    first = next(i for i, h in enumerate(hist) if h[0] == "ESTOP")
    assert first <= 1, hist[:5]
    after = [z for m, z in hist[first + 1:]]
    assert after and max(after) - min(after) < 1e-3
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
