"""Durable event log: every mode change, alarm, command and operator action, in SQLite.

One table, one row per event, in WAL mode, so a process killed at any
instant (``kill -9``) loses no committed event. :class:`EventLog` commits each
event before it returns; :class:`LogWriter` takes the log off the control
path (a thread commits the queued events in order, in batches, and keeps them
in memory while the log is locked or the disk full). ``synchronous=FULL`` (default) also survives a power loss at the cost
of an fsync per event; ``NORMAL`` survives process crashes only and is
faster.

Times: ``t`` is the controller's clock (seconds, from the injected clock, so
a simulated run logs simulated time); ``wall`` is the wall-clock time of the
write (UTC, ISO 8601), for audits.

A loadarm log says so: ``PRAGMA application_id`` is :data:`APPLICATION_ID` and the table ``loadarm_meta``
holds the :data:`SCHEMA_VERSION`. A writer (:class:`EventLog`) creates a new log in an empty or missing file,
migrates a log of an older loadarm (schema 1: the ``events`` table alone, no identity) and refuses anything
else: a foreign SQLite file (even one with its own ``events`` table), a corrupt file, a log of a newer schema,
a file it cannot write (checked before the run starts). A reader (:meth:`EventLog.open_existing`) opens the
file read-only (``mode=ro``), so a query never changes it, not even its journal mode.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import sqlite3
import stat
import urllib.parse
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable

from loadarm.errors import EventLogError
from loadarm.vocab import UNLIMITED_CODES, event_label

__all__ = ["Event", "EventLog", "EventLogError", "LogWriter", "LogStatus", "check_samples", "KINDS", "RateLimiter", "RATE_LIMITED_KINDS", "APPLICATION_ID",
           "SCHEMA_VERSION"]

#: Event kinds.
KINDS = ("mode", "alarm", "alarm_state", "command", "interlock", "operator", "sensor", "sample", "info", "security")

#: ``PRAGMA application_id`` of a loadarm log ("LARM").
APPLICATION_ID = 0x4C41524D
#: Schema of the logs this loadarm writes: 1 was the ``events`` table alone (before the identity), 2 adds it.
SCHEMA_VERSION = 2

_COLUMNS = ("id", "run", "t", "wall", "state", "kind", "reason", "data")

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
CREATE TABLE IF NOT EXISTS loadarm_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


def _identify(db: sqlite3.Connection, name: str) -> int:
    """The schema version of an open database: 0 for a truly empty one (no schema object of any kind, user_version 0,
    application_id 0), 1 for an old loadarm log, else its ``loadarm_meta`` version; :class:`EventLogError` for
    anything that is not a loadarm log (found: a file holding only a view, or only a user_version, was adopted)."""
    app = db.execute("PRAGMA application_id").fetchone()[0]
    user_version = db.execute("PRAGMA user_version").fetchone()[0]
    objects = {(r[0], r[1]) for r in db.execute("SELECT type, name FROM sqlite_master")}
    tables = {n for kind, n in objects if kind == "table"} - {"sqlite_sequence"}
    if app == APPLICATION_ID:
        try:
            row = db.execute("SELECT value FROM loadarm_meta WHERE key = 'schema_version'").fetchone()
            text = row[0]
            version = int(text)
            if not isinstance(text, str) or text != str(version) or version < 1:
                raise ValueError
        except (sqlite3.DatabaseError, TypeError, ValueError):
            raise EventLogError(f"{name}: a loadarm event log without a readable schema version (damaged; "
                                f"loadarm writes an integer in [1, {SCHEMA_VERSION}])") from None
        if version > SCHEMA_VERSION:
            raise EventLogError(f"{name}: an event log of schema {version}, written by a newer loadarm; this one "
                                f"reads schema {SCHEMA_VERSION} and older")
        return version
    if app != 0:
        raise EventLogError(f"{name}: not a loadarm event log (SQLite application_id {app:#x})")
    if not objects and user_version == 0:
        return 0
    cols = tuple(r[1] for r in db.execute("PRAGMA table_info(events)")) if "events" in tables else ()
    schema1 = {("table", "events"), ("table", "sqlite_sequence")}
    if objects <= schema1 and cols == _COLUMNS and user_version == 0:
        return 1
    what = ", ".join(f"the {kind} {n}" for kind, n in sorted(objects)) or f"user_version {user_version}"
    raise EventLogError(f"{name}: not a loadarm event log (it holds {what})")


#: How many times a log's journal is looked for again when it vanishes while it is copied for inspection (another
#: process writing it: found in a fresh clone's suite, the other writer's ``-wal`` checkpointed and removed
#: between its listing and its copy).
INSPECT_ATTEMPTS = 5


def _copy_with_journal(path: Path, target: Path) -> bool:
    """Copy ``path`` and its hot ``-wal`` or ``-journal`` beside ``target`` when it has one (True); False when it
    has none (nothing copied: the file is opened as it is, immutable). Another process may be writing the log: a
    journal that vanishes while it is copied (checkpointed and removed by its writer) is looked for again, at most
    :data:`INSPECT_ATTEMPTS` times."""
    import shutil
    import time

    sidecars = [Path(f"{path}{suffix}") for suffix in ("-wal", "-journal")]
    for _ in range(INSPECT_ATTEMPTS):
        hot = [s for s in sidecars if s.is_file() and s.stat().st_size > 0]
        if not hot:
            return False
        try:
            shutil.copyfile(path, target)
            for s in hot:
                shutil.copyfile(s, Path(f"{target}{s.name[len(path.name):]}"))
            return True
        except FileNotFoundError as exc:
            if Path(exc.filename or "") not in hot:
                raise EventLogError(f"{path}: cannot inspect it and its journal on a copy ({exc.strerror}: "
                                    f"{exc.filename}); nothing was changed") from None
            time.sleep(0.05)                      # its writer checkpointed and removed it: look again
        except OSError as exc:
            raise EventLogError(f"{path}: cannot inspect it and its journal on a copy ({exc.strerror or exc}: "
                                f"{exc.filename or target.parent}); nothing was changed") from None
    raise EventLogError(f"{path}: its journal kept vanishing while it was inspected ({INSPECT_ATTEMPTS} times: "
                        "another process is writing it); nothing was changed: try again")


def _inspect(path: Path) -> int:
    """What the file at ``path`` is, read without changing a byte: its schema version (:func:`_identify`) after an
    integrity check. A file without journal files is opened ``immutable`` (no lock, no journal, nothing written
    beside it); one with a hot ``-wal`` or ``-journal`` (its writer was killed) is inspected on a copy, so the
    recovery SQLite makes on opening happens to the copy (found: a foreign database's journal was rolled back and
    removed by the open that then refused it; a corrupt log was written to before it was refused).

    Raises
    ------
    EventLogError
        Not a loadarm log, damaged, or of a newer schema.
    """
    import tempfile

    with tempfile.TemporaryDirectory(prefix="loadarm-inspect-") as tmp:
        hot = _copy_with_journal(path, Path(tmp) / "log.db")
        if hot:
            uri = f"file:{urllib.parse.quote(str(Path(tmp) / 'log.db'))}"
        else:
            uri = f"file:{urllib.parse.quote(os.path.abspath(path))}?mode=ro&immutable=1"
        try:
            db = sqlite3.connect(uri, uri=True, isolation_level=None)
        except sqlite3.DatabaseError as exc:
            raise EventLogError(f"{path}: cannot open event log ({_sqlite_reason(exc)})") from None
        try:
            version = _identify(db, str(path))
            if version:
                problems = [r[0] for r in db.execute("PRAGMA quick_check(5)")]
                if problems != ["ok"]:
                    raise EventLogError(f"{path}: a damaged event log (SQLite's integrity check: "
                                        f"{'; '.join(problems)[:200]})")
            return version
        except sqlite3.DatabaseError as exc:
            raise EventLogError(f"{path}: cannot read event log ({_sqlite_reason(exc)})") from None
        finally:
            db.close()


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
    """Append-only SQLite event log (WAL; :meth:`append` one transaction per event, :meth:`append_many` one per
    batch).

    Parameters
    ----------
    path : str or Path
        Database file (created with its directory); ``":memory:"`` for tests (the command line refuses it).
    run : str
        Identifier written with every event of this writer.
    synchronous : {'FULL', 'NORMAL'}
        SQLite durability level.

    Raises
    ------
    EventLogError
        The file is not a regular file, not a loadarm log, corrupt, of a newer schema, or not writable.
    """

    def __init__(self, path: str | Path, *, run: str = "run", synchronous: str = "FULL", _readonly: bool = False):
        if synchronous not in ("FULL", "NORMAL"):
            raise EventLogError(f"synchronous must be FULL or NORMAL, got {synchronous!r}")
        self.path = str(path)
        self.run = run
        self.readonly = _readonly
        memory = self.path == ":memory:"
        if not memory:
            _check_file(Path(self.path), must_exist=_readonly)
            if not _readonly:
                _check_orphans(Path(self.path))
                if Path(self.path).is_file() and Path(self.path).stat().st_size > 0:
                    _inspect(Path(self.path))             # read-only first: a foreign or damaged file is untouched
                Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        try:
            if _readonly:
                self._db = sqlite3.connect(_read_uri(Path(self.path)), uri=True, isolation_level=None,
                                           check_same_thread=False)
            else:
                self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False,
                                           timeout=BUSY_TIMEOUT)
            self.version = _identify(self._db, self.path)
            if _readonly:
                if self.version == 0:
                    raise EventLogError(f"{self.path}: an empty database, not an event log")
                return
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(f"PRAGMA synchronous={synchronous}")
            if self.version < SCHEMA_VERSION:            # a new log, or an older loadarm's: make it this schema
                self._db.executescript("BEGIN IMMEDIATE;" + _SCHEMA
                                       + f"PRAGMA application_id = {APPLICATION_ID};"
                                       + "INSERT OR REPLACE INTO loadarm_meta VALUES ('schema_version', "
                                       + f"'{SCHEMA_VERSION}'); COMMIT;")
                self.version = SCHEMA_VERSION
            # a real write now, so a file that cannot be written fails here, not at the run's first event (found:
            # a read-only or immutable file opened and an empty write transaction passed; the run then failed)
            self._db.execute("INSERT OR REPLACE INTO loadarm_meta VALUES ('last_writer', ?)",
                             (datetime.now(timezone.utc).isoformat(timespec="seconds"),))
        except EventLogError:
            self._close_quietly()
            raise
        except sqlite3.DatabaseError as exc:
            self._close_quietly()
            raise EventLogError(f"{self.path}: cannot open event log ({_sqlite_reason(exc)})") from None

    def _close_quietly(self) -> None:
        db = getattr(self, "_db", None)
        if db is not None:
            try:
                db.close()
            except sqlite3.Error:
                pass

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
        if self.readonly:
            raise EventLogError(f"{self.path}: opened read-only")
        wall = datetime.now(timezone.utc).isoformat(timespec="microseconds")
        try:
            cur = self._db.execute(
                "INSERT INTO events (run, t, wall, state, kind, reason, data) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (self.run, float(t), wall, state, kind, reason, json.dumps(data, default=float)))
        except sqlite3.DatabaseError as exc:               # disk full, file removed or damaged under us
            raise EventLogError(f"{self.path}: cannot write event ({_sqlite_reason(exc)})") from None
        return int(cur.lastrowid)

    def append_many(self, rows) -> None:
        """Write events in one transaction (all or none), in order.

        Parameters
        ----------
        rows : sequence of tuple
            ``(t, state, kind, reason, data, wall)`` each (``wall`` ISO 8601, when the event happened).
        """
        if self.readonly:
            raise EventLogError(f"{self.path}: opened read-only")
        values = [(self.run, float(t), wall, state, kind, reason,
                   data if isinstance(data, str) else json.dumps(data, default=float))
                  for t, state, kind, reason, data, wall in rows]
        try:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.executemany("INSERT INTO events (run, t, wall, state, kind, reason, data) "
                                     "VALUES (?, ?, ?, ?, ?, ?, ?)", values)
                self._db.execute("COMMIT")
            except BaseException:
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                raise
        except sqlite3.DatabaseError as exc:               # locked, disk full, file removed or damaged under us
            raise EventLogError(f"{self.path}: cannot write events ({_sqlite_reason(exc)})") from None

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
        try:
            rows = self._db.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as exc:
            raise EventLogError(f"{self.path}: cannot read the event log ({_sqlite_reason(exc)})") from None
        return [self._event(r) for r in rows]

    def _event(self, r: tuple) -> Event:
        """One row as an Event, every field checked (a damaged or hand-edited row is named, not trusted)."""
        ident, run, t, wall, state, kind, reason, data = r
        problem = None
        if not all(isinstance(v, str) for v in (run, wall, state, kind, reason)):
            problem = "a text column holds another type"
        elif not isinstance(t, (int, float)) or not math.isfinite(t):
            problem = f"t = {t!r} is not a finite number"
        elif kind not in KINDS:
            problem = f"kind {kind!r} is not one of {', '.join(KINDS)}"
        else:
            try:
                data = json.loads(data) if isinstance(data, str) else None
            except ValueError:
                data = None
            if not isinstance(data, dict):
                problem = "data is not a JSON object"
        if problem:
            raise EventLogError(f"{self.path}: event id {ident}: {problem}")
        return Event(int(ident), run, float(t), wall, state, kind, reason, data)

    def close(self) -> None:
        """Close the database."""
        self._db.close()

    def __enter__(self) -> "EventLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @staticmethod
    def open_existing(path: str | Path) -> "EventLog":
        """Open a log that must already exist, read-only (for queries: the file is never changed).

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
            If the file does not exist, is empty, or is not a loadarm event log.
        """
        return EventLog(path, _readonly=True)


@dataclass(frozen=True, slots=True)
class LogStatus:
    """What a :class:`LogWriter` can say of its log at an instant.

    Attributes
    ----------
    ok : bool
        The log takes events as they come (False: writes fail or stall; the events wait in memory).
    pending : int
        Events waiting to be written.
    lost : int
        Events dropped because the buffer was full (0 unless the log was unavailable for long).
    error : str
        The last write's failure ("" when the last write succeeded).
    written : int
        Events written so far.
    """

    ok: bool
    pending: int
    lost: int
    error: str
    written: int

    def change_note(self, goes_on: str) -> tuple[str, str, dict]:
        """The event that annunciates this status to the log it is of, the one wording of every service: the
        log unavailable (an ``alarm``, ``fault.event_log``) or back (``info``, ``info.event_log_restored``).

        Parameters
        ----------
        goes_on : str
            What goes on without its log ("the controller", "the bank").

        Returns
        -------
        (str, str, dict)
            The event's kind, reason and data.
        """
        if self.ok:
            return ("info", f"{event_label('info.event_log_restored')}: {self.written} events written in order, "
                            f"{self.lost} lost", {"code": "info.event_log_restored", "lost": self.lost})
        why = self.error or "writes stalled"
        return ("alarm", f"{event_label('fault.event_log')}: {why}; {self.pending} events kept in memory, "
                         f"{goes_on} goes on", {"code": "fault.event_log", "error": why})

    def unwritten(self, n: int, wait: float) -> str:
        """Why ``n`` events were left unwritten when the log was closed with ``wait`` seconds to finish (the
        one wording of every command that closes a log).

        Parameters
        ----------
        n : int
        wait : float
            s.

        Returns
        -------
        str
        """
        return f"{n} events could not be written in {wait:g} s ({self.error or 'the log stalled'})"


class LogWriter:
    """The event log off the control path: :meth:`append` queues an event and returns at once; a writer thread
    commits the queue in order. A write that fails (the file locked by another process, a full disk) is retried
    with a growing pause, the events kept in memory in order, so none is lost when the log returns; only a
    buffer of ``capacity`` events overflowing loses any, and the next event written says how many.

    Found: a log locked by another process for 12 s stopped ``loadarm serve`` (exit 2), its guidance, OPC UA
    and screen with it.

    Parameters
    ----------
    log : EventLog
        Opened for writing (the writer owns it from now on: :meth:`close` closes it).
    capacity : int
        Events held in memory at most while the log is unavailable.
    stall : float
        The log counts as unavailable when the oldest waiting event has waited this long, s (a write that hangs
        rather than fails).
    clock : callable
        Monotonic seconds (injected: tests pass a fake).
    """

    def __init__(self, log: "EventLog", *, capacity: int = 50_000, stall: float = 2.0,
                 clock=None, retry: tuple[float, float] = (0.05, 1.0)):
        import collections
        import threading
        import time

        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity!r}")
        self.log, self.capacity, self.stall, self.retry = log, capacity, stall, retry
        self.path, self.run = log.path, log.run
        self.clock = clock or time.monotonic
        self._sleep, self._now = time.sleep, time.monotonic
        self._queue: collections.deque = collections.deque()
        self._cv = threading.Condition()
        self._closing = False
        self._error, self._lost, self._written, self._noted = "", 0, 0, 0
        self._thread = threading.Thread(target=self._work, name="loadarm-eventlog", daemon=True)
        self._thread.start()

    def append(self, t: float, state: str, kind: str, reason: str, **data: Any) -> None:
        """Queue one event (never blocks, never raises for the log's sake; an unknown kind is a bug and raises).

        Parameters
        ----------
        t, state, kind, reason, **data
            As :meth:`EventLog.append`.
        """
        if kind not in KINDS:
            raise EventLogError(f"event kind must be one of {', '.join(KINDS)}, got {kind!r}")
        wall = datetime.now(timezone.utc).isoformat(timespec="microseconds")
        data = _frozen(data)                      # serialised here: the values as they are now, and a value that
        state, reason = _text(state), _text(reason)      # cannot be written is found in the caller's thread
        with self._cv:
            if len(self._queue) >= self.capacity:
                self._lost += 1
                return
            now = self.clock()
            gap = self._lost - self._noted
            if gap:                                        # where the events were lost, the log says how many
                self._queue.append((now, (t, state, "alarm", f"{gap} events lost: the event log was unavailable "
                                          f"and its buffer of {self.capacity} full",
                                          _frozen({"code": "fault.events_lost", "lost": gap}), wall)))
                self._noted += gap
            self._queue.append((now, (t, state, kind, reason, data, wall)))
            self._cv.notify()

    def status(self) -> LogStatus:
        """The log's state now (any thread)."""
        with self._cv:
            pending = len(self._queue)
            stalled = pending > 0 and self.clock() - self._queue[0][0] > self.stall
            return LogStatus(not self._error and not stalled, pending, self._lost, self._error, self._written)

    def flush(self, timeout: float) -> bool:
        """Wait until every queued event is written, at most ``timeout`` s; whether they all are."""
        end = self._now() + timeout
        with self._cv:
            while self._queue or self._busy:
                left = end - self._now()
                if left <= 0:
                    return False
                self._cv.wait(min(left, 0.05))
            return True

    def close(self, timeout: float = 30.0) -> int:
        """Write what is queued (waiting at most ``timeout`` s for an unavailable log), stop the thread and close
        the log; the number of events that could not be written (0: none lost)."""
        self.flush(timeout)
        with self._cv:
            self._closing = True
            unwritten = len(self._queue) + self._lost
            self._cv.notify_all()
        self._thread.join(max(1.0, 2 * BUSY_TIMEOUT))
        if not self._thread.is_alive():
            self.log.close()
        return unwritten

    def __enter__(self) -> "LogWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    _busy = False
    #: Events committed in one transaction at most (a backlog is written in batches: one fsync each).
    BATCH = 256

    def _work(self) -> None:
        """The writer thread: the queue's head written (a batch of it when it has grown), then removed; a failure
        retried after a growing pause, the events kept in order."""
        pause, size = self.retry[0], self.BATCH
        while True:
            with self._cv:
                while not self._queue and not self._closing:
                    self._cv.wait()
                if self._closing:
                    return
                batch = [item for _, item in itertools.islice(self._queue, size)]
                self._busy = True
            try:
                self.log.append_many(batch)
            except Exception as exc:              # noqa: BLE001 - the thread outlives any one write's failure
                with self._cv:
                    self._busy, self._error = False, str(exc) or type(exc).__name__
                    if not isinstance(exc, EventLogError) and size == 1:     # not the log's fault: this event's
                        self._queue.popleft()                                 # (counted lost, never retried)
                        self._lost += 1
                    self._cv.notify_all()
                self._sleep(pause)
                pause = min(2 * pause, self.retry[1])
                size = max(1, size // 2)          # a nearly full disk may still take a smaller transaction
                continue
            pause, size = self.retry[0], min(self.BATCH, 2 * size)
            with self._cv:
                for _ in batch:
                    self._queue.popleft()
                self._written += len(batch)
                self._error, self._busy = "", False
                self._cv.notify_all()


def _frozen(data: dict) -> str:
    """An event's data as the JSON written (a value JSON cannot hold is written as its text, never dropped)."""
    try:
        return json.dumps(data, default=float)
    except (TypeError, ValueError, OverflowError, RecursionError):
        return json.dumps({"unwritable": repr(data)[:1000]})


def _text(text: str) -> str:
    """Text SQLite can store (a lone surrogate, from undecodable bytes, is written as its escape)."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def check_samples(samples, keys, modes) -> None:
    """Refuse a damaged or hand-edited state sample before it is replayed: its state must be one of ``modes``
    and each of ``keys`` a finite number (found: a KeyError from a hand-edited log).

    Parameters
    ----------
    samples : iterable of Event
    keys : iterable of str
        The data every sample must carry.
    modes : sequence of str
        The guidance modes.

    Raises
    ------
    EventLogError
        Naming the event's id, the field and the value.
    """
    for e in samples:
        if e.state not in modes:
            raise EventLogError(f"event id {e.id}: state {e.state!r} is not a guidance mode ({', '.join(modes)})")
        for key in keys:
            v = e.data.get(key)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise EventLogError(f"event id {e.id}: a sample needs a finite number '{key}', got {v!r}")


def _sqlite_reason(exc: sqlite3.Error) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def _check_file(p: Path, *, must_exist: bool) -> None:
    """A log must be a regular file (a FIFO or a device would block or mislead SQLite)."""
    try:
        st = os.stat(p)
    except FileNotFoundError:
        if must_exist:
            raise EventLogError(f"{p}: no such event log") from None
        return
    except OSError as exc:
        raise EventLogError(f"{p}: cannot open event log ({exc.__class__.__name__})") from None
    if not stat.S_ISREG(st.st_mode):
        raise EventLogError(f"{p}: an event log must be a regular file")


def _check_orphans(p: Path) -> None:
    """Journal files beside a missing or empty database are someone's unfinished writes: never adopted."""
    if p.is_file() and p.stat().st_size > 0:
        return
    for suffix in ("-wal", "-journal"):
        side = Path(f"{p}{suffix}")
        if side.is_file() and side.stat().st_size > 0:
            raise EventLogError(f"{p}: {'missing' if not p.exists() else 'empty'}, but {side.name} beside it holds "
                                "unfinished writes; not an event log loadarm will start")


def _read_uri(p: Path) -> str:
    """The URI a reader opens a log with: ``immutable`` when no writer has it open (no ``-wal``: nothing is
    created beside it, found: ``loadarm log`` left ``-wal`` and ``-shm`` files), else read-only through the
    writer's WAL (a live log, or one whose writer was killed: its latest events; SQLite then adds a ``-shm``
    beside the ``-wal`` if it is missing)."""
    live = Path(f"{p}-wal").exists()
    return f"file:{urllib.parse.quote(os.path.abspath(p))}?mode=ro" + ("" if live else "&immutable=1")


#: How long a write waits for another connection's lock before it fails (and the writer retries), s.
BUSY_TIMEOUT = 1.0

#: Kinds whose repeats are rate-limited; safety events (mode, alarm, command, interlock, operator) never are.
#: A refused login or command (``security``) is: an attacker's thousand wrong passwords are one line and a count.
RATE_LIMITED_KINDS = ("info", "sensor", "security")

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

    #: Kinds of alike events kept at most; past it, those whose window has passed are forgotten.
    MAX_KEYS = 10_000

    def __init__(self, window: float = 10.0):
        if not (window > 0 and math.isfinite(window)):
            raise ValueError(f"window must be a positive number of seconds, got {window!r}")
        self.window = window
        self._open: dict = {}            # key -> [time let through, suppressed count]

    def admit(self, t: float, kind: str, reason: str, code: str = "") -> tuple[bool, int]:
        """Whether to write this event, and how many alike events were suppressed before it.

        Parameters
        ----------
        t : float
            Event time, s.
        kind, reason : str
            The event.
        code : str
            Its event code, if any: :data:`loadarm.vocab.UNLIMITED_CODES` are never limited.

        Returns
        -------
        write : bool
            Write it.
        suppressed : int
            Alike events counted since the last one written (to say so in this one).
        """
        if kind not in RATE_LIMITED_KINDS or code in UNLIMITED_CODES:
            return True, 0
        key = (kind, _NUMBER.sub("#", reason))
        if len(self._open) > self.MAX_KEYS:                 # alike runs long over: forgotten (bounded memory)
            self._open = {k: v for k, v in self._open.items() if t - v[0] < self.window}
        slot = self._open.get(key)
        if slot is None or t - slot[0] >= self.window:
            suppressed = 0 if slot is None else slot[1]
            self._open[key] = [t, 0]
            return True, suppressed
        slot[1] += 1
        return False, 0
