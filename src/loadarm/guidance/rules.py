"""The guidance controller's safety rules, each a named method run in the fixed order of
:attr:`SafetyRules.SAFETY_RULES` every cycle (tested one by one): the hard-wired E-stop and the manual
emergencies, the sensors' faults, the connected-mode alarm escalation over the one sequence
(:mod:`loadarm.arm.sequence`), the emergency release, the annunciation, and the last word on motion.

A mixin of :class:`loadarm.guidance.controller.GuidanceController`: the rules read and write its state
(:class:`loadarm.guidance.modes.GuidanceState`) and its settings; the dispatcher and the mode handlers are there.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.alarms import AlarmState, next_alarm_state
from loadarm.arm.sequence import stage_of, valve_worst_time
from loadarm.arm.slew import forward3d
from loadarm.guidance.modes import (
    ALARM_OFF_DELAY,
    ALARM_STAGES,
    CONNECTED_MODES,
    ERS_CONFIRM_WINDOW,
    ERS_SWITCH_DISCREPANCY,
    MODE_OF_SEVERITY,
    Cycle,
    Mode,
)
from loadarm.guidance.monitor import prediction_times, stage_leads
from loadarm.guidance.voting import AXES
from loadarm.vocab import (ALARM_RULES, ANNUNCIATED, CHANGE_ROUTES, CONDITION_TEXT, RESET_BLOCKING, ROUTE_DESIGN,
                           ROUTE_MEASURED, ROUTE_PREDICTION, STAGE_EVENT, Severity, event_label)

if TYPE_CHECKING:  # the model is only ever received, never built, here
    pass

__all__ = ["SafetyRules"]


class SafetyRules:
    """The safety rules of the guidance controller (a mixin: see the module docstring)."""

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
            self._raise(cyc.now, cyc.q, Severity.ESD1, why, rule="fault")

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
            self._raise(now, cyc.q, Severity.ESD1, "manual ESD-1 by the operator", rule="operator")
        if "ers" in acts and s.release_since is None:
            s.ers_armed_at = now
            self._event("info", f"manual ERS armed: confirm within {ERS_CONFIRM_WINDOW:g} s")
        if "ers_confirm" in acts:
            if s.ers_armed_at is not None and now - s.ers_armed_at <= ERS_CONFIRM_WINDOW:
                s.ers_armed_at = None
                self._command_esd1(now, "manual ERS by the operator")
                self._raise(now, cyc.q, Severity.RELEASE, "manual ERS confirmed by the operator", rule="operator")
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

    def _connected_level(self, now: float, q) -> tuple[Severity, str, str, str]:
        """Position alarms and time to the nearest face (measured and design drift, or the prediction), the more
        severe: the level, its cause in words, the face it guards (:data:`loadarm.vocab.FACES`) and the rule
        that raised it (:data:`loadarm.vocab.ALARM_RULES`)."""
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
        rule = "position" if level > Severity.NORMAL else ""
        if s.forecast is None:
            s.leads = self._leads(now)
            if p is None:
                p = tuple(float(v) for v in forward3d(self.arm, *q))
            # the prediction stands in for the measured routes before ESD-1 only (after it, every route acts)
            s.trusted = None if (self.predictor is None or alarmed or self.moorings.lost_at is not None) \
                else self.predictor.trusted(s.leads[Severity.ESD1])
            s.unused = self._unused_why()
            s.forecast = mon.time_to_limit(p, max(s.leads.values()), alarmed=alarmed, now=now,
                                           design_too=s.trusted is not None)
            s.next_forecast = now + mon.fit.period
            self._predict(now)
        stage, t, route, face_f, rule_f = self._forecast_stage(now)
        if stage > level:
            level, face, rule = stage, face_f, rule_f
            why = f"{route}: {face_f} face in {t:.1f} s, the {stage.label} needs {s.leads[stage]:.1f} s"
        return level, why, face, rule

    def _predict(self, now: float) -> None:
        """The prediction's time to the nearest face (bound and mean), kept for the cycles until the next
        forecast."""
        s = self.state
        f = None if self.predictor is None else self.predictor.forecast
        if f is None:
            s.predicted, s.predicted_face = (), ""
            return
        lead = max(s.leads.values())
        if s.predicted and s.predicted[3] is f and s.predicted[4] == lead:
            return                               # the same forecast, the same lead: its times stand (from "at")
        bound, mean, s.predicted_face = prediction_times(self.monitor.model, f, self.predictor.within, now, lead)
        s.predicted = (bound, mean, now, f, lead)

    def _shadow(self, now: float, today: Severity, f) -> None:
        """Follow the rule without the prediction (the measured routes and the floor): each onset of its call for
        ESD-1 is an event (``info.measured_esd1``, held or not), and the onset of the call in progress is kept
        until the call ends (before ESD-1) or the connection does: the ESD-1 event says since when that rule had
        called for it (``measured_since``), how a campaign compares both rules on the same runs.

        It also keeps the hold's deadline (``hold_until``): a call starting within :data:`ALARM_OFF_DELAY` of the
        last one's end continues its hold (a flickering call is one call, so the limit bounds it, found: the
        basis's calls apart by under 5 s); a new one may be held for the hold limit from its onset, and every
        forecast of the call shortens that to when it would leave the release no more than its whole lead
        (``time - release lead`` from the forecast): a call that forecasts the face 18 s away when the release
        needs 20 s is not held at all (found: the limit alone let Hs 2.0-2.5 m seed 533's calls of "face in
        18-35 s" stand 15 s).
        """
        s = self.state
        if today < Severity.ESD1:
            if s.esd_since is None and s.shadow_esd1_at is not None:
                self._event("info", f"{event_label('info.measured_esd1_end')} after {now - s.shadow_esd1_at:.1f} s",
                            code="info.measured_esd1_end", since=s.shadow_esd1_at)
                s.shadow_esd1_at, s.shadow_end_at = None, now
            return
        onset = s.shadow_esd1_at is None
        if onset:
            s.shadow_esd1_at = now
            if s.hold_since is None or now - s.shadow_end_at >= ALARM_OFF_DELAY - 1e-9:
                s.hold_since, s.hold_until = now, now + self.hold_limit
        if self.hold_budget:
            s.hold_until = min(s.hold_until, now + f.time - s.leads[Severity.RELEASE])
        if onset:
            hold = s.trusted is not None and not self._change_seen(f, now) and now < s.hold_until - 1e-9
            held = " (held: the prediction is trusted and does not)" if hold else ""
            self._event("info", f"{event_label('info.measured_esd1')}: {f.route}: {f.face} face in {f.time:.1f} s"
                                f"{held}", code="info.measured_esd1", held=bool(held))

    def _forecast_stage(self, now: float) -> tuple[Severity, float, str, str, str]:
        """The stage the forecasts call for: ``(stage, time to the face, route in words, face, rule)``.

        Without a trusted prediction: the time-to-limit forecast's (the measured routes and the design-drift
        floor; the one rule :func:`loadarm.arm.sequence.stage_of`: the pre-alarm warns of a drift it sees).
        With one: the floor's and the prediction's, the more severe (the prediction also warns); but a call for
        ESD-1 by a change detector (:data:`loadarm.vocab.CHANGE_ROUTES`: a velocity step, a break-out) is held
        only with two witnesses that the ship is still the one the prediction learned (:meth:`_change_seen`):
        the track's latest block inside the prediction's intervals, and the berth's mooring load monitoring
        reading with the moorings holding (:mod:`loadarm.guidance.moorings`; when it finds them lost the
        prediction stands down altogether). Found: a break-out's ESD-1 0.2 s later than without the prediction
        (seed 111), held until the departure test's second block; and, over 1000 break-outs, 5 held with the
        track still inside the intervals (up to 12.3 s: at the break-out test's call a break-out's prediction
        errors are no larger than the waves'), so the track alone cannot be the witness; holding no change
        detector's call at all loses the hold of the waves' false calls (hs15_tracked seed 0: the break-out test
        calls at 208 s with the track within its intervals). No call is held longer than the hold limit
        (:func:`loadarm.arm.sequence.hold_limit`, ESD-1's lead less the release's: 15 s for the paper's sequence),
        nor past the instant its own forecasts leave the release no more than its whole lead, calls apart by less
        than the alarms' off-delay being one (:meth:`_shadow`): then it is raised, rule ``hold_limit`` (found: a
        wave's call just before a failure and a third of the lines or fewer parting, which neither witness sees,
        held ESD-1 up to 11 s; Hs 2.0-2.5 m seed 533's break-out calls, 10.8-19.0 s each, held until no ESD-1
        came in the run). So a call the prediction wrongly held still leaves the release its lead by the call's
        own forecast: the coupler free before the face; what a hold may cost is the ESD-1 shutdown's own time.
        """
        s, f, ld = self.state, self.state.forecast, self.state.leads
        s.holding = False
        legs = (ld[Severity.RELEASE], ld[Severity.SECOND], ld[Severity.ESD1], ld.get(Severity.PRE_ALARM, -math.inf))
        today = Severity(stage_of(f.time, f.measured, *legs)) if math.isfinite(f.time) else Severity.NORMAL
        self._shadow(now, today, f)
        measured = self._measured_stage(today, f)
        if s.trusted is None:
            return measured
        floor = Severity(stage_of(f.design, math.inf, *legs)) if math.isfinite(f.design) else Severity.NORMAL
        t_p = s.predicted[0] - (now - s.predicted[2]) if s.predicted else math.inf
        pre = t_p if s.trusted.claimed >= ld.get(Severity.PRE_ALARM, 0.0) else math.inf
        pred = Severity(stage_of(t_p, pre, *legs)) if math.isfinite(t_p) else Severity.NORMAL
        if pred >= floor:
            best = (pred, max(t_p, 0.0), ROUTE_PREDICTION, s.predicted_face, "prediction")
        else:
            best = (floor, f.design, ROUTE_DESIGN, f.face, "floor")
        if today >= Severity.ESD1 and measured[0] > best[0]:
            if self._change_seen(f, now) or not self.hold_limit > 0.0:   # nothing may be held (NaN neither)
                return measured
            if now >= s.hold_until - 1e-9:     # the hold spent: "measured" if it had none (its forecast too short)
                return (*measured[:4], "hold_limit" if now > s.hold_since + 1e-9 else "measured")
            s.holding = True
        return best if best[0] > Severity.NORMAL else (Severity.NORMAL, math.inf, "", "", "")

    def prediction_unused(self) -> str:
        """Why the claimed prediction does not stand in for the measured routes now
        (:data:`loadarm.vocab.PREDICTION_UNUSED`), ``""`` when it does or there is none: ``detached`` while not
        connected, else the reason decided with the trust at the last time-to-limit forecast."""
        if self.predictor is None or self.predictor.forecast is None:
            return ""
        return "detached" if not self.attached() else self.state.unused

    def _unused_why(self) -> str:
        """The reason, decided with :attr:`GuidanceState.trusted`, in the order the rules ask."""
        s, pr = self.state, self.predictor
        if pr is None or pr.forecast is None or s.trusted is not None:
            return ""
        if not self.attached():
            return "detached"
        if s.esd_since is not None:
            return "esd1"
        if self.moorings.lost_at is not None:
            return "moorings"
        return "departed" if pr.departed_at is not None else "short"

    def held_call(self, now: float) -> tuple:
        """The call for ESD-1 the trusted prediction holds now: ``(since, until)``, its joined onset and when its
        hold runs out at the latest, s; ``()`` when none is held. Held: this cycle's decision held it, or the
        call dropped out less than the off-delay ago (found by review: the line vanished in that gap while the
        hold ran on, and a call returning after its budget raised ESD-1 with no line before it).

        Parameters
        ----------
        now : float
            s.

        Returns
        -------
        tuple of float
        """
        s = self.state
        if s.esd_since is not None or s.raised >= Severity.ESD1 or s.hold_since is None:
            return ()
        gap = s.shadow_esd1_at is None and now - s.shadow_end_at < ALARM_OFF_DELAY - 1e-9
        return (s.hold_since, s.hold_until) if s.holding or gap else ()

    def _change_seen(self, f, now: float) -> bool:
        """Whether the forecast's route is a change detector's and a witness says the ship changed: the track
        has left the prediction's intervals on its latest block (two tests agree), or the mooring load
        monitoring does not say the moorings hold (not linked, or the moorings lost)."""
        if f.route not in CHANGE_ROUTES:
            return False
        return not self.moorings.holding(now) or (self.predictor is not None and self.predictor.outside > 0)

    @staticmethod
    def _measured_stage(today: Severity, f) -> tuple[Severity, float, str, str, str]:
        """The rule without the prediction's answer for ``today``'s stage of the forecast ``f``."""
        if today == Severity.NORMAL:
            return today, math.inf, "", "", ""
        t = f.measured if today == Severity.PRE_ALARM else f.time
        route = f.route if t == f.time else ROUTE_MEASURED
        return today, t, route, f.face, "floor" if route == ROUTE_DESIGN else "measured"

    def _raise(self, now: float, q, level: Severity, why: str, face: str = "", rule: str = "") -> None:
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
                by = f" [{ALARM_RULES[rule]}]" if rule else ""
                self._event("alarm", f"{event_label(code)}: {why}{by}", code=code, severity=int(stage),
                            severity_label=stage.label, face=face, rule=rule,
                            **({"measured_since": s.shadow_esd1_at, "hold_since": s.hold_since}
                               if stage == Severity.ESD1 else {}),
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
        s.level, why, face, s.rule = self._connected_level(cyc.now, cyc.q)
        self._raise(cyc.now, cyc.q, s.level, why, face, s.rule)

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
        if level == Severity.NORMAL and not (s.valve_fault or s.switch_fault or sensor or s.log_fault) and s.quiet:
            return                               # nothing present, nothing to acknowledge (all normal): fast path
        present = {"PRE_ALARM": level >= Severity.PRE_ALARM and self.seq.pre_alarm_lead > 0, "ESD1": level >= Severity.ESD1,
                   "SECOND": level >= Severity.SECOND, "RELEASE": level >= Severity.RELEASE,
                   "ERS_VALVE_FAULT": s.valve_fault, "ERS_SWITCH_FAULT": s.switch_fault, "SENSOR_FAULT": sensor,
                   "EVENT_LOG_FAULT": s.log_fault}
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
        """Whether every annunciated alarm an ESD-1 reset waits for (:data:`loadarm.vocab.RESET_BLOCKING`) is back
        to normal (cleared and acknowledged).

        Returns
        -------
        bool
        """
        return all(self.state.alarms[tag] == AlarmState.NORMAL for tag in RESET_BLOCKING)

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
