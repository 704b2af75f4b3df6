"""``loadarm user add | list | remove | passwd`` (issue 29, item 15): each change logged to the event log, and
effective at once on a running screen (a removed user's cookie is refused at its next request)."""

from __future__ import annotations

import io
import json

import pytest

from loadarm.cli import main
from loadarm.opcua.security import LiveUsers, Role, StateDir

from .test_hmi import ORIGIN, FakeClock, FakeService


def _user(capsys, monkeypatch, *args, password=None):
    if password is not None:
        monkeypatch.setattr("sys.stdin", io.StringIO(password + "\n"))
    code = main(["user", *args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def test_add_list_passwd_remove_each_logged(capsys, monkeypatch, tmp_path):
    st, db = str(tmp_path / "st"), str(tmp_path / "ev.db")
    common = ["--state-dir", st, "--db", db]
    assert _user(capsys, monkeypatch, "add", "alice", "--role", "operator", "--password-stdin", *common,
                 password="pw-alice")[0] == 0
    assert _user(capsys, monkeypatch, "add", "bob", "--role", "viewer", "--password-stdin", *common,
                 password="pw-bob")[0] == 0
    code, out, _ = _user(capsys, monkeypatch, "list", "--state-dir", st, "--json")
    assert code == 0 and json.loads(out) == [{"user": "alice", "role": "operator"}, {"user": "bob", "role": "viewer"}]
    code, out, _ = _user(capsys, monkeypatch, "list", "--state-dir", st)
    assert code == 0 and "alice" in out and "operator" in out and "scrypt" not in out
    code, out, _ = _user(capsys, monkeypatch, "passwd", "alice", "--password-stdin", *common, password="pw-new")
    assert code == 0 and "password of alice (operator) changed" in out
    users = StateDir(st).users()
    assert users.authenticate("alice", "pw-new") and not users.authenticate("alice", "pw-alice")
    code, out, _ = _user(capsys, monkeypatch, "remove", "bob", *common)
    assert code == 0 and "user bob (viewer) removed" in out and StateDir(st).users().names() == ["alice"]
    assert main(["log", "--db", db, "--run", "users", "--json"]) == 0
    events = json.loads(capsys.readouterr().out)
    assert [(e["kind"], e["data"]["code"], e["data"]["user"]) for e in events] == [
        ("security", "security.user_added", "alice"), ("security", "security.user_added", "bob"),
        ("security", "security.password_changed", "alice"), ("security", "security.user_removed", "bob")]
    assert all(e["data"]["by"] and e["wall"] for e in events) and "pw-" not in json.dumps(events)


@pytest.mark.parametrize("args", [["remove", "carol"], ["passwd", "carol", "--password-stdin"]])
def test_an_unknown_user_is_refused_in_one_line_and_nothing_is_logged(capsys, monkeypatch, tmp_path, args):
    st, db = tmp_path / "st", tmp_path / "ev.db"
    StateDir(st).users().add("alice", Role.OPERATOR, "pw")
    code, out, err = _user(capsys, monkeypatch, *args, "--state-dir", str(st), "--db", str(db), password="x")
    assert code == 2 and out == "" and err.count("\n") == 1 and "no user 'carol'" in err and "alice" in err
    assert not db.exists()


def test_a_change_that_cannot_be_logged_is_not_made(capsys, monkeypatch, tmp_path):
    st = tmp_path / "st"
    StateDir(st).users().add("alice", Role.OPERATOR, "pw")
    foreign = tmp_path / "notes.txt"
    foreign.write_text("not an event log")
    code, _, err = _user(capsys, monkeypatch, "remove", "alice", "--state-dir", str(st), "--db", str(foreign))
    assert code == 2 and err.count("\n") == 1 and StateDir(st).users().names() == ["alice"]


def test_live_users_follow_the_file(tmp_path):
    st = StateDir(tmp_path / "st")
    st.users().add("alice", Role.OPERATOR, "pw")
    live = LiveUsers(st.users_file)
    before = live.stamp("alice")
    assert before and live.authenticate("alice", "pw")
    st.users().add("bob", Role.VIEWER, "pw-bob")
    assert live.authenticate("bob", "pw-bob") and live.stamp("alice") == before      # a new user: no restart
    st.users().set_password("alice", "pw2")
    assert live.stamp("alice") != before
    st.users_file.write_text("[users.alice]\nrole = 'nobody'\n")          # a hand edit gone wrong: the last valid
    assert live.authenticate("bob", "pw-bob")
    st.users_file.unlink()
    assert len(live) == 0 and live.stamp("bob") is None


@pytest.fixture
def screen(tmp_path, model):
    from fastapi.testclient import TestClient

    from loadarm.hmi.app import create_app

    st = StateDir(tmp_path / "state")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    st.users().add("victor", Role.VIEWER, "pw-victor")
    service = FakeService()
    app = create_app(service, st.path, model, clock=FakeClock(), wall=FakeClock(1.8e9), frame_rate=100.0,
                     name="test")
    return st, service, TestClient(app), TestClient(app)


def _login(client, user, password):
    r = client.post("/api/login", json={"user": user, "password": password})
    assert r.status_code == 200, r.text


@pytest.mark.parametrize("change", ["remove", "passwd"])
def test_a_removed_user_s_cookie_is_refused_at_the_next_request(capsys, monkeypatch, screen, change):
    """Removal (and a password change) ends the user's open sessions at once: the next HTTP request is not
    logged in, the WebSocket closes, the old password no longer logs in; another user's session goes on."""
    from starlette.websockets import WebSocketDisconnect

    st, service, alice, victor = screen
    _login(alice, "alice", "pw-alice")
    _login(victor, "victor", "pw-victor")
    assert alice.get("/api/session").json()["user"] == "alice"
    with pytest.raises(WebSocketDisconnect) as closed:
        with alice.websocket_connect("/ws", headers=ORIGIN) as ws:
            assert json.loads(ws.receive_text())
            args = ["remove", "alice"] if change == "remove" else ["passwd", "alice", "--password-stdin"]
            code, _, err = _user(capsys, monkeypatch, *args, "--state-dir", str(st.path), "--db",
                                 str(st.path.parent / "ev.db"), password="pw-other")
            assert code == 0, err
            service.step(t=1.0)
            while True:                 # the trend of the frame before may come; a frame after it may not
                assert json.loads(ws.receive_text())["type"] != "state", "a frame after the user was removed"
    assert closed.value.code == 4401
    assert alice.get("/api/session").json()["user"] is None and alice.get("/api/geometry").status_code == 401
    assert alice.post("/api/login", json={"user": "alice", "password": "pw-alice"}).status_code == 401
    assert victor.get("/api/session").json()["user"] == "victor"
    if change == "passwd":
        _login(alice, "alice", "pw-other")
        assert alice.get("/api/session").json()["user"] == "alice"
