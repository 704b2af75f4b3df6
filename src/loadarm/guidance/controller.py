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

from loadarm.arm.alarms import AlarmState, AlarmThresholds, next_alarm_state
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import ROUNDOFF_M
from loadarm.arm.sequence import stage_of, valve_worst_time
from loadarm.arm.slew import forward3d, inverse3d, jacobian3d, reach_mask3d
from loadarm.guidance.drift import FIT_PERIOD
from loadarm.guidance.estimator import Estimate
from loadarm.guidance.modes import (
    ALARM_OFF_DELAY,
    ALARM_STAGES,
    CONNECTED_MODES,
    ERS_CONFIRM_WINDOW,
    ERS_SWITCH_DISCREPANCY,
    MODE_OF_SEVERITY,
    Command,
    Cycle,
    GuidanceState,
    Mode,
    OperatorInput,
    PlantFeedback,
)
from loadarm.guidance.monitor import EnvelopeMonitor, stage_leads
from loadarm.guidance.voting import AXES, reset_votes, vote
from loadarm.params.scenario import GuidanceSettings, check_drift_window
from loadarm.vocab import ANNUNCIATED, CONDITION_TEXT, STAGE_EVENT, Severity, event_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["GuidanceController"]


class GuidanceController:
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
        if float(q.beta) > self.thr.beta_first:
            return f"target needs beta {math.degrees(float(q.beta)):.1f} deg, beyond the first alarm"
        if abs(float(q.phi)) > self.thr.slew_first:
            return f"target needs slew {math.degrees(float(q.phi)):.1f} deg, beyond the slew alarm"
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
        for action in op.actions:
            self._event("operator", action)
        for rule in self.SAFETY_RULES:
            getattr(self, rule)(cyc)
        rates = getattr(self, self.HANDLERS[self.state.mode])(cyc)
        return self._command(self.rule_no_motion_when_held_or_attached(rates))

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

    def _command(self, rates) -> Command:
        """This cycle's command from the state and the final rates."""
        s = self.state
        attached = self.attached()
        ttl = s.forecast.time if (attached and s.forecast is not None) else math.inf
        faces = s.forecast.by_face if (attached and s.forecast is not None) else ()
        return Command(s.mode, tuple(float(v) for v in rates), attached, s.esd_since is not None,
                       s.release_since is not None, s.valves_cmd_since is not None,
                       s.release_started_at is not None, s.level if attached else Severity.NORMAL, ttl,
                       tuple(s.events), faces)

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
    SAFETY_RULES = ("rule_emergency_stop", "rule_manual_emergency", "rule_sensor_fault", "rule_alarm_escalation",
                    "rule_ers_switches", "rule_emergency_release_sequence", "rule_annunciate")

    def rule_sensor_fault(self, cyc: "Cycle") -> None:
        """An axis whose angle sensors cannot be voted (:mod:`loadarm.guidance.voting`) while attached: ESD-1
        (the position alarms and the time to limit can no longer be trusted; the release stays armed on what
        can). Detached, :meth:`rule_no_motion_when_held_or_attached` stops the arm on any sensor fault.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        st = self.state.votes
        if st.status == "lost" and self.attached() and self.state.raised < Severity.ESD1:
            axes = ", ".join(AXES[j] for j in range(3) if st.lost[j])
            why = f"{axes} angle sensors disagree and cannot be voted: the position alarms cannot be trusted"
            self._command_esd1(cyc.now, why)
            self._raise(cyc.now, cyc.q, Severity.ESD1, why)

    def rule_ers_switches(self, cyc: "Cycle") -> None:
        """The ERS valves' two closed limit switches must agree: one made and the other not for longer than
        :data:`ERS_SWITCH_DISCREPANCY` is a switch fault alarm (in any mode: a switch stuck "closed" is found
        while the valves are open, before it matters). The valves count as closed only with both made
        (:attr:`PlantFeedback.ers_valves_closed`), so a false "closed" never opens the coupler.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s, sw = self.state, cyc.fb.ers_switches
        if not (len(sw) > 1 and any(sw) and not all(sw)):
            s.switches_odd_since, s.switch_fault = None, False
            return
        if s.switches_odd_since is None:
            s.switches_odd_since = cyc.now
        if not s.switch_fault and cyc.now - s.switches_odd_since > ERS_SWITCH_DISCREPANCY:
            s.switch_fault = True
            made = ", ".join(f"switch {i + 1} {'closed' if v else 'open'}" for i, v in enumerate(sw))
            self._event("alarm", f"{event_label('fault.ers_switch')}: the {CONDITION_TEXT['ERS_SWITCH_FAULT']} ({made}) for "
                                 f"{cyc.now - s.switches_odd_since:.1f} s: the valves are not taken as closed and the "
                                 "coupler stays closed until both confirm", code="fault.ers_switch",
                        severity=int(Severity.SECOND), severity_label="fault")

    def rule_emergency_stop(self, cyc: "Cycle") -> None:
        """E-stop from any mode, in this very cycle (the mode to resume is kept). It stops the drives; when
        connected it also initiates ESD-1, and the release stays armed on its own thresholds.

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

    def rule_manual_emergency(self, cyc: "Cycle") -> None:
        """Manual ESD-1 and manual ERS (armed, then confirmed within :data:`ERS_CONFIRM_WINDOW`) from any
        connected state, E-stop included.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s, now, acts = self.state, cyc.now, cyc.acts
        if not acts & {"esd", "ers", "ers_confirm"}:
            return
        if not self.attached():
            for a in sorted(acts & {"esd", "ers", "ers_confirm"}):
                self._event("info", f"{a} refused: the coupler is not connected")
            return
        if "esd" in acts:
            self._command_esd1(now, "manual ESD-1 by the operator")
            self._raise(now, cyc.q, Severity.ESD1, "manual ESD-1 by the operator")
        if "ers" in acts and s.release_since is None:
            s.ers_armed_at = now
            self._event("info", f"manual ERS armed: confirm within {ERS_CONFIRM_WINDOW:g} s")
        if "ers_confirm" in acts:
            if s.ers_armed_at is not None and now - s.ers_armed_at <= ERS_CONFIRM_WINDOW:
                s.ers_armed_at = None
                self._command_esd1(now, "manual ERS by the operator")
                self._raise(now, cyc.q, Severity.RELEASE, "manual ERS confirmed by the operator")
            elif s.release_since is None:
                self._event("info", "ERS confirmation refused: no manual ERS armed in the last "
                                    f"{ERS_CONFIRM_WINDOW:g} s")
        if s.ers_armed_at is not None and now - s.ers_armed_at > ERS_CONFIRM_WINDOW:
            s.ers_armed_at = None

    def _leads(self, now: float) -> dict:
        """The stage leads now: while the ERS valves are unconfirmed, the time left to their timeout (the worst
        case it allows; found: counting the nominal closing time, a valve 4 s slow ate the release margin)."""
        s, q = self.state, self.seq
        valves_left = None
        if s.valves_closed_at is not None:
            valves_left = 0.0
        elif s.valves_cmd_since is not None:
            valves_left = s.valves_cmd_since + valve_worst_time(q) - now
        release_left = None if s.release_started_at is None else s.release_started_at + q.erc_release_time - now
        return stage_leads(q, valves_left=valves_left, release_left=release_left)

    def _connected_level(self, now: float, q) -> tuple[Severity, str, str]:
        """Position alarms and time to the nearest face (measured and design drift), the more severe: the level,
        its cause in words and the face it guards (:data:`loadarm.vocab.FACES`)."""
        s = self.state
        alarmed = s.esd_since is not None
        mon = self.monitor
        p = None                                # the position, computed only in a cycle that needs it
        if mon.fit.due(now):                    # a new sample: refit now; spread, the step test and the
            p = tuple(float(v) for v in forward3d(self.arm, *q))      # forecast in later cycles (cycle time)
            mon.observe(now, p)
            mon.refit(alarmed, step=not self.spread)
            if not self.spread:
                s.forecast = None
        elif mon.step_pending:
            mon.test_step()
        elif now >= s.next_forecast:
            s.forecast = None
        level, why = self.thr.level(q[2], q[0])
        face = self.thr.face(q[2], q[0], level)
        if s.forecast is None:
            s.leads = self._leads(now)
            if p is None:
                p = tuple(float(v) for v in forward3d(self.arm, *q))
            s.forecast = mon.time_to_limit(p, max(s.leads.values()), alarmed=alarmed, now=now)
            s.next_forecast = now + mon.fit.period
        f = s.forecast
        if math.isfinite(f.time):
            ld = s.leads                         # the one rule (loadarm.arm.sequence.stage_of): the pre-alarm warns
            stage = Severity(stage_of(f.time, f.measured, ld[Severity.RELEASE], ld[Severity.SECOND],  # of a drift
                                      ld[Severity.ESD1], ld.get(Severity.PRE_ALARM, -math.inf)))   # it sees
            if stage > level:
                t = f.measured if stage == Severity.PRE_ALARM else f.time
                route = f.route if t == f.time else "measured drift"
                level, face, why = stage, f.face, (f"{route}: {f.face} face in {t:.1f} s, the {stage.label} "
                                                   f"needs {ld[stage]:.1f} s")
        return level, why, face

    def _raise(self, now: float, q, level: Severity, why: str, face: str = "") -> None:
        """Raise the connected-mode stage to ``level`` (one alarm event per stage passed), commanding ESD-1 at
        the first alarm and requesting ERS-2 at release."""
        s = self.state
        if level <= s.raised:
            return
        for stage in ALARM_STAGES:               # one event per stage passed, in order
            if stage == Severity.PRE_ALARM and self.seq.pre_alarm_lead <= 0:
                continue                         # no pre-alarm configured
            if s.raised < stage <= level:
                code = STAGE_EVENT[stage]
                self._event("alarm", f"{event_label(code)}: {why}", code=code, severity=int(stage),
                            severity_label=stage.label, face=face,
                            beta_deg=math.degrees(q[2]), slew_deg=math.degrees(q[0]))
        s.raised = level
        if level >= Severity.ESD1:
            self._command_esd1(now, why)
        if level >= Severity.RELEASE and s.release_since is None:
            s.release_since = now
            self._close_ers_valves(now)
            self._event("command", "ERS-2 requested: release the coupler once the ERS valves are confirmed closed")
        new = MODE_OF_SEVERITY[level]
        if new == Mode.CONNECTED:                # the pre-alarm is a warning: the mode stays
            return
        if s.mode == Mode.ESTOP:
            s.resume = new
        else:
            self._go(now, new, why)

    def rule_alarm_escalation(self, cyc: "Cycle") -> None:
        """While attached, whatever the mode: raise the alarm stage on position (the customer's angles) and on
        the time to the nearest face against the sequence still to run, one stage at a time.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s = self.state
        if not self.attached():
            s.level = Severity.NORMAL
            return
        s.level, why, face = self._connected_level(cyc.now, cyc.q)
        self._raise(cyc.now, cyc.q, s.level, why, face)

    def _command_esd1(self, now: float, why: str) -> None:
        s = self.state
        with_valves = self.seq.ers_valves_close_at == "esd1"
        if s.esd_since is None:
            s.esd_since = now
            valves = "and ERS valves" if with_valves else "valves (the ERS valves close at ERS-2)"
            self._event("command", f"ESD-1: stop transfer pumps, close ESD {valves} ({why})")
        if with_valves:
            self._close_ers_valves(now)

    def _close_ers_valves(self, now: float) -> None:
        if self.state.valves_cmd_since is None:
            self.state.valves_cmd_since = now

    def rule_emergency_release_sequence(self, cyc: "Cycle") -> None:
        """ERS valves confirmed closed (the plant's limit switches) -> ERS-2, in any mode while attached (an
        E-stop stops the drives, never the release).

        The confirmation is an event of its own; a valve not confirmed ``ers_valve_timeout`` after its
        closing time is a fault alarm, and the coupler stays closed. The coupler opens only after the
        confirmation and is free ``erc_release_time`` after it began to open.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s, now, q = self.state, cyc.now, self.seq
        if not self.attached() or s.valves_cmd_since is None:
            return
        if s.valves_closed_at is None:
            if cyc.fb.ers_valves_closed:
                s.valves_closed_at = now
                s.valve_fault = False
                self._event("interlock", f"{event_label('interlock.valves_confirmed')} (limit switches): the coupler "
                                         "may open", code="interlock.valves_confirmed", after_s=now - s.valves_cmd_since)
            elif not s.valve_fault and now - s.valves_cmd_since > q.ers_valve_time + q.ers_valve_timeout:
                s.valve_fault = True
                self._event("alarm", f"{event_label('fault.ers_valve')}: not confirmed closed "
                                     f"{now - s.valves_cmd_since:.1f} s after the command; the coupler stays closed "
                                     "(product may be live)", code="fault.ers_valve",
                            severity=int(Severity.RELEASE), severity_label="fault")
        if s.valves_closed_at is not None and s.release_started_at is None and (
                not cyc.fb.ers_valves_closed or s.switch_fault):
            # found (review): a confirmation latched at +10 s opened the coupler at ERS-2 a minute later although
            # a switch had dropped since; the coupler opens only on switches that say closed in that very cycle
            s.valves_closed_at = None
            self._event("alarm", f"{event_label('fault.ers_unconfirmed')}: the coupler stays closed",
                        code="fault.ers_unconfirmed", severity=int(Severity.SECOND), severity_label="fault")
            return
        if s.release_since is None or s.valves_closed_at is None:
            return
        if s.release_started_at is None:
            s.release_started_at = now
            self._event("command", f"{event_label('command.coupler_opening')} (ERS valves confirmed closed)",
                        code="command.coupler_opening")
        if now - s.release_started_at >= q.erc_release_time:
            self._event("command", f"{event_label('command.release_complete')}: coupler free",
                        code="command.release_complete")
            self._detach()
            if s.mode == Mode.ESTOP:
                s.resume = Mode.RETURN           # drives stay stopped until the operator resets
            else:
                self._go(now, Mode.RETURN, "released; returning to stored")

    def _detach(self) -> None:
        s = self.state
        s.esd_since = s.release_since = s.valves_cmd_since = s.valves_closed_at = s.release_started_at = None
        s.valve_fault = False
        s.raised = Severity.NORMAL
        s.forecast = None
        s.disconnect_phase = ""
        s.ers_armed_at = None

    def rule_annunciate(self, cyc: "Cycle") -> None:
        """ISA-18.2 states of the annunciated alarms: a condition clears after :data:`ALARM_OFF_DELAY` s clear;
        ``ack`` acknowledges every alarm, ``ack:TAG`` the one (an OPC UA Acknowledge on its condition); each
        change of state is logged.

        Parameters
        ----------
        cyc : Cycle
            This cycle's inputs.
        """
        s, now = self.state, cyc.now
        level = s.level if self.attached() else Severity.NORMAL
        sensor = s.votes.status != "ok"
        if level == Severity.NORMAL and not (s.valve_fault or s.switch_fault or sensor) and s.quiet:
            return                               # nothing present, nothing to acknowledge (all normal): fast path
        present = {"PRE_ALARM": level >= Severity.PRE_ALARM and self.seq.pre_alarm_lead > 0, "ESD1": level >= Severity.ESD1,
                   "SECOND": level >= Severity.SECOND, "RELEASE": level >= Severity.RELEASE,
                   "ERS_VALVE_FAULT": s.valve_fault, "ERS_SWITCH_FAULT": s.switch_fault, "SENSOR_FAULT": sensor}
        ack_all = "ack" in cyc.acts
        for tag in ANNUNCIATED:
            if present[tag]:
                s.last_active[tag] = now
            active = now - s.last_active[tag] < ALARM_OFF_DELAY
            new = next_alarm_state(s.alarms[tag], active, ack_all or f"ack:{tag}" in cyc.acts)
            if new != s.alarms[tag]:
                self._event("alarm_state", f"{tag}: {new.value}", tag=tag, alarm_state=new.value,
                            previous=s.alarms[tag].value)
                s.alarms[tag] = new
        s.quiet = all(v == AlarmState.NORMAL for v in s.alarms.values())

    def alarms_clear(self) -> bool:
        """Whether every annunciated alarm is back to normal (cleared and acknowledged).

        Returns
        -------
        bool
        """
        return all(v == AlarmState.NORMAL for v in self.state.alarms.values())

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
        """Zero rates in ESTOP and HOLD, while attached (the actuators are free; the ship moves the arm) and with
        an angle sensor fault (the voted angles stand on one channel, or none).

        Parameters
        ----------
        rates : array_like
            The handler's command, rad/s.

        Returns
        -------
        ndarray
            The command actually sent.
        """
        s = self.state
        if s.mode in (Mode.ESTOP, Mode.HOLD) or s.mode in CONNECTED_MODES:
            return np.zeros(3)
        status = s.votes.status
        # an axis without a vote: no motion at all; one channel rejected: no new approach, but the retraction
        # after a release (clear of the manifold) and the operator's jog go on, on the healthy channel
        if status == "lost" or (status == "degraded" and s.mode in (Mode.APPROACH, Mode.STANDOFF)):
            if s.refused != "sensor":
                self._event("info", f"motion stopped in {s.mode.value}: angle sensor fault (reset once both agree)")
                s.refused = "sensor"
            return np.zeros(3)
        return np.asarray(rates, dtype=float)

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
                f"{k} {v.value}" for k, v in s.alarms.items() if v != AlarmState.NORMAL)
        if why_not:
            self._event("info", f"reset refused: {why_not}")
            return
        s.esd_since = s.valves_cmd_since = s.valves_closed_at = None
        s.valve_fault = False
        s.raised = Severity.NORMAL
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


