"""Logins and sessions of the operator's screen: the OPC UA server's users file and roles, a session token in an
HttpOnly, SameSite=Strict cookie, a CSRF token per session that every command carries, and a limit on failed
logins. The clock is injected (tests pass a fake)."""

from __future__ import annotations

import hmac
import secrets
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from loadarm.opcua.security import Role

__all__ = ["COOKIE", "SESSION_IDLE", "LOGIN_FAILURES", "LOGIN_WINDOW", "Session", "Sessions", "LoginLimiter"]

#: The session cookie's name.
COOKIE = "loadarm_session"
#: A session unused this long ends, s (a shift).
SESSION_IDLE = 8 * 3600.0
#: Failed logins allowed per user name and per client address in :data:`LOGIN_WINDOW`.
LOGIN_FAILURES = 5
#: The window of :data:`LOGIN_FAILURES`, s.
LOGIN_WINDOW = 60.0


@dataclass
class Session:
    """One logged-in user: name, role, the CSRF token the page sends with each command, last use (clock s)."""

    user: str
    role: Role
    csrf: str
    last: float

    def csrf_ok(self, token) -> bool:
        """The token is this session's (constant-time)."""
        return isinstance(token, str) and hmac.compare_digest(token.encode(), self.csrf.encode())


class Sessions:
    """Session tokens to sessions (thread-safe; the server's event loop and tests share it)."""

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, idle: float = SESSION_IDLE):
        self.clock, self.idle = clock, idle
        self._by_token: dict[str, Session] = {}
        self._lock = threading.Lock()

    def open(self, user: str, role: Role) -> tuple[str, Session]:
        """A new session: its token (for the cookie) and itself."""
        token = secrets.token_urlsafe(32)
        s = Session(user, role, secrets.token_urlsafe(32), self.clock())
        with self._lock:
            self._by_token[token] = s
        return token, s

    def get(self, token: str | None) -> Session | None:
        """The live session of a token, its last use renewed (None: no such session, or it expired)."""
        if not token:
            return None
        now = self.clock()
        with self._lock:
            s = self._by_token.get(token)
            if s is None:
                return None
            if now - s.last > self.idle:
                del self._by_token[token]
                return None
            s.last = now
            return s

    def close(self, token: str | None) -> None:
        with self._lock:
            self._by_token.pop(token or "", None)


class LoginLimiter:
    """At most :data:`LOGIN_FAILURES` failed logins per user name and per client in :data:`LOGIN_WINDOW`:
    beyond that a login is refused before its password is checked (429), until the window has passed."""

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, failures: int = LOGIN_FAILURES,
                 window: float = LOGIN_WINDOW):
        self.clock, self.failures, self.window = clock, failures, window
        self._fails: dict[str, list[float]] = {}
        self._lock = threading.Lock()

    def _recent(self, key: str, now: float) -> list[float]:
        kept = [t for t in self._fails.get(key, ()) if now - t < self.window]
        self._fails[key] = kept
        return kept

    def blocked(self, user: str, client: str) -> float:
        """Seconds until a login for ``user`` from ``client`` may be tried again (0: now)."""
        now = self.clock()
        with self._lock:
            wait = 0.0
            for key in (f"user:{user}", f"client:{client}"):
                recent = self._recent(key, now)
                if len(recent) >= self.failures:
                    wait = max(wait, self.window - (now - recent[0]))
            return wait

    def failed(self, user: str, client: str) -> None:
        now = self.clock()
        with self._lock:
            for key in (f"user:{user}", f"client:{client}"):
                self._recent(key, now).append(now)

    def succeeded(self, user: str) -> None:
        with self._lock:
            self._fails.pop(f"user:{user}", None)
