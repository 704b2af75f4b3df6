"""The bank over OPC UA (issue 31, item 6): ``loadarm serve --bank``.

:class:`BankService` runs the bank's kinematic world (:class:`loadarm.sim.bank.BankWorld`: every arm connected to
one moored ship) on the wall clock in its own thread and publishes each state as an immutable
:class:`BankSnapshot`; :class:`BankServer` serves it, secure as the single arm's server
(:class:`loadarm.opcua.server.SecureServer`: its endpoints, certificates, users and roles).

The address space follows OPC 40001-1 (Machinery)'s idea of a machine made of components: under
``Objects/Machines/LoadingArmBank``, the bank's ``Identification`` and its own variables (the nearest clash between
any two arms, which pair, which parts), and a ``Components`` object (Machinery's MachineComponentsType browse name)
with one object per arm, each with its ``Identification`` (DI's browse name) and a ``Guidance`` object holding the
arm's variables under the single arm's names (:data:`loadarm.opcua.server.VARIABLES`: joints, margins) and the
bank's per arm (swivel angles and margins, the nearest neighbour). As for the single arm, the companion nodesets'
types are not loaded: their browse names, in their namespaces.

Every variable is read-only: this world has no controller to take a request (the bank offers no method; a write
is refused with ``BadUserAccessDenied``, an engineer's too). On a jetty, each arm's own ``loadarm serve`` takes its
requests and the PLC owns the E-stop and the ERS. Each arm's alarms (its stage conditions and its manifold load)
are Part 9 conditions under its ``Guidance/Alarms``: an operator's Acknowledge of one is the one call taken
(:func:`loadarm.opcua.server.acknowledge_method`), applied by the service at its next state.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
import dataclasses
from dataclasses import dataclass

import numpy as np

from loadarm import __version__
from loadarm.arm.alarms import AlarmState, next_alarm_state
from loadarm.eventlog import RateLimiter
from loadarm.guidance.bank import BankForecast, BankMonitor
from loadarm.guidance.manifold_alarm import ManifoldLoadAlarm, ManifoldLoadStatus
from loadarm.guidance.modes import ALARM_OFF_DELAY
from loadarm.guidance.monitor import stage_leads
from loadarm.opcua.server import APP_URI, PUBLISH_RATE, SnapshotServer, acknowledge_method, conditions, unece_unit_id
from loadarm.opcua.service import LATE_TAIL
from loadarm.sim.bank import BankState, BankWorld
from loadarm.vocab import (BANK_CONDITIONS, CONDITIONS, EVENTS, FACE_LABELS, STAGE_EVENT, SWIVEL_FACE_TABLE,
                           Severity, condition_severity, condition_text, event_label, priority)

__all__ = [
    "ARM_STATES",
    "ARM_VARIABLES",
    "ARM_ALARM_TAGS",
    "BANK_ALARM_TAGS",
    "BANK_INDEX",
    "BANK_NAME",
    "BANK_APP_URI",
    "BANK_STATES",
    "BANK_VARIABLES",
    "BankServer",
    "BankService",
    "BankSnapshot",
    "arm_values",
    "bank_address_space_markdown",
    "bank_values",
]

#: The bank server's application URI (in its certificate).
BANK_APP_URI = f"{APP_URI}:bank"
#: The bank's world is computed this often, Hz (the moored ship's motion is sampled at 10 Hz).
WORLD_RATE = 10.0
#: The bank's monitor forecasts its faces every this many states (once a second: a forecast costs about 25 ms on
#: a loaded two-core machine, 2026-12-05).
FORECAST_EVERY = 10

#: The most events from outside and alarms the service keeps (the oldest go first; each is logged as it comes).
NOTES_KEPT = 10_000

_DEG, _M, _S = ("DD", "deg", "degree"), ("MTR", "m", "metre"), ("SEC", "s", "second")
#: Each arm's Double variables: browse name, unit (UNECE code, symbol, description), range, what it is (the single
#: arm's names where it has them).
ARM_VARIABLES = (
    ("Slew_deg", _DEG, (-180.0, 180.0), "slew angle"),
    ("Alpha_deg", _DEG, (-180.0, 180.0), "inboard arm angle"),
    ("Beta_deg", _DEG, (0.0, 180.0), "elbow angle (customer's beta)"),
    ("FlangeX_m", _M, (-100.0, 100.0), "the arm's flange (its coupler), bank frame"),
    ("FlangeY_m", _M, (-100.0, 100.0), "the arm's flange (its coupler), bank frame"),
    ("FlangeZ_m", _M, (-100.0, 100.0), "the arm's flange (its coupler), bank frame"),
) + tuple((f"Margin_{face}_deg", _DEG, (-180.0, 180.0), f"margin to the face, in its joint's angle: {text}")
          for face, text in FACE_LABELS.items()) + tuple(
    (f"Swivel{k}_deg", _DEG, (-180.0, 180.0), f"swivel {k}'s angle") for k in (1, 2, 3)) + tuple(
    (f"SwivelMargin_{f.name}_deg", _DEG, (-360.0, 360.0), f"margin to the swivel's stop: {f.label}")
    for f in SWIVEL_FACE_TABLE) + (
    ("NearestClearance_m", _M, (-100.0, 200.0), "clearance to the nearest other arm (capsules, negative: overlap)"),
    ("TimeToLimit_s", _S, (0.0, 3600.0), "the bank monitor's time to this arm's nearest face (its own envelope's, "
                                         "its swivels' stops, its clash with a neighbour; -1: none within the "
                                         "horizon)"),
    ("ManifoldLoad", ("C62", "1", "one"), (-1.0, 100.0), "the arm's largest load on its presentation flange over its "
                                                        "allowable (-1: not yet computed)"),)
#: Each arm's other variables: browse name, type, what it is.
ARM_STATES = (("Mode", str, "the arm's mode (CONNECTED: every arm of this world is on its flange)"),
              ("AlarmStage", int, "the arm's stage: the more severe of its position alarm (the customer's angles) "
                                  "and the bank monitor's (its time to its nearest face against the sequence's "
                                  "leads)"),
              ("AlarmStageText", str, "its words"),
              ("NearestArm", str, "the nearest other arm"),
              ("ManifoldLoadAlarm", bool, "the arm's manifold-load alarm (fault.manifold_load): a load past its "
                                          "allowable for the bank file's alarm_delay, until below its deadband"),
              ("ManifoldLoadState", str, "that alarm's ISA-18.2 state (normal, unacknowledged, acknowledged, "
                                         "returned to normal, unacknowledged)"),
              ("ManifoldLoadGoverning", str, "the load of ManifoldLoad (axial force, ..., torsion moment)"),
              ("NearestParts", str, "the two parts that come closest (this arm's first)"))
#: The bank's Double variables.
BANK_VARIABLES = (
    ("NearestClearance_m", _M, (-100.0, 200.0), "the smallest clearance between any two arms"),
    ("RequiredClearance_m", _M, (0.0, 10.0), "the bank's minimum clearance (clearance.min_clearance)"),
    ("Time_s", _S, (0.0, 1e7), "the world's time"),
    ("TimeToLimit_s", _S, (0.0, 3600.0), "the bank monitor's time to the bank's nearest face (-1: none within the "
                                         "horizon)"),
)
#: The bank's other variables.
BANK_STATES = (("NearestPair", str, "the two arms closest to each other, A/B"),
               ("NearestParts", str, "their two parts that come closest"),
               ("ClashAbnormal", bool, "the nearest clearance is below the required one"),
               ("ManifoldLoadAbnormal", bool, "an arm's manifold-load alarm is active"),
               ("AlarmStage", int, "the most severe arm's stage (ESD-1 and ERS-2 act on every arm)"),
               ("NearestFace", str, "the face the monitor forecasts first (a code of vocab.FACE_TABLE, an arm's own "
                                    "face, or of vocab.BANK_FACE_TABLE), empty: none"),
               ("NearestFaceArms", str, "the arm (its own face, a swivel's stop) or the two arms (the clash) of that "
                                        "face"),
               ("Cycle", int, "counts the world's states"))
_KINDS = {bool: "Boolean", int: "Int64", str: "String"}

_log = logging.getLogger(__name__)
#: The event log's own fields: a note's data key of the same name is logged as ``data_<key>``.
_LOG_FIELDS = ("self", "t", "state", "kind", "reason")


def bank_address_space_markdown() -> str:
    """The bank's node tree's tables for docs/plant-integration.md, from the server's own declarations.

    Returns
    -------
    str
        Markdown: the bank's variables, then each arm's.
    """
    rows = ["| node | type | unit | what |", "|---|---|---|---|"]
    rows += [f"| `{n}` | Double | {u[1]} | {w} |" for n, u, _, w in BANK_VARIABLES]
    rows += [f"| `{n}` | {_KINDS[k]} |  | {w} |" for n, k, w in BANK_STATES]
    rows += [f"| `Components/ARM/Guidance/{n}` | Double | {u[1]} | {w} |" for n, u, _, w in ARM_VARIABLES]
    rows += [f"| `Components/ARM/Guidance/{n}` | {_KINDS[k]} |  | {w} |" for n, k, w in ARM_STATES]
    rows += [f"| `Components/ARM/Guidance/Alarms/{t}` | AlarmConditionType |  | severity {condition_severity(t)}: "
             f"{condition_text(t)} |" for t in ARM_ALARM_TAGS]
    return "\n".join(rows) + "\n"


#: Each arm's stage alarms: one per stage condition (the single arm's, :data:`loadarm.vocab.CONDITIONS`).
STAGE_CONDITIONS = tuple(c for c in CONDITIONS if c.stage is not None)
_STAGE_RANK = {c.tag: int(c.stage) for c in STAGE_CONDITIONS}
#: Each arm's annunciated alarms, served as OPC UA Part 9 conditions under its ``Guidance/Alarms``: its stage
#: conditions, then the bank's own (:data:`loadarm.vocab.BANK_CONDITIONS`: its manifold load).
ARM_ALARM_TAGS = tuple(c.tag for c in STAGE_CONDITIONS) + tuple(c.tag for c in BANK_CONDITIONS)
#: The bank's own alarms (not an arm's), under ``Bank/Alarms``: its event log unavailable (as the single arm's).
BANK_ALARM_TAGS = ("EVENT_LOG_FAULT",)
#: The arm index of the bank's own alarms in the conditions' keys, and the name its alarm lines carry.
BANK_INDEX, BANK_NAME = -1, "bank"


@dataclass(frozen=True)
class BankAlarm:
    """One line of the bank's alarm list: an arm's stage alarm or its manifold-load alarm, or the bank's own
    (:data:`BANK_ALARM_TAGS`, its arm :data:`BANK_NAME`), in its ISA-18.2 state.

    Attributes
    ----------
    arm : str
    tag : str
        :data:`STAGE_CONDITIONS`' or :data:`loadarm.vocab.BANK_CONDITIONS`' (``MANIFOLD_LOAD``).
    state : AlarmState
        Not normal.
    raised_at : float
        World time it became active, s.
    """

    arm: str
    tag: str
    state: AlarmState
    raised_at: float

    @property
    def code(self) -> str:
        """``<arm>:<tag>``, the line's key."""
        return f"{self.arm}:{self.tag}"


@dataclass(frozen=True)
class BankSnapshot:
    """One published state of the bank.

    Attributes
    ----------
    seq : int
        Counts the states.
    wall : float
        Wall-clock time it was computed, s since the epoch.
    state : BankState
    forecast : BankForecast or None
        The bank monitor's latest forecast (:class:`loadarm.guidance.bank.BankMonitor`; None before the first).
    loads : ManifoldLoadStatus or None
        Each arm's manifold load and its alarm (:class:`loadarm.guidance.manifold_alarm.ManifoldLoadAlarm`).
    alarms : tuple of BankAlarm
        The alarms not normal, the most urgent first, then the oldest.
    conditions : dict of (int, str) to AlarmState
        Every arm's every alarm of :data:`ARM_ALARM_TAGS` (arm index, tag) and the bank's own
        (:data:`BANK_INDEX`, tag of :data:`BANK_ALARM_TAGS`) in its ISA-18.2 state (the OPC UA conditions).
    suppressed : frozenset of (int, str)
        The stage alarms suppressed by design: an arm's stages below its most severe active one (ISA-18.2's
        state-based suppression: the list above leaves them out, the conditions say SuppressedState).
    """

    seq: int
    wall: float
    state: BankState
    forecast: BankForecast | None = None
    loads: ManifoldLoadStatus | None = None
    alarms: tuple = ()
    conditions: dict = dataclasses.field(default_factory=dict)
    suppressed: frozenset = frozenset()

    def stage(self, i: int) -> Severity:
        """Arm ``i``'s stage: the more severe of its position alarm and the bank monitor's.

        Parameters
        ----------
        i : int

        Returns
        -------
        Severity
        """
        monitor = self.forecast.stages[i] if self.forecast is not None else Severity.NORMAL
        return Severity(max(int(self.state.stages[i]), int(monitor)))


def _deg(v) -> float:
    return math.degrees(float(v))


def _ttl(v: float) -> float:
    return float(v) if math.isfinite(v) else -1.0


def arm_values(snap: BankSnapshot, i: int) -> dict:
    """Arm ``i``'s variables as the server publishes them (:data:`ARM_VARIABLES` and :data:`ARM_STATES`).

    Parameters
    ----------
    snap : BankSnapshot
    i : int

    Returns
    -------
    dict
    """
    state = snap.state
    k = state.nearest_of(i)
    a, b = state.pairs[k]
    other = b if a == i else a
    parts = state.clash(k)["parts"]
    mine = parts if a == i else parts[::-1]
    stage = snap.stage(i)
    ttl = snap.forecast.by_arm[i] if snap.forecast is not None else math.inf
    out = {"Slew_deg": _deg(state.q[i, 0]), "Alpha_deg": _deg(state.q[i, 1]), "Beta_deg": _deg(state.q[i, 2]),
           "FlangeX_m": float(state.flanges[i, 0]), "FlangeY_m": float(state.flanges[i, 1]),
           "FlangeZ_m": float(state.flanges[i, 2]),
           **{f"Margin_{face}_deg": _deg(state.margins[i, j]) for j, face in enumerate(FACE_LABELS)},
           **{f"Swivel{j + 1}_deg": _deg(state.swivels[i, j]) for j in range(3)},
           **{f"SwivelMargin_{f.name}_deg": _deg(state.swivel_margins[i, j]) for j, f in enumerate(SWIVEL_FACE_TABLE)},
           "NearestClearance_m": float(state.pair_clearance[k]), "TimeToLimit_s": _ttl(ttl),
           "Mode": "CONNECTED", "AlarmStage": int(stage), "AlarmStageText": stage.label,
           "NearestArm": state.names[other], "NearestParts": " / ".join(mine), **_load_values(snap.loads, i)}
    return out


def _load_values(loads: ManifoldLoadStatus | None, i: int) -> dict:
    """Arm ``i``'s manifold-load variables."""
    if loads is None or not math.isfinite(float(loads.utilisation[i])):
        return {"ManifoldLoad": -1.0, "ManifoldLoadAlarm": False, "ManifoldLoadState": "normal",
                "ManifoldLoadGoverning": ""}
    return {"ManifoldLoad": float(loads.utilisation[i]), "ManifoldLoadAlarm": bool(loads.active[i]),
            "ManifoldLoadState": loads.states[i].value, "ManifoldLoadGoverning": loads.governing[i]}


def bank_values(snap: BankSnapshot) -> dict:
    """The bank's own variables as the server publishes them (:data:`BANK_VARIABLES` and :data:`BANK_STATES`).

    Parameters
    ----------
    snap : BankSnapshot

    Returns
    -------
    dict
    """
    st, fc = snap.state, snap.forecast
    c = st.clash(st.nearest_pair)
    return {"NearestClearance_m": c["clearance"], "RequiredClearance_m": st.required, "Time_s": st.t,
            "TimeToLimit_s": _ttl(fc.time if fc is not None else math.inf),
            "NearestPair": "/".join(c["arms"]), "NearestParts": " / ".join(c["parts"]),
            "ClashAbnormal": bool(c["abnormal"]),
            "ManifoldLoadAbnormal": bool(snap.loads is not None and any(snap.loads.active)),
            "AlarmStage": int(max(snap.stage(i) for i in range(len(st.names)))),
            "NearestFace": fc.face if fc is not None else "",
            "NearestFaceArms": "/".join(fc.arms) if fc is not None else "", "Cycle": int(snap.seq)}


class BankService:
    """The bank's world in real time: a state every ``1 / WORLD_RATE`` run seconds, on the wall clock, in its own
    thread; the latest published as one reference (read by the servers without a lock).

    Parameters
    ----------
    world : BankWorld
    clock : callable
        Monotonic seconds (injected: tests pass a fake).
    sleep : callable
    speedup : float
        Run seconds per wall second.
    wall : callable
        Wall-clock seconds since the epoch.
    log : loadarm.eventlog.LogWriter or None
        The bank's event log (``serve --bank --db``): every note, at the bank's time, with the bank's most severe
        stage as its state. Off the world's thread: a locked log or a full disk never stops the bank (its events
        wait in memory; the journal says so when it fails and when it returns).
    """

    def __init__(self, world: BankWorld, *, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, speedup: float = 1.0,
                 wall: Callable[[], float] = time.time, log=None):
        if not speedup > 0:
            raise ValueError(f"speedup must be > 0, got {speedup!r}")
        self.world, self.clock, self.sleep, self.speedup, self.wall = world, clock, sleep, speedup, wall
        self.log = log
        self._log_ok = True
        #: The bank's time of the state being computed (or the last), s: the time its events are logged at, and
        #: its most severe arm stage then.
        self._t, self._stage = 0.0, Severity.NORMAL
        #: The bank's event-log alarm: its ISA-18.2 state and when it rose; and the last state's time the log
        #: was unavailable (the alarm clears only :data:`ALARM_OFF_DELAY` s after, as the single arm's).
        self._log_alarm: tuple[AlarmState, float] = (AlarmState.NORMAL, math.nan)
        self._log_bad_at = -math.inf
        #: Whether that alarm's condition is active (the log unavailable, or within the off-delay since).
        self._log_active = False
        #: Alike events of the rate-limited kinds (refused logins and commands) let through once per window, as
        #: the single arm's (:class:`loadarm.eventlog.RateLimiter`): a thousand wrong passwords are one line.
        self._limiter = RateLimiter()
        self._note_lock = threading.Lock()
        self._snapshot: BankSnapshot | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.finished = threading.Event()
        self.error: BaseException | None = None
        self.late = 0
        #: The last late states, ``(state, s behind its time)`` (as :attr:`GuidanceService.late_tail`).
        self.late_tail: deque = deque(maxlen=LATE_TAIL)
        #: The bank's connected monitoring (the swivels' stops, the clash of neighbours; the single arm's forecast).
        self.monitor = BankMonitor(world.bank)
        #: Its horizon: the longest stage lead of the bank's arms, s.
        self.horizon = max(max(stage_leads(m.sequence).values()) for m in world.bank.models)
        self._forecast: BankForecast | None = None
        self._observed = -math.inf
        #: Each arm's live manifold-load alarm.
        self.loads = ManifoldLoadAlarm(world.bank)
        #: Acknowledgements asked and not yet applied, under :attr:`_lock`: of every alarm (the screen's), by whom,
        #: and of one alarm each (an OPC UA client's Acknowledge), (arm index, tag) to whom and the comment: bounded
        #: by the alarms.
        self._lock = threading.Lock()
        self._ack_all: list[str] = []
        self._asked: dict[tuple[int, str], tuple[str, str]] = {}
        #: Every event (the alarms' rises and clears, acknowledgements, refused logins and commands), with the wall
        #: time it came: the screen's journal; in the event log too when there is one.
        self.notes: deque[tuple[float, str, str, dict]] = deque(maxlen=NOTES_KEPT)
        #: Each (arm, stage condition) not normal: its ISA-18.2 state and when it rose.
        self._stage_alarms: dict[tuple[int, str], tuple[AlarmState, float]] = {}
        #: When each arm's manifold-load alarm last rose, s.
        self._load_raised = [math.nan] * len(world.bank.names)

    @property
    def bank(self):
        """The bank."""
        return self.world.bank

    def snapshot(self) -> BankSnapshot | None:
        """The latest state (None before the first)."""
        return self._snapshot

    def note(self, kind: str, reason: str, data: dict) -> None:
        """An event (any thread): kept for the journal and, with an event log, queued to it at the bank's time
        (the last state's) with the bank's most severe stage as its state.

        Parameters
        ----------
        kind : str
            An event log kind (:data:`loadarm.eventlog.KINDS`).
        reason : str
        data : dict
            Its ``code`` (:data:`loadarm.vocab.EVENTS`) among them.
        """
        with self._note_lock:                  # the journal's order is the log's, whichever thread notes
            write, suppressed = self._limiter.admit(self._t, kind, reason, data.get("code", ""))
            if not write:
                return
            if suppressed:
                reason = f"{reason} (and {suppressed} alike in the last {self._limiter.window:g} s)"
            self.notes.append((self.wall(), kind, reason, dict(data)))
            if self.log is not None:
                self._log_note(kind, reason, data)
        _log.warning("%s", reason)

    def _log_note(self, kind: str, reason: str, data: dict) -> None:
        """One note to the event log: at its own time (its data's ``t``) or the bank's; a data key that is one of
        the log's own fields renamed ``data_<key>``; never raising (a bug's event is reported, the bank goes on)."""
        fields = dict(data)
        t = fields.get("t")
        timed = isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t)
        if timed:
            fields.pop("t")
        fields = {(f"data_{k}" if k in _LOG_FIELDS else k): v for k, v in fields.items()}
        try:
            self.log.append(float(t) if timed else self._t, self.stage_name(), kind, reason, **fields)
        except Exception as exc:               # noqa: BLE001 - the bank never stops for its log
            _log.error("event not logged (%s): %s", exc, reason)

    def stage_name(self) -> str:
        """The bank's most severe arm stage at the state being annunciated, or the last (``normal`` before the
        first state): the event log's state column.

        Returns
        -------
        str
        """
        return Severity(self._stage).name.lower()

    def _watch_log(self) -> None:
        """The event log became unavailable or came back: a note each way (the bank goes on; its events wait in
        memory, in order)."""
        status = self.log.status()
        if status.ok == self._log_ok:
            return
        self._log_ok = status.ok
        kind, reason, data = status.change_note("the bank")
        if status.ok or self._log_active:      # what was written; or unavailable again within the off-delay
            self.note(kind, reason, data)      # (the alarm still active: not raised again; found by review)
        else:
            self.note(kind, reason, {**data, "arm": BANK_NAME, "tag": "EVENT_LOG_FAULT", "active": True})

    def acknowledge(self, user: str = "operator") -> None:
        """The operator acknowledged every alarm (the bank's screen): applied at the next state and noted then,
        with the user.

        Parameters
        ----------
        user : str
        """
        with self._lock:
            self._ack_all.append(user)

    def request_ack(self, user: str, key: tuple[int, str], comment: str = "") -> bool:
        """An operator acknowledged one alarm (an OPC UA condition's Acknowledge): applied at the next state and
        noted then, with the operator's comment. Never blocks for long (called from the server's event loop).

        Parameters
        ----------
        user : str
        key : (int, str)
            The arm's index and the alarm's tag (:data:`ARM_ALARM_TAGS`), or :data:`BANK_INDEX` and a tag of
            :data:`BANK_ALARM_TAGS`.
        comment : str
            The Acknowledge's comment (at most 200 characters kept).

        Returns
        -------
        bool
            False when that alarm's acknowledgement is already waiting for the next state (found by review:
            every repeat was queued, each a note).
        """
        with self._lock:
            if key in self._asked:
                return False
            self._asked[key] = (user, str(comment)[:200])
            return True

    def _take_acks(self) -> tuple[bool, frozenset]:
        """The acknowledgements asked since the last state, taken at once (none lost between a test and a clear),
        each noted with its user as it is applied: whether every alarm is, and which single alarms."""
        with self._lock:
            every, self._ack_all = self._ack_all, []
            asked, self._asked = self._asked, {}
        for user in every:
            self.note("operator", f"every alarm acknowledged by {user}", {"user": user, "action": "ack"})
        for (i, tag), (user, comment) in sorted(asked.items()):
            said = f": {comment!r}" if comment else ""
            arm = BANK_NAME if i == BANK_INDEX else self.bank.names[i]
            whose = "the bank" if i == BANK_INDEX else f"arm {arm}"
            self.note("operator", f"{condition_text(tag)} acknowledged: {whose}, by {user}{said}",
                      {"arm": arm, "tag": tag, "user": user, "action": "ack", "comment": comment})
        return bool(every), frozenset(asked)

    def _stage_states(self, snap: BankSnapshot, acknowledge: bool, asked: frozenset) -> None:
        """The stage alarms' ISA-18.2 states at this state (each arm's stage against each stage condition,
        acknowledged all at once or one by one), each rise and clear a note."""
        t = snap.state.t
        for i, name in enumerate(self.bank.names):
            stage = snap.stage(i)
            for c in STAGE_CONDITIONS:
                old, since = self._stage_alarms.get((i, c.tag), (AlarmState.NORMAL, math.nan))
                active = stage >= c.stage
                new = next_alarm_state(old, active, acknowledge or (i, c.tag) in asked)
                if new == AlarmState.UNACKED and old not in (AlarmState.UNACKED, AlarmState.ACKED):
                    since = t                      # risen, or risen again from returned-to-normal (found by review)
                if active != (old in (AlarmState.UNACKED, AlarmState.ACKED)):
                    self.note("alarm", f"{c.text}{'' if active else ' cleared'}: arm {name}",
                              {"arm": name, "tag": c.tag, "active": active, "t": t, "code": STAGE_EVENT[c.stage]})
                if new == AlarmState.NORMAL:
                    self._stage_alarms.pop((i, c.tag), None)
                else:
                    self._stage_alarms[(i, c.tag)] = (new, since)

    def _annunciate(self, snap: BankSnapshot, acknowledge: bool, asked: frozenset = frozenset()) -> BankSnapshot:
        """The snapshot with its alarms: the stage alarms' states (:meth:`_stage_states`), every alarm's state
        (the conditions) and the alarm list (:meth:`_alarm_list`)."""
        self._stage_states(snap, acknowledge, asked)
        names = self.bank.names
        loads = [AlarmState(s) for s in snap.loads.states] if snap.loads is not None else \
            [AlarmState.NORMAL] * len(names)
        conds = {(i, tag): self._stage_alarms.get((i, tag), (AlarmState.NORMAL, math.nan))[0]
                 for i in range(len(names)) for tag in _STAGE_RANK}
        conds.update({(i, "MANIFOLD_LOAD"): st for i, st in enumerate(loads)})
        conds[(BANK_INDEX, "EVENT_LOG_FAULT")] = self._log_state(snap.state.t, acknowledge, asked)
        suppressed = frozenset((i, c.tag) for i in range(len(names)) for c in STAGE_CONDITIONS
                               if c.stage < snap.stage(i))
        return dataclasses.replace(snap, alarms=self._alarm_list(loads), conditions=conds, suppressed=suppressed)

    def _log_state(self, t: float, acknowledge: bool, asked: frozenset) -> AlarmState:
        """The bank's event-log alarm's ISA-18.2 state at time ``t``: active while the log is unavailable and for
        :data:`ALARM_OFF_DELAY` s after (ISA-18.2's off-delay, as the single arm's alarms: found by review, a log
        failing and returning by turns made the bank's alarm chatter where the arm's did not)."""
        if not self._log_ok:
            self._log_bad_at = t
        old, since = self._log_alarm
        active = t - self._log_bad_at < ALARM_OFF_DELAY
        if self._log_active and not active:    # the alarm's clear, once the off-delay has passed (never limited)
            self.note("alarm", f"{event_label('fault.event_log')} cleared: the bank", {
                "code": "fault.event_log", "arm": BANK_NAME, "tag": "EVENT_LOG_FAULT", "active": False})
        self._log_active = active
        new = next_alarm_state(old, active, acknowledge or (BANK_INDEX, "EVENT_LOG_FAULT") in asked)
        if new == AlarmState.UNACKED and old not in (AlarmState.UNACKED, AlarmState.ACKED):
            since = t
        self._log_alarm = (new, since)
        return new

    def _alarm_list(self, loads) -> tuple:
        """The alarm list: each arm's most severe stage alarm not normal and its manifold-load alarm (``loads``,
        each arm's state), the most urgent first, then the oldest."""
        names = self.bank.names
        # one line an arm: its most severe stage alarm not normal (the lower stages of the same escalation are
        # suppressed by design, ISA-18.2's state-based suppression: four arms would otherwise list sixteen)
        # (the most severe active one first: found by review, a returned ESD-1 hid an active pre-alarm)
        top: dict[int, tuple] = {}
        for (i, tag), (st, since) in self._stage_alarms.items():
            rank = (st in (AlarmState.UNACKED, AlarmState.ACKED), _STAGE_RANK[tag])
            if i not in top or rank > top[i][0]:
                top[i] = (rank, tag, st, since)
        out = [BankAlarm(names[i], tag, st, since) for i, (_, tag, st, since) in sorted(top.items())]
        out += [BankAlarm(names[i], "MANIFOLD_LOAD", st, self._load_raised[i])
                for i, st in enumerate(loads) if st != AlarmState.NORMAL]
        if self._log_alarm[0] != AlarmState.NORMAL:
            out.append(BankAlarm(BANK_NAME, "EVENT_LOG_FAULT", *self._log_alarm))
        order = {n: i for i, n in enumerate(names)} | {BANK_NAME: BANK_INDEX}
        return tuple(sorted(out, key=lambda a: (priority(a.tag)[0], a.raised_at, order[a.arm])))

    def _load_events(self, status: ManifoldLoadStatus) -> None:
        """Each manifold-load alarm that rose or cleared, as an event."""
        for e in status.events:
            if e["active"]:
                self._load_raised[self.bank.names.index(e["arm"])] = float(e["t"])
            word = "" if e["active"] else " cleared"
            self.note("alarm", f"{EVENTS[e['code']].label}{word}: arm {e['arm']}, {e['load']} at "
                               f"{e['utilisation']:.2f} of its allowable", dict(e))

    def step(self, k: int) -> BankSnapshot:
        """Compute and publish the ``k``-th state: the world's, and the bank monitor's forecast (fed every state,
        forecast every :data:`FORECAST_EVERY`).

        Parameters
        ----------
        k : int

        Returns
        -------
        BankSnapshot
        """
        state = self.world.state(k / WORLD_RATE)
        self._t = state.t
        if state.t <= self._observed:          # a time gone back (a test stepping states): a new connection
            self.monitor.reset()
            self._forecast = None
            self.loads = ManifoldLoadAlarm(self.world.bank)
            self._stage_alarms.clear()
            self._log_bad_at = -math.inf       # its off-delay too (found by review: a healthy log re-raised it)
        self._observed = state.t
        if self.monitor.observe(state.t, state.manifold, state.ship_angles):
            self.monitor.refit()
        if k % FORECAST_EVERY == 0 or self._forecast is None:
            self._forecast = self.monitor.time_to_limit(state.manifold, state.ship_angles, self.horizon, now=state.t)
        every, asked = self._take_acks()
        names = self.world.bank.names
        acked = names if every else tuple(names[i] for i, tag in sorted(asked) if tag == "MANIFOLD_LOAD")
        displacement = state.manifold - np.asarray(self.world.bank.file.manifold.position, dtype=float)
        loads = self.loads.step(state.t, displacement, state.ship_angles, wind=self.world.wind, acknowledge=acked)
        snap = BankSnapshot(k, self.wall(), state, self._forecast, loads)
        self._stage = max(snap.stage(i) for i in range(len(names)))     # this state's events are logged in it
        if self.log is not None:
            self._watch_log()
        self._load_events(loads)
        snap = self._annunciate(snap, every, asked)
        self._snapshot = snap
        return snap

    def start(self) -> None:
        """Run in its own thread."""
        self._thread = threading.Thread(target=self._guarded, name="loadarm-bank", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop and wait for the thread."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    def _guarded(self) -> None:
        try:
            self.run()
        except BaseException as exc:             # reported to the caller
            self.error = exc
        finally:
            self.finished.set()

    def run(self) -> None:
        """Every state of the world's length on the clock (in the calling thread), until its end or :meth:`stop`."""
        start = self.clock()
        n = math.floor(self.world.duration * WORLD_RATE + 1e-9) + 1
        for k in range(n):
            if self._stop.is_set():
                break
            delay = start + k / WORLD_RATE / self.speedup - self.clock()
            if delay > 0:
                self.sleep(delay)
            elif delay < -1.0 / WORLD_RATE / self.speedup:
                self.late += 1
                self.late_tail.append((k, -delay))
            self.step(k)


class BankServer(SnapshotServer):
    """The OPC UA server of a :class:`BankService`, in its own thread (see the module's notes).

    Parameters
    ----------
    service : BankService
    state_dir : path
    endpoint : str
        ``opc.tcp://HOST:PORT`` (default loopback).
    insecure : bool
        Also offer the unsecured endpoint (a lab only).
    anonymous : bool
        Also accept anonymous, read-only sessions.
    """

    def __init__(self, service: BankService, state_dir, endpoint: str = "opc.tcp://127.0.0.1:4840", *,
                 insecure: bool = False, anonymous: bool = False):
        name = service.bank.file.bank.name
        super().__init__(service, name, state_dir, endpoint, BANK_APP_URI, f"loadarm bank ({name})",
                         insecure=insecure, period=1.0 / PUBLISH_RATE, anonymous=anonymous)

    def _security_event(self, code: str, reason: str, data: dict) -> None:
        """A refused login: kept by the service (which logs it too)."""
        self.service.note("security", reason, {"code": code, **data})

    async def _build(self, server) -> dict:
        from asyncua import ua

        ns, mns, dns, machines = await self._machines(server)
        bank = await machines.add_object(ua.NodeId("Bank", ns), ua.QualifiedName("LoadingArmBank", ns))
        await _identification(bank, "Bank", ns, dns, self.name, f"{BANK_APP_URI}:{self.name}")
        nodes: dict = {"bank": {}, "arms": [], "conditions": {}}
        await _variables(bank, "Bank", ns, BANK_VARIABLES, BANK_STATES, nodes["bank"])
        comps = await bank.add_object(ua.NodeId("Bank.Components", ns), ua.QualifiedName("Components", mns))
        bk = self.service.bank
        for arm, path in zip(bk.file.arms, bk.paths, strict=True):
            base = f"Bank.Components.{arm.name}"
            obj = await comps.add_object(ua.NodeId(base, ns), ua.QualifiedName(arm.name, ns))
            await _identification(obj, base, ns, dns, f"{arm.name} ({path.name})",
                                  f"{BANK_APP_URI}:{self.name}:{arm.name}")
            guidance = await obj.add_object(ua.NodeId(f"{base}.Guidance", ns), ua.QualifiedName("Guidance", ns))
            mine: dict = {}
            await _variables(guidance, f"{base}.Guidance", ns, ARM_VARIABLES, ARM_STATES, mine)
            nodes["arms"].append(mine)
            conds = await conditions(server, guidance, ns, ARM_ALARM_TAGS, prefix=f"{arm.name}: ", source=arm.name)
            nodes["conditions"].update({(len(nodes["arms"]) - 1, tag): c for tag, c in conds.items()})
        own = await conditions(server, bank, ns, BANK_ALARM_TAGS, prefix=f"{BANK_NAME}: ", source=BANK_NAME)
        nodes["conditions"].update({(BANK_INDEX, tag): c for tag, c in own.items()})
        server.iserver.isession.add_method_callback(
            ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge),
            acknowledge_method(nodes["conditions"], self.service.request_ack, self.service.note))
        return nodes

    async def _publish(self, nodes: dict, snap: BankSnapshot) -> None:
        await _write(nodes["bank"], bank_values(snap))
        for i, mine in enumerate(nodes["arms"]):
            await _write(mine, arm_values(snap, i))
        for key, state in snap.conditions.items():
            cond = nodes["conditions"].get(key)
            sup = key in snap.suppressed
            if cond is not None and (cond.state != state.value or cond.suppressed != sup):
                await cond.report(state.value, sup)


async def _identification(parent, base: str, ns: int, dns: int, model: str, uri: str) -> None:
    """An Identification object (DI's browse name) with the nameplate's properties."""
    from asyncua import ua

    ident = await parent.add_object(ua.NodeId(f"{base}.Identification", ns), ua.QualifiedName("Identification", dns))
    for key, value in (("Manufacturer", ua.LocalizedText("loadarm (open source)")), ("Model", model),
                       ("ProductInstanceUri", uri), ("SoftwareRevision", __version__), ("SerialNumber", model)):
        await ident.add_property(ua.NodeId(f"{base}.Identification.{key}", ns), ua.QualifiedName(key, dns), value)


async def _variables(parent, base: str, ns: int, doubles, others, out: dict) -> None:
    """Read-only variables under ``parent``: Doubles with their EngineeringUnits and EURange, the others typed."""
    from asyncua import ua

    for bname, (code, symbol, text), (lo, hi), what in doubles:
        v = await parent.add_variable(ua.NodeId(f"{base}.{bname}", ns), ua.QualifiedName(bname, ns), math.nan,
                                      varianttype=ua.VariantType.Double)
        await v.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(ua.LocalizedText(what))))
        await v.add_property(ua.NodeId(f"{base}.{bname}.EngineeringUnits", ns), ua.QualifiedName("EngineeringUnits", 0),
                             ua.EUInformation(NamespaceUri="http://www.opcfoundation.org/UA/units/un/cefact",
                                              UnitId=unece_unit_id(code), DisplayName=ua.LocalizedText(symbol),
                                              Description=ua.LocalizedText(text)))
        await v.add_property(ua.NodeId(f"{base}.{bname}.EURange", ns), ua.QualifiedName("EURange", 0),
                             ua.Range(Low=lo, High=hi))
        out[bname] = (v, ua.VariantType.Double)
    for bname, kind, what in others:
        vt = getattr(ua.VariantType, _KINDS[kind])
        v = await parent.add_variable(ua.NodeId(f"{base}.{bname}", ns), ua.QualifiedName(bname, ns), kind(),
                                      varianttype=vt)
        await v.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(ua.LocalizedText(what))))
        out[bname] = (v, vt)


async def _write(nodes: dict, values: dict) -> None:
    from asyncua import ua

    for key, (node, vt) in nodes.items():
        v = values[key]
        await node.write_value(ua.Variant(float(v) if vt == ua.VariantType.Double else v, vt))
