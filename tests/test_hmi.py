"""The operator's web screen (issue 15) without a browser: logins, cookies, CSRF, the login limit, the WebSocket's
frames and acknowledged commands, roles, the dead-man on a dropped screen, the alarm list and shelving, and
the assets (nothing from outside). The browser tests are in tests/test_hmi_browser.py."""

from __future__ import annotations

from datetime import datetime
import json
import math

import numpy as np
import re

import pytest

from loadarm.opcua.security import Role, StateDir

SCENARIO = "examples/scenarios/driftoff.toml"


class FakeClock:
    def __init__(self, t=1000.0):
        self.t = t

    def __call__(self):
        return self.t


class FakeService:
    """A guidance service whose snapshot the test sets; it records the requests it gets."""

    def __init__(self):
        from loadarm.vocab import ANNUNCIATED

        self.requests = []
        self.notes = []
        self.seq = 0
        self.alarms = {tag: "normal" for tag in ANNUNCIATED}
        self.mode = "MANUAL"
        self.t = 0.0
        self.wall = math.nan
        self.loop = type("Loop", (), {"events": []})()

    def snapshot(self):
        from loadarm.sim.snapshot import Snapshot

        return Snapshot(seq=self.seq, t=self.t, mode=self.mode, q=(0.0, 1.0, 2.0), coupler=(10.0, 0.0, 2.0),
                        flange_estimate=(10.0, 0.0, 2.0), estimate_healthy=True, distance=0.0, level=0,
                        time_to_limit=math.inf, connected=False, esd=False, release=False, coupler_open=False,
                        ers_valves_closed=False, alarms=dict(self.alarms),
                        margins={"beta_max": math.nan, "slew_pos": 0.3}, wall=self.wall)

    jog_speed = 0.15

    def request(self, req):
        self.requests.append(req)

    def note(self, kind, reason, data):
        self.notes.append((kind, reason, data))

    def step(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)
        self.seq += 1


@pytest.fixture
def app_env(tmp_path, model):
    from fastapi.testclient import TestClient

    from loadarm.hmi.app import create_app

    st = StateDir(tmp_path / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    st.users().add("victor", Role.VIEWER, "pw-victor")
    service, clock, wall = FakeService(), FakeClock(), FakeClock(1.8e9)
    app = create_app(service, st.path, model, clock=clock, wall=wall, frame_rate=100.0, name="test")
    client = TestClient(app)                   # host "testserver", for HTTP and the WebSocket alike
    return {"client": client, "service": service, "clock": clock, "app": app, "wall": wall}


def _login(client, user="alice", password="pw-alice"):
    r = client.post("/api/login", json={"user": user, "password": password})
    assert r.status_code == 200, r.text
    return r.json()


ORIGIN = {"origin": "http://testserver"}


def test_login_sets_an_http_only_same_site_strict_cookie_and_a_csrf_token(app_env):
    c = app_env["client"]
    assert c.get("/api/session").json()["user"] is None
    assert c.get("/api/geometry").status_code == 401
    r = c.post("/api/login", json={"user": "alice", "password": "pw-alice"})
    cookie = r.headers["set-cookie"]
    assert "loadarm_session=" in cookie and "HttpOnly" in cookie and "SameSite=strict" in cookie
    body = r.json()
    assert body["user"] == "alice" and body["role"] == "operator" and len(body["csrf"]) >= 32
    assert c.get("/api/session").json()["csrf"] == body["csrf"]
    assert c.get("/api/geometry").json()["b"] > 0
    assert "default-src 'self'" in r.headers["content-security-policy"]
    # logout needs the CSRF token: a forged form post cannot end the session
    assert c.post("/api/logout").status_code == 403
    assert c.post("/api/logout", headers={"X-CSRF-Token": body["csrf"]}).status_code == 200
    assert c.get("/api/session").json()["user"] is None


@pytest.mark.parametrize("body", [{"user": "alice"}, {"user": 1, "password": "x"}, "not json"])
def test_a_malformed_login_is_a_400_not_a_traceback(app_env, body):
    c = app_env["client"]
    r = c.post("/api/login", json=body) if isinstance(body, dict) else \
        c.post("/api/login", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 400 and "user" in r.json()["detail"]


def test_failed_logins_are_limited_per_user_then_allowed_after_the_window(app_env):
    from loadarm.hmi.sessions import LOGIN_FAILURES, LOGIN_WINDOW

    c, clock = app_env["client"], app_env["clock"]
    for _ in range(LOGIN_FAILURES):
        assert c.post("/api/login", json={"user": "alice", "password": "wrong"}).status_code == 401
    r = c.post("/api/login", json={"user": "alice", "password": "pw-alice"})      # even the right one: refused
    assert r.status_code == 429 and int(r.headers["retry-after"]) == math.ceil(LOGIN_WINDOW)
    clock.t += LOGIN_WINDOW / 2
    assert c.post("/api/login", json={"user": "alice", "password": "pw-alice"}).status_code == 429
    clock.t += LOGIN_WINDOW / 2 + 0.01
    assert c.post("/api/login", json={"user": "alice", "password": "pw-alice"}).status_code == 200


def test_a_session_unused_for_a_shift_ends(app_env):
    from loadarm.hmi.sessions import SESSION_IDLE

    c, clock = app_env["client"], app_env["clock"]
    _login(c)
    clock.t += SESSION_IDLE - 1
    assert c.get("/api/session").json()["user"] == "alice"          # used: renewed
    clock.t += SESSION_IDLE + 1
    assert c.get("/api/session").json()["user"] is None


def test_the_websocket_refuses_no_session_and_another_origin(app_env):
    from starlette.websockets import WebSocketDisconnect

    c = app_env["client"]
    with pytest.raises(WebSocketDisconnect) as e:
        with c.websocket_connect("/ws", headers=ORIGIN) as ws:
            ws.receive_text()
    assert e.value.code == 4403
    _login(c)
    with pytest.raises(WebSocketDisconnect) as e:
        with c.websocket_connect("/ws", headers={"origin": "http://evil.example"}) as ws:
            ws.receive_text()
    assert e.value.code == 4403


def _frame(ws):
    while True:
        msg = json.loads(ws.receive_text())
        if msg["type"] == "state":
            return msg


def _ack(ws):
    while True:
        msg = json.loads(ws.receive_text())
        if msg["type"] == "ack":
            return msg


def test_frames_carry_a_sequence_number_and_json_safe_values(app_env):
    c, service = app_env["client"], app_env["service"]
    _login(c)
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        f = _frame(ws)
        service.step(t=0.02)
        g = _frame(ws)
        while g["seq"] == f["seq"]:
            g = _frame(ws)
    assert g["seq"] == f["seq"] + 1 and f["mode"] == "MANUAL"
    assert f["time_to_limit"] is None and f["margins"]["beta_max"] is None and f["margins"]["slew_pos"] == 0.3
    assert f["pressures"] == [None] * 5 and f["alarms"] == []


def test_a_command_s_acknowledgement_names_the_cycle_it_was_queued_after_and_a_refusal_none(app_env):
    """The bound the E-stop's browser test holds (the cycle after the next takes a command) needs the cycle the
    controller had published when the command was queued; a refused command was queued after none."""
    c, service = app_env["client"], app_env["service"]
    csrf = _login(c)["csrf"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        ws.send_text(json.dumps({"type": "cmd", "seq": 1, "action": "stop", "csrf": csrf}))
        first = _ack(ws)["cycle"]
        service.step(t=0.02)
        service.step(t=0.04)
        ws.send_text(json.dumps({"type": "cmd", "seq": 2, "action": "estop", "csrf": csrf}))
        assert _ack(ws)["cycle"] == first + 2 == service.snapshot().seq
        ws.send_text(json.dumps({"type": "cmd", "seq": 3, "action": "estop", "csrf": "forged"}))
        assert "cycle" not in _ack(ws)


def test_an_operator_s_commands_are_acknowledged_by_sequence_and_reach_the_controller_with_the_user(app_env):
    c, service = app_env["client"], app_env["service"]
    csrf = _login(c)["csrf"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        ws.send_text(json.dumps({"type": "cmd", "seq": 7, "action": "jog", "jog": [0, 0, 0.1], "csrf": csrf}))
        a = _ack(ws)
        # a command taken names the controller's last published cycle when it was queued
        assert a == {"type": "ack", "seq": 7, "ok": True, "message": "jog sent", "cycle": service.snapshot().seq}
        ws.send_text(json.dumps({"type": "cmd", "seq": 8, "action": "estop", "csrf": "forged"}))
        a = _ack(ws)
        assert a["seq"] == 8 and not a["ok"] and "CSRF" in a["message"]
        ws.send_text(json.dumps({"type": "cmd", "seq": 9, "action": "launch", "csrf": csrf}))
        assert "unknown command" in _ack(ws)["message"]
        ws.send_text(json.dumps({"type": "cmd", "seq": 10, "action": "jog", "jog": [0, "x", 0], "csrf": csrf}))
        assert not _ack(ws)["ok"]
        ws.send_text("{not json")
        assert _ack(ws) == {"type": "ack", "seq": None, "ok": False, "message": "not a command"}
        ws.send_text(json.dumps({"type": "cmd", "seq": 11, "action": "stop", "csrf": csrf}))
        assert _ack(ws)["ok"]
    assert [(r.action, r.user, r.jog) for r in service.requests] == [("jog", "alice", (0.0, 0.0, 0.1)),
                                                                     ("stop", "alice", (0.0, 0.0, 0.0))]


def test_a_viewer_can_request_esd_1_and_nothing_else(app_env):
    from loadarm.hmi.app import COMMANDS

    c, service = app_env["client"], app_env["service"]
    s = _login(c, "victor", "pw-victor")
    assert s["commands"] == ["esd"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        for i, action in enumerate(sorted(COMMANDS)):
            ws.send_text(json.dumps({"type": "cmd", "seq": i, "action": action, "csrf": s["csrf"], "tag": "ESD1",
                                     "seconds": 60}))
            a = _ack(ws)
            assert a["ok"] == (action == "esd"), (action, a)
            if action != "esd":
                assert "needs the operator role, victor is viewer" in a["message"]
    assert [(r.action, r.user) for r in service.requests] == [("esd", "victor")]


def test_a_screen_whose_session_ends_gets_no_more_frames(app_env):
    from starlette.websockets import WebSocketDisconnect

    c = app_env["client"]
    csrf = _login(c)["csrf"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        _frame(ws)
        assert c.post("/api/logout", headers={"X-CSRF-Token": csrf}).status_code == 200
        with pytest.raises(WebSocketDisconnect) as e:
            for _ in range(100):
                ws.receive_text()
        assert e.value.code == 4401


def test_a_screen_dropped_mid_jog_stops_the_jog(app_env):
    """The dead-man across the network: the page stops its jog when the key or button is released, and if the
    connection drops instead, the server asks the controller to stop (the controller's own 0.5 s jog hold
    would stop it too)."""
    c, service = app_env["client"], app_env["service"]
    csrf = _login(c)["csrf"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        ws.send_text(json.dumps({"type": "cmd", "seq": 1, "action": "jog", "jog": [0.1, 0, 0], "csrf": csrf}))
        assert _ack(ws)["ok"]
    assert [r.action for r in service.requests] == ["jog", "stop"]
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:          # no jog: a closed screen asks nothing
        _frame(ws)
    assert [r.action for r in service.requests] == ["jog", "stop"]


def test_alarms_are_listed_by_priority_with_their_time_and_can_be_shelved_for_a_limited_time(app_env):
    from loadarm.hmi.state import SHELVE_MAX

    c, service = app_env["client"], app_env["service"]
    csrf = _login(c)["csrf"]
    service.step(t=10.0, alarms={**service.alarms, "PRE_ALARM": "unacknowledged"})
    service.step(t=12.0, alarms={**service.alarms, "ESD1": "unacknowledged"})
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        f = _frame(ws)
        assert [(a["tag"], a["priority_name"], a["state"]) for a in f["alarms"]] == [
            ("ESD1", "medium", "unacknowledged"), ("PRE_ALARM", "low", "unacknowledged")]
        assert f["alarms"][0]["raised_at"] == 12.0
        ws.send_text(json.dumps({"type": "cmd", "seq": 1, "action": "shelve", "tag": "PRE_ALARM",
                                 "seconds": SHELVE_MAX + 1, "csrf": csrf}))
        assert not _ack(ws)["ok"]
        ws.send_text(json.dumps({"type": "cmd", "seq": 2, "action": "shelve", "tag": "SECOND", "seconds": 60,
                                 "csrf": csrf}))
        assert "SECOND is not active" in _ack(ws)["message"]
        ws.send_text(json.dumps({"type": "cmd", "seq": 3, "action": "shelve", "tag": "PRE_ALARM", "seconds": 60,
                                 "csrf": csrf}))
        assert _ack(ws)["ok"]
        service.step(t=13.0, wall=datetime(2026, 12, 4, 14, 3, 0).timestamp())
        f = _frame(ws)
        while f["seq"] != service.seq:
            f = _frame(ws)
        assert [a["tag"] for a in f["alarms"]] == ["ESD1"]
        assert [(a["tag"], a["shelved_until"]) for a in f["shelved"]] == [("PRE_ALARM", 72.0)]
        # issue 29 item 4: the shelving's end as a time of day (59 s of run time after this snapshot's 14:03:00)
        assert f["shelved"][0]["until_clock"].endswith("14:03:59")
        service.step(t=72.0)                       # the shelving's time is up: back in the list
        f = _frame(ws)
        while f["seq"] != service.seq:
            f = _frame(ws)
        assert [a["tag"] for a in f["alarms"]] == ["ESD1", "PRE_ALARM"] and f["shelved"] == []
    assert [(r.action, r.tag) for r in service.requests] == [("shelve", "PRE_ALARM")]


def test_the_alarm_book_on_its_own():
    from loadarm.hmi.state import AlarmBook, priority

    assert [priority(t)[1] for t in ("RELEASE", "SECOND", "ESD1", "PRE_ALARM")] == ["critical", "high", "medium",
                                                                                  "low"]
    b = AlarmBook()
    assert b.update(1.0, {"ESD1": "unacknowledged"})[0].raised_at == 1.0
    assert b.update(5.0, {"ESD1": "acknowledged"})[0].raised_at == 1.0            # raised once, not re-raised
    assert b.shelve("ESD1", 5.0, float("nan"), {"ESD1": "acknowledged"})
    assert b.shelve("ESD1", 5.0, 30, {"ESD1": "acknowledged"}) == ""
    assert b.update(6.0, {"ESD1": "acknowledged"})[0].shelved_until == 35.0
    assert b.update(7.0, {"ESD1": "normal"}) == []                                 # normal: forgotten
    assert b.update(8.0, {"ESD1": "unacknowledged"})[0].shelved_until is None      # a new activation shows
    assert b.unshelve("ESD1") == "ESD1 is not shelved"


def test_the_assets_are_all_in_the_package_and_ask_nothing_from_outside():
    from loadarm.hmi.app import _static_dir

    files = sorted(_static_dir().iterdir())
    assert {f.name for f in files} >= {"index.html", "hmi.js", "hmi.css"}
    for f in files:
        text = f.read_text()
        urls = [u for u in re.findall(r"(?:https?:)?//[\w.-]+\.\w+[^\s\"')]*", text)
                if not u.startswith("http://www.w3.org/2000/svg")]
        assert not urls, (f.name, urls)


@pytest.mark.slow
def test_serve_with_hmi_from_the_command_line_serves_the_page_and_a_login(tmp_path):
    """What a new user runs: ``loadarm serve --scenario driftoff.toml --hmi 127.0.0.1:PORT`` in its own process;
    the page, its assets and a login answer on that port, and Ctrl-C (SIGINT) stops it (exit 130, the
    shell's code for an interrupt, after stopping both servers and saying where the controller stopped)."""
    import os
    import signal
    import subprocess
    import sys

    import httpx2 as httpx

    from loadarm.testing.loadtest import free_port

    st = StateDir(tmp_path / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    port, opc = free_port(), free_port()
    proc = subprocess.Popen([sys.executable, "-m", "loadarm.cli", "serve", "--scenario", SCENARIO, "--state-dir",
                             str(st.path), "--endpoint", f"opc.tcp://127.0.0.1:{opc}", "--hmi", f"127.0.0.1:{port}",
                             "--db", str(tmp_path / "events.db"), "--scripted"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONFAULTHANDLER": "1"},
                            # found in CI: a child of a test worker inherits SIGINT ignored, and serve never
                            # stopped; it now installs its own handler, and this test starts it that way
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        line = proc.stdout.readline()
        assert f"operator's screen on http://127.0.0.1:{port}/" in line, line + proc.stderr.read()
        with httpx.Client(base_url=f"http://127.0.0.1:{port}") as c:
            assert "<title>loadarm HMI</title>" in c.get("/").text
            assert c.get("/static/hmi.js").status_code == 200
            assert c.post("/api/login", json={"user": "alice", "password": "pw-alice"}).json()["role"] == "operator"
            assert c.get("/api/geometry").json()["a"] > 0
        # Ctrl-C once the server says it stops on it (found in CI under load: a SIGINT sent while the OPC UA
        # server was still starting, after the screen already answered, left the process hanging past 15 s)
        started = [line]
        for _ in range(20):
            started.append(proc.stdout.readline())
            if "Ctrl-C stops" in started[-1] or not started[-1]:
                break
        assert "Ctrl-C stops" in started[-1], "".join(started)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(15)
        except subprocess.TimeoutExpired:      # where it hangs: faulthandler dumps every thread on SIGABRT
            proc.send_signal(signal.SIGABRT)
            try:
                proc.wait(10)
            finally:
                proc.kill()
            raise AssertionError("serve did not stop within 15 s of Ctrl-C; its threads:\n"
                                 + proc.stderr.read()[-8000:]) from None
    rest, err = proc.stdout.read(), proc.stderr.read()
    assert code == 130, err
    assert "stopped at t = " in rest and " late cycles" in rest, rest + err


def test_the_frame_of_a_real_snapshot_is_json(model):
    """The service's own snapshot (the drift-off on the hydraulic plant, a few cycles) makes a frame that JSON
    carries: pressures in Pa from the servo, the geometry's zones ordered by reach."""
    from loadarm.hmi.state import AlarmBook, frame, geometry
    from loadarm.opcua.service import GuidanceService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import ClosedLoop

    sc, m = load_scenario(SCENARIO)
    service = GuidanceService(ClosedLoop(sc, m, scripted=False), clock=lambda: 0.0, sleep=lambda s: None)
    loop = service.loop
    for k in range(5):
        service._publish(k, loop.time(k), loop.cycle(k))
    snap = service.snapshot()
    f = json.loads(json.dumps(frame(snap, m, AlarmBook().update(snap.t, snap.alarms), sent_at=0.0)))
    assert all(p is not None and 1e5 < p < 400e5 for p in f["pressures"]), f["pressures"]
    g = geometry(m)
    reach = [z["from_r"] for z in g["zones"]] + [g["zones"][-1]["to_r"]]
    assert reach == sorted(reach) and g["sequence_time"] > m.sequence.esd_time


# --------------------------------------------------------------------------- replay

@pytest.fixture(scope="module")
def logged_run(tmp_path_factory):
    """The drift-off (kinematic plant) written to an event log, and its events."""
    from loadarm.eventlog import EventLog
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    db = tmp_path_factory.mktemp("replay") / "events.db"
    sc, model = load_scenario(SCENARIO)
    with EventLog(db, run="driftoff-replay") as log:
        result = run_scenario(sc, model, log=log, plant="kinematic")
    with EventLog.open_existing(db) as log:
        events = log.query(run="driftoff-replay")
    return {"db": db, "events": events, "result": result, "model": model}


@pytest.mark.slow                      # the logged drift-off: seconds (make test SLOW=1, CI)
def test_a_replay_shows_the_logged_sample_at_its_cursor_and_the_alarms_raised_when_logged(logged_run):
    from loadarm.arm.slew import forward3d
    from loadarm.errors import EventLogError
    from loadarm.hmi.replay import ReplayService

    clock = FakeClock(0.0)
    r = ReplayService(logged_run["events"], logged_run["model"], clock=clock)
    assert (r.t0, r.t1) == (0.0, 320.0) and r.snapshot().mode == "STORED"
    clock.t += 10.0                                      # playing at 1x from the start
    assert r.snapshot().t == 10.0
    r.seek(236.5)
    snap = r.snapshot()
    sample = next(e for e in logged_run["events"] if e.kind == "sample" and e.t == snap.t)
    assert snap.t == 236.0 and snap.mode == sample.state
    assert snap.coupler == tuple(float(v) for v in forward3d(logged_run["model"].arm, *snap.q))
    # raised when the log has it (found, issue 26: at the 1 Hz sample after it, 212.0 s for 211.2 s)
    res = logged_run["result"]
    raised = r.raised_at(snap)
    assert snap.alarms["ESD1"] != "normal" and raised["ESD1"] == res.first_code("stage.esd1")
    assert raised["RELEASE"] == res.first_code("stage.release")
    r.pause()
    clock.t += 100.0
    assert r.cursor() == 236.5
    r.play(10.0)
    clock.t += 100.0
    assert r.cursor() == 320.0                           # stops at the end
    for bad in (float("nan"), "x"):
        with pytest.raises(ValueError, match="seek needs a finite run time"):
            r.seek(bad)
    with pytest.raises(ValueError, match=r"speed in \(0, 100\]"):
        r.play(0)
    with pytest.raises(PermissionError):
        r.request(None)
    with pytest.raises(EventLogError, match="no state samples"):
        ReplayService([e for e in logged_run["events"] if e.kind != "sample"], logged_run["model"])


@pytest.mark.slow                      # the logged drift-off: seconds (make test SLOW=1, CI)
def test_the_replay_screen_has_a_slider_and_takes_no_command(tmp_path, logged_run):
    from fastapi.testclient import TestClient

    from loadarm.hmi.app import create_app
    from loadarm.hmi.replay import ReplayService

    st = StateDir(tmp_path / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    r = ReplayService(logged_run["events"], logged_run["model"], clock=FakeClock(0.0))
    c = TestClient(create_app(r, st.path, logged_run["model"], frame_rate=100.0))
    s = _login(c)
    assert s["replay"] is True and s["commands"] == []
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        # a loadarm run's log (simulated): its times of day from its start, and the bar says so
        assert _frame(ws)["replay"] == {"t": 0.0, "t0": 0.0, "t1": 320.0, "playing": True, "speed": 1.0,
                                        "simulated": True}
        # the first logged sample (1 Hz) after ESD-1, showing the mode and alarms the log has there (found: a
        # fixed 212 s in ALARM1 fell after the release once the lead counted the ERS valves' timeout)
        res = logged_run["result"]
        t = float(math.ceil(res.first("alarm", "ALARM1")))
        mode = [r.split(" -> ")[1].split(":")[0] for tm, _, k, r, _ in res.events if k == "mode" and tm <= t][-1]
        ws.send_text(json.dumps({"type": "seek", "seq": 1, "t": t}))
        assert _ack(ws) == {"type": "ack", "seq": 1, "ok": True, "message": f"seek at {t:.1f} s"}
        f = _frame(ws)
        for _ in range(50):
            if f["t"] == t:
                break
            f = _frame(ws)
        assert f["t"] == t and f["mode"] == mode and "ESD1" in [a["tag"] for a in f["alarms"]], (f, mode)
        ws.send_text(json.dumps({"type": "play", "seq": 2, "speed": 1000}))
        assert not _ack(ws)["ok"]
        ws.send_text(json.dumps({"type": "cmd", "seq": 3, "action": "estop", "csrf": s["csrf"]}))
        assert _ack(ws)["message"] == "refused: a replay takes no command"
        with c.websocket_connect("/ws", headers=ORIGIN) as other:        # another screen: its own slider
            assert _frame(other)["t"] == 0.0
        assert _frame(ws)["t"] == t


@pytest.mark.slow                      # the logged drift-off: seconds (make test SLOW=1, CI)
@pytest.mark.parametrize("args, match", [
    ([], "--replay needs --hmi HOST:PORT"),
    (["--hmi", "127.0.0.1:0"], "--replay needs --config (or --scenario)"),
    (["--hmi", "127.0.0.1:0", "--config", "examples/paper.toml", "--run", "nope"], "--run 'nope': no such run")])
def test_serve_replay_refuses_what_it_cannot_replay_in_one_line(capsys, tmp_path, logged_run, args, match):
    from loadarm.cli import main

    assert main(["serve", "--replay", str(logged_run["db"]), "--state-dir", str(tmp_path / "s"), *args]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1


def test_alarm_colours_are_used_for_alarms_only():
    """ISA-101: the alarm colours (--p1..--p4) appear only in the alarm list's priorities and on an active
    alarm's band in the side view; nothing else on the screen uses them, and the script sets no colour."""
    from loadarm.hmi.app import _static_dir

    css = (_static_dir() / "hmi.css").read_text()
    css = re.sub(r"/\*.*?\*/", "", css, flags=re.S)
    rules = re.findall(r"([^{}]+)\{([^}]*)\}", css)
    users = [sel.strip() for sel, body in rules if re.search(r"var\(--p[1-4]\)", body)]
    assert users and all(("tr.alarm" in u and ".prio" in u) or ".zone.active" in u for u in users), users
    js = (_static_dir() / "hmi.js").read_text()
    assert not re.search(r"#[0-9a-fA-F]{6}\b", js.replace('fill: "#303030"', "")), "the script sets a colour"


def test_a_replay_refuses_a_damaged_sample_naming_it(model):
    """The replay takes the same check as ``loadarm log --png`` (:func:`loadarm.eventlog.check_samples`): a
    hand-edited sample is refused, naming the event, not drawn from (its frames would have died in the
    server's sender)."""
    from loadarm.errors import EventLogError
    from loadarm.eventlog import Event
    from loadarm.hmi.replay import ReplayService

    good = {"phi": 0.0, "alpha": 1.0, "beta": 2.0, "distance": 1.0}
    ok = Event(1, "r", 0.0, "", "STORED", "sample", "state sample", good)
    assert ReplayService([ok], model).snapshot().mode == "STORED"
    with pytest.raises(EventLogError, match="event id 2: a sample needs a finite number 'alpha', got 'x'"):
        ReplayService([ok, Event(2, "r", 1.0, "", "STORED", "sample", "", {**good, "alpha": "x"})], model)
    with pytest.raises(EventLogError, match="event id 3: state 'NOPE' is not a guidance mode"):
        ReplayService([ok, Event(3, "r", 1.0, "", "NOPE", "sample", "", good)], model)


def test_a_simulated_run_s_replay_times_its_events_from_its_start(model):
    """Found in the second trial of issue 29: the replay of a ``loadarm run`` log (simulated about 2000 times faster
    than real time) gave every event of the release one time of day, its log's wall clock. A run whose log's clock
    kept less than :data:`REAL_TIME_FRACTION` of its run time is simulated: its events' times of day are its start's
    plus their run time, and the replay bar says so; a run on the wall clock keeps its log's times."""
    from datetime import datetime, timedelta, timezone

    from loadarm.eventlog import Event
    from loadarm.hmi.app import _static_dir
    from loadarm.hmi.replay import REAL_TIME_FRACTION, ReplayService

    start = datetime(2026, 12, 5, 17, 29, 43, tzinfo=timezone.utc)
    sample = {"phi": 0.0, "alpha": 1.0, "beta": 2.0, "distance": 1.0}

    def run(wall_per_run_s):
        def at(i, t, kind, reason, data):
            return Event(i, "r", t, (start + timedelta(seconds=t * wall_per_run_s)).isoformat(), "CONNECTED", kind,
                         reason, data)
        return [at(1, 0.0, "sample", "", sample), at(2, 211.2, "alarm", "ALARM1: arm stretched", {}),
                at(3, 211.8, "alarm", "RELEASE: arm stretched", {}), at(4, 229.2, "alarm", "returned", {}),
                at(5, 300.0, "sample", "", sample)]

    now = start.timestamp()
    simulated = ReplayService(run(0.0005), model)
    walls = [j["wall"] - now for j in simulated.journal(now)]
    assert simulated.simulated and simulated.replay_state()["simulated"] is True
    assert walls == pytest.approx([211.2, 211.8, 229.2])
    assert len({j["clock"] for j in simulated.journal(now)}) == 2      # 211.2 and 211.8 s in one second, not 229.2
    assert simulated.snapshot().wall == pytest.approx(now)
    assert ReplayService(run(0.5 * REAL_TIME_FRACTION), model).simulated               # serve --speedup 20
    assert not ReplayService(run(1.0), model).simulated                                 # real time
    real = ReplayService(run(0.5), model)                                    # serve --speedup 2: its log's clock
    assert not real.simulated and real.replay_state()["simulated"] is False
    assert [j["wall"] - now for j in real.journal(now)] == pytest.approx([105.6, 105.9, 114.6])
    js = (_static_dir() / "hmi.js").read_text()
    assert "r.simulated ? \" · simulated run: times of day from its start\"" in js


def test_the_hmi_page_states_the_figures_the_code_uses():
    """docs/hmi.md's figures are the code's: shelving, the login limit, the session's idle end, the frame rate,
    the jog's hold, the forecast's resolution and step, the page's stale limit and shelving request."""
    import inspect
    from pathlib import Path

    from loadarm.guidance.monitor import EnvelopeMonitor
    from loadarm.hmi.app import FRAME_RATE, _static_dir
    from loadarm.hmi.sessions import LOGIN_FAILURES, LOGIN_WINDOW, SESSION_IDLE
    from loadarm.hmi.state import SHELVE_MAX
    from loadarm.opcua.service import JOG_HOLD

    doc = " ".join((Path(__file__).parents[1] / "docs" / "hmi.md").read_text().split())
    js = (_static_dir() / "hmi.js").read_text()
    defaults = inspect.signature(EnvelopeMonitor).parameters
    stale = int(re.search(r"const STALE_MS = (\d+);", js).group(1)) / 1000
    shelve = int(re.search(r"const SHELVE_S = (\d+);", js).group(1))
    for text in (f"for at most {SHELVE_MAX:g} s (the button asks for {shelve // 60} minutes)",
                 f"after {LOGIN_FAILURES} failures in {LOGIN_WINDOW:g} s", f"unused for {SESSION_IDLE / 3600:g} hours",
                 f"a frame at up to {FRAME_RATE:g} Hz", f"not renewed within {JOG_HOLD:g} s",
                 f"the nearest to 1/{1 / defaults['resolution'].default:g} s",
                 f"the scan's {defaults['step'].default:g} s step"):
        assert text in doc, text
    # issue 29 item 2: the horizon the page quotes is the code's (the longest stage lead of the paper's case)
    from loadarm.guidance.monitor import stage_leads
    from loadarm.params.config import load_config
    from loadarm.params.compiler import compile_model

    horizon = max(stage_leads(compile_model(load_config("examples/paper.toml")).sequence).values())
    assert f"Beyond the forecast's horizon (the longest stage lead, from the code: {horizon:g} s" in doc
    assert f'it reads **"> {horizon:g} s"**' in doc
    assert stale < 1.2                                  # the banner's example is past the watchdog's limit


@pytest.mark.slow                      # the drift-off live and logged: ~9 s (make test SLOW=1, CI)
def test_the_replay_shows_what_the_live_screen_showed_at_every_logged_sample(tmp_path):
    """Replay and live build their snapshots with one function (``loadarm.sim.snapshot``). Found (issue 26): the
    replay of the drift-off showed "time to limit 9 s" while every face said "none", a zero flange velocity and no
    drift arrow while the ship drifted at 0.2 m/s: the log kept neither, and the replay computed its own state.

    The drift-off runs live on the service (every cycle published, as ``loadarm serve`` does, the screen's alarm
    book fed every cycle) and is logged; at every logged sample the replay's snapshot equals the live one, field
    by field (but what only a live cycle has: its computing time, lateness, the link, the pressures, the wall
    clock), and so do the alarm lists, raised times included."""
    from dataclasses import asdict

    from loadarm.eventlog import EventLog
    from loadarm.hmi.replay import ReplayService
    from loadarm.hmi.state import AlarmBook
    from loadarm.opcua.service import GuidanceService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import ClosedLoop

    sc, model = load_scenario(SCENARIO)
    db = tmp_path / "events.db"
    live, book = {}, AlarmBook()
    with EventLog(db, run="live") as log:
        service = GuidanceService(ClosedLoop(sc, model, log=log, scripted=True, plant="kinematic"),
                                  clock=lambda: 0.0, sleep=lambda s: None)
        publish = service._publish

        def keep(k, now, cmd):
            publish(k, now, cmd)
            snap = service.snapshot()
            live[snap.t] = (snap, [a.to_dict() for a in book.update(snap.t, snap.alarms)])

        service._publish = keep
        service.run()
    with EventLog.open_existing(db) as log:
        events = log.query(run="live")
    replay = ReplayService(events, model, clock=lambda: 0.0)
    replay.pause()
    only_live = {"cycle_us", "late", "plant_ok", "pressures", "wall", "seq", "modes"}   # modes: the live tail
    samples = [e for e in events if e.kind == "sample"]
    book_r, seen = AlarmBook(), {"ttl": 0, "faces": 0, "moving": 0, "alarms": 0}
    for e in samples:
        replay.seek(e.t)
        snap_r = replay.snapshot()
        snap_l, alarms_l = live[e.t]
        a, b = asdict(snap_l), asdict(snap_r)
        for key in only_live:
            a.pop(key), b.pop(key)
        assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True), e.t
        assert [x.to_dict() for x in book_r.update(snap_r.t, snap_r.alarms, replay.raised_at(snap_r))] == alarms_l
        seen["ttl"] += snap_r.time_to_limit < float("inf")
        seen["faces"] += bool(snap_r.time_to_faces)
        seen["moving"] += any(abs(v) > 0.05 for v in snap_r.flange_velocity)
        seen["alarms"] += bool(alarms_l)
    # the comparison covered the defect's states: a time to a limit with its faces, a drifting flange, alarms
    assert len(samples) > 300 and all(n > 5 for n in seen.values()), seen
    # issue 29 item 6: the same trends, point by point (the live service's, kept at the log's sample times)
    end = samples[-1].t
    assert replay.trend(end) == service.trend.window_at(end) and len(replay.trend(end)) == len(samples)


@pytest.mark.slow
def test_a_screen_that_samples_the_snapshots_still_sees_every_mode(tmp_path):
    """Found in CI: at 8x the screen's 20 Hz frames (0.4 s of the run apart) missed the drift-off's ALARM1,
    held for less than a frame. Every snapshot carries the last mode changes by cycle: a screen that reads only
    every 40th snapshot (4 s of the run), fed through :func:`loadarm.hmi.state.frame`, rebuilds the run's whole
    mode sequence, in order, from the frames' ``modes``; the frames' ``mode`` alone misses some."""
    from loadarm.hmi.state import AlarmBook, frame
    from loadarm.opcua.service import GuidanceService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import ClosedLoop

    sc, model = load_scenario(SCENARIO)
    service = GuidanceService(ClosedLoop(sc, model, scripted=True, plant="kinematic"), clock=lambda: 0.0,
                              sleep=lambda s: None)
    publish, every_cycle, sampled = service._publish, [], []

    def keep(k, now, cmd):
        publish(k, now, cmd)
        snap = service.snapshot()
        if not every_cycle or every_cycle[-1] != snap.mode:
            every_cycle.append(snap.mode)
        if k % 40 == 0:
            sampled.append(frame(snap, model, AlarmBook().update(snap.t, snap.alarms), sent_at=0.0))

    service._publish = keep
    service.run()
    seen, last_cycle, plain = [], -1, []
    for f in sampled:                                   # what hmi.js's onFrame does
        for k, m in f["modes"]:
            if k > last_cycle:
                last_cycle = k
                if not seen or seen[-1] != m:
                    seen.append(m)
        if not plain or plain[-1] != f["mode"]:
            plain.append(f["mode"])
    assert "ALARM1" in every_cycle and seen == every_cycle, (seen, every_cycle)
    assert plain != every_cycle, "the test samples too often to show the loss"


# --------------------------------------------------------------------------- issue 29: what the screen says

def _snap(model, **kw):
    from loadarm.sim.snapshot import Snapshot

    base = dict(seq=1, t=100.0, mode="CONNECTED", q=(0.0, 1.0, 1.5), coupler=(13.0, 0.0, 1.0),
                flange_estimate=(13.0, 0.0, 1.0), estimate_healthy=True, distance=0.0, level=0,
                time_to_limit=math.inf, connected=True, esd=False, release=False, coupler_open=False,
                ers_valves_closed=False, horizon=65.0, route="", drift=(0.19, 0.03, 0.0))
    return Snapshot(**{**base, **kw})


def test_time_to_limit_beyond_the_horizon_reads_greater_than_it_and_no_forecast_is_its_own_state(model):
    """Issue 29 item 2: "none" read as safe. Beyond the forecast's horizon (the longest stage lead, from the
    code) the screen says "> H s"; attached without a healthy estimate, "NO FORECAST"; not attached, "not
    connected"; the drift the forecast used is said with its speed and direction."""
    from loadarm.guidance.monitor import stage_leads
    from loadarm.hmi.state import forecast_state, geometry
    from loadarm.sim.snapshot import snapshot, state_sample

    horizon = max(stage_leads(model.sequence).values())
    assert geometry(model)["horizon"] == horizon
    f = forecast_state(_snap(model, horizon=horizon), model)
    assert (f["state"], f["text"]) == ("beyond", f"> {horizon:.0f} s")
    assert "design drift 0.15 m/s, any direction; measured 0.19 m/s off the berth (9 deg)" == f["basis"]
    f = forecast_state(_snap(model, time_to_limit=28.9, route="break-out",
                             time_to_faces={"beta_max": 28.9, "slew_pos": 40.0}), model)
    assert (f["state"], f["text"], f["face_words"]) == ("time", "28.9 s", "arm stretched: flange too far out")
    assert f["basis"].startswith("break-out: 0.19 m/s off the berth")
    assert forecast_state(_snap(model, estimate_healthy=False), model)["text"] == "NO FORECAST: no healthy estimate"
    assert forecast_state(_snap(model, horizon=math.nan), model)["state"] == "none"
    assert forecast_state(_snap(model, connected=False), model)["text"] == "not connected"
    # the horizon, the route and the drift travel from the controller's command through the log's sample
    from loadarm.guidance.modes import Command, Mode
    from loadarm.guidance.estimator import Estimate

    cmd = Command(Mode.CONNECTED, (0.0, 0.0, 0.0), True, False, False, horizon=horizon, route="measured drift",
                  drift=(0.1, 0.0, 0.0))
    est = Estimate(t=1.0, position=(13.0, 0.0, 1.0), velocity=(0.1, 0.0, 0.0), sigma=0.01, age=0.0, healthy=True,
                   reason="")
    snap = snapshot(model, 0, 1.0, "CONNECTED", json.loads(json.dumps(
        state_sample(cmd, (0.0, 1.0, 1.5), est, 0.0, False, {}))))
    assert (snap.horizon, snap.route, snap.drift) == (horizon, "measured drift", (0.1, 0.0, 0.0))


def test_faces_are_named_in_the_operator_s_words_and_the_ship_is_the_berth_s_hull(model):
    """Issue 29 item 4: the geometry gives the vocabulary's words of every face (the page writes those, never
    a code), and the ship is the berth's hull lying against the berthing line, its length and beam."""
    from loadarm.hmi.app import _static_dir
    from loadarm.hmi.state import geometry
    from loadarm.params.berth import ShipSection
    from loadarm.vocab import FACE_WORDS, FACES

    g = geometry(model)
    assert g["face_words"] == FACE_WORDS and g["faces"] == list(FACES)
    js = (_static_dir() / "hmi.js").read_text()
    assert "g.face_words[face]" in js and "`margin ${face}`" not in js and "time to ${face}" not in js
    ship, pts = ShipSection(), g["ship"]["outline"]
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    assert min(xs) == pytest.approx(model.berth.berthing_line, abs=1e-3)
    assert max(xs) - min(xs) == pytest.approx(ship.beam, abs=1e-3)
    assert max(ys) - min(ys) == pytest.approx(ship.length_pp, abs=1e-3)
    assert len(pts) > 40                                 # a hull's waterline, not a box


def test_only_the_state_indicator_blinks_never_the_priority():
    """Issue 29 item 3: the blink is on the state's indicator; no rule animates the priority cell."""
    from loadarm.hmi.app import _static_dir

    css = re.sub(r"/\*.*?\*/", "", (_static_dir() / "hmi.css").read_text(), flags=re.S)
    animated = [sel.strip() for sel, body in re.findall(r"([^{}]+)\{([^}]*)\}", css)
                if "animation" in body or "visibility" in body and "@keyframes" not in sel]
    assert animated and all(".prio" not in a for a in animated), animated
    assert any("td.state .ind" in a for a in animated), animated


def test_alarm_times_are_the_time_of_day_from_the_injected_wall_clock_dated_when_not_today(app_env):
    """Issue 29 item 4: an alarm carries the wall-clock time its snapshot was published (the service's
    injected clock), shown as the time of day, with the date once the day has changed."""
    from datetime import datetime

    from loadarm.hmi.state import clock_text

    c, service = app_env["client"], app_env["service"]
    raised = datetime(2026, 12, 4, 14, 3, 27).timestamp()
    assert clock_text(raised, raised + 60) == "14:03:27"
    assert clock_text(raised, raised + 86400) == "2026-12-04 14:03:27"
    _login(c)
    service.step(t=10.0, wall=raised, alarms={**service.alarms, "ESD1": "unacknowledged"})
    app_env["wall"].t = raised + 5
    with c.websocket_connect("/ws", headers=ORIGIN) as ws:
        f = _frame(ws)
        assert [(a["tag"], a["raised_wall"], a["clock"], a["raised_at"]) for a in f["alarms"]] == [
            ("ESD1", raised, "14:03:27", 10.0)]


def test_the_journal_lists_the_event_log_with_a_filter_and_a_search(app_env):
    """Issue 29 item 5: the journal is the run's events (never its samples), newest first, in the operator's
    words from their codes, filtered by kind and searched by words."""
    c, service = app_env["client"], app_env["service"]
    assert c.get("/api/journal").status_code == 401
    _login(c)
    service.step(t=12.0, wall=1.8e9)
    service.loop.events += [
        (10.0, "CONNECTED", "alarm", "ALARM1: break-out: beta_max face in 20 s", {"code": "stage.esd1",
                                                                                   "face": "beta_max"}),
        (10.0, "ALARM1", "alarm_state", "ESD1: unacknowledged", {"tag": "ESD1", "alarm_state": "unacknowledged"}),
        (11.0, "ALARM1", "operator", "alice: ack ESD1", {"user": "alice", "action": "ack", "tag": "ESD1"}),
        (11.0, "ALARM1", "sample", "state sample", {}),
        (11.5, "ALARM1", "mode", "ALARM1 -> RELEASE", {"previous": "ALARM1", "mode": "RELEASE"})]
    j = c.get("/api/journal").json()
    assert [e["kind"] for e in j["entries"]] == ["mode", "operator", "alarm_state", "alarm"]
    assert j["entries"][-1]["text"] == "ALARM1: arm stretched: flange too far out"
    assert j["entries"][-2]["priority_name"] == "medium" and j["entries"][-1]["wall"] == 1.8e9 - 2.0
    assert [e["kind"] for e in c.get("/api/journal?kind=alarms").json()["entries"]] == ["alarm_state", "alarm"]
    assert [e["text"] for e in c.get("/api/journal?q=alice+ack").json()["entries"]] == ["alice: ack ESD1"]
    assert c.get("/api/journal?kind=nope").status_code == 400


def test_the_journal_names_no_face_by_its_code_even_from_an_event_without_codes():
    """Issue 29 item 4 (found in review: the journal's "everything" showed the drift-off's ESD-1 command as
    "(velocity step: beta_max face in 27.9 s, ...)"): an event without codes keeps its message, every face in it
    in the operator's words."""
    from loadarm.hmi.state import journal_entry
    from loadarm.vocab import FACE_WORDS, FACES

    reason = ("ESD-1: stop transfer pumps, close ESD and ERS valves (velocity step: beta_max face in 27.9 s, "
              "slew_neg and alpha_min)")
    text = journal_entry(211.2, None, "ALARM1", "command", reason, {}, 0.0)["text"]
    assert text == ('ESD-1: stop transfer pumps, close ESD and ERS valves (velocity step: '
                    f'"{FACE_WORDS["beta_max"]}" in 27.9 s, "{FACE_WORDS["slew_neg"]}" and '
                    f'"{FACE_WORDS["alpha_min"]}")')
    assert not [f for f in FACES if f in text]


def test_the_journal_says_when_the_prediction_held_a_call():
    """Found by review: the journal's line of a measured drift's call for ESD-1 dropped its ``held`` flag, so the
    operator could not tell a call the prediction held from one it raised ESD-1 on."""
    from loadarm.hmi.state import journal_entry

    def text(held):
        return journal_entry(208.0, None, "CONNECTED", "info", "x", {"code": "info.measured_esd1", "held": held},
                             0.0)["text"]

    assert text(True) == "measured drift calls for ESD-1 (held by the prediction)"
    assert text(False) == "measured drift calls for ESD-1"


def test_the_trend_log_keeps_ten_minutes_at_the_log_s_sample_times(model):
    """Issue 29 items 5, 6: a point at the first snapshot at or after each whole second (the event log's
    sample rule, so the replay's trends are the live ones), the last 600 s of them."""
    from loadarm.sim.snapshot import TREND_WINDOW, TrendLog

    log = TrendLog()
    for k in range(0, 14000):
        log.add(_snap(model, t=k * 0.05, time_to_limit=30.0, margins={"beta_max": 0.5, "slew_pos": 0.2},
                      flange_velocity=(0.12, 0.16, 0.0)))
    pts = log.window_at(699.95)
    assert [p["t"] for p in pts[:2]] == [100.0, 101.0] and pts[-1]["t"] == 699.0 and len(pts) == TREND_WINDOW
    assert pts[-1] == {"t": 699.0, "beta": 1.5, "margin": 0.2, "face": "slew_pos", "ttl": 30.0,
                       "drift": pytest.approx(math.hypot(0.19, 0.03)), "speed": pytest.approx(0.2)}
    # the drift is the forecast's (found in review: the flange's speed, waves and all, was trended as the drift)
    log = TrendLog()
    log.add(_snap(model, t=0.0, flange_velocity=(0.3, 0.0, 0.0), drift=()))
    log.add(_snap(model, t=1.0, flange_velocity=(0.0, 0.1, 0.0), drift=(0.01, 0.0, 0.0)))
    assert [(p["drift"], p["speed"]) for p in log.window_at(1.0)] == [(None, 0.3), (0.01, 0.1)]


def test_the_prediction_reaches_the_screen_with_its_interval_and_its_rule(model):
    """Issue 30 item 5: the controller's prediction travels through the log's sample (every 5 s of its claim)
    to the screen: the time to limit with its interval ("face in 42 s at the earliest, 65 s on the mean track":
    the mean track's crossing is no upper bound, so not written as a range), whether it is used (trusted) or
    only shown, the predicted track and band for the top view, and the rule that raised the level in words."""
    from loadarm.guidance.estimator import Estimate
    from loadarm.guidance.modes import Command, Mode
    from loadarm.guidance.predict import Forecast
    from loadarm.hmi.state import forecast_state, prediction_state
    from loadarm.sim.snapshot import snapshot, state_sample

    h = np.arange(1, 121, dtype=float)
    mean = np.array([13.0, 1.0, 0.5]) + 0.01 * h[:, None] * np.array([1.0, 0.0, 0.0])
    lo, hi = mean - 0.2, mean + 0.2
    lo[60:], hi[60:] = np.nan, np.nan
    fc = Forecast(h, mean, lo, hi, 60.0, 99.0, "online AR")
    cmd = Command(Mode.ALARM1, (0.0, 0.0, 0.0), True, True, False, horizon=65.0, route="design drift",
                  prediction=fc, predicted=(42.0, 65.0), rule="prediction", trusted=True, moorings="holding")
    est = Estimate(t=1.0, position=(13.0, 1.0, 0.5), velocity=(0.0, 0.0, 0.0), sigma=0.01, age=0.0, healthy=True,
                   reason="")
    sample = state_sample(cmd, (0.0, 1.0, 1.5), est, 0.0, False, {})
    p = sample["prediction"]
    assert p["claimed"] == 60.0 and p["h"] == [5.0 * k for k in range(1, 13)] and p["trusted"] is True
    assert p["ttl"] == [42.0, 65.0] and len(p["mean"]) == 12
    snap = snapshot(model, 1, 100.0, "ALARM1", json.loads(json.dumps(sample)))
    f = forecast_state(snap, model)
    assert f["prediction"]["state"] == "trusted"
    assert f["prediction"]["text"] == "prediction: face in 42 s at the earliest, 65 s on the mean track"
    assert f["prediction"]["moorings"] == "moorings holding" and not f["prediction"]["moorings_abnormal"]
    assert f["rule_words"] == "prediction"
    assert len(f["prediction"]["track"]) == 12 and len(f["prediction"]["band"]) == 12
    x0, y0, x1, y1 = f["prediction"]["band"][0]
    assert x0 < mean[4, 0] < x1 and y0 < mean[4, 1] < y1
    assert prediction_state(None, True)["state"] == "none"
    assert prediction_state({**p, "trusted": False}, True)["text"].startswith("prediction (not used): ")
    gone = prediction_state({**p, "trusted": False, "unused": "departed"}, True)
    assert gone["why"] == "the track left its intervals" and gone["why_abnormal"] is True
    short = prediction_state({**p, "trusted": False, "unused": "short"}, True)
    assert short["why"] == "claimed short of ESD-1's lead" and short["why_abnormal"] is False
    assert prediction_state({**p, "trusted": True, "unused": ""}, True)["why"] == ""
    assert prediction_state({**p, "trusted": False, "unused": "departed"}, False)["why"] == ""   # not connected
    no_face = prediction_state({**p, "ttl": [None, None]}, True)
    assert no_face["text"] == "prediction: no face within 60 s" and no_face["moorings"] == "no mooring load monitoring"
    lost = prediction_state({**p, "trusted": False}, True, "lost")
    assert lost["moorings"] == "MOORINGS LOST: lines slack" and lost["moorings_abnormal"] is True
    silent = prediction_state(None, True, "silent")        # said even with no prediction: the witness's state
    assert silent["moorings"] == "mooring load monitoring silent" and silent["moorings_abnormal"] is True
    off = prediction_state(p, False, "lost")                # not connected: nothing to say of the moorings
    assert off["text"] == "prediction (not used): face in 42 s at the earliest, 65 s on the mean track" and off["moorings"] == ""
    assert off["moorings_abnormal"] is False


def test_the_screen_s_band_holds_the_mean_track_as_the_rule_s_box_does():
    """An edge calibrated inside the mean (nearly all of a window's errors of one sign: a negative multiplier)
    would draw the band to one side of its track; the sample's band holds the mean, as the rule's box does
    (``monitor.predicted_crossing``), and keeps the other edge and the beyond-the-claim NaN as they are (found by
    review)."""
    from loadarm.guidance.predict import Forecast
    from loadarm.sim.snapshot import prediction_sample

    h = np.arange(1, 121, dtype=float)
    mean = np.array([13.0, 1.0, 0.5]) + 0.01 * h[:, None] * np.array([1.0, 0.0, 0.0])
    lo, hi = mean + 0.05, mean + 0.3                       # the lower edge above the mean on every axis
    lo[60:], hi[60:] = np.nan, np.nan
    p = prediction_sample(Forecast(h, mean, lo, hi, 60.0, 99.0, "online AR"), (42.0, 65.0), True)
    got_lo, got_hi, got_mean = (np.array(p[k]) for k in ("lo", "hi", "mean"))
    assert np.all(got_lo <= got_mean) and np.all(got_mean <= got_hi)
    assert np.allclose(got_lo, got_mean) and np.allclose(got_hi, hi[4:60:5].round(4))
    assert np.all(np.isfinite(got_lo)) and len(got_lo) == 12
