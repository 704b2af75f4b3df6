"""The guidance controller in real time (``loadarm serve``): the closed loop of a scenario paced by a wall clock,
the operator's requests taken from a queue, the state published as immutable snapshots.

The control loop runs in its own thread and never waits on the network: requests arrive through a
:class:`queue.SimpleQueue` (put by the OPC UA server's event loop without blocking), each is applied at the start
of the next cycle and written to the event log with the user's name; the server reads the latest
:class:`Snapshot` (one reference, replaced whole each cycle).

A jog request lasts :data:`JOG_HOLD` unless renewed: the dead-man of a jog over a network (the request stops
when the client stops renewing it, or its link drops).
"""

from __future__ import annotations

import collections
import gc
import itertools
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from loadarm.guidance.modes import CONNECTED_MODES, OperatorInput
from loadarm.sim.snapshot import MODE_TAIL, Snapshot, TrendLog, snapshot, state_sample
from loadarm.vocab import ACTIONS, ANNUNCIATED, TAGGED_ACTIONS, event_label

__all__ = ["ACTIONS", "JOG_HOLD", "REALTIME_SWITCH_INTERVAL", "Request", "freeze_heap", "Note", "GuidanceService",
           "parse_jog"]

#: How long one jog request moves the arm unless renewed, s.
JOG_HOLD = 0.5
#: The interpreter's thread switch interval in a real-time process (``loadarm serve``, ``plc-sim``), s: the
#: control thread waits at most this long for the interpreter while the servers' threads run (Python's default
#: 5 ms let 15 clients sampling at 10 ms put the cycle's p99 at 8.7x its p99 without them; at 0.1 ms, 1.4x).
REALTIME_SWITCH_INTERVAL = 1e-4
#: How many late cycles a service keeps, with how late each was (:attr:`GuidanceService.late_tail`).
LATE_TAIL = 1000


def freeze_heap() -> int:
    """Collect the garbage, then move every object the process holds into the collector's permanent generation
    (:func:`gc.freeze`): call it once a real-time process is built (the model, the servers' address spaces, the
    compiled kernels) and before its control thread starts. The collector's full passes then scan only what came
    after. Found (CI, ``test_twenty_clients_at_10_hz_do_not_make_the_guidance_cycle_late``): with the clients'
    process on the other core, a full pass in the OPC UA server's thread over the whole heap held the interpreter
    for 250-390 ms, and the guidance cycles due meanwhile started up to 350 ms late (12-19 in a row).

    Returns
    -------
    int
        How many objects are frozen.
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()

def parse_jog(value, limit: float) -> tuple[float, float, float]:
    """A jog's coupler velocity from a screen or an OPC UA client, taken strictly: three finite numbers (not
    text, not booleans), m/s, of speed at most ``limit`` (found: ``"123"`` was jogged as (1, 2, 3) m/s, and
    1e300 or booleans were accepted).

    Parameters
    ----------
    value : sequence
        ``[vx, vy, vz]``, m/s.
    limit : float
        The guidance's jog speed, m/s.

    Returns
    -------
    tuple of float

    Raises
    ------
    ValueError
        Naming what was sent and what is allowed.
    """
    want = f"jog must be three numbers [vx, vy, vz] in m/s of speed at most {limit:g} m/s"
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{want}, got {str(value)[:80]!r}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        raise ValueError(f"{want}, got {str(list(value))[:80]!r}")
    try:
        v = tuple(float(x) for x in value)
    except OverflowError:                                  # found: a 400-digit integer
        raise ValueError(f"{want}, got a number too large for a float") from None
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{want}, got {list(v)!r}")
    speed = math.sqrt(sum(x * x for x in v))
    if speed > limit * (1 + 1e-12):
        raise ValueError(f"{want}, got {speed:.6g} m/s")
    return v


@dataclass(frozen=True)
class Request:
    """One operator request.

    Attributes
    ----------
    action : str
        A key of :data:`ACTIONS`.
    user : str
        Who asked (for the event log).
    jog : tuple of float
        Coupler velocity for ``jog``, m/s.
    tag : str
        For ``ack``: the one alarm to acknowledge (``""``: every alarm).
    """

    action: str
    user: str
    jog: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tag: str = ""

    def __post_init__(self):
        if self.action not in ACTIONS:
            raise ValueError(f"action must be one of {', '.join(ACTIONS)}, got {self.action!r}")
        if len(self.jog) != 3 or not all(math.isfinite(v) for v in self.jog):
            raise ValueError(f"jog must be three finite velocities, got {self.jog!r}")
        if self.tag and (self.action not in TAGGED_ACTIONS or self.tag not in ANNUNCIATED):
            raise ValueError(f"tag must be one of {', '.join(ANNUNCIATED)} with action 'ack', 'shelve' or "
                             f"'unshelve', got {self.tag!r}")
        if self.action in ("shelve", "unshelve") and not self.tag:
            raise ValueError(f"{self.action} needs the alarm's tag")


@dataclass(frozen=True)
class Note:
    """An event from outside the control thread (a refused login or command): the control thread writes it to
    the event log with its own events, in order.

    Attributes
    ----------
    kind : str
        The event log's kind (:data:`loadarm.eventlog.KINDS`).
    reason : str
    data : dict
        With its ``code`` (:data:`loadarm.vocab.EVENTS`).
    """

    kind: str
    reason: str
    data: dict


class GuidanceService:
    """A :class:`loadarm.sim.loop.ClosedLoop` run in real time with live operator requests.

    Parameters
    ----------
    loop : ClosedLoop
        Built with ``scripted=False`` for an operator-driven run.
    clock : callable
        Monotonic seconds (injected: tests pass a fake).
    sleep : callable
        Sleeps a number of seconds.
    speedup : float
        Run seconds per wall second.
    wall : callable
        Wall-clock seconds since the epoch, stamped on each snapshot (injected: tests pass a fake).
    """

    def __init__(self, loop, *, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, speedup: float = 1.0,
                 wall: Callable[[], float] = time.time):
        if not speedup > 0:
            raise ValueError(f"speedup must be > 0, got {speedup!r}")
        self.loop, self.clock, self.sleep, self.speedup, self.wall = loop, clock, sleep, speedup, wall
        #: The screen's trends: the last 10 minutes, a point per logged sample's time (the replay's are the same).
        self.trend = TrendLog()
        self._requests: queue.SimpleQueue = queue.SimpleQueue()
        self._snapshot: Snapshot | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._jog = (0.0, 0.0, 0.0)
        self._jog_until = -math.inf
        self.late = 0
        #: The last :data:`LATE_TAIL` late cycles, ``(cycle, s behind its time)``: a stall of the machine shows
        #: as one run of consecutive cycles caught up back to back, a slow cycle as scattered ones.
        self.late_tail: collections.deque = collections.deque(maxlen=LATE_TAIL)
        self._link_ok = True
        self._log_ok = True
        #: Wall-clock time each mode change was published, ``[(mode, s since the epoch)]`` (the screen's
        #: latency is measured against it).
        self.mode_changes: list[tuple[str, float]] = []
        #: The last :data:`loadarm.sim.snapshot.MODE_TAIL` mode changes ``(cycle, mode)``, on every snapshot (a
        #: mode held for less than a screen's frame is still shown in its order: found in CI at 8x, where
        #: ALARM1 lasted less than one 20 Hz frame).
        self._mode_tail: collections.deque = collections.deque(maxlen=MODE_TAIL)
        self.finished = threading.Event()
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ thread-safe side
    def request(self, req: Request) -> None:
        """Queue an operator request (any thread; never blocks)."""
        self._requests.put(req)

    def note(self, kind: str, reason: str, data: dict) -> None:
        """Queue an event for the log, written by the control thread at its next cycle (any thread; never
        blocks)."""
        self._requests.put(Note(kind, reason, dict(data)))

    @property
    def jog_speed(self) -> float:
        """The fastest jog the guidance takes, m/s (faster requests are refused, not clamped)."""
        return self.loop.ctrl.g.jog_speed

    def snapshot(self) -> Snapshot | None:
        """The latest state (None before the first cycle)."""
        return self._snapshot

    def start(self) -> None:
        """Run the loop in its own thread."""
        self._thread = threading.Thread(target=self._run_guarded, name="loadarm-guidance", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop and wait for it."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    # ------------------------------------------------------------------ the control thread
    def _run_guarded(self) -> None:
        try:
            self.run()
        except BaseException as exc:          # reported to the caller, who decides (the CLI exits non-zero)
            self.error = exc
        finally:
            self.finished.set()

    def run(self) -> None:
        """Run every cycle of the scenario on the clock (in the calling thread), until the end (a continuous
        loop: none) or :meth:`stop`."""
        loop = self.loop
        watch = getattr(loop.log, "status", None)          # a LogWriter's: the log off the control path
        start = self.clock()
        for k in (itertools.count() if loop.continuous else range(loop.n)):
            if self._stop.is_set():
                break
            now = loop.time(k)
            delay = start + now / self.speedup - self.clock()
            if delay > 0:
                self.sleep(delay)
            elif delay < -loop.dt / self.speedup:
                self.late += 1
                self.late_tail.append((k, -delay))
            live = self._take_requests(now)
            if watch is not None:
                self._watch_log(now, watch())
            ok = getattr(loop.io, "link_ok", True)
            if ok != self._link_ok:
                live = self._link_changed(now, ok, live)
            cmd = loop.cycle(k, live)
            self._publish(k, now, cmd)

    def _take_requests(self, now: float) -> OperatorInput:
        actions: list[str] = []
        while True:
            try:
                req = self._requests.get_nowait()
            except queue.Empty:
                break
            if isinstance(req, Note):
                self.loop.emit(now, self.loop.ctrl.state.mode.value, req.kind, req.reason, req.data)
                continue
            if req.action == "jog" and req.jog == self._jog and now < self._jog_until:
                self._jog_until = now + JOG_HOLD       # a held jog renewed: one action, logged once
                continue
            actions.extend((f"ack:{req.tag}",) if req.tag and req.action == "ack" else ACTIONS[req.action])
            if req.action == "jog":
                self._jog, self._jog_until = req.jog, now + JOG_HOLD
            elif req.action in ("stop", "estop"):
                self._jog, self._jog_until = (0.0, 0.0, 0.0), -math.inf
            mode = self.loop.ctrl.state.mode.value
            data = {"user": req.user, "action": req.action}
            if req.action == "jog":
                data["jog"] = [float(v) for v in req.jog]
            if req.tag:
                data["tag"] = req.tag
            self.loop.emit(now, mode, "operator", f"{req.user}: {req.action}" + (f" {req.tag}" if req.tag else ""),
                           data)
        jog = self._jog if now < self._jog_until else (0.0, 0.0, 0.0)
        return OperatorInput(tuple(dict.fromkeys(actions)), jog)

    def _watch_log(self, now: float, status) -> None:
        """The event log became unavailable (an alarm, ``EVENT_LOG_FAULT``; the controller goes on, its events
        kept in memory) or came back (its events written in order)."""
        if status.ok == self._log_ok:
            return
        self._log_ok = status.ok
        self.loop.ctrl.state.log_fault = not status.ok
        self.loop.emit(now, self.loop.ctrl.state.mode.value, *status.change_note("the controller"))

    def _link_changed(self, now: float, ok: bool, live: OperatorInput) -> OperatorInput:
        """The PLC link died (an alarm; ESD-1 if the coupler is on the flange, else the motion stopped: manual
        mode, no jog; the PLC's watchdog stops the drives on its side) or came back (its values are good again; the controller reads the arm where it is,
        so nothing jumps)."""

        self._link_ok = ok
        mode = self.loop.ctrl.state.mode
        if ok:
            self.loop.emit(now, mode.value, "info", "PLC link restored", {})
            return live
        attached = mode in CONNECTED_MODES
        self.loop.emit(now, mode.value, "alarm", f"{event_label('fault.plc_link')}: its values are bad"
                       + ("; ESD-1 initiated" if attached else "; motion stopped (the PLC's watchdog stops the "
                                                               "drives)"), {"code": "fault.plc_link"})
        self._jog, self._jog_until = (0.0, 0.0, 0.0), -math.inf
        return OperatorInput(live.actions + (("esd",) if attached else ("manual",)), (0.0, 0.0, 0.0))

    def _publish(self, k: int, now: float, cmd) -> None:
        loop = self.loop
        sig, i = loop.rec.sig, loop.slot(k)
        q = (sig["phi"][i], sig["alpha"][i], sig["beta"][i])       # the cycle's joints, as the log records them
        sample = state_sample(cmd, q, loop.estimate, sig["distance"][i], loop.io.feedback.ers_valves_closed,
                              loop.ctrl.state.alarms)
        if not self._mode_tail or self._mode_tail[-1][1] != cmd.mode.value:
            self._mode_tail.append((k, cmd.mode.value))
        self._snapshot = snapshot(loop.model, k, now, cmd.mode.value, sample, cycle_us=float(loop.cycle_us[i]),
                                  late=self.late, plant_ok=self._link_ok, wall=self.wall(), modes=tuple(self._mode_tail),
                                  pressures=tuple(float(v) for v in getattr(loop.io, "pressures", (math.nan,) * 5)))
        self.trend.add(self._snapshot)
        if not self.mode_changes or self.mode_changes[-1][0] != cmd.mode.value:
            self.mode_changes.append((cmd.mode.value, self._snapshot.wall))
