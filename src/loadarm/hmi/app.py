"""The operator's web screen: a FastAPI application (login, session cookie, CSRF, a WebSocket of live frames and
commands) over a :class:`loadarm.opcua.service.GuidanceService`, and :class:`HmiServer`, uvicorn in its own
thread (the guidance loop keeps its thread; nothing here blocks the event loop: the service's snapshot is a
reference read and its requests go through a queue).

Every asset is in the package (``static/``): no CDN, no external font. The page's Content-Security-Policy
allows its own origin only."""


import asyncio
import json
import math
import socket
import threading
import time
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from urllib.parse import urlsplit

from loadarm.hmi.sessions import COOKIE, SECRET_BYTES, LoginLimiter, Sessions
from loadarm.hmi.state import JOURNAL_KINDS, AlarmBook, frame, geometry, journal_entry
from loadarm.opcua.security import LiveUsers, StateDir, is_user_name
from loadarm.opcua.service import JOG_HOLD, Request, parse_jog
from loadarm.vocab import COMMANDS, TAGGED_ACTIONS

__all__ = ["COMMANDS", "FRAME_RATE", "LOGIN_BODY", "LoginScreen", "ack", "create_app", "screen_app", "HmiServer",
           "parse_hmi_address", "same_origin", "valid_host"]

#: Frames per second pushed to each screen (at most: a frame goes only when the controller has a new cycle).
FRAME_RATE = 20.0
#: On stop, open connections (a screen's WebSocket) get this long to close, s; then they are cut (a Ctrl-C of
#: ``loadarm serve`` ends the process within seconds, whatever a browser does).
STOP_GRACE = 2.0
#: A frame is sent at least this often even if the controller's cycle did not change, s (the page's own
#: watchdog then tells a stalled controller from a dropped link by the sequence number).
KEEPALIVE = 0.25

#: The largest login request body, bytes (a user name and a password of :data:`SECRET_BYTES` each, in JSON).
LOGIN_BODY = 4 * SECRET_BYTES
#: The largest WebSocket message a screen may send, bytes (a command is a few hundred).
WS_MESSAGE = 4096
#: Commands taken whatever their sequence number: repeating one is harmless, refusing one is not (found: a tab
#: behind another tab's numbers had its E-stop refused as a replay).
UNNUMBERED = ("stop", "estop", "esd")

_CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
        "frame-ancestors 'none'; base-uri 'none'; form-action 'self'")


def _static_dir() -> Path:
    return Path(str(resources.files("loadarm.hmi") / "static"))


def ack(seq, ok: bool, message: str, **extra) -> str:
    """A screen's acknowledgement of a message it sent on the WebSocket (JSON text, ``type`` "ack").

    Parameters
    ----------
    seq : int or None
        The message's sequence number (None when it had none, or was no JSON).
    ok : bool
        Whether it was taken.
    message : str
        What was done, or why not.
    **extra
        More fields: ``last_seq`` (a stale sequence number's refusal), ``cycle`` (a command taken: the
        controller's last published cycle when it was queued; the cycle after the next takes it at the latest,
        the one under way then may finish without it).

    Returns
    -------
    str
    """
    return json.dumps({"type": "ack", "seq": seq, "ok": ok, "message": message, **extra})


def _json_error(detail: str, status: int, headers: dict | None = None):
    from fastapi.responses import JSONResponse

    return JSONResponse({"detail": detail}, status_code=status, headers=headers)


def same_origin(origin: str | None, host: str | None, scheme: str) -> bool:
    """Whether a request's ``Origin`` is the server's own: the same scheme, host and port exactly (found: the
    scheme was ignored and ``evil://HOST`` passed).

    Parameters
    ----------
    origin : str or None
        The ``Origin`` header.
    host : str or None
        The ``Host`` header.
    scheme : str
        The request's scheme: ``http`` or ``https`` (``ws`` and ``wss`` are taken as these).

    Returns
    -------
    bool
    """
    scheme = {"ws": "http", "wss": "https"}.get(scheme, scheme)
    default = {"http": 80, "https": 443}.get(scheme)
    if not origin or not host or default is None:
        return False
    try:
        o, h = urlsplit(origin), urlsplit(f"//{host}")
        if o.scheme != scheme or o.path or o.query or o.fragment or o.username or o.password or h.username:
            return False
        return bool(o.hostname) and o.hostname == h.hostname and (o.port or default) == (h.port or default)
    except ValueError:                                  # a port that is not one
        return False


class _RefusedBody(Exception):
    def __init__(self, detail: str, status: int):
        super().__init__(detail)
        self.detail, self.status = detail, status


async def _login_body(request) -> tuple[str, str]:
    """The user and password of a login: a same-origin JSON body of at most :data:`LOGIN_BODY` bytes, read no
    further than that (found: a cross-origin ``text/plain`` body logged in; a 5 MB password was hashed)."""
    origin = request.headers.get("origin")
    if origin is not None and not same_origin(origin, request.headers.get("host"), request.url.scheme):
        raise _RefusedBody("a login must come from this screen's own origin", 403)
    if request.headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
        raise _RefusedBody("a login must come from this screen's own origin", 403)
    if request.headers.get("content-type", "").split(";")[0].strip().lower() != "application/json":
        raise _RefusedBody("a login is a JSON body (Content-Type: application/json)", 415)
    length = request.headers.get("content-length", "0")
    if not length.isdigit() or int(length) > LOGIN_BODY:
        raise _RefusedBody(f"a login body may not exceed {LOGIN_BODY} bytes", 413)
    raw = bytearray()
    async for chunk in request.stream():
        raw += chunk
        if len(raw) > LOGIN_BODY:
            raise _RefusedBody(f"a login body may not exceed {LOGIN_BODY} bytes", 413)
    try:
        body = json.loads(raw)
        user, password = body["user"], body["password"]
        if not isinstance(user, str) or not isinstance(password, str):
            raise TypeError
        size = len(password.encode())           # a lone surrogate cannot be encoded: refused here, not a 500
    except (ValueError, KeyError, TypeError, RecursionError):     # found: "[" * 2000 raised RecursionError
        raise _RefusedBody("send {\"user\": ..., \"password\": ...} (UTF-8 text)", 400) from None
    if size > SECRET_BYTES:
        raise _RefusedBody(f"a password has at most {SECRET_BYTES} bytes", 400)
    return user, password


def _run_time(t) -> str:
    """A journal entry's run time as its search text (none: an event from outside the run)."""
    return "" if t is None else f"{t:.1f}"


class LoginScreen:
    """What every screen's routes share (the single arm's, the bank's): the users, the sessions, the login limit
    and the fixed drawing of one service. Each route is a method; :func:`screen_app` wires them. A screen adds
    :meth:`session_json` and :meth:`ws`.

    Parameters
    ----------
    service
        Its :meth:`note` (a security event) and its snapshots.
    state_dir : path
        The OPC UA server's state directory: its ``users.toml``.
    clock : callable
        Monotonic seconds, for sessions and the login limit.
    wall : callable
        Wall-clock seconds, stamped on each frame.
    frame_rate : float
        Frames per second to each screen.
    name : str
        Shown in the title.
    geo : dict
        The fixed drawing (JSON-ready), served to a logged-in screen.
    """

    def __init__(self, service, state_dir, clock, wall, frame_rate: float, name: str, geo: dict):
        self.service, self.wall, self.frame_rate, self.name, self.geo = service, wall, frame_rate, name, geo
        self.users = LiveUsers(StateDir(state_dir).users_file)       # the file as it is now (loadarm user)
        self.sessions = Sessions(clock=clock, users=self.users)          # a removed user's session ends at once
        self.limiter = LoginLimiter(clock=clock)

    def get_journal(self, request):
        """The alarm journal, newest first: ``kind`` one of :data:`loadarm.hmi.state.JOURNAL_KINDS`, ``q`` words
        to find (each, in any case), at most ``limit`` entries; ``total`` those that matched."""
        if self.current(request)[1] is None:
            return _json_error("not logged in", 401)
        p = request.query_params
        kinds = JOURNAL_KINDS.get(p.get("kind", "all"))
        if kinds is None:
            return _json_error(f"kind is one of {', '.join(JOURNAL_KINDS)}", 400)
        words = p.get("q", "")[:200].lower().split()
        limit = int(p.get("limit", "500")) if p.get("limit", "500").isdigit() else 500
        got = [e for e in self.journal() if e["kind"] in kinds
               and all(w in f"{e['clock']} {_run_time(e['t'])} {e['kind']} {e['tag'] or ''} {e['text']}".lower()
                       for w in words)]
        return {"entries": got[::-1][:limit], "total": len(got), "kinds": list(JOURNAL_KINDS)}

    def journal(self) -> list[dict]:
        """Every journal entry (:func:`loadarm.hmi.state.journal_entry`'s fields), oldest first: the screen's."""
        return []

    def current(self, request) -> tuple[str | None, object]:
        token = request.cookies.get(COOKIE)
        return token, self.sessions.get(token)

    def session_json(self, s) -> dict:
        """The session as the page gets it (the screen's own: its role's commands, its flags)."""
        raise NotImplementedError

    async def ws(self, websocket) -> None:
        """The screen's WebSocket: its frames out, the page's messages in."""
        raise NotImplementedError

    def get_session(self, request):
        _, s = self.current(request)
        if s is None:                     # not an error: the page shows the login (no console error either)
            return {"user": None, "name": self.name}
        return self.session_json(s)

    async def login(self, request):
        from fastapi.responses import JSONResponse

        try:
            user, password = await _login_body(request)
        except _RefusedBody as exc:
            return _json_error(exc.detail, exc.status)
        client = request.client.host if request.client else "?"
        name = user if is_user_name(user) else "<not a user name>"       # bounded before any use
        wait, ticket = self.limiter.begin(name, client)      # the slot is taken before the password is checked
        if wait > 0:
            self.note("security.login_limited", "screen login refused: too many failed logins", user=name,
                      client=client)
            return _json_error(f"too many failed logins: try again in {math.ceil(wait)} s", 429,
                               {"Retry-After": str(math.ceil(wait))})
        who = await asyncio.to_thread(self.users.authenticate, user, password) if is_user_name(user) else None
        if who is None:                                       # scrypt above: off the event loop
            self.note("security.login_refused", "screen login refused: wrong user name or password", user=name,
                      client=client)
            return _json_error("wrong user name or password", 401)
        self.limiter.succeeded(user, client, ticket)
        token, s = self.sessions.open(who.name, who.role)
        response = JSONResponse(self.session_json(s))
        response.set_cookie(COOKIE, token, httponly=True, samesite="strict", path="/",
                            secure=request.url.scheme == "https")
        return response

    def note(self, code: str, reason: str, **data) -> None:
        """A security event for the event log (the service writes it with the controller's events; a replay has
        no log to write to)."""
        self.service.note("security", reason, {"code": code, **data})

    def logout(self, request):
        from fastapi.responses import JSONResponse

        token, s = self.current(request)
        if s is None or not s.csrf_ok(request.headers.get("X-CSRF-Token")):
            return _json_error("not logged in, or no CSRF token", 403)
        self.sessions.close(token)
        response = JSONResponse({"detail": "logged out"})
        response.delete_cookie(COOKIE, path="/")
        return response

    def get_geometry(self, request):
        if self.current(request)[1] is None:
            return _json_error("not logged in", 401)
        return self.geo


class _Screen(LoginScreen):
    """The single arm's screen: its login (:class:`LoginScreen`), the alarm book and the frame cache of one
    service, its journal and its commands. :func:`create_app` wires it."""

    def __init__(self, service, state_dir, model, clock, wall, frame_rate: float, name: str, berth=None):
        super().__init__(service, state_dir, clock, wall, frame_rate, name, geometry(model, berth))
        self.model, self.book = model, AlarmBook()
        self.cache: dict = {"seq": None, "alarms": []}
        self.lock = threading.Lock()
        self.replay = hasattr(service, "new_cursor")      # a logged run (loadarm.hmi.replay): no commands, a slider
        self.anchor = getattr(service, "anchor", None)    # where the flange was first seen healthy (the ship's)

    def session_json(self, s) -> dict:
        return {"user": s.user, "role": s.role.name.lower(), "csrf": s.csrf, "name": self.name,
                "replay": self.replay, "last_seq": s.last_cmd, "jog_speed": self.service.jog_speed,
                "commands": [] if self.replay else sorted(c for c, r in COMMANDS.items() if s.role >= r)}

    def alarms_for(self, snap):
        with self.lock:
            if self.cache["seq"] != snap.seq:
                raised = self.service.raised_at(snap) if self.replay else None
                walls = self.service.raised_wall(snap) if self.replay else None
                self.cache["seq"], self.cache["alarms"] = snap.seq, self.book.update(
                    snap.t, snap.alarms, raised, wall=snap.wall, raised_wall=walls)
            if self.anchor is None and snap.estimate_healthy and all(map(math.isfinite, snap.flange_estimate)):
                self.anchor = tuple(snap.flange_estimate)
            return self.cache["alarms"]

    def trend(self, snap) -> list[dict]:
        """The trends' points up to ``snap`` (the last 10 minutes): the replay's from its log, the live
        service's from its cycles (none from a service that keeps none)."""
        if self.replay:
            return self.service.trend(snap.t)
        log = getattr(self.service, "trend", None)
        return [] if log is None else log.window_at(snap.t)

    def journal(self) -> list[dict]:
        """Every journal entry (:func:`loadarm.hmi.state.journal_entry`), oldest first: the replay's log, or the
        live run's events (what it writes to its log), each timed on the wall clock from the latest snapshot's
        (its run time back at the service's speed-up)."""
        now = self.wall()
        if self.replay:
            return self.service.journal(now)
        loop = getattr(self.service, "loop", None)
        snap = self.service.snapshot()
        if loop is None or snap is None:
            return []
        speed = getattr(self.service, "speedup", 1.0)
        base = snap.wall if math.isfinite(snap.wall) else None
        return [journal_entry(t, None if base is None else base - (snap.t - t) / speed, mode, kind, reason, data,
                              now)
                for t, mode, kind, reason, data in list(loop.events) if kind in JOURNAL_KINDS["all"]]

    def _refusal(self, s, msg: dict) -> str | None:
        """Why a screen's command is refused before it is built (CSRF, replay, unknown, role), or None."""
        action = msg.get("action")
        if not s.csrf_ok(msg.get("csrf")):
            return "refused: no valid CSRF token"
        if self.replay:
            return "refused: a replay takes no command"
        if action not in COMMANDS:
            return f"unknown command {action!r}"
        if s.role < COMMANDS[action]:
            return (f"refused: {action} needs the {COMMANDS[action].name.lower()} role, "
                    f"{s.user} is {s.role.name.lower()}")
        return None

    def _shelving(self, action: str, tag: str, msg: dict) -> str | None:
        """The alarm book's refusal of a shelve or unshelve, or None (other actions are not the book's)."""
        if action == "shelve":
            snap = self.service.snapshot()
            return self.book.shelve(tag, snap.t if snap else 0.0, msg.get("seconds"), snap.alarms if snap else {})
        if action == "unshelve":
            return self.book.unshelve(tag)
        return None

    def command(self, s, msg: dict) -> tuple[bool, str]:
        """One command from a screen: checked (CSRF, sequence number, role, arguments), then queued to the
        controller; a refusal is logged as a security event."""
        ok, message = self._command(s, msg)
        if not ok:
            self.note("security.command_refused", f"screen command of {s.user} refused: {message}",
                      user=s.user, action=str(msg.get("action"))[:64])
        return ok, message

    def _command(self, s, msg: dict) -> tuple[bool, str]:
        why = self._refusal(s, msg)
        if why:
            return False, why
        why = None if msg.get("action") in UNNUMBERED else s.take_seq(msg.get("seq"))
        if why:
            return False, f"refused: {why}"
        action = msg.get("action")
        tag = (msg.get("tag") or "") if action in TAGGED_ACTIONS else ""
        try:
            jog = parse_jog(msg.get("jog"), self.service.jog_speed) if action == "jog" else (0.0, 0.0, 0.0)
            req = Request(action, s.user, jog, tag=tag if isinstance(tag, str) else repr(tag))
        except (TypeError, ValueError) as exc:
            return False, f"refused: {exc}"
        why = self._shelving(action, tag, msg)
        if why:
            return False, f"refused: {why}"
        with self.lock:
            self.cache["seq"] = None                       # the next frame shows the shelving
        self.service.request(req)
        return True, f"{action} sent" + (f" ({tag})" if tag else "")

    async def push(self, websocket, cursor, token: str | None) -> None:
        """Frames to one screen, at most ``frame_rate`` a second, a keep-alive at least every ``KEEPALIVE``."""
        last_seq, last_sent, trended = None, -math.inf, None
        while True:
            snap = self.service.snapshot(cursor) if self.replay else self.service.snapshot()
            now = time.monotonic()
            if snap is not None and (snap.seq != last_seq or now - last_sent >= KEEPALIVE):
                if self.sessions.get(token) is None:       # the session ended (logout, idle): no more frames
                    await websocket.close(code=4401)
                    return
                f = frame(snap, self.model, self.alarms_for(snap), sent_at=self.wall(), anchor=self.anchor)
                if self.replay:
                    f["replay"] = self.service.replay_state(cursor)
                await websocket.send_text(json.dumps(f))
                trended = await self._send_trend(websocket, snap, trended)
                last_seq, last_sent = snap.seq, now
            await asyncio.sleep(1.0 / self.frame_rate)

    async def _send_trend(self, websocket, snap, last: float | None) -> float | None:
        """The trend points a screen has not had (``type`` "trend"): the new ones, or the whole window again
        (``reset``) when the run time went back or jumped (a replay's slider). Returns the last point's time."""
        points = self.trend(snap)
        if not points or points[-1]["t"] == last:
            return last
        new = [p for p in points if last is not None and p["t"] > last]
        reset = last is None or points[-1]["t"] < last or not new or new[0]["t"] - last > 2.5
        await websocket.send_text(json.dumps({"type": "trend", "reset": reset, "points": points if reset else new}))
        return points[-1]["t"]

    def message(self, s, text: str, cursor, jogging: dict, token: str | None) -> tuple[str, bool]:
        """One message from a screen and the reply it gets; True when the session has ended (stop listening)."""
        try:
            msg = json.loads(text)
            seq = msg.get("seq") if isinstance(msg, dict) else None
            if self.replay and isinstance(msg, dict) and msg.get("type") in ("seek", "play", "pause"):
                return ack(seq, *_replay_control(cursor, msg)), False
            if not isinstance(msg, dict) or msg.get("type") != "cmd":
                raise ValueError
        except (ValueError, RecursionError):             # found: "[" * 2000 ended the screen's handler
            return ack(None, False, "not a command"), False
        if self.sessions.get(token) is None:
            return ack(seq, False, "session ended: log in again"), True
        snap = None if self.replay else self.service.snapshot()      # before the queue: the bound is safe
        ok, message = self.command(s, msg)
        if ok and msg.get("action") == "jog":
            jogging["until"] = time.monotonic() + JOG_HOLD
        elif ok and msg.get("action") in ("stop", "estop"):
            jogging["until"] = -math.inf
        stale = not ok and "sequence number" in message   # the page adopts the session's last number
        extra = {"last_seq": s.last_cmd} if stale else {}
        if ok and snap is not None:
            extra["cycle"] = snap.seq
        return ack(seq, ok, message, **extra), False

    async def ws(self, websocket) -> None:
        from fastapi import WebSocketDisconnect

        s = self.sessions.get(websocket.cookies.get(COOKIE))
        origin, host = websocket.headers.get("origin"), websocket.headers.get("host")
        if s is None or not same_origin(origin, host, websocket.url.scheme):
            await websocket.close(code=4403)          # not logged in, or a page of another origin
            return
        await websocket.accept()
        jogging = {"until": -math.inf}
        cursor = self.service.new_cursor() if self.replay else None      # each screen moves its own slider
        token = websocket.cookies.get(COOKIE)
        sender = asyncio.create_task(self.push(websocket, cursor, token))
        try:
            ended = False
            while not ended:
                got = await websocket.receive()
                if got.get("type") == "websocket.disconnect":
                    break
                text = got.get("text")
                if text is None:
                    reply, ended = ack(None, False, "refused: a command is a JSON text message"), False
                elif len(text) > WS_MESSAGE:
                    reply, ended = ack(None, False, f"refused: a message may not exceed {WS_MESSAGE} "
                                                       "characters"), False
                else:
                    reply, ended = self.message(s, text, cursor, jogging, token)
                await websocket.send_text(reply)
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()
            if time.monotonic() < jogging["until"]:   # the dead-man: a screen that drops mid-jog stops it
                self.service.request(Request("stop", s.user))


def create_app(service, state_dir, model, *, clock: Callable[[], float] = time.monotonic,
               wall: Callable[[], float] = time.time, frame_rate: float = FRAME_RATE, name: str = "loadarm",
               berth=None):
    """The HMI's FastAPI application.

    Parameters
    ----------
    service : GuidanceService
        Its :meth:`snapshot` and :meth:`request` (anything with those two).
    state_dir : path
        The OPC UA server's state directory: its ``users.toml`` (the same users and roles).
    model : ArmModel
    clock : callable
        Monotonic seconds, for sessions and the login limit (injected: tests pass a fake).
    wall : callable
        Wall-clock seconds, stamped on each frame.
    frame_rate : float
        Frames per second to each screen.
    name : str
        Shown in the title.
    berth : loadarm.params.berth.Berth, optional
        The ship the top view draws (default the design ship: :func:`loadarm.hmi.state.ship_outline`).

    Returns
    -------
    FastAPI
    """
    screen = _Screen(service, state_dir, model, clock, wall, frame_rate, name, berth)
    app = screen_app(screen, f"loadarm HMI ({name})", "index.html", ("/",),
                     {"/api/geometry": screen.get_geometry, "/api/journal": screen.get_journal})
    app.state.book = screen.book
    return app


def screen_app(screen: LoginScreen, title: str, page: str, paths: tuple[str, ...], gets: dict):
    """A screen's FastAPI application: the security headers (the page's Content-Security-Policy: its own origin
    only) on every response, its page, the session, login and logout, its JSON routes, its WebSocket (``/ws``)
    and the package's assets (``/static``).

    Parameters
    ----------
    screen : LoginScreen
        The routes' methods.
    title : str
        The application's title.
    page : str
        The page's file in ``static/``.
    paths : tuple of str
        Where the page is served.
    gets : dict
        Path -> the screen's method answering a GET there (it takes the request).

    Returns
    -------
    FastAPI
        With ``state.sessions`` the screen's sessions.
    """
    from fastapi import FastAPI, WebSocket
    from fastapi import Request as HttpRequest
    from fastapi.responses import FileResponse
    from fastapi.staticfiles import StaticFiles

    app = FastAPI(title=title, docs_url=None, redoc_url=None, openapi_url=None)
    app.state.sessions = screen.sessions

    @app.middleware("http")
    async def headers(request, call_next):
        response = await call_next(request)
        response.headers["Content-Security-Policy"] = _CSP
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Referrer-Policy"] = "no-referrer"
        response.headers["Cache-Control"] = "no-store"
        return response

    async def index():
        return FileResponse(_static_dir() / page, media_type="text/html")

    for path in paths:
        app.add_api_route(path, index, methods=["GET"])

    @app.get("/api/session")
    async def get_session(request: HttpRequest):
        return screen.get_session(request)

    @app.post("/api/login")
    async def login(request: HttpRequest):
        return await screen.login(request)

    @app.post("/api/logout")
    async def logout(request: HttpRequest):
        return screen.logout(request)

    def answer(method):
        async def get(request: HttpRequest):
            return method(request)
        return get

    for path, method in gets.items():
        app.add_api_route(path, answer(method), methods=["GET"])

    @app.websocket("/ws")
    async def ws(websocket: WebSocket):
        await screen.ws(websocket)

    app.mount("/static", StaticFiles(directory=_static_dir()), name="static")
    return app


def _replay_control(cursor, msg: dict) -> tuple[bool, str]:
    """A replay's slider and buttons on one screen's cursor: seek to a run time, play at a speed, pause."""
    try:
        if msg["type"] == "seek":
            cursor.seek(msg.get("t"))
        elif msg["type"] == "play":
            cursor.play(msg.get("speed", 1.0))
        else:
            cursor.pause()
    except ValueError as exc:
        return False, f"refused: {exc}"
    return True, f"{msg['type']} at {cursor.cursor():.1f} s"


def parse_hmi_address(text: str) -> tuple[str, int]:
    """The address of ``--hmi``.

    Parameters
    ----------
    text : str
        ``HOST:PORT`` (``[::1]:PORT`` for IPv6).

    Returns
    -------
    host : str
    port : int

    Raises
    ------
    ValueError
        Naming what is wrong.
    """
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise ValueError(f"--hmi must be HOST:PORT (e.g. 127.0.0.1:8080), got {text!r}")
    bracketed = host.startswith("[") and host.endswith("]")
    host = host[1:-1] if bracketed else host
    if not valid_host(host, ipv6=bracketed):             # found: '[::1' was reported only after a 15 s lookup
        raise ValueError(f"--hmi must be HOST:PORT with HOST an IPv4 address, a host name or [IPv6], got {text!r}")
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"--hmi port must be in [0, 65535], got {port!r}")
    return host, int(port)


def valid_host(host: str, *, ipv6: bool = False) -> bool:
    """Whether ``host`` is an IP address or a host name by its form (checked before any lookup: a malformed one,
    such as ``256.1.1.1``, otherwise waits for the resolver).

    Parameters
    ----------
    host : str
    ipv6 : bool
        It was written in brackets: an IPv6 address.

    Returns
    -------
    bool
    """
    import ipaddress
    import re

    try:
        addr = ipaddress.ip_address(host)
        return addr.version == (6 if ipv6 else 4)
    except ValueError:
        pass
    if ipv6 or re.fullmatch(r"[0-9.]+", host):          # digits and dots that are no IPv4 address
        return False
    return re.fullmatch(r"(?=.{1,253}$)([A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?\.?)+", host) is not None


class HmiServer:
    """uvicorn serving the HMI in its own thread, on a socket bound here (port 0: an ephemeral one).

    Parameters
    ----------
    app : FastAPI
    host : str
        Loopback unless told otherwise.
    port : int
    """

    def __init__(self, app, host: str = "127.0.0.1", port: int = 8080):
        self.app, self.host, self.port = app, host, port
        self._server = None
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def start(self) -> None:
        import uvicorn

        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise OSError(f"--hmi {self.host}:{self.port}: {exc.strerror}") from None
        sock.listen(64)
        self.port = sock.getsockname()[1]
        self._server = uvicorn.Server(uvicorn.Config(self.app, log_level="warning", lifespan="off",
                                                     ws="websockets-sansio", access_log=False,
                                                     ws_max_size=16 * WS_MESSAGE, h11_max_incomplete_event_size=16384,
                                                     timeout_graceful_shutdown=STOP_GRACE))
        started = threading.Event()

        def run():
            try:
                loop = asyncio.new_event_loop()
                asyncio.set_event_loop(loop)
                task = loop.create_task(self._server.serve(sockets=[sock]))
                loop.call_soon(started.set)
                loop.run_until_complete(task)
            except BaseException as exc:          # reported to the caller
                self.error = exc
                started.set()
            finally:
                sock.close()

        self._thread = threading.Thread(target=run, name="loadarm-hmi", daemon=True)
        self._thread.start()
        started.wait(10)
        t0 = time.monotonic()
        while not self._server.started and self.error is None and time.monotonic() - t0 < 10:
            time.sleep(0.01)
        if self.error is not None:
            raise self.error

    def stop(self, timeout: float = 2 * STOP_GRACE) -> None:
        """Stop serving: open connections get :data:`STOP_GRACE` s to finish, the thread ``timeout`` s to end (a
        daemon: the process does not wait for it longer)."""
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout)
