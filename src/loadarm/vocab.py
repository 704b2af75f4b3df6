"""The safety vocabulary, declared once: the envelope's faces, the annunciated alarms, the roles and the
operator's actions with the one rule of who may request what.

Everything that names a face, an alarm or an action (the controller, the design check, alarm design, the
OPC UA server, the operator's screen, the report) reads these tables; none keeps a list of its own
(``tests/test_vocab.py`` fails on a second declaration of a face text, an alarm text or an action table).

* :data:`FACE_TABLE`: each face of the attached envelope with the operator's words, the joint and end it is,
  and the flange motion that brings it nearer (a property test holds the words to the geometry);
* :data:`CONDITIONS`: each annunciated alarm with its alarm stage, OPC UA severity, ISA-18.2 priority and text;
* :class:`Role` and :data:`ACTION_TABLE`: each operator request, what the controller does with it, the least
  role that may ask for it and where it is offered (the screen, an OPC UA method). The screen and the
  OPC UA server both serve this one table;
* :data:`EVENT_TABLE`: the event codes. An event carries its code in its data; its text starts with the code's
  label and adds the values. Metrics, figures and the CLI read the code.

The role rule (written down here, served by both interfaces): viewing needs a signed-in user or an anonymous
OPC UA session; every request needs a signed-in user of the action's role. ESD-1 is open to a signed-in
viewer (the ship's side, by the ship-shore link): it only stops the transfer and closes valves, as any
person on the jetty may by the hard-wired ESD push button. An anonymous session may request nothing.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from loadarm.errors import ConfigError

#: Classification of a position the arm cannot reach (not a severity).
UNREACHABLE = -1


_LABELS = {UNREACHABLE: "unreachable", 0: "normal", 1: "pre-alarm", 2: "first alarm (ESD-1)", 3: "second alarm",
           4: "release (ERS-2)"}


class Severity(enum.IntEnum):
    """Ordered alarm severity, the same everywhere."""

    NORMAL = 0
    PRE_ALARM = 1
    ESD1 = 2
    SECOND = 3
    RELEASE = 4

    @property
    def label(self) -> str:
        """Short human label, as used in tables, logs and the report."""
        return _LABELS[int(self)]


__all__ = ["Severity", "UNREACHABLE", "severity_label", "Face", "FACE_TABLE", "FACES", "FACE_LABELS", "FACE_WORDS",
           "SWIVEL_FACE_TABLE", "CLASH_FACE", "BANK_FACE_TABLE", "BANK_FACE_WORDS", "Condition", "CONDITIONS", "ANNUNCIATED",
           "CONDITION_SEVERITY", "CONDITION_TEXT", "BANK_CONDITIONS", "condition_text", "condition_severity", "RESET_BLOCKING", "PRIORITIES", "priority", "Role", "Action", "ACTION_TABLE",
           "ACTIONS", "COMMANDS", "METHODS", "TAGGED_ACTIONS", "action_role", "EventCode", "EVENT_TABLE",
           "EVENTS", "STAGE_EVENT", "event_label", "alarm_label", "ALARM_RULES", "SHARED_ALARM_RULES",
           "ROUTE_DESIGN", "ROUTE_MEASURED", "ROUTE_STEP", "ROUTE_BREAKOUT", "ROUTE_PREDICTION", "MEASURED_ROUTES",
           "CHANGE_ROUTES", "MOORINGS_TEXT", "UNLIMITED_CODES", "PREDICTION_UNUSED", "PREDICTION_UNUSED_ABNORMAL"]


@dataclass(frozen=True, slots=True)
class Face:
    """One face of the attached envelope.

    Attributes
    ----------
    name : str
        The code (``beta_max``, ...), in the order of :func:`loadarm.arm.faces.face_margins`' last axis.
    words : str
        The operator's words: what the arm looks like there and what the flange did.
    detail : str
        The joint and the cylinder end, for the engineer.
    joint : str
        ``beta``, ``alpha`` or ``slew``.
    end : str
        ``max`` or ``min``: the joint's upper or lower limit.
    towards : tuple of float
        A flange motion (unit vector in the jetty frame, x off the berth, y along it, z up) that brings this
        face nearer wherever the arm can reach (held by ``tests/test_vocab.py``; ``beta`` faces: radially, out
        or in, marked by a zero vector and :attr:`radial`).
    radial : int
        +1: moving the flange away from the inboard pivot brings the face nearer; -1: towards it; 0: use
        :attr:`towards`.
    unit : str
        The unit of the face's margin (the joint angle's).
    turning : tuple of float
        A face of the connected coupler (:data:`SWIVEL_FACE_TABLE`): the ship's rotation (unit rotation vector in
        the jetty frame) that brings it nearer (held by ``tests/test_bank.py``); zero for the arm's faces.
    """

    name: str
    words: str
    detail: str
    joint: str
    end: str
    towards: tuple[float, float, float]
    radial: int = 0
    unit: str = "rad"
    turning: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def label(self) -> str:
        """Words and detail together, as the design check and the OPC UA margins describe the face."""
        return f"{self.words} ({self.detail})"


#: The faces. Alpha is the inboard arm's angle from the upward vertical: it is largest when the inboard arm
#: is lowest, i.e. at the lowest flange (the paper's corner table: 10 deg at the highest flange, 117 deg at
#: the lowest), so ``alpha_max`` is the flange too low and ``alpha_min`` the flange too high.
FACE_TABLE: tuple[Face, ...] = (
    Face("beta_max", "arm stretched: flange too far out", "beta at cylinder 2's extended end",
         "beta", "max", (0.0, 0.0, 0.0), radial=+1),
    Face("beta_min", "arm folded: flange too close in", "beta at cylinder 2's retracted end, coupler towards "
         "the jetty", "beta", "min", (0.0, 0.0, 0.0), radial=-1),
    Face("alpha_max", "inboard arm down: flange too low", "alpha at cylinder 1's end, inboard arm far from "
         "the vertical", "alpha", "max", (0.0, 0.0, -1.0)),
    Face("alpha_min", "inboard arm up: flange too high", "alpha at cylinder 1's other end, inboard arm near "
         "the vertical", "alpha", "min", (0.0, 0.0, 1.0)),
    Face("slew_pos", "slewed to its limit: flange too far along the berth, +y", "slew at its positive limit",
         "slew", "max", (0.0, 1.0, 0.0)),
    Face("slew_neg", "slewed to its limit: flange too far along the berth, -y", "slew at its negative limit",
         "slew", "min", (0.0, -1.0, 0.0)),
)
#: The face codes, in the order of :func:`loadarm.arm.faces.face_margins`' last axis.
FACES: tuple[str, ...] = tuple(f.name for f in FACE_TABLE)
#: The operator's words of each face.
FACE_WORDS: dict[str, str] = {f.name: f.words for f in FACE_TABLE}
#: Words and detail of each face (the design check's refusals, the OPC UA margins' descriptions).
FACE_LABELS: dict[str, str] = {f.name: f.label for f in FACE_TABLE}


#: The style-80 triple swivel's travel limits and the clash between two arms of a bank (issue 31): faces of the
#: connected bank, declared apart from :data:`FACE_TABLE` (the single arm's monitor, kernel, screen and OPC UA
#: margins iterate that one and its fixed order; these reach them when the bank does). Swivel 1 turns about the
#: arm's hinge axis (along the berth: it takes the ship's roll), swivel 2 about the coupler's vertical drop (the
#: ship's yaw and the slew), swivel 3 about the flange's normal (the ship's pitch): :mod:`loadarm.arm.swivel`.
#: ``turning`` is the ship's rotation, in the jetty frame, that nears each face wherever the arm connects.
SWIVEL_FACE_TABLE: tuple[Face, ...] = (
    Face("swivel1_max", "coupler swivel 1 at its limit: ship heeled away from the jetty",
         "swivel 1 (about the hinge axis) at its upper stop", "swivel1", "max", (0.0, 0.0, 0.0),
         turning=(0.0, 1.0, 0.0)),
    Face("swivel1_min", "coupler swivel 1 at its limit: ship heeled towards the jetty",
         "swivel 1 (about the hinge axis) at its lower stop", "swivel1", "min", (0.0, 0.0, 0.0),
         turning=(0.0, -1.0, 0.0)),
    Face("swivel2_max", "coupler swivel 2 at its limit: ship yawed anticlockwise (seen from above)",
         "swivel 2 (about the coupler's drop) at its upper stop", "swivel2", "max", (0.0, 0.0, 0.0),
         turning=(0.0, 0.0, 1.0)),
    Face("swivel2_min", "coupler swivel 2 at its limit: ship yawed clockwise (seen from above)",
         "swivel 2 (about the coupler's drop) at its lower stop", "swivel2", "min", (0.0, 0.0, 0.0),
         turning=(0.0, 0.0, -1.0)),
    Face("swivel3_max", "coupler swivel 3 at its limit: ship pitched, its +y end up",
         "swivel 3 (about the flange's normal) at its upper stop", "swivel3", "max", (0.0, 0.0, 0.0),
         turning=(1.0, 0.0, 0.0)),
    Face("swivel3_min", "coupler swivel 3 at its limit: ship pitched, its -y end up",
         "swivel 3 (about the flange's normal) at its lower stop", "swivel3", "min", (0.0, 0.0, 0.0),
         turning=(-1.0, 0.0, 0.0)),
)
#: Two arms of a bank closer than the bank's minimum clearance (:mod:`loadarm.arm.clearance`).
CLASH_FACE = Face("clash", "arms too close: clash with the next arm",
                  "capsule clearance between two arms of the bank below its minimum", "clearance", "min",
                  (0.0, 0.0, 0.0), unit="m")
#: The bank's faces: the swivels' and the clash.
BANK_FACE_TABLE: tuple[Face, ...] = SWIVEL_FACE_TABLE + (CLASH_FACE,)
#: Their words.
BANK_FACE_WORDS: dict[str, str] = {f.name: f.words for f in BANK_FACE_TABLE}


#: ISA-18.2 priorities, most urgent first, with the OPC UA severity (1-1000) each starts at.
PRIORITIES: tuple[tuple[str, int], ...] = (("critical", 900), ("high", 700), ("medium", 500), ("low", 1))


@dataclass(frozen=True, slots=True)
class Condition:
    """One annunciated alarm.

    Attributes
    ----------
    tag : str
        The code the controller, the event log, the OPC UA condition and the screen use.
    stage : Severity or None
        The connected-mode alarm stage it annunciates (None: an equipment fault).
    severity : int
        OPC UA severity, 1-1000 (the ISA-18.2 priority follows from it: :func:`priority`).
    text : str
        What it means, for the condition's message and the screen's alarm list.
    blocks_reset : bool
        An ESD-1 reset waits until it is cleared and acknowledged (False: it says nothing of the arm's safety,
        e.g. the event log).
    """

    tag: str
    stage: Severity | None
    severity: int
    text: str
    blocks_reset: bool = True

    @property
    def priority(self) -> tuple[int, str]:
        """ISA-18.2 priority: rank (1 the most urgent) and name."""
        for rank, (name, floor) in enumerate(PRIORITIES, start=1):
            if self.severity >= floor:
                return rank, name
        return len(PRIORITIES), PRIORITIES[-1][0]


#: The annunciated alarms, in the order the controller keeps them.
CONDITIONS: tuple[Condition, ...] = (
    Condition("PRE_ALARM", Severity.PRE_ALARM, 300, "pre-alarm: the flange nears the ESD-1 threshold"),
    Condition("ESD1", Severity.ESD1, 600, "ESD-1: pumps stopped, ERS valves closing"),
    Condition("SECOND", Severity.SECOND, 800, "second alarm: release imminent"),
    Condition("RELEASE", Severity.RELEASE, 1000, "ERS-2: release of the coupler"),
    Condition("ERS_VALVE_FAULT", None, 800, "ERS valves not confirmed closed in time"),
    Condition("ERS_SWITCH_FAULT", None, 800, "ERS valves' closed limit switches disagree"),
    Condition("SENSOR_FAULT", None, 800, "a joint-angle sensor is frozen, drifting or failed"),
    Condition("EVENT_LOG_FAULT", None, 500, "event log unavailable: events kept in memory until it returns",
              blocks_reset=False),
)
#: The bank's own annunciated alarm (its screen's list; a bank's stage alarms are :data:`CONDITIONS`' per arm).
BANK_CONDITIONS: tuple[Condition, ...] = (
    Condition("MANIFOLD_LOAD", None, 500, "a load on the ship's manifold past its allowable", blocks_reset=False),
)
_BY_TAG = {c.tag: c for c in CONDITIONS + BANK_CONDITIONS}
#: The annunciated alarms' tags.
ANNUNCIATED: tuple[str, ...] = tuple(c.tag for c in CONDITIONS)
#: OPC UA severity (1-1000) of each annunciated alarm.
CONDITION_SEVERITY: dict[str, int] = {c.tag: c.severity for c in CONDITIONS}
#: What each annunciated alarm means.
CONDITION_TEXT: dict[str, str] = {c.tag: c.text for c in CONDITIONS}
def condition_text(tag: str) -> str:
    """What an annunciated alarm means (:data:`CONDITIONS` or :data:`BANK_CONDITIONS`).

    Parameters
    ----------
    tag : str

    Returns
    -------
    str
    """
    return _BY_TAG[tag].text


def condition_severity(tag: str) -> int:
    """An annunciated alarm's OPC UA severity, 1-1000 (:data:`CONDITIONS` or :data:`BANK_CONDITIONS`).

    Parameters
    ----------
    tag : str

    Returns
    -------
    int
    """
    return _BY_TAG[tag].severity


#: The alarms an ESD-1 reset waits for.
RESET_BLOCKING: tuple[str, ...] = tuple(c.tag for c in CONDITIONS if c.blocks_reset)


def priority(tag: str) -> tuple[int, str]:
    """An annunciated alarm's ISA-18.2 priority.

    Parameters
    ----------
    tag : str
        One of :data:`ANNUNCIATED` or :data:`BANK_CONDITIONS`' tags.

    Returns
    -------
    rank : int
        1 the most urgent.
    name : str
        ``critical``, ``high``, ``medium`` or ``low``.

    Raises
    ------
    KeyError
        For a tag that is not annunciated.
    """
    return _BY_TAG[tag].priority


class Role(enum.IntEnum):
    """What a signed-in user may do; each role includes the ones below it."""

    VIEWER = 1
    OPERATOR = 2
    ENGINEER = 3

    @classmethod
    def parse(cls, text: str, source: str = "role") -> "Role":
        """The role named ``text`` (case-insensitive).

        Raises
        ------
        ConfigError
            Naming the allowed roles.
        """
        try:
            return cls[str(text).upper()]
        except KeyError:
            raise ConfigError(f"{source}: unknown role {text!r}; one of viewer, operator, engineer") from None


@dataclass(frozen=True, slots=True)
class Action:
    """One operator request.

    Attributes
    ----------
    name : str
        The request's code (the screen's command, the service's :class:`loadarm.opcua.service.Request`).
    controller : tuple of str
        The controller actions it becomes (empty: kept by the screen, logged only).
    role : Role
        The least role that may request it.
    screen : bool
        Offered on the operator's screen.
    method : str or None
        The OPC UA method that requests it (None: not offered there).
    args : tuple of str
        The OPC UA method's input arguments.
    what : str
        What it does, for the method's description and the docs (``{jog_hold}`` and ``{ers_window}`` are
        filled in by the server with the service's and the controller's values).
    """

    name: str
    controller: tuple[str, ...]
    role: Role
    screen: bool
    method: str | None = None
    args: tuple[str, ...] = ()
    what: str = ""


#: Every operator request and who may make it, where. ``ers`` asks; ``ers_confirm`` confirms within the
#: controller's window (the OPC UA method ManualERS takes both, by its Confirm argument).
ACTION_TABLE: tuple[Action, ...] = (
    Action("start", ("start",), Role.OPERATOR, True, "StartApproach", (), "start the automatic approach to the "
           "standoff"),
    Action("connect", ("connect",), Role.OPERATOR, True, "Connect", (), "connect the coupler at the standoff"),
    Action("disconnect", ("disconnect",), Role.OPERATOR, False, "Disconnect", (), "controlled disconnection"),
    Action("jog", ("manual",), Role.OPERATOR, True, "Jog", ("vx", "vy", "vz"), "jog the coupler (m/s) for "
           "{jog_hold:g} s; renew to keep moving"),
    Action("stop", ("manual",), Role.OPERATOR, True, "Stop", (), "stop (manual mode, no motion)"),
    Action("estop", ("estop",), Role.OPERATOR, True, "EStop", (), "request the emergency stop (the PLC's "
           "hard-wired chain decides)"),
    Action("esd", ("esd",), Role.VIEWER, True, "ManualESD1", (), "manual ESD-1"),
    Action("ers", ("ers",), Role.OPERATOR, True, "ManualERS", ("Confirm",), "manual emergency release: call, "
           "then call with Confirm = true within {ers_window:g} s"),
    Action("ers_confirm", ("ers_confirm",), Role.OPERATOR, True),
    Action("reset", ("reset",), Role.OPERATOR, True, "Reset", (), "reset after an emergency stop or an alarm"),
    Action("ack", ("ack",), Role.OPERATOR, True, "AcknowledgeAlarm", (), "acknowledge every alarm"),
    Action("auto", ("auto",), Role.OPERATOR, False),
    Action("shelve", (), Role.OPERATOR, True),
    Action("unshelve", (), Role.OPERATOR, True),
)
_ACTION = {a.name: a for a in ACTION_TABLE}
#: Request to the controller actions it becomes.
ACTIONS: dict[str, tuple[str, ...]] = {a.name: a.controller for a in ACTION_TABLE}
#: The screen's commands and the least role each needs.
COMMANDS: dict[str, Role] = {a.name: a.role for a in ACTION_TABLE if a.screen}
#: The OPC UA methods: (browse name, request, input arguments, description).
METHODS: tuple[tuple[str, str, tuple[str, ...], str], ...] = tuple(
    (a.method, a.name, a.args, a.what) for a in ACTION_TABLE if a.method)
#: The requests that may name one alarm (``tag``).
TAGGED_ACTIONS: tuple[str, ...] = ("ack", "shelve", "unshelve")


def action_role(name: str) -> Role:
    """The least role that may request an action.

    Parameters
    ----------
    name : str
        One of :data:`ACTIONS`.

    Returns
    -------
    Role

    Raises
    ------
    KeyError
        For an action that is not declared.
    """
    return _ACTION[name].role


@dataclass(frozen=True, slots=True)
class EventCode:
    """One kind of event the metrics, figures, the CLI and the screen read by its code (never by its text).

    Attributes
    ----------
    code : str
        The code, carried in the event's data as ``code``.
    kind : str
        The event log's kind (:data:`loadarm.eventlog.KINDS`).
    label : str
        The short name the event's text starts with and the figures mark it by.
    stage : Severity or None
        The alarm stage it raises, for the stage events.
    """

    code: str
    kind: str
    label: str
    stage: Severity | None = None


#: The events read by code: the alarm stages, the equipment faults, the ERS interlock and the release.
EVENT_TABLE: tuple[EventCode, ...] = (
    EventCode("stage.pre_alarm", "alarm", "PRE-ALARM", Severity.PRE_ALARM),
    EventCode("stage.esd1", "alarm", "ALARM1", Severity.ESD1),
    EventCode("stage.second", "alarm", "ALARM2", Severity.SECOND),
    EventCode("stage.release", "alarm", "RELEASE", Severity.RELEASE),
    EventCode("fault.sensor", "alarm", "SENSOR FAULT"),
    EventCode("fault.ers_switch", "alarm", "ERS SWITCH FAULT"),
    EventCode("fault.ers_valve", "alarm", "ERS VALVE FAULT"),
    EventCode("fault.ers_unconfirmed", "alarm", "ERS valves no longer confirmed closed (a limit switch dropped)"),
    EventCode("fault.plc_link", "alarm", "PLC link lost"),
    EventCode("fault.hpu_trip", "alarm", "HPU trip"),
    EventCode("fault.accumulator_spent", "alarm", "ERS accumulator spent"),
    EventCode("fault.overstretched", "alarm", "ARM OVERSTRETCHED"),
    EventCode("fault.servo", "alarm", "hydraulic servo fault"),
    EventCode("fault.not_clear", "alarm", "coupler not clear of the ship's manifold"),
    EventCode("fault.manifold_load", "alarm", "MANIFOLD LOAD"),
    EventCode("fault.event_log", "alarm", "EVENT LOG UNAVAILABLE"),
    EventCode("fault.events_lost", "alarm", "events lost"),
    EventCode("info.event_log_restored", "info", "event log restored"),
    EventCode("info.measured_esd1", "info", "measured drift calls for ESD-1"),
    EventCode("info.measured_esd1_end", "info", "measured drift's call for ESD-1 ends"),
    EventCode("info.moorings_lost", "info",
              "moorings lost: more than a third of the lines slack, the prediction stands down"),
    EventCode("info.prediction_departed", "info",
              "the track left the prediction's intervals: the prediction stands down"),
    EventCode("info.prediction_recalibrated", "info",
              "not connected, the track left the prediction's intervals: its calibration begins again"),
    EventCode("info.prediction_reset", "info",
              "connection ended: the departure found while connected is cleared, the prediction's calibration "
              "begins again"),
    EventCode("info.moorings_silent", "info", "mooring load monitoring silent: no change detector's call is held"),
    EventCode("interlock.valves_confirmed", "interlock", "ERS valves confirmed closed"),
    EventCode("command.coupler_opening", "command", "ERS-2: coupler opening"),
    EventCode("command.release_complete", "command", "ERS-2 release complete"),
    EventCode("security.login_refused", "security", "login refused"),
    EventCode("security.login_limited", "security", "login refused: too many failures"),
    EventCode("security.command_refused", "security", "command refused"),
    EventCode("security.user_added", "security", "user added"),
    EventCode("security.user_removed", "security", "user removed"),
    EventCode("security.password_changed", "security", "password changed"),
)
#: Info events each of which a study reads, so an event log's rate limiter never counts them away
#: (:class:`loadarm.eventlog.RateLimiter`): the calls for ESD-1 of the rule without the prediction, whose onsets and
#: ends :meth:`loadarm.sim.result.RunResult.held_calls` pairs (found: with alike ends within 10 s counted away, a
#: call's end went missing and the next onset swallowed it: Hs 2.0-2.5 m seed 533's call at 426.62 s). They cannot
#: flood: a call starts or ends only at a new forecast (the drift fit's 0.2 s), only before ESD-1, and a joined
#: call stands at most the hold limit (15 s) before ESD-1 latches; so at most 5 a second, about 4 sustained. And
#: the predictor's departures: once per connection while connected (a campaign counts these), cleared once when
#: the connection ends, and while not connected at most one per calibration (5 minutes of errors at least; not
#: counted by a campaign).
UNLIMITED_CODES: frozenset[str] = frozenset({"info.measured_esd1", "info.measured_esd1_end",
                                             "info.prediction_departed", "info.prediction_recalibrated",
                                             "info.prediction_reset"})
#: Code to its record.
EVENTS: dict[str, EventCode] = {e.code: e for e in EVENT_TABLE}
#: The code of each connected-mode alarm stage's event.
STAGE_EVENT: dict[Severity, str] = {e.stage: e.code for e in EVENT_TABLE if e.stage is not None}


#: The rules that raise a connected-mode alarm stage, by code (an alarm event carries its rule's code in its data
#: as ``rule``; the figures, the journal and the campaigns read the code): the customer's position alarm, the
#: design-drift floor (Lanquetin), a drift measured on the track (the drift fit, its velocity-step and break-out
#: tests), the flange prediction's calibrated bound (issue 30), the operator's manual ESD-1 or ERS, and an
#: equipment fault (angle sensors that cannot be voted).
ALARM_RULES: dict[str, str] = {
    "position": "position alarm",
    "floor": "design-drift floor",
    "measured": "measured drift",
    "prediction": "prediction",
    "hold_limit": "measured drift, held to the hold limit",
    "operator": "operator's request",
    "fault": "equipment fault",
}

#: The rules that raise ESD-1 alike with and without the prediction: today's rule (the rule without it) has them
#: too, so a campaign counts an ESD-1 of theirs as today's (``CampaignRun.alarm1_today_s``, issue 30).
SHARED_ALARM_RULES: frozenset[str] = frozenset({"position", "floor", "operator", "fault"})

#: The routes of the time-to-limit forecast, in the words its events and the screen show: the design-drift floor,
#: the drift fitted on the track, the fit's two change detectors (a step in the velocity, a break-out's growing
#: acceleration) and the flange prediction (issue 30).
ROUTE_DESIGN, ROUTE_MEASURED, ROUTE_STEP, ROUTE_BREAKOUT, ROUTE_PREDICTION = (
    "design drift", "measured drift", "velocity step", "break-out", "prediction")
#: The routes measured on the flange's track.
MEASURED_ROUTES: tuple[str, ...] = (ROUTE_MEASURED, ROUTE_STEP, ROUTE_BREAKOUT)
#: The routes of a detected change of regime: their call for ESD-1 is not held by the prediction (learned on the
#: regime before the change) once the track has left the prediction's intervals (``guidance.rules``).
CHANGE_ROUTES: tuple[str, ...] = (ROUTE_STEP, ROUTE_BREAKOUT)

#: Why a claimed prediction does not stand in for the measured routes, by code (``""``: it does, or there is
#: none), in the order the rules ask (:meth:`loadarm.guidance.rules.SafetyRules.prediction_unused`).
PREDICTION_UNUSED: dict[str, str] = {"detached": "not connected",
                                     "esd1": "ESD-1 raised: every route acts",
                                     "moorings": "the moorings are lost",
                                     "departed": "the track left its intervals",
                                     "short": "claimed short of ESD-1's lead"}
#: Those of :data:`PREDICTION_UNUSED` a screen marks abnormal (the ship is not the one the prediction learned).
PREDICTION_UNUSED_ABNORMAL: frozenset[str] = frozenset({"moorings", "departed"})
#: The berth's mooring load monitoring as the guidance reads it (:mod:`loadarm.guidance.moorings`), by state:
#: none linked, the moorings holding, silent (read before, no fresh reading now: no witness), or lost (more than
#: a third of the lines slack: the prediction stood down).
MOORINGS_TEXT: dict[str, str] = {"none": "no mooring load monitoring", "holding": "moorings holding",
                                 "silent": "mooring load monitoring silent",
                                 "lost": "MOORINGS LOST: lines slack"}


def event_label(code: str) -> str:
    """The short name of an event code.

    Parameters
    ----------
    code : str
        One of :data:`EVENTS`.

    Returns
    -------
    str

    Raises
    ------
    KeyError
        For a code that is not declared.
    """
    return EVENTS[code].label


def alarm_label(data: dict | None) -> str:
    """The label an alarm event is marked by in figures.

    Parameters
    ----------
    data : dict or None
        The event's data.

    Returns
    -------
    str
        Its code's label (:func:`event_label`), or ``"alarm"`` for an event that carries no declared code (a
        log written before event codes).
    """
    code = (data or {}).get("code")
    return EVENTS[code].label if code in EVENTS else "alarm"


def severity_label(value: int) -> str:
    """Label of a classification value: a :class:`Severity` or :data:`UNREACHABLE`.

    Parameters
    ----------
    value : int
        The value.

    Returns
    -------
    str
    """
    return _LABELS[int(value)]
