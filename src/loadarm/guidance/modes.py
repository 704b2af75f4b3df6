"""The guidance controller's vocabulary of state: its modes, what it takes each cycle (the operator's input, the
plant's feedback), what it gives (the command), and its mutable state (:class:`GuidanceState`, like MuJoCo's
``MjData``: the controller's rules read and write it, nothing else does)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.alarms import AlarmState
from loadarm.guidance.estimator import Estimate
from loadarm.guidance.monitor import LimitForecast
from loadarm.guidance.voting import VoteState
from loadarm.vocab import ANNUNCIATED, Severity

if TYPE_CHECKING:  # the model is only ever received, never built, here
    pass

__all__ = ["Mode", "MODES", "CONNECTED_MODES", "MODE_OF_SEVERITY", "SEVERITY_OF_MODE", "ALARM_STAGES",
           "ERS_SWITCH_DISCREPANCY", "ERS_CONFIRM_WINDOW", "ALARM_OFF_DELAY", "OperatorInput", "PlantFeedback",
           "Command", "Cycle", "GuidanceState"]


class Mode(str, enum.Enum):
    """Controller modes."""

    STORED = "STORED"
    APPROACH = "APPROACH"
    HOLD = "HOLD"
    STANDOFF = "STANDOFF"
    CONNECTED = "CONNECTED"
    ALARM1 = "ALARM1"
    ALARM2 = "ALARM2"
    RELEASE = "RELEASE"
    RETURN = "RETURN"
    DISCONNECT = "DISCONNECT"
    MANUAL = "MANUAL"
    ESTOP = "ESTOP"


#: Modes in which the coupler is attached to the flange.
CONNECTED_MODES = (Mode.CONNECTED, Mode.ALARM1, Mode.ALARM2, Mode.RELEASE, Mode.DISCONNECT)


#: The connected mode that each severity puts the controller in (the pre-alarm is a warning only: the mode stays),
#: and back.
MODE_OF_SEVERITY = {Severity.NORMAL: Mode.CONNECTED, Severity.PRE_ALARM: Mode.CONNECTED, Severity.ESD1: Mode.ALARM1,
                    Severity.SECOND: Mode.ALARM2, Severity.RELEASE: Mode.RELEASE}


SEVERITY_OF_MODE = {m: sev for sev, m in MODE_OF_SEVERITY.items() if sev != Severity.PRE_ALARM}


#: The stages the connected-mode monitoring raises, in order.
ALARM_STAGES = (Severity.PRE_ALARM, Severity.ESD1, Severity.SECOND, Severity.RELEASE)


#: The two ERS closed limit switches may disagree this long (one made a little before the other as the valves
#: seat), s; longer is a switch fault.
ERS_SWITCH_DISCREPANCY = 2.0


#: A manual ERS must be confirmed within this time, s.
ERS_CONFIRM_WINDOW = 10.0


#: An alarm condition counts as cleared only after staying clear this long, s (ISA-18.2 off-delay: no
#: chattering from waves near a threshold).
ALARM_OFF_DELAY = 5.0


@dataclass(frozen=True, slots=True)
class OperatorInput:
    """What the operator did this cycle.

    Attributes
    ----------
    actions : tuple of str
        Any of ``start``, ``connect``, ``disconnect`` (controlled), ``estop``, ``reset``, ``manual``, ``auto``,
        ``esd`` (manual ESD-1), ``ers`` then ``ers_confirm`` (manual emergency release, confirmed within
        :data:`ERS_CONFIRM_WINDOW`), ``ack`` (acknowledge every alarm), ``ack:TAG`` (acknowledge one of
        :data:`ANNUNCIATED`).
    jog : tuple of float
        Joystick: requested coupler velocity in MANUAL mode, m/s (x, y, z).
    """

    actions: tuple[str, ...] = ()
    jog: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class PlantFeedback:
    """What the plant reports back each cycle (the PLC's inputs, not the controller's guesses).

    Attributes
    ----------
    ers_switches : tuple of bool
        Each closed limit switch of the ERS valves (two independent ones in the field; a PLC that votes them
        itself reports one).
    angles : tuple of float or None
        The joint angles' second channel (slew, alpha, beta), rad, beside the encoders' (None: no redundancy).
    line_loads : tuple of float or None
        The berth's mooring load monitoring: each line's load as a share of its MBL, the latest reading (None: no
        monitoring linked; :class:`loadarm.guidance.moorings.MooringWatch`).
    """

    ers_switches: tuple = ()
    angles: tuple | None = None
    line_loads: tuple | None = None

    @property
    def ers_valves_closed(self) -> bool:
        """Every closed limit switch made (and at least one reported)."""
        return bool(self.ers_switches) and all(self.ers_switches)


@dataclass(frozen=True, slots=True)
class Command:
    """One cycle's output.

    Attributes
    ----------
    mode : Mode
        Mode after this cycle.
    rates : tuple of float
        Commanded joint rates (slew, alpha, beta), rad/s; zero when the
        actuators are free (connected) or stopped.
    connected : bool
        Coupler attached to the flange.
    esd : bool
        ESD-1 active (transfer pumps stopped, ERS valves closing).
    release : bool
        ERS-2 release requested (the coupler opens once the ERS valves are confirmed closed).
    close_ers_valves : bool
        The ERS valves are commanded closed (ESD-1 or a controlled disconnection).
    coupler_open : bool
        The coupler is opening or open (never before the ERS valves were confirmed closed).
    level : Severity
        Connected-mode alarm level this cycle (``NORMAL`` when not attached).
    time_to_limit : float
        Forecast time to the nearest face of the envelope, s (``inf`` when none is in sight or not attached).
    events : tuple of (kind, reason, data)
        Events of this cycle, for the event log.
    time_to_faces : tuple of (str, float)
        The forecast's time to each face it crossed within its horizon, nearest first (:class:`LimitForecast`).
    horizon : float
        How far ahead the forecast looked, s (the longest stage lead now; ``inf`` when not attached): a
        ``time_to_limit`` of ``inf`` means beyond it.
    route : str
        The forecast's route to the nearest face (:attr:`LimitForecast.route`; ``""``: none in sight).
    drift : tuple of float
        The measured drift velocity the forecast extrapolated (the route's fit; the drift fit's when the design
        drift governs), m/s; ``()`` when there is no fit yet or not attached.
    prediction : Forecast or None
        The flange predictor's latest claimed forecast (:class:`loadarm.guidance.predict.Forecast`: mean and
        calibrated interval per horizon), whether or not it is trusted for the alarms; None: no prediction.
    predicted : tuple of float
        The time to the nearest face by the prediction, s: ``(bound, mean)``, the calibrated bound's (what the
        predictive alarms use) and the mean track's (``inf``: none within the claimed horizon); ``()``: none.
    rule : str
        The rule behind this cycle's connected-mode level (:data:`loadarm.vocab.ALARM_RULES`; ``""``: normal).
    trusted : bool
        The prediction stands in for the measured routes (claimed past the ESD-1 lead, the track within its
        intervals, ESD-1 not raised).
    unused : str
        Why a claimed prediction does not (:data:`loadarm.vocab.PREDICTION_UNUSED`; ``""``: it does, or none).
    moorings : str
        The mooring load monitoring's state (:data:`loadarm.vocab.MOORINGS_TEXT`: ``none``, ``holding``,
        ``lost``).
    held : tuple of float
        ``(since, until)``, s: the rule without the prediction calls for ESD-1 and the trusted prediction holds
        the call (ISA-18.2's suppressed by design: the operator is told), since its joined onset and at most
        until its hold runs out (:meth:`loadarm.guidance.rules.SafetyRules.held_call`); ``()``: no call held.
    """

    mode: Mode
    rates: tuple[float, float, float]
    connected: bool
    esd: bool
    release: bool
    close_ers_valves: bool = False
    coupler_open: bool = False
    level: Severity = Severity.NORMAL
    time_to_limit: float = math.inf
    events: tuple = ()
    time_to_faces: tuple = ()
    horizon: float = math.inf
    route: str = ""
    drift: tuple = ()
    prediction: object = None
    predicted: tuple = ()
    rule: str = ""
    trusted: bool = False
    moorings: str = "none"
    held: tuple = ()
    unused: str = ""


@dataclass(frozen=True, slots=True)
class Cycle:
    """One cycle's inputs, as the rules and handlers see them.

    Attributes
    ----------
    now : float
        Time, s.
    q : tuple of float
        Measured joint angles (slew, alpha, beta), rad.
    est : Estimate
        Flange estimate.
    op : OperatorInput
        Operator inputs.
    acts : frozenset of str
        The operator's actions.
    dt : float
        Nominal cycle period, s.
    fb : PlantFeedback
        The plant's feedback.
    """

    now: float
    q: tuple
    est: Estimate
    op: OperatorInput
    acts: frozenset
    dt: float
    fb: PlantFeedback = PlantFeedback()


@dataclass
class GuidanceState:
    """The controller's mutable state (like MuJoCo's ``MjData`` beside the model): everything that changes from
    one cycle to the next. Build one to start a controller in a given mode (tests, a restart after a fault).

    Attributes
    ----------
    mode : Mode
        Current mode.
    entered : float
        Time the mode was entered, s.
    speed : float
        Cartesian speed command along the approach, m/s.
    refused : str
        ``"jog"`` while a jog out of the envelope is being refused (so the refusal is logged once).
    esd_since : float or None
        Time ESD-1 was commanded.
    valves_cmd_since : float or None
        Time the ERS valves were commanded closed (ESD-1 or a controlled disconnection).
    valves_closed_at : float or None
        Time the plant confirmed the ERS valves closed (the interlock the coupler waits for).
    valve_fault : bool
        The ERS valves did not confirm in time (fault alarm; the coupler stays closed).
    release_since : float or None
        Time the release (ERS-2) was requested.
    release_started_at : float or None
        Time the coupler began to open (never before ``valves_closed_at``).
    raised : Severity
        Highest stage raised since the connection (or the last reset).
    level : Severity
        Connected-mode level of the last cycle.
    forecast : LimitForecast or None
        The latest time-to-limit forecast.
    leads : dict of Severity to float
        The stage leads it was compared with (:func:`loadarm.guidance.monitor.stage_leads`), s.
    next_forecast : float
        Time of the next forecast, s.
    ers_armed_at : float or None
        A manual ERS waiting for its confirmation since this time.
    disconnect_phase : str
        Controlled disconnection: ``"valves"``, ``"drain"``, ``"unclamp"`` or ``""``.
    phase_since : float
        Time the disconnection phase began, s.
    lift_target : ndarray or None
        After a controlled disconnection, the point straight above the flange to lift to first.
    alarms : dict of str to AlarmState
        ISA-18.2 state of each annunciated alarm.
    last_active : dict of str to float
        Last time each alarm's condition was present (for the off-delay).
    quiet : bool
        Every annunciated alarm is normal (the annunciator's fast path).
    resume : Mode
        Mode to resume after an emergency stop.
    switches_odd_since : float or None
        Since when the ERS limit switches disagree, s.
    switch_fault : bool
        They have disagreed longer than :data:`ERS_SWITCH_DISCREPANCY` (until they agree again).
    log_fault : bool
        The event log is unavailable (set by the real-time loop from its log writer; annunciated as
        ``EVENT_LOG_FAULT``, it changes nothing of the arm's control).
    votes : VoteState
        The joint-angle voter's memory.
    trusted : Forecast or None
        The prediction the last time-to-limit forecast trusted in place of the measured routes (None: it did not).
    predicted : tuple of float
        ``(bound, mean, at, forecast, lead)``: the prediction's time to the nearest face by its calibrated bound
        and by its mean, s from ``at``, and the forecast and lead they were found for; ``()`` when there is none.
    predicted_face : str
        The face of the bound's crossing.
    shadow_esd1_at : float or None
        Since when the rule without the prediction (the measured routes and the floor) has called for ESD-1
        without a break (None: it does not; after ESD-1, its first call's time): what a campaign compares the
        predictive alarms with.
    hold_since : float or None
        The onset of the held call in progress, calls apart by less than :data:`ALARM_OFF_DELAY` counted as one
        (None: none stands).
    hold_until : float
        When the held call in progress must raise ESD-1: its onset plus the hold limit, or sooner where a forecast
        of the call leaves the release less than its whole lead by then (:meth:`loadarm.guidance.rules.SafetyRules._shadow`).
    shadow_end_at : float
        When the last call of the rule without the prediction ended, s (``-inf``: none yet).
    holding : bool
        This cycle the trusted prediction held that rule's call (the decision itself, what the screen says).
    rule : str
        The rule behind the connected-mode level (:data:`loadarm.vocab.ALARM_RULES`).
    moorings : str
        The mooring load monitoring's state (:meth:`loadarm.guidance.moorings.MooringWatch.state`).
    departed_said : float or None
        The predictor's departure the event log was told of (its time; None: none).
    recalibrated_said : float
        The last departure before the connection (the calibration began again) the event log was told of, s.
    unused : str
        Why the claimed prediction was not trusted at the last time-to-limit forecast
        (:data:`loadarm.vocab.PREDICTION_UNUSED`; ``""``: it was, or none).
    events : list
        Events of the current cycle.
    """

    mode: Mode = Mode.STORED
    entered: float = 0.0
    speed: float = 0.0
    refused: str = ""
    esd_since: float | None = None
    valves_cmd_since: float | None = None
    valves_closed_at: float | None = None
    valve_fault: bool = False
    release_since: float | None = None
    release_started_at: float | None = None
    raised: Severity = Severity.NORMAL
    level: Severity = Severity.NORMAL
    forecast: LimitForecast | None = None
    leads: dict = field(default_factory=dict)
    next_forecast: float = -math.inf
    ers_armed_at: float | None = None
    disconnect_phase: str = ""
    phase_since: float = 0.0
    lift_target: np.ndarray | None = None
    alarms: dict = field(default_factory=lambda: {tag: AlarmState.NORMAL for tag in ANNUNCIATED})
    last_active: dict = field(default_factory=lambda: {tag: -math.inf for tag in ANNUNCIATED})
    quiet: bool = True
    resume: Mode = Mode.APPROACH
    switches_odd_since: float | None = None
    switch_fault: bool = False
    log_fault: bool = False
    votes: VoteState = field(default_factory=VoteState)
    trusted: object = None
    predicted: tuple = ()
    predicted_face: str = ""
    shadow_esd1_at: float | None = None
    hold_since: float | None = None
    hold_until: float = math.inf
    shadow_end_at: float = -math.inf
    holding: bool = False
    rule: str = ""
    moorings: str = "none"
    departed_said: float | None = None
    recalibrated_said: float = -math.inf
    unused: str = ""
    events: list = field(default_factory=list)

    def clear_calls(self) -> None:
        """Forget the rule without the prediction's call and the hold (at a connection, and at an ESD-1 reset:
        found by review, a call from before the reset otherwise ended with the whole ESD-1 episode in it, and a
        call just after the reset joined that group with its hold spent, raising ESD-1 at once)."""
        self.shadow_esd1_at, self.hold_since, self.hold_until, self.shadow_end_at = None, None, math.inf, -math.inf
        self.holding = False


MODES = tuple(m.value for m in Mode)
