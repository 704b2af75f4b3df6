"""Replaying a logged run on the operator's screen (``loadarm serve --replay DB --run ID --hmi ...``): the run's
once-a-second state samples as snapshots, at a cursor in run time that plays at a speed or is moved by the
screen's time slider. Read-only: a replay takes no command."""

import logging
import math
import threading
import time
from collections.abc import Callable
from datetime import datetime

import numpy as np

from loadarm.errors import EventLogError
from loadarm.eventlog import check_samples
from loadarm.guidance.modes import MODES
from loadarm.hmi.state import JOURNAL_KINDS, journal_entry
from loadarm.sim.snapshot import TREND_WINDOW, snapshot, trend_point
from loadarm.vocab import ANNUNCIATED

__all__ = ["ReplayService", "ReplayCursor", "REAL_TIME_FRACTION"]

#: A run whose log's wall clock advanced by less than this fraction of its run time was simulated (``loadarm run``,
#: about 2000 times faster than real time; ``serve --speedup`` up to 10x keeps its log's clock).
REAL_TIME_FRACTION = 0.1


class ReplayService:
    """What :func:`loadarm.hmi.app.create_app` needs of a service (``snapshot``, ``request``), over a logged
    run, plus the cursor the screen moves (``seek``, ``play``, ``pause``, ``replay_state``).

    Parameters
    ----------
    events : list of loadarm.eventlog.Event
        One run's events, in order.
    model : ArmModel
        The installation the run was made on (for the coupler's position and the margins from the joints).
    clock : callable
        Monotonic seconds (injected: tests pass a fake).

    Raises
    ------
    EventLogError
        The run has no state samples, or one is damaged (:func:`loadarm.eventlog.check_samples`).
    """

    def __init__(self, events, model, *, clock: Callable[[], float] = time.monotonic):

        self.samples = [e for e in events if e.kind == "sample"]
        if not self.samples:
            raise EventLogError("the run has no state samples to replay (they are logged once a second by "
                                "loadarm run and loadarm serve)")
        check_samples(self.samples, ("phi", "alpha", "beta", "distance"), MODES)
        self.model, self.clock = model, clock
        self.times = np.array([e.t for e in self.samples])
        self.t0, self.t1 = float(self.times[0]), float(self.times[-1])
        self._cursor = ReplayCursor(self.t0, self.t1, clock)
        self._cache: dict[int, object] = {}
        #: The run was simulated: its events' times of day are its start's plus their run time (found: the replay of
        #: a ``loadarm run`` log gave one time of day to the 18 s from ESD-1 to the release's end, its wall clock).
        self.simulated = _simulated(self.samples)
        self._start = (_epoch(self.samples[0].wall), float(self.samples[0].t))
        # each sample's alarms (every annunciated one, normal if not logged) and when each active one was raised:
        # at its logged transition out of normal (found: the 1 Hz sample after it, ESD-1 shown at 212.0 s where
        # the log has 211.2 s), or at the first sample showing it in a log without those transitions
        raises = _raise_times(events, self.wall_of)
        self._alarms, self._raised, self._raised_wall, since = [], [], [], {}
        for e in self.samples:
            states = {tag: "normal" for tag in ANNUNCIATED}
            states.update(e.data.get("alarms", {}))
            since = {tag: since.get(tag) or _raised_by(raises.get(tag, ()), e.t, self.wall_of(e))
                     for tag, st in states.items() if st != "normal"}
            self._alarms.append(states)
            self._raised.append({tag: t for tag, (t, _) in since.items()})
            self._raised_wall.append({tag: w for tag, (_, w) in since.items()})
        self.events = [e for e in events if e.kind in JOURNAL_KINDS["all"]]
        healthy = [e for e in self.samples if e.data.get("healthy") and None not in (e.data.get("flange") or [None])]
        #: Where the flange was first seen healthy (the ship is drawn moved from there).
        self.anchor = tuple(healthy[0].data["flange"]) if healthy else None

    #: A replay takes no command; its screen still runs the login limit.
    jog_speed = 0.0

    def note(self, kind: str, reason: str, data: dict) -> None:
        """A security event of the replay's screen: a replay opens its log read-only and writes nothing, so the
        event goes to Python's logging (``loadarm.hmi``) only."""
        logging.getLogger("loadarm.hmi").warning("%s: %s", kind, reason)

    def new_cursor(self) -> "ReplayCursor":
        """A cursor of its own (each screen moves its own slider), at the run's start, playing at 1x."""
        return ReplayCursor(self.t0, self.t1, self.clock)

    def cursor(self) -> float:
        """The default cursor's run time, s."""
        return self._cursor.cursor()

    def seek(self, t: float) -> None:
        """Move the default cursor (:meth:`ReplayCursor.seek`)."""
        self._cursor.seek(t)

    def play(self, speed: float = 1.0) -> None:
        """Play the default cursor (:meth:`ReplayCursor.play`)."""
        self._cursor.play(speed)

    def pause(self) -> None:
        """Pause the default cursor."""
        self._cursor.pause()

    def replay_state(self, cursor: "ReplayCursor | None" = None) -> dict:
        """A cursor's slider state (default the service's own), and whether the run was simulated."""
        return {**(cursor or self._cursor).state(), "simulated": self.simulated}

    def wall_of(self, event) -> float:
        """When an event of the run happened on the wall clock, s since the epoch: the log's time, or for a
        simulated run (:attr:`simulated`) the run's start on the log's clock plus the event's run time."""
        if self.simulated:
            return self._start[0] + (float(event.t) - self._start[1])
        return _epoch(event.wall)

    def raised_at(self, snap) -> dict:
        """When each alarm active in ``snap`` (one of :meth:`snapshot`'s) was raised, run time s."""
        return self._raised[snap.seq]

    def raised_wall(self, snap) -> dict:
        """When each alarm active in ``snap`` was raised on the wall clock (the log's), s since the epoch."""
        return self._raised_wall[snap.seq]

    def trend(self, t: float) -> list[dict]:
        """The trend points of run time ``(t - TREND_WINDOW, t]``: one per logged sample
        (:func:`loadarm.sim.snapshot.trend_point`, what the live service keeps at the same times)."""
        lo = int(np.searchsorted(self.times, t - TREND_WINDOW, side="right"))
        hi = int(np.searchsorted(self.times, t, side="right"))
        return [trend_point(self._at(i)) for i in range(lo, hi)]

    def journal(self, now: float) -> list[dict]:
        """The run's journal (:func:`loadarm.hmi.state.journal_entry`), oldest first, each at its time of day
        (:meth:`wall_of`)."""
        return [journal_entry(e.t, self.wall_of(e), e.state, e.kind, e.reason, e.data, now) for e in self.events]

    def request(self, req) -> None:
        raise PermissionError("a replay takes no command")

    def snapshot(self, cursor: "ReplayCursor | None" = None):
        """The sample at or before a cursor (default the service's own) as a
        :class:`loadarm.sim.snapshot.Snapshot` (its ``seq`` the sample's index)."""
        i = int(np.searchsorted(self.times, (cursor or self._cursor).cursor(), side="right")) - 1
        return self._at(max(i, 0))

    def _at(self, i: int):
        snap = self._cache.get(i)
        if snap is None:
            snap = self._cache[i] = self._snapshot(i)
        return snap

    def _snapshot(self, i: int):
        e = self.samples[i]
        return snapshot(self.model, i, e.t, e.state, e.data, wall=self.wall_of(e))


def _epoch(wall: str) -> float:
    """A log's wall-clock time (ISO 8601) in s since the epoch (NaN if it is not one)."""
    try:
        return datetime.fromisoformat(wall).timestamp()
    except (TypeError, ValueError):
        return math.nan


def _simulated(samples) -> bool:
    """Whether a run's log's wall clock advanced by less than :data:`REAL_TIME_FRACTION` of its run time."""
    run = float(samples[-1].t) - float(samples[0].t)
    wall = _epoch(samples[-1].wall) - _epoch(samples[0].wall)
    return run > 0 and math.isfinite(wall) and wall < REAL_TIME_FRACTION * run


def _raise_times(events, wall_of) -> dict[str, list[tuple[float, float]]]:
    """Each alarm's logged transitions out of normal, (run time s, wall clock s by ``wall_of``), in order (its
    ``alarm_state`` events)."""
    out: dict[str, list[tuple[float, float]]] = {}
    last: dict[str, str] = {}
    for e in events:
        if e.kind != "alarm_state":
            continue
        tag, st = e.data.get("tag"), e.data.get("alarm_state")
        if tag is None or st is None:
            continue
        if st != "normal" and last.get(tag, "normal") == "normal":
            out.setdefault(tag, []).append((float(e.t), wall_of(e)))
        last[tag] = st
    return out


def _raised_by(times, t: float, wall: float) -> tuple[float, float]:
    """The last of an alarm's raise times at or before ``t`` (``t`` and ``wall``, the sample's, when the log has
    none)."""
    k = int(np.searchsorted(np.asarray([r[0] for r in times], dtype=float), t, side="right")) - 1
    return times[k] if k >= 0 else (float(t), wall)


class ReplayCursor:
    """A point in a replayed run's time that plays at a speed or stands, moved by one screen's slider.

    Parameters
    ----------
    t0, t1 : float
        The run's first and last sample times, s.
    clock : callable
        Monotonic seconds.
    """

    def __init__(self, t0: float, t1: float, clock: Callable[[], float]):
        self.t0, self.t1, self.clock = t0, t1, clock
        self._lock = threading.Lock()
        self._at, self._since, self.speed, self.playing = t0, clock(), 1.0, True

    def cursor(self) -> float:
        """The run time shown now, s (it stops at the run's end)."""
        with self._lock:
            t = self._at + (self.clock() - self._since) * self.speed if self.playing else self._at
        return min(max(t, self.t0), self.t1)

    def seek(self, t: float) -> None:
        """Show run time ``t`` (clamped to the run; a non-finite ``t`` is refused)."""
        if not (isinstance(t, (int, float)) and math.isfinite(t)):
            raise ValueError(f"seek needs a finite run time in s, got {t!r}")
        with self._lock:
            self._at, self._since = min(max(float(t), self.t0), self.t1), self.clock()

    def play(self, speed: float = 1.0) -> None:
        """Play from the cursor at ``speed`` run seconds per second (0 < speed <= 100)."""
        if not (isinstance(speed, (int, float)) and math.isfinite(speed) and 0 < speed <= 100):
            raise ValueError(f"play needs a speed in (0, 100], got {speed!r}")
        at = self.cursor()
        with self._lock:
            self._at, self._since, self.speed, self.playing = at, self.clock(), float(speed), True

    def pause(self) -> None:
        """Stand at the cursor."""
        at = self.cursor()
        with self._lock:
            self._at, self.playing = at, False

    def state(self) -> dict:
        """The slider's state: ``t`` (the cursor), ``t0``, ``t1``, ``playing``, ``speed``."""
        return {"t": self.cursor(), "t0": self.t0, "t1": self.t1, "playing": self.playing, "speed": self.speed}
