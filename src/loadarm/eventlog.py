"""Durable event log: every mode change, alarm, command and operator action, in SQLite.

One table, one row per event, each committed in its own transaction in WAL
mode, so a process killed at any instant (``kill -9``) loses no committed
event. ``synchronous=FULL`` (default) also survives a power loss at the cost
of an fsync per event; ``NORMAL`` survives process crashes only and is
faster.

Times: ``t`` is the controller's clock (seconds, from the injected clock, so
a simulated run logs simulated time); ``wall`` is the wall-clock time of the
write (UTC, ISO 8601), for audits.
"""

from __future__ import annotations

import json
import math
import re
import sqlite3
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable

from .errors import LoadarmError

__all__ = ["Event", "EventLog", "EventLogError", "KINDS", "RateLimiter", "RATE_LIMITED_KINDS"]

#: Event kinds.
KINDS = ("mode", "alarm", "alarm_state", "command", "interlock", "operator", "sensor", "sample", "info")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS events (
    id     INTEGER PRIMARY KEY AUTOINCREMENT,
    run    TEXT    NOT NULL,
    t      REAL    NOT NULL,
    wall   TEXT    NOT NULL,
    state  TEXT    NOT NULL,
    kind   TEXT    NOT NULL,
    reason TEXT    NOT NULL,
    data   TEXT    NOT NULL DEFAULT '{}'
);
CREATE INDEX IF NOT EXISTS events_t ON events (run, t);
"""


class EventLogError(LoadarmError, ValueError):
    """The event log cannot be opened or an event is malformed."""


@dataclass(frozen=True, slots=True)
class Event:
    """One logged event.

    Attributes
    ----------
    id : int
        Sequence number (monotonic).
    run : str
        Run identifier.
    t : float
        Controller time, s.
    wall : str
        Wall-clock time of the write, ISO 8601 UTC.
    state : str
        Controller mode when the event happened.
    kind : str
        One of :data:`KINDS`.
    reason : str
        Human-readable cause.
    data : dict
        Extra values (JSON).
    """

    id: int
    run: str
    t: float
    wall: str
    state: str
    kind: str
    reason: str
    data: dict

    def as_dict(self) -> dict:
        """JSON-friendly form."""
        return {"id": self.id, "run": self.run, "t": self.t, "wall": self.wall, "state": self.state,
                "kind": self.kind, "reason": self.reason, "data": self.data}


class EventLog:
    """Append-only SQLite event log (WAL, one transaction per event).

    Parameters
    ----------
    path : str or Path
        Database file (created with its directory); ``":memory:"`` for tests.
    run : str
        Identifier written with every event of this writer.
    synchronous : {'FULL', 'NORMAL'}
        SQLite durability level.
    """

    def __init__(self, path: str | Path, *, run: str = "run", synchronous: str = "FULL"):
        if synchronous not in ("FULL", "NORMAL"):
            raise EventLogError(f"synchronous must be FULL or NORMAL, got {synchronous!r}")
        self.path = str(path)
        self.run = run
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        try:
            self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(f"PRAGMA synchronous={synchronous}")
            self._db.executescript(_SCHEMA)
        except sqlite3.DatabaseError as exc:
            raise EventLogError(f"{self.path}: cannot open event log ({exc})") from None

    def append(self, t: float, state: str, kind: str, reason: str, **data: Any) -> int:
        """Write one event and commit it before returning.

        Parameters
        ----------
        t : float
            Controller time, s.
        state : str
            Current mode.
        kind : str
            One of :data:`KINDS`.
        reason : str
            Cause, one line.
        **data
            JSON-serialisable extra values.

        Returns
        -------
        int
            The event's id.
        """
        if kind not in KINDS:
            raise EventLogError(f"event kind must be one of {', '.join(KINDS)}, got {kind!r}")
        wall = datetime.now(timezone.utc).isoformat(timespec="microseconds")
        cur = self._db.execute(
            "INSERT INTO events (run, t, wall, state, kind, reason, data) VALUES (?, ?, ?, ?, ?, ?, ?)",
            (self.run, float(t), wall, state, kind, reason, json.dumps(data, default=float)))
        return int(cur.lastrowid)

    def query(self, *, since: float | None = None, kinds: Iterable[str] | None = None,
              run: str | None = None) -> list[Event]:
        """Events in time order.

        Parameters
        ----------
        since : float, optional
            Only events with ``t >= since``, s.
        kinds : iterable of str, optional
            Only these kinds.
        run : str, optional
            Only this run.

        Returns
        -------
        list of Event
        """
        sql = "SELECT id, run, t, wall, state, kind, reason, data FROM events WHERE 1=1"
        args: list[Any] = []
        if since is not None:
            sql += " AND t >= ?"
            args.append(float(since))
        if kinds is not None:
            kinds = list(kinds)
            bad = [k for k in kinds if k not in KINDS]
            if bad:
                raise EventLogError(f"unknown event kind(s) {bad}; known: {', '.join(KINDS)}")
            sql += f" AND kind IN ({','.join('?' * len(kinds))})"
            args += kinds
        if run is not None:
            sql += " AND run = ?"
            args.append(run)
        sql += " ORDER BY id"
        return [Event(r[0], r[1], r[2], r[3], r[4], r[5], r[6], json.loads(r[7]))
                for r in self._db.execute(sql, args)]

    def close(self) -> None:
        """Close the database."""
        self._db.close()

    def __enter__(self) -> "EventLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @staticmethod
    def open_existing(path: str | Path) -> "EventLog":
        """Open a log that must already exist (for queries).

        Parameters
        ----------
        path : str or Path
            Database file.

        Returns
        -------
        EventLog

        Raises
        ------
        EventLogError
            If the file does not exist or is not an event log.
        """
        p = Path(path)
        if not p.is_file():
            raise EventLogError(f"{p}: no such event log")
        log = EventLog(p)
        try:
            log._db.execute("SELECT count(*) FROM events").fetchone()
        except sqlite3.DatabaseError as exc:  # pragma: no cover
            raise EventLogError(f"{p}: not an event log ({exc})") from None
        return log


#: Kinds whose repeats are rate-limited; safety events (mode, alarm, command, interlock, operator) never are.
RATE_LIMITED_KINDS = ("info", "sensor")

_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


class RateLimiter:
    """Let the first of a run of alike events through, then one line with the count per window.

    Two events are alike when their kind and their reason with every number blanked out are the same (a
    refusal that names a changing distance is one event repeated). Only :data:`RATE_LIMITED_KINDS` are
    limited, so a fault cannot flood the log with fsync'd lines while no alarm or command is ever dropped.

    Parameters
    ----------
    window : float
        Seconds after an alike event was let through during which its repeats are only counted.
    """

    def __init__(self, window: float = 10.0):
        if not (window > 0 and math.isfinite(window)):
            raise ValueError(f"window must be a positive number of seconds, got {window!r}")
        self.window = window
        self._open: dict = {}            # key -> [time let through, suppressed count]

    def admit(self, t: float, kind: str, reason: str) -> tuple[bool, int]:
        """Whether to write this event, and how many alike events were suppressed before it.

        Parameters
        ----------
        t : float
            Event time, s.
        kind, reason : str
            The event.

        Returns
        -------
        write : bool
            Write it.
        suppressed : int
            Alike events counted since the last one written (to say so in this one).
        """
        if kind not in RATE_LIMITED_KINDS:
            return True, 0
        key = (kind, _NUMBER.sub("#", reason))
        slot = self._open.get(key)
        if slot is None or t - slot[0] >= self.window:
            suppressed = 0 if slot is None else slot[1]
            self._open[key] = [t, 0]
            return True, suppressed
        slot[1] += 1
        return False, 0

