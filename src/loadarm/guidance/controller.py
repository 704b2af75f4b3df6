"""The guidance state machine: approach, standoff, connected monitoring, alarms, release, return.

Modes::

    STORED -> APPROACH -> STANDOFF -> CONNECTED -> ALARM1 (ESD-1) -> ALARM2 -> RELEASE (ERS-2) -> RETURN -> STORED
    HOLD (estimate lost while moving), MANUAL (joystick jog), ESTOP (from any mode)

The controller is pure logic on an injected clock: :meth:`GuidanceController.step`
takes the time, the measured joint angles, the flange estimate and the
operator's inputs, and returns the joint-rate command and the events of that
cycle. The same code runs in simulation and in real time.

Safety rules (each tested):

* no motion command without a fresh, healthy flange estimate: the cycle that
  sees it stale commands zero rates and enters HOLD;
* a target outside the envelope (unreachable, beyond the first-alarm angle or
  the slew alarm) is refused, not approached;
* emergency stop from any mode: zero rates in the same cycle;
* joint and stroke limits: a command that would cross a limit within the next
  cycle is cut to stop at it;
* alarms on drift speed as well as position (see :class:`AlarmThresholds`).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..alarms import AlarmThresholds, Severity
from ..geometry import Arm
from ..kinematics import ROUNDOFF_M, jacobian_entries
from ..slew import forward3d, inverse3d, reach_mask3d
from .scenario import Guidance
from .sensor import Estimate

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from ..model import ArmModel

__all__ = ["Mode", "Command", "OperatorInput", "Cycle", "GuidanceState", "GuidanceController"]


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
    MANUAL = "MANUAL"
    ESTOP = "ESTOP"


#: Modes in which the coupler is attached to the flange.
CONNECTED_MODES = (Mode.CONNECTED, Mode.ALARM1, Mode.ALARM2, Mode.RELEASE)
#: The connected mode that each severity puts the controller in, and back.
MODE_OF_SEVERITY = {Severity.NORMAL: Mode.CONNECTED, Severity.ESD1: Mode.ALARM1, Severity.SECOND: Mode.ALARM2,
                    Severity.RELEASE: Mode.RELEASE}
SEVERITY_OF_MODE = {m: sev for sev, m in MODE_OF_SEVERITY.items()}
#: The stages the connected-mode monitoring raises, in order.
ALARM_STAGES = (Severity.ESD1, Severity.SECOND, Severity.RELEASE)


@dataclass(frozen=True, slots=True)
class OperatorInput:
    """What the operator did this cycle.

    Attributes
    ----------
    actions : tuple of str
        Any of ``start``, ``connect``, ``disconnect``, ``estop``, ``reset``,
        ``manual``, ``auto``.
    jog : tuple of float
        Joystick: requested coupler velocity in MANUAL mode, m/s (x, y, z).
    """

    actions: tuple[str, ...] = ()
    jog: tuple[float, float, float] = (0.0, 0.0, 0.0)


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
        ERS-2 release in progress or done.
    events : tuple of (kind, reason, data)
        Events of this cycle, for the event log.
    """

    mode: Mode
    rates: tuple[float, float, float]
    connected: bool
    esd: bool
    release: bool
    events: tuple = ()


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
    """

    now: float
    q: tuple
    est: Estimate
    op: OperatorInput
    acts: frozenset
    dt: float


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
    v_r, v_phi : float
        Filtered outward speed (m/s) and slew rate (rad/s) of the attached coupler.
    last_r, last_phi, last_t : float or None
        Previous sample of the drift filter.
    refused : str
        ``"jog"`` while a jog out of the envelope is being refused (so the refusal is logged once).
    esd_since, release_since : float or None
        Time ESD-1 was commanded / the release (ERS-2) was requested.
    valves_closed_at : float or None
        Time the ERS valves were confirmed closed (the interlock the coupler waits for).
    release_started_at : float or None
        Time the coupler began to open (never before ``valves_closed_at``).
    resume : Mode
        Mode to resume after an emergency stop (or a pending approach).
    events : list
        Events of the current cycle.
    """

    mode: Mode = Mode.STORED
    entered: float = 0.0
    speed: float = 0.0                 # current Cartesian speed command along the approach, m/s
    v_r: float = 0.0                   # filtered outward speed, m/s
    v_phi: float = 0.0                 # filtered slew rate, rad/s
    last_r: float | None = None
    last_phi: float | None = None
    last_t: float | None = None
    refused: str = ""
    esd_since: float | None = None
    release_since: float | None = None
    valves_closed_at: float | None = None
    release_started_at: float | None = None
    resume: Mode = Mode.APPROACH
    events: list = field(default_factory=list)


class GuidanceController:
    """The guidance state machine (see the module docstring).

    Parameters
    ----------
    model : ArmModel
        Arm, alarms, approach limits, stored position (2D, taken at y = 0).
    g : Guidance
        Guidance settings.
    state : GuidanceState, optional
        Start in this state (default: stored, no alarm).

    Notes
    -----
    :meth:`step` is a dispatcher: the operator's actions are logged, the safety rules of :attr:`SAFETY_RULES`
    run in that fixed order (each a named method, tested on its own), the handler of the resulting mode
    (:attr:`HANDLERS`) computes the rate command, and :meth:`rule_no_motion_when_held_or_attached` has the last
    word on it.
    """

    def __init__(self, model: ArmModel, g: Guidance, state: "GuidanceState | None" = None):
        self.arm: Arm = model.arm
        self.g = g
        self.lim = model.joint_limits
        self.thr = AlarmThresholds.from_settings(model, g)
        self.v_max = model.approach.max_speed
        self.a_max = model.approach.max_accel
        sx, sz = model.approach.stored
        self.stored = np.array([sx, 0.0, sz])
        self.dt_nominal = 1.0 / g.rate
        self.state = GuidanceState() if state is None else state

    # ---------------------------------------------------------------- helpers
    def _event(self, kind: str, reason: str, **data) -> None:
        self.state.events.append((kind, reason, data))

    def _go(self, now: float, mode: Mode, reason: str) -> None:
        if mode != self.state.mode:
            self._event("mode", f"{self.state.mode.value} -> {mode.value}: {reason}", previous=self.state.mode.value,
                        mode=mode.value)
            self.state.mode = mode
            self.state.entered = now
            self.state.speed = 0.0

    def standoff_point(self, flange: np.ndarray) -> np.ndarray:
        """Point ``standoff`` metres from the flange, horizontally towards the riser.

        Parameters
        ----------
        flange : ndarray, shape (3,)
            Flange position, m.

        Returns
        -------
        ndarray, shape (3,)
        """
        h = np.array([flange[0], flange[1], 0.0])
        n = np.linalg.norm(h)
        if n < 1e-9:
            return flange.copy()
        return flange - self.g.standoff * h / n

    def target_ok(self, p: np.ndarray) -> str:
        """Why a target may not be approached ('' if it may): reach, first alarm, slew alarm.

        Parameters
        ----------
        p : ndarray, shape (3,)
            Target, m.

        Returns
        -------
        str
        """
        if not np.all(np.isfinite(p)):
            return "target is not a finite position"
        if not bool(reach_mask3d(self.arm, p[0], p[1], p[2])):
            return f"target ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) m is out of the arm's reach"
        q = inverse3d(self.arm, p[0], p[1], p[2])
        if float(q.beta) > self.thr.beta_first:
            return f"target needs beta {math.degrees(float(q.beta)):.1f} deg, beyond the first alarm"
        if abs(float(q.phi)) > self.thr.slew_first:
            return f"target needs slew {math.degrees(float(q.phi)):.1f} deg, beyond the slew alarm"
        if not self.lim.contains((q.phi, q.alpha, q.beta)):
            return "target is outside the cylinders' strokes"
        return ""

    def _jacobian3d(self, phi, alpha, beta) -> np.ndarray:
        # the planar entries (rows rho and z) are kinematics.jacobian_entries on floats: the same formula as
        # kinematics.jacobian, without NumPy's per-call cost in the guidance cycle
        b, c = self.arm.b, self.arm.c
        sa, ca = math.sin(alpha), math.cos(alpha)
        sab, cab = math.sin(alpha - beta), math.cos(alpha - beta)
        rho = b * sa - c * sab
        drho_da, drho_db, dz_da, dz_db = jacobian_entries(b, c, 1.0, ca, sa, cab, sab)
        cp, sp = math.cos(phi), math.sin(phi)
        return np.array([[-rho * sp, drho_da * cp, drho_db * cp],
                         [rho * cp, drho_da * sp, drho_db * sp],
                         [0.0, dz_da, dz_db]])

    def _rates_for_velocity(self, q, v: np.ndarray) -> np.ndarray:
        J = self._jacobian3d(*q)
        try:
            qd = np.linalg.solve(J, v)
        except np.linalg.LinAlgError:
            return np.zeros(3)
        return self._limit(q, qd)

    def _limit(self, q, qd: np.ndarray) -> np.ndarray:
        """Scale a rate command to the rate limits, then stop any joint at its range limit."""
        qd = np.asarray(qd, dtype=float)
        if not np.all(np.isfinite(qd)):
            return np.zeros(3)
        scale = max(1.0, *(abs(qd[i]) / self.lim.rate[i] for i in range(3)))
        qd = qd / scale
        dt = self.dt_nominal
        for i, (lo, hi) in enumerate((self.lim.phi, self.lim.alpha, self.lim.beta)):
            nxt = q[i] + qd[i] * dt
            if nxt > hi:
                qd[i] = max((hi - q[i]) / dt, 0.0) if q[i] < hi else min(qd[i], 0.0)
            elif nxt < lo:
                qd[i] = min((lo - q[i]) / dt, 0.0) if q[i] > lo else max(qd[i], 0.0)
        return qd

    def _move_towards(self, now: float, q, target: np.ndarray, v_target: np.ndarray, dt: float) -> np.ndarray:
        """Cartesian speed profile towards a (moving) target, replanned every cycle, as joint rates."""
        p = np.array([float(v) for v in forward3d(self.arm, *q)])
        d = target - p
        dist = float(np.linalg.norm(d))
        # accelerate at a_max, never faster than v_max, and slow down to arrive at rest relative to the target
        v_allow = min(self.v_max, math.sqrt(2.0 * self.a_max * max(dist - ROUNDOFF_M, 0.0)))
        self.state.speed = min(v_allow, self.state.speed + self.a_max * dt)
        v = (d / dist * self.state.speed if dist > 1e-9 else np.zeros(3)) + v_target
        return self._rates_for_velocity(q, v)

    def _monitor(self, now: float, q) -> tuple[int, str]:
        p = np.array([float(v) for v in forward3d(self.arm, *q)])
        rho = math.hypot(p[0], p[1])
        r = math.hypot(rho, p[2] - self.arm.a)
        s = self.state
        if s.last_t is not None and now > s.last_t:
            dt = now - s.last_t
            k = dt / (self.g.drift_filter + dt)
            s.v_r += k * ((r - s.last_r) / dt - s.v_r)
            s.v_phi += k * ((q[0] - s.last_phi) / dt - s.v_phi)
        s.last_r, s.last_phi, s.last_t = r, q[0], now
        return self.thr.level(q[2], q[0], r, s.v_r, s.v_phi)

    # ---------------------------------------------------------------- the cycle
    def step(self, now: float, q, est: Estimate, op: OperatorInput = OperatorInput()) -> Command:
        """One guidance cycle: decide the mode and the joint-rate command.

        Parameters
        ----------
        now : float
            Time from the injected clock, s.
        q : tuple of float
            Measured joint angles (slew, alpha, beta), rad.
        est : Estimate
            Flange estimate at ``now``.
        op : OperatorInput
            Operator actions and joystick.

        Returns
        -------
        Command
        """
        cyc = Cycle(now, tuple(float(v) for v in q), est, op, frozenset(op.actions), self.dt_nominal)
        self.state.events = []
        for action in op.actions:
            self._event("operator", action)
        for rule in self.SAFETY_RULES:
            getattr(self, rule)(cyc)
        rates = getattr(self, self.HANDLERS[self.state.mode])(cyc)
        rates = self.rule_no_motion_when_held_or_attached(rates)
        s = self.state
        return Command(s.mode, tuple(float(v) for v in rates), self.attached(), s.esd_since is not None,
                       s.release_since is not None, tuple(s.events))

    def attached(self) -> bool:
        """Whether the coupler is on the flange (a connected mode, or an emergency stop taken from one).

        Returns
        -------
        bool
        """
        s = self.state
        return s.mode in CONNECTED_MODES or (s.mode == Mode.ESTOP and s.resume in CONNECTED_MODES)

    # ---------------------------------------------------------------- safety rules, in this order
    #: Named rules run every cycle before the mode handler, in this order.
    SAFETY_RULES = ("rule_emergency_stop", "rule_alarm_escalation", "rule_emergency_release_sequence")

    def rule_emergency_stop(self, cyc: "Cycle") -> None:
        """E-stop from any mode, in this very cycle (the mode to resume is kept).

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        if "estop" in cyc.acts and self.state.mode != Mode.ESTOP:
            self.state.resume = self.state.mode
            self._go(cyc.now, Mode.ESTOP, "emergency stop pressed")
            if self.attached():                  # connected: the E-stop also initiates ESD-1
                self._command_esd1(cyc.now, "emergency stop while connected")

    def rule_alarm_escalation(self, cyc: "Cycle") -> None:
        """While attached, whatever the mode: raise the alarm level on angle and drift speed, one stage at a time,
        commanding ESD-1 at the first alarm and ERS-2 at release.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        if not self.attached():
            return
        s, now, q = self.state, cyc.now, cyc.q
        level, why = self._monitor(now, q)
        current = SEVERITY_OF_MODE.get(s.mode if s.mode != Mode.ESTOP else s.resume, Severity.NORMAL)
        if level <= current:
            return
        for stage in ALARM_STAGES:               # one event per stage passed, in order
            if current < stage <= level:
                self._event("alarm", f"{MODE_OF_SEVERITY[stage].value}: {why}", severity=int(stage),
                            severity_label=stage.label, beta_deg=math.degrees(q[2]), slew_deg=math.degrees(q[0]),
                            v_r=s.v_r)
        if level >= Severity.ESD1:
            self._command_esd1(now, why)
        if level >= Severity.RELEASE and s.release_since is None:
            s.release_since = now
            self._event("command", "ERS-2 requested: release the coupler once the ERS valves are confirmed closed")
        new = MODE_OF_SEVERITY[level]
        if s.mode == Mode.ESTOP:
            s.resume = new
        else:
            self._go(now, new, why)

    def _command_esd1(self, now: float, why: str) -> None:
        if self.state.esd_since is None:
            self.state.esd_since = now
            self._event("command", f"ESD-1: stop transfer pumps, close ERS valves ({why})")

    def rule_emergency_release_sequence(self, cyc: "Cycle") -> None:
        """The ESD-1 -> ERS valves closed -> ERS-2 sequence, in any mode while attached (an E-stop stops the
        drives, never the release).

        The ESD-1 sequence, ERS valves included, completes within ``esd_time``; their limit switches confirm
        it then (an event of its own). The coupler opens only after that confirmation, and is free
        ``ers_time`` after it began to open.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s, now = self.state, cyc.now
        if not self.attached() or s.esd_since is None:
            return
        if s.valves_closed_at is None and now - s.esd_since >= self.g.esd_time:
            s.valves_closed_at = now
            self._event("interlock", "ERS valves confirmed closed (limit switches): the coupler may open")
        if s.release_since is None or s.valves_closed_at is None:
            return
        if s.release_started_at is None:
            s.release_started_at = now
            self._event("command", "ERS-2: coupler opening (ERS valves confirmed closed)")
        if now - s.release_started_at >= self.g.ers_time:
            self._event("command", "ERS-2 release complete: coupler free")
            s.esd_since = s.release_since = s.valves_closed_at = s.release_started_at = None
            if s.mode == Mode.ESTOP:
                s.resume = Mode.RETURN           # drives stay stopped until the operator resets
            else:
                self._go(now, Mode.RETURN, "released; returning to stored")

    def rule_fresh_estimate(self, cyc: "Cycle") -> bool:
        """No motion without a fresh, healthy flange estimate: the cycle that sees it stale enters HOLD.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.

        Returns
        -------
        bool
            True when the estimate may be used.
        """
        if cyc.est.healthy:
            return True
        if self.state.mode != Mode.HOLD:
            self._go(cyc.now, Mode.HOLD, f"flange estimate lost: {cyc.est.reason}; motion stopped")
        return False

    def rule_target_in_envelope(self, cyc: "Cycle", target: np.ndarray) -> bool:
        """A target outside the envelope (unreachable, beyond the first alarm or the slew alarm, outside the
        strokes) is refused: the arm returns to stored.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        target : ndarray, shape (3,)
            The point the arm would move to, m.

        Returns
        -------
        bool
            True when the target may be approached.
        """
        why_not = self.target_ok(target)
        if why_not:
            self._go(cyc.now, Mode.RETURN, f"target refused: {why_not}")
            return False
        return True

    def rule_no_motion_when_held_or_attached(self, rates) -> np.ndarray:
        """Zero rates in ESTOP and HOLD, and while attached (the actuators are free; the ship moves the arm).

        Parameters
        ----------
        rates : array_like
            The handler's command, rad/s.

        Returns
        -------
        ndarray
            The command actually sent.
        """
        if self.state.mode in (Mode.ESTOP, Mode.HOLD) or self.state.mode in CONNECTED_MODES:
            return np.zeros(3)
        return np.asarray(rates, dtype=float)

    # ---------------------------------------------------------------- one handler per mode
    #: The handler of each mode.
    HANDLERS = {Mode.ESTOP: "_on_estop", Mode.MANUAL: "_on_manual", Mode.STORED: "_on_stored",
                Mode.APPROACH: "_on_moving", Mode.STANDOFF: "_on_moving", Mode.HOLD: "_on_moving",
                Mode.CONNECTED: "_on_attached", Mode.ALARM1: "_on_attached", Mode.ALARM2: "_on_attached",
                Mode.RELEASE: "_on_attached", Mode.RETURN: "_on_return"}

    def _on_estop(self, cyc: "Cycle") -> np.ndarray:
        if "reset" in cyc.acts:
            back = self.state.resume if self.state.resume in CONNECTED_MODES else Mode.RETURN
            self._go(cyc.now, back, "operator reset after emergency stop")
        return np.zeros(3)

    def _on_manual(self, cyc: "Cycle") -> np.ndarray:
        if "auto" in cyc.acts:
            self._go(cyc.now, Mode.RETURN, "operator back to automatic")
            return np.zeros(3)
        q = cyc.q
        v = np.array(cyc.op.jog, dtype=float)
        n = float(np.linalg.norm(v))
        if n > self.g.jog_speed:
            v *= self.g.jog_speed / n
        p = np.array([float(x) for x in forward3d(self.arm, *q)])
        nxt = p + v * cyc.dt
        top = np.array([0.0, 0.0, self.arm.a])
        outward = (np.linalg.norm(nxt - top) > np.linalg.norm(p - top)
                   or abs(math.atan2(nxt[1], nxt[0])) > abs(math.atan2(p[1], p[0])))
        why_not = self.target_ok(nxt) if n > 0 else ""
        if why_not and outward:
            if self.state.refused != "jog":          # refuse a jog that leaves the envelope; moving back in is allowed
                self._event("info", f"jog refused: {why_not}")
                self.state.refused = "jog"
            return np.zeros(3)
        self.state.refused = ""
        return self._rates_for_velocity(q, v)

    def _on_stored(self, cyc: "Cycle") -> np.ndarray:
        est = cyc.est
        if "manual" in cyc.acts:
            self._go(cyc.now, Mode.MANUAL, "operator took manual control")
        elif "start" in cyc.acts:               # only a fresh operator action starts anything
            if not est.healthy:
                self._refuse(f"no fresh flange estimate ({est.reason})")
            else:
                why_not = self.target_ok(self.standoff_point(np.array(est.position)))
                if why_not:
                    self._refuse(why_not)
                else:
                    self._go(cyc.now, Mode.APPROACH, "operator started the approach")
        return np.zeros(3)

    def _on_moving(self, cyc: "Cycle") -> np.ndarray:
        s, now, est, q = self.state, cyc.now, cyc.est, cyc.q
        if "manual" in cyc.acts:
            self._go(now, Mode.MANUAL, "operator took manual control")
            return np.zeros(3)
        if not self.rule_fresh_estimate(cyc):
            return np.zeros(3)
        target = self.standoff_point(np.array(est.position))
        if not self.rule_target_in_envelope(cyc, target):
            return np.zeros(3)
        if s.mode == Mode.HOLD:
            self._go(now, Mode.APPROACH, "flange estimate healthy again")
        p = np.array([float(x) for x in forward3d(self.arm, *q)])
        dist = float(np.linalg.norm(target - p))
        if s.mode == Mode.APPROACH and dist <= self.g.arrive_tolerance:
            self._go(now, Mode.STANDOFF, f"at the standoff point ({dist * 1e3:.0f} mm)")
        if s.mode == Mode.STANDOFF and "connect" in cyc.acts:
            self._go(now, Mode.CONNECTED, "operator connected the coupler")
            self._event("command", "actuators released: the arm follows the ship")
            s.last_t = None
            s.v_r = s.v_phi = 0.0
            return np.zeros(3)
        return self._move_towards(now, q, target, np.array(est.velocity), cyc.dt)

    def _on_attached(self, cyc: "Cycle") -> np.ndarray:
        s, now = self.state, cyc.now
        if s.mode == Mode.CONNECTED and "disconnect" in cyc.acts:
            self._go(now, Mode.RETURN, "operator disconnected the coupler")
        return np.zeros(3)            # actuators free: the ship moves the arm

    def _on_return(self, cyc: "Cycle") -> np.ndarray:
        p = np.array([float(x) for x in forward3d(self.arm, *cyc.q)])
        if float(np.linalg.norm(self.stored - p)) <= self.g.arrive_tolerance:
            self._go(cyc.now, Mode.STORED, "arm stored")
            self.state.resume = Mode.STORED
            return np.zeros(3)
        return self._move_towards(cyc.now, cyc.q, self.stored, np.zeros(3), cyc.dt)

    def _refuse(self, why: str) -> None:
        """A refused command is logged once and forgotten: nothing starts later without a new action."""
        self._event("info", f"approach refused: {why}")
