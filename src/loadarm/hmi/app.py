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

from loadarm.opcua.security import StateDir
from loadarm.vocab import COMMANDS, TAGGED_ACTIONS
from loadarm.hmi.sessions import COOKIE, LoginLimiter, Sessions
from loadarm.hmi.state import AlarmBook, frame, geometry
from loadarm.opcua.service import JOG_HOLD, Request

__all__ = ["COMMANDS", "FRAME_RATE", "create_app", "HmiServer", "parse_hmi_address"]

#: Frames per second pushed to each screen (at most: a frame goes only when the controller has a new cycle).
FRAME_RATE = 20.0
#: A frame is sent at least this often even if the controller's cycle did not change, s (the page's own
#: watchdog then tells a stalled controller from a dropped link by the sequence number).
KEEPALIVE = 0.25

_CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
        "frame-ancestors 'none'; base-uri 'none'; form-action 'self'")


def _static_dir() -> Path:
    return Path(str(resources.files("loadarm.hmi") / "static"))


def create_app(service, state_dir, model, *, clock: Callable[[], float] = time.monotonic,
               wall: Callable[[], float] = time.time, frame_rate: float = FRAME_RATE, name: str = "loadarm"):
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

    Returns
    -------
    FastAPI
    """
    from fastapi import FastAPI, Request as HttpRequest, WebSocket, WebSocketDisconnect
    from fastapi.responses import FileResponse, JSONResponse
    from fastapi.staticfiles import StaticFiles


    state = StateDir(state_dir)
    users = state.users()
    sessions, limiter, book = Sessions(clock=clock), LoginLimiter(clock=clock), AlarmBook()
    geo = geometry(model)
    cache: dict = {"seq": None, "alarms": []}
    lock = threading.Lock()
    app = FastAPI(title=f"loadarm HMI ({name})", docs_url=None, redoc_url=None, openapi_url=None)
    app.state.sessions, app.state.book = sessions, book

    @app.middleware("http")
    async def headers(request, call_next):
        response = await call_next(request)
        response.headers["Content-Security-Policy"] = _CSP
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Referrer-Policy"] = "no-referrer"
        response.headers["Cache-Control"] = "no-store"
        return response

    def current(request) -> tuple[str | None, object]:
        token = request.cookies.get(COOKIE)
        return token, sessions.get(token)

    replay = hasattr(service, "new_cursor")        # a logged run (loadarm.hmi.replay): no commands, a slider

    def session_json(s) -> dict:
        return {"user": s.user, "role": s.role.name.lower(), "csrf": s.csrf, "name": name, "replay": replay,
                "commands": [] if replay else sorted(c for c, r in COMMANDS.items() if s.role >= r)}

    @app.get("/")
    async def index():
        return FileResponse(_static_dir() / "index.html", media_type="text/html")

    @app.get("/api/session")
    async def get_session(request: HttpRequest):
        _, s = current(request)
        if s is None:                     # not an error: the page shows the login (no console error either)
            return {"user": None, "name": name}
        return session_json(s)

    @app.post("/api/login")
    async def login(request: HttpRequest):
        try:
            body = await request.json()
            user, password = body["user"], body["password"]
            if not isinstance(user, str) or not isinstance(password, str):
                raise TypeError
        except (ValueError, KeyError, TypeError):
            return JSONResponse({"detail": "send {\"user\": ..., \"password\": ...}"}, status_code=400)
        client = request.client.host if request.client else "?"
        wait = limiter.blocked(user, client)
        if wait > 0:
            return JSONResponse({"detail": f"too many failed logins: try again in {math.ceil(wait)} s"},
                                status_code=429, headers={"Retry-After": str(math.ceil(wait))})
        who = await asyncio.to_thread(users.authenticate, user, password)     # scrypt: off the event loop
        if who is None:
            limiter.failed(user, client)
            return JSONResponse({"detail": "wrong user name or password"}, status_code=401)
        limiter.succeeded(user)
        token, s = sessions.open(who.name, who.role)
        response = JSONResponse(session_json(s))
        response.set_cookie(COOKIE, token, httponly=True, samesite="strict", path="/",
                            secure=request.url.scheme == "https")
        return response

    @app.post("/api/logout")
    async def logout(request: HttpRequest):
        token, s = current(request)
        if s is None or not s.csrf_ok(request.headers.get("X-CSRF-Token")):
            return JSONResponse({"detail": "not logged in, or no CSRF token"}, status_code=403)
        sessions.close(token)
        response = JSONResponse({"detail": "logged out"})
        response.delete_cookie(COOKIE, path="/")
        return response

    @app.get("/api/geometry")
    async def get_geometry(request: HttpRequest):
        if current(request)[1] is None:
            return JSONResponse({"detail": "not logged in"}, status_code=401)
        return geo

    def alarms_for(snap):
        with lock:
            if cache["seq"] != snap.seq:
                raised = service.raised_at(snap) if replay else None
                cache["seq"], cache["alarms"] = snap.seq, book.update(snap.t, snap.alarms, raised)
            return cache["alarms"]

    def command(s, msg: dict) -> tuple[bool, str]:
        """One command from a screen: checked (CSRF, role, arguments), then queued to the controller."""
        action = msg.get("action")
        if not s.csrf_ok(msg.get("csrf")):
            return False, "refused: no valid CSRF token"
        if replay:
            return False, "refused: a replay takes no command"
        if action not in COMMANDS:
            return False, f"unknown command {action!r}"
        if s.role < COMMANDS[action]:
            return False, f"refused: {action} needs the {COMMANDS[action].name.lower()} role, " \
                          f"{s.user} is {s.role.name.lower()}"
        tag = (msg.get("tag") or "") if action in TAGGED_ACTIONS else ""
        try:
            jog = tuple(float(v) for v in msg.get("jog", (0.0, 0.0, 0.0)))
            req = Request(action, s.user, jog if action == "jog" else (0.0, 0.0, 0.0), tag=tag)
        except (TypeError, ValueError) as exc:
            return False, f"refused: {exc}"
        snap = service.snapshot()
        if action == "shelve":
            why = book.shelve(tag, snap.t if snap else 0.0, msg.get("seconds"), snap.alarms if snap else {})
            if why:
                return False, f"refused: {why}"
        elif action == "unshelve":
            why = book.unshelve(tag)
            if why:
                return False, f"refused: {why}"
        with lock:
            cache["seq"] = None                       # the next frame shows the shelving
        service.request(req)
        return True, f"{action} sent" + (f" ({tag})" if tag else "")

    @app.websocket("/ws")
    async def ws(websocket: WebSocket):
        s = sessions.get(websocket.cookies.get(COOKIE))
        origin, host = websocket.headers.get("origin"), websocket.headers.get("host")
        if s is None or origin is None or origin.split("://", 1)[-1] != host:
            await websocket.close(code=4403)          # not logged in, or a page of another origin
            return
        await websocket.accept()
        jogging = {"until": -math.inf}
        cursor = service.new_cursor() if replay else None      # each screen moves its own slider
        token = websocket.cookies.get(COOKIE)

        async def push():
            last_seq, last_sent = None, -math.inf
            while True:
                snap = service.snapshot(cursor) if replay else service.snapshot()
                now = time.monotonic()
                if snap is not None and (snap.seq != last_seq or now - last_sent >= KEEPALIVE):
                    if sessions.get(token) is None:       # the session ended (logout, idle): no more frames
                        await websocket.close(code=4401)
                        return
                    f = frame(snap, model, alarms_for(snap), sent_at=wall())
                    if replay:
                        f["replay"] = cursor.state()
                    await websocket.send_text(json.dumps(f))
                    last_seq, last_sent = snap.seq, now
                await asyncio.sleep(1.0 / frame_rate)

        sender = asyncio.create_task(push())
        try:
            while True:
                text = await websocket.receive_text()
                try:
                    msg = json.loads(text)
                    seq = msg.get("seq") if isinstance(msg, dict) else None
                    if replay and isinstance(msg, dict) and msg.get("type") in ("seek", "play", "pause"):
                        ok, message = _replay_control(cursor, msg)
                        await websocket.send_text(json.dumps({"type": "ack", "seq": seq, "ok": ok,
                                                              "message": message}))
                        continue
                    if not isinstance(msg, dict) or msg.get("type") != "cmd":
                        raise ValueError
                except ValueError:
                    await websocket.send_text(json.dumps({"type": "ack", "seq": None, "ok": False,
                                                          "message": "not a command"}))
                    continue
                if sessions.get(websocket.cookies.get(COOKIE)) is None:
                    await websocket.send_text(json.dumps({"type": "ack", "seq": seq, "ok": False,
                                                          "message": "session ended: log in again"}))
                    break
                ok, message = command(s, msg)
                if ok and msg.get("action") == "jog":
                    jogging["until"] = time.monotonic() + JOG_HOLD
                elif ok and msg.get("action") in ("stop", "estop"):
                    jogging["until"] = -math.inf
                await websocket.send_text(json.dumps({"type": "ack", "seq": seq, "ok": ok, "message": message}))
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()
            if time.monotonic() < jogging["until"]:   # the dead-man: a screen that drops mid-jog stops it
                service.request(Request("stop", s.user))

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
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"--hmi port must be in [0, 65535], got {port!r}")
    return host, int(port)


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
                                                     ws="websockets-sansio", access_log=False))
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

    def stop(self) -> None:
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(10)
