"""Logins and sessions of the operator's screen: the OPC UA server's users file and roles, a session token in an
HttpOnly, SameSite=Strict cookie, a CSRF token per session that every command carries, and a limit on failed
logins (:class:`loadarm.opcua.security.LoginLimiter`, the OPC UA server's too). The clock is injected (tests
pass a fake)."""

from __future__ import annotations

import hmac
import secrets
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from loadarm.opcua.security import LOGIN_FAILURES, LOGIN_WINDOW, SECRET_BYTES, LoginLimiter, Role

__all__ = ["COOKIE", "SESSION_IDLE", "LOGIN_FAILURES", "LOGIN_WINDOW", "SECRET_BYTES", "Session", "Sessions",
           "LoginLimiter"]

#: The session cookie's name.
COOKIE = "loadarm_session"
#: A session unused this long ends, s (a shift).
SESSION_IDLE = 8 * 3600.0


@dataclass
class Session:
    """One logged-in user: name, role, the CSRF token the page sends with each command, last use (clock s), and
    the sequence number of its last command (each command's must be higher: a captured command cannot be
    replayed)."""

    user: str
    role: Role
    csrf: str
    last: float
    last_cmd: int = 0
    stamp: str | None = None
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)

    def csrf_ok(self, token) -> bool:
        """The token is this session's (constant-time)."""
        return isinstance(token, str) and hmac.compare_digest(token.encode(), self.csrf.encode())

    def take_seq(self, seq) -> str | None:
        """Take a command's sequence number: None when it is an integer above the session's last (it becomes the
        last), else why it is refused."""
        if isinstance(seq, bool) or not isinstance(seq, int) or not 0 < seq < 2 ** 53:
            return f"a command needs an integer sequence number in [1, 2^53), got {seq!r}"
        with self._lock:
            if seq <= self.last_cmd:
                return (f"sequence number {seq} is not above this session's last command's ({self.last_cmd}): "
                        "a replayed command")
            self.last_cmd = seq
        return None


class Sessions:
    """Session tokens to sessions (thread-safe; the server's event loop and tests share it).

    Given the users (:class:`loadarm.opcua.security.LiveUsers`, the file as it is now), a session lasts only while
    its user's entry is the one it was opened under: a user removed (``loadarm user remove``), a password changed
    or a user added again ends the user's sessions at their next request, the screen's WebSocket included.
    """

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, idle: float = SESSION_IDLE, users=None):
        self.clock, self.idle, self.users = clock, idle, users
        self._by_token: dict[str, Session] = {}
        self._lock = threading.Lock()

    def open(self, user: str, role: Role) -> tuple[str, Session]:
        """A new session: its token (for the cookie) and itself."""
        token = secrets.token_urlsafe(32)
        stamp = None if self.users is None else self.users.stamp(user)
        s = Session(user, role, secrets.token_urlsafe(32), self.clock(), stamp=stamp)
        with self._lock:
            self._by_token[token] = s
        return token, s

    def get(self, token: str | None) -> Session | None:
        """The live session of a token, its last use renewed (None: no such session, it expired, or its user was
        removed or changed)."""
        if not token:
            return None
        now = self.clock()
        stamps = None if self.users is None else self.users.current()
        with self._lock:
            s = self._by_token.get(token)
            if s is None:
                return None
            if now - s.last > self.idle or (stamps is not None and stamps.stamp(s.user) != s.stamp):
                del self._by_token[token]
                return None
            s.last = now
            return s

    def close(self, token: str | None) -> None:
        with self._lock:
            self._by_token.pop(token or "", None)
