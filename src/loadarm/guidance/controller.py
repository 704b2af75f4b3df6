"""The guidance state machine: approach, standoff, connected monitoring, alarms, release, return.

Modes::

    STORED -> APPROACH -> STANDOFF -> CONNECTED -> ALARM1 (ESD-1) -> ALARM2 -> RELEASE (ERS-2) -> RETURN -> STORED
    CONNECTED -> DISCONNECT (close ERS valves, drain, unclamp) -> RETURN (lift off first)
    ALARM1 / ALARM2 -> CONNECTED (condition cleared, alarms acknowledged, operator reset)
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
* while attached: the customer's position alarms (:class:`~loadarm.arm.alarms.AlarmThresholds`) and the time to
  the nearest face of the envelope from the measured and the design drift
  (:class:`~loadarm.guidance.monitor.EnvelopeMonitor`) against the sequence still to run, whichever is more
  severe;
* the coupler opens only after the plant confirms the ERS valves closed: both of their independent closed
  limit switches (a single switch that fails "closed" would open the coupler on live product); switches that
  disagree are a fault alarm, and a valve that does not confirm in time is one too; the coupler stays closed;
* the joint angles are voted from two channels per axis (:mod:`loadarm.guidance.voting`): a frozen, drifting or
  failed sensor is an alarm and the other channel is used; with an axis that cannot be voted the controller
  fails safe: ESD-1 while attached, no motion otherwise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.alarms import AlarmState, AlarmThresholds
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import ROUNDOFF_M
from loadarm.arm.sequence import hold_limit
from loadarm.arm.slew import forward3d, inverse3d, jacobian3d, reach_mask3d
from loadarm.guidance.drift import FIT_PERIOD
from loadarm.guidance.estimator import Estimate
from loadarm.guidance.modes import (
    CONNECTED_MODES,
    Command,
    Cycle,
    GuidanceState,
    Mode,
    OperatorInput,
    PlantFeedback,
)
from loadarm.guidance.monitor import EnvelopeMonitor
from loadarm.guidance.moorings import LOST_SHARE, MooringWatch
from loadarm.guidance.predict import GATE_FACTOR, GATE_PERSIST, FlangePredictor
from loadarm.guidance.rules import SafetyRules
from loadarm.guidance.voting import AXES, reset_votes, vote
from loadarm.params.scenario import GuidanceSettings, check_drift_window
from loadarm.vocab import CONDITION_TEXT, RESET_BLOCKING, ROUTE_BREAKOUT, ROUTE_STEP, Severity, event_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["GuidanceController"]


class GuidanceController(SafetyRules):
    """The guidance state machine (see the module docstring).

    Parameters
    ----------
    model : ArmModel
        Arm, alarms, approach limits, stored position (2D, taken at y = 0).
    g : GuidanceSettings
        The compiled ``[guidance]`` section (:meth:`loadarm.params.scenario.Guidance.compile`).
    state : GuidanceState, optional
        Start in this state (default: stored, no alarm).

    Notes
    -----
    :meth:`step` is a dispatcher: the operator's actions are logged, the safety rules of :attr:`SAFETY_RULES`
    run in that fixed order (each a named method, tested on its own), the handler of the resulting mode
    (:attr:`HANDLERS`) computes the rate command, and :meth:`rule_no_motion_when_held_or_attached` has the last
    word on it.
    """

    def __init__(self, model: ArmModel, g: GuidanceSettings, state: "GuidanceState | None" = None):
        if not isinstance(g, GuidanceSettings):
            raise TypeError(f"the guidance controller takes GuidanceSettings, the compiled [guidance] section "
                            f"(Guidance.compile()), got {type(g).__name__}")
        self.arm: Arm = model.arm
        self.g = g
        self.lim = model.joint_limits
        self.thr = AlarmThresholds.from_model(model)
        self.seq = model.sequence
        check_drift_window(g, self.seq, source="guidance settings")
        # the drift fit samples every whole number of cycles, about 0.2 s apart (every cycle when slower), so that
        # its time base is exact at any guidance rate
        per_sample = max(1, math.ceil(FIT_PERIOD * g.rate - 1e-9))
        self.monitor = EnvelopeMonitor(model, g.drift_window, period=per_sample / g.rate)
        self.predictor = None if g.prediction == "off" else FlangePredictor(g.prediction)
        self.moorings = MooringWatch()
        self.hold_limit = hold_limit(self.seq)  # how long the prediction may hold a call for ESD-1, s
        self.hold_budget = True   # each call's own forecasts bound its hold too (False: a study's view without)
        self.v_max = model.approach.max_speed
        self.a_max = model.approach.max_accel
        sx, sz = model.approach.stored
        self.stored = np.array([sx, 0.0, sz])
        self.dt_nominal = 1.0 / g.rate
        # the drift fit, the velocity-step test and the forecast go to three different cycles when the guidance
        # runs at least three cycles per fit sample; slower, all three run in the sample's cycle
        self.spread = per_sample >= 3
        enc = model.encoder
        self.angle_tol = math.radians(enc.discrepancy_deg)
        self.vote_persist, self.frozen_time = enc.discrepancy_time, enc.frozen_time
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
        if self.thr.level(float(q.beta), 0.0)[0] >= Severity.ESD1:        # the one boundary rule: at it, it sounds
            return f"target needs beta {math.degrees(float(q.beta)):.1f} deg, at or beyond the first alarm"
        if self.thr.level(0.0, float(q.phi))[0] >= Severity.ESD1:
            return f"target needs slew {math.degrees(float(q.phi)):.1f} deg, at or beyond the slew alarm"
        if not self.lim.contains((q.phi, q.alpha, q.beta)):
            return "target is outside the cylinders' strokes"
        return ""

    def _rates_for_velocity(self, q, v: np.ndarray) -> np.ndarray:
        J = jacobian3d(self.arm, *q)
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

    # ---------------------------------------------------------------- the cycle
    def step(self, now: float, q, est: Estimate, op: OperatorInput = OperatorInput(),
             fb: PlantFeedback = PlantFeedback()) -> Command:
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
        fb : PlantFeedback
            The plant's feedback (ERS valve limit switches).

        Returns
        -------
        Command
        """
        self.state.events = []
        acts = frozenset(op.actions)
        cyc = Cycle(now, self._voted(now, q, est, fb, acts), est, op, acts, self.dt_nominal, fb)
        self._track(cyc)
        for action in op.actions:
            self._event("operator", action)
        for rule in self.SAFETY_RULES:
            getattr(self, rule)(cyc)
        rates = getattr(self, self.HANDLERS[self.state.mode])(cyc)
        return self._command(self.rule_no_motion_when_held_or_attached(rates), now)

    def preload(self, t, p) -> None:
        """Feed the predictor a track of the flange before the run (a terminal's berth monitoring: the ship at
        its berth before the arm connects).

        Parameters
        ----------
        t : ndarray (n,)
            Times, s (before the first cycle's), increasing.
        p : ndarray (n, 3)
            Positions, m.
        """
        if self.predictor is not None:
            self.predictor.latch = False                  # not connected: a departure restarts the calibration
            for ti, pi in zip(t, p):
                self.predictor.push(float(ti), pi)

    def _track(self, cyc: "Cycle") -> None:
        """Feed the predictor this cycle's flange position: the encoders' while attached, the flange tracker's
        healthy estimate before (none: a gap, which starts its track again); and read the mooring load
        monitoring (lost, or gone silent: an event says so; lost, the rules trust the prediction no more)."""
        pr = self.predictor
        self.moorings.update(cyc.now, cyc.fb.line_loads)
        said, self.state.moorings = self.state.moorings, self.moorings.state(cyc.now)
        if self.state.moorings != said and self.state.moorings in ("lost", "silent"):
            code = f"info.moorings_{self.state.moorings}"
            self._event("info", event_label(code), code=code, slack_share=LOST_SHARE, fault=self.moorings.fault)
        if pr is None or cyc.now < pr.next_sample:
            return
        cleared = len(pr.cleared)
        pr.latch = self.attached()                        # off: a departure latched while connected is cleared
        for at in pr.cleared[cleared:]:
            self._event("info", event_label("info.prediction_reset"), code="info.prediction_reset", departed_at=at)
        if self.attached():
            pr.push(cyc.now, np.array([float(v) for v in forward3d(self.arm, *cyc.q)]))
        elif cyc.est.healthy:
            pr.push(cyc.now, np.asarray(cyc.est.position, dtype=float))
        for at in [a for a in pr.recalibrated if a > self.state.recalibrated_said]:
            self.state.recalibrated_said = at
            self._event("info", event_label("info.prediction_recalibrated"), code="info.prediction_recalibrated",
                        departed_at=at, factor=GATE_FACTOR, blocks=GATE_PERSIST)
        if pr.departed_at is not None and pr.departed_at != self.state.departed_said:
            self.state.departed_said = pr.departed_at
            self._event("info", event_label("info.prediction_departed"), code="info.prediction_departed",
                        departed_at=pr.departed_at, factor=GATE_FACTOR, blocks=GATE_PERSIST)

    def _voted(self, now: float, q, est: Estimate, fb: PlantFeedback, acts: frozenset) -> tuple:
        """The joint angles to use: the encoders voted against the second channel (:mod:`.voting`), the
        flange tracker's inverse kinematics the third opinion while attached; each channel found wrong is an
        alarm. Without a second channel, the encoders as they are."""
        q = tuple(float(v) for v in q)
        if fb.angles is None:
            return q
        st = self.state.votes
        channels = (q, tuple(float(v) for v in fb.angles))
        if "reset" in acts:
            for j in reset_votes(st, channels, tol=self.angle_tol):
                self._event("info", f"{AXES[j]} angle sensors agree again: both trusted after the operator's reset")
        ref = None
        if self.attached() and est.healthy:

            def ref():                              # out of reach: NaN, no opinion (found: check=True raised)
                qq = inverse3d(self.arm, *est.position, check=False)
                return (float(qq.phi), float(qq.alpha), float(qq.beta))
        v = vote(st, now, channels, ref, tol=self.angle_tol, persist=self.vote_persist, frozen_time=self.frozen_time)
        for j, why in v.found:
            used = "" if st.lost[j] else "; using the other channel"
            self._event("alarm", f"{event_label('fault.sensor')}: {AXES[j]} angle {why}{used}", code="fault.sensor",
                        severity=int(Severity.SECOND), severity_label="fault", axis=AXES[j])
        return v.q

    def _command(self, rates, now: float) -> Command:
        """This cycle's command from the state and the final rates."""
        s = self.state
        attached = self.attached()
        f = s.forecast if attached else None
        ttl = f.time if f is not None else math.inf
        faces = f.by_face if f is not None else ()
        horizon = max(s.leads.values()) if (f is not None and s.leads) else math.inf
        return Command(s.mode, tuple(float(v) for v in rates), attached, s.esd_since is not None,
                       s.release_since is not None, s.valves_cmd_since is not None,
                       s.release_started_at is not None, s.level if attached else Severity.NORMAL, ttl,
                       tuple(s.events), faces, horizon, f.route if f is not None else "",
                       self._forecast_drift(f), None if self.predictor is None else self.predictor.forecast,
                       self._predicted(now) if attached else (), s.rule if attached else "",
                       attached and s.trusted is not None, s.moorings, self.held_call(now) if attached else (),
                       self.prediction_unused())

    def _predicted(self, now: float) -> tuple:
        """The prediction's times to the nearest face now, ``(bound, mean)`` s, or ``()``."""
        p = self.state.predicted
        if not p:
            return ()
        age = max(now - p[2], 0.0)
        return (max(p[0] - age, 0.0), max(p[1] - age, 0.0))

    def _forecast_drift(self, f) -> tuple:
        """The measured drift velocity a forecast extrapolated (its route's fit; the drift fit's when the design
        drift governs), m/s, or ``()``."""
        if f is None:
            return ()
        mon = self.monitor
        est = {ROUTE_STEP: mon.step_est, ROUTE_BREAKOUT: mon.breakout_est}.get(f.route, mon.est)
        return () if est is None else tuple(float(v) for v in est.v)

    def attached(self) -> bool:
        """Whether the coupler is on the flange (a connected mode, or an emergency stop taken from one).

        Returns
        -------
        bool
        """
        s = self.state
        return s.mode in CONNECTED_MODES or (s.mode == Mode.ESTOP and s.resume in CONNECTED_MODES)

    # ---------------------------------------------------------------- one handler per mode
    #: The handler of each mode.
    HANDLERS = {Mode.ESTOP: "_on_estop", Mode.MANUAL: "_on_manual", Mode.STORED: "_on_stored",
                Mode.APPROACH: "_on_moving", Mode.STANDOFF: "_on_moving", Mode.HOLD: "_on_moving",
                Mode.CONNECTED: "_on_attached", Mode.ALARM1: "_on_attached", Mode.ALARM2: "_on_attached",
                Mode.RELEASE: "_on_attached", Mode.DISCONNECT: "_on_disconnect", Mode.RETURN: "_on_return"}

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
            elif self.state.switch_fault:       # the interlock's own sensors must agree before a transfer
                self._refuse(f"the {CONDITION_TEXT['ERS_SWITCH_FAULT']} (ERS_SWITCH_FAULT)")
            elif self.state.votes.status != "ok":
                self._refuse("an angle sensor is faulty (SENSOR_FAULT): reset once both channels agree")
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
            self.monitor.reset()
            s.forecast, s.next_forecast, s.raised, s.level = None, -math.inf, Severity.NORMAL, Severity.NORMAL
            s.rule = ""
            s.clear_calls()
            return np.zeros(3)
        return self._move_towards(now, q, target, np.array(est.velocity), cyc.dt)

    def _on_attached(self, cyc: "Cycle") -> np.ndarray:
        s, now = self.state, cyc.now
        if "disconnect" in cyc.acts:
            if s.mode == Mode.CONNECTED and s.esd_since is None:
                self._go(now, Mode.DISCONNECT, "operator started a controlled disconnection: closing the ERS valves")
                s.valves_cmd_since = now
                s.disconnect_phase, s.phase_since = "valves", now
                self._event("command", "close the ERS valves (controlled disconnection)")
            else:
                self._event("info", f"disconnection refused in {s.mode.value}: reset the alarm first or use the ERS")
        if "reset" in cyc.acts and s.mode in (Mode.ALARM1, Mode.ALARM2):
            self._reset_esd(now)
        return np.zeros(3)            # actuators free: the ship moves the arm

    def _reset_esd(self, now: float) -> None:
        """ESD-1 back to CONNECTED: only once the condition has cleared and every alarm is acknowledged."""
        s = self.state
        why_not = ""
        if s.release_since is not None:
            why_not = "the release (ERS-2) has been requested"
        elif s.level > Severity.NORMAL:
            why_not = f"the condition is still present ({s.level.label})"
        elif not self.alarms_clear():
            why_not = "alarms not yet cleared and acknowledged: " + ", ".join(
                f"{k} {v.value}" for k, v in s.alarms.items() if v != AlarmState.NORMAL and k in RESET_BLOCKING)
        if why_not:
            self._event("info", f"reset refused: {why_not}")
            return
        s.esd_since = s.valves_cmd_since = s.valves_closed_at = None
        s.valve_fault = False
        s.raised = Severity.NORMAL
        s.clear_calls()
        self._event("command", "ESD-1 reset: ERS valves reopen; the transfer may restart")
        self._go(now, Mode.CONNECTED, "operator reset after the alarm cleared")

    def _on_disconnect(self, cyc: "Cycle") -> np.ndarray:
        """Controlled disconnection: ERS valves confirmed closed -> drain -> unclamp -> lift off (RETURN)."""
        s, now, q = self.state, cyc.now, self.seq
        if s.disconnect_phase == "valves" and s.valves_closed_at is not None:
            s.disconnect_phase, s.phase_since = "drain", now
            self._event("command", "draining the arm")
        elif s.disconnect_phase == "drain" and now - s.phase_since >= q.drain_time:
            s.disconnect_phase, s.phase_since = "unclamp", now
            self._event("command", "arm drained: unclamping the coupler")
        elif s.disconnect_phase == "unclamp" and now - s.phase_since >= q.unclamp_time:
            p = np.array([float(x) for x in forward3d(self.arm, *cyc.q)])
            self._event("command", "coupler unclamped: lifting off the flange")
            self._detach()
            s.lift_target = p + np.array([0.0, 0.0, q.lift_off])
            self._go(now, Mode.RETURN, "disconnected; lifting off, then returning to stored")
        return np.zeros(3)

    def _on_return(self, cyc: "Cycle") -> np.ndarray:
        s = self.state
        p = np.array([float(x) for x in forward3d(self.arm, *cyc.q)])
        if s.lift_target is not None:
            if float(np.linalg.norm(s.lift_target - p)) <= self.g.arrive_tolerance:
                s.lift_target = None
                s.speed = 0.0
            else:
                return self._move_towards(cyc.now, cyc.q, s.lift_target, np.zeros(3), cyc.dt)
        if float(np.linalg.norm(self.stored - p)) <= self.g.arrive_tolerance:
            self._go(cyc.now, Mode.STORED, "arm stored")
            s.resume = Mode.STORED
            return np.zeros(3)
        return self._move_towards(cyc.now, cyc.q, self.stored, np.zeros(3), cyc.dt)

    def _refuse(self, why: str) -> None:
        """A refused command is logged once and forgotten: nothing starts later without a new action."""
        self._event("info", f"approach refused: {why}")
