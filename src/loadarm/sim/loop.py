"""Closed-loop scenario runs: ship + sensor + estimator + guidance controller + arm plant + event log.

The plant is kinematic: between connections the joints follow the commanded
rates (already limited by the controller to the slew-drive and cylinder
speeds); while the coupler is attached the arm is carried by the flange
(joint angles from the 3D inverse kinematics of the true flange position). If
the flange ever leaves the arm's reach while attached, the run records an
*overstretch*: the failure the alarms exist to prevent. The manual connection
itself (the last ``standoff`` metre, pulled by the operator) is not modelled:
on ``connect`` the coupler is put on the flange.

Everything runs on a simulated clock, so runs are exact and repeatable; the
same controller runs in real time with a wall clock.
"""

from __future__ import annotations

import collections
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.actuators import cylinder_lengths, joint_angles_from_cylinders, length_limits
from loadarm.arm.faces import FACES, face_margins, first_face
from loadarm.arm.slew import forward3d, inverse3d, reach_mask3d
from loadarm.design.check import MANIFOLD_CLEARANCE, accumulator_usable_volume, cylinder_oil
from loadarm.eventlog import EventLog, RateLimiter
from loadarm.guidance.controller import (
    MODES,
    SEVERITY_OF_MODE,
    Command,
    GuidanceController,
    Mode,
    OperatorInput,
    PlantFeedback,
)
from loadarm.guidance.estimator import FlangeEstimator
from loadarm.guidance.voting import AXES
from loadarm.hydraulics.servo import HydraulicArm
from loadarm.hydraulics.simulate import SimulationError
from loadarm.params.scenario import Scenario, check_run_size
from loadarm.results import Metric, Result
from loadarm.ship.flange import flange_motion
from loadarm.ship.model import moored_ship
from loadarm.sim.plots import run_timeline_figure
from loadarm.sim.sensors import sensor_readings
from loadarm.sim.snapshot import state_sample
from loadarm.vocab import Severity, event_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["RUN_METRICS", "FAILURES", "RunResult", "run_scenario", "ClosedLoop", "SimulatedPlant", "ScriptedOperator", "ArmPlant", "ErsValves", "wall_clock_pacer",
           "MANIFOLD_CLEARANCE"]

#: The time the coupler has to put :data:`loadarm.design.check.MANIFOLD_CLEARANCE` between itself and the ship's flange
#: after a release, s.
CLEARANCE_TIME = 30.0


def wall_clock_pacer(speedup: float = 1.0) -> Callable[[float], None]:
    """A pacer that makes :func:`run_scenario` keep step with the wall clock.

    Parameters
    ----------
    speedup : float
        Simulated seconds per wall second (1 = real time).

    Returns
    -------
    callable
        ``pace(t)`` sleeps until ``t / speedup`` wall seconds after its first call.
    """
    if not speedup > 0:
        raise ValueError(f"speedup must be > 0, got {speedup!r}")
    start: list[float] = []

    def pace(t: float) -> None:
        if not start:
            start.append(time.monotonic() - t / speedup)
        delay = start[0] + t / speedup - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    return pace



#: The ways a run fails the safety chain, declared once (codes; the words are for people): the run's verdict, the
#: campaign's counters and ``loadarm run``'s exit status all read these.
FAILURES = {
    "overstretch_before_isolation": "the arm overstretched before the ERS valves were confirmed closed (live product)",
    "overstretch": "the arm overstretched",
    "opened_on_live_product": "the coupler began to open before the ERS valves were confirmed closed",
    "missed_alarm": "the flange reached a face before the release completed",
}

#: The headline numbers of a guidance run, declared once.
RUN_METRICS = (
    Metric("scenario", "scenario"),
    Metric("verdict", "verdict"),
    Metric("duration_s", "simulated", "s", ".1f"),
    Metric("final_mode", "final mode"),
    Metric("alarm1_s", "first alarm (ESD-1)", "s", ".2f", none="-"),
    Metric("alarm2_s", "second alarm", "s", ".2f", none="-"),
    Metric("release_s", "release (ERS-2)", "s", ".2f", none="-"),
    Metric("release_complete_s", "release complete", "s", ".2f", none="-"),
    Metric("overstretched_s", "overstretched", "s", ".2f", none="no"),
    Metric("release_margin_s", "release margin to the limit", "s", ".2f", none="-"),
    Metric("cleared_s", "coupler clear of the manifold", "s", ".2f", none="-"),
    Metric("retracted_s", "arm retracted clear of its release point", "s", ".2f", none="-"),
    Metric("connected_s", "time connected", "s", ".1f"),
    Metric("max_beta_deg", "max beta", "deg", ".1f"),
    Metric("max_abs_slew_deg", "max |slew|", "deg", ".1f"),
    Metric("events", "events", "", "d"),
)


@dataclass(frozen=True)
class RunResult(Result):
    """Signals and events of one run.

    Attributes
    ----------
    name : str
        Scenario name.
    signals : dict of str to ndarray
        ``t, mode (index into MODES), phi, alpha, beta, x, y, z, fx, fy, fz, ex, ey, ez, healthy, distance,
        severity`` (:class:`loadarm.arm.alarms.Severity` of the connected mode), ``level`` (connected-mode alarm
        level), ``ttl`` (forecast time to the nearest face, s; NaN when none in sight), ``connected`` at every
        guidance cycle.
    events : list of tuple
        ``(t, mode, kind, reason, data)`` in order.
    overstretched_at : float or None
        First time the attached arm could not reach the flange, s.
    cycle_us : ndarray
        Wall time of each controller cycle (estimate + decide), microseconds.
    beta_thresholds_deg : tuple of float
        The run's first, second and release angles (for the timeline figure).
    limit_at : float or None
        First time after the connection the true flange lies past a face of the arm's envelope (where an
        arm still attached would be overstretched), s: in the run or on the flange's trajectory up to
        ``LIMIT_LOOKAHEAD`` s after it.
    limit_face : str
        That face (:data:`loadarm.arm.faces.FACES`).
    """

    name: str
    signals: dict
    events: list
    overstretched_at: float | None
    cycle_us: np.ndarray = field(repr=False)
    beta_thresholds_deg: tuple = ()
    limit_at: float | None = None
    limit_face: str = ""

    METRICS = RUN_METRICS

    def first(self, kind: str, contains: str = "") -> float | None:
        """Time of the first event of a kind whose reason contains a text, s (None if none); for reading a run
        by eye. Metrics read codes (:meth:`first_code`)."""
        for t, _, k, reason, _ in self.events:
            if k == kind and contains in reason:
                return t
        return None

    def first_code(self, code: str) -> float | None:
        """Time of the first event with an event code (:data:`loadarm.vocab.EVENT_TABLE`), s (None if none).

        Parameters
        ----------
        code : str
            E.g. ``"stage.esd1"``, ``"command.release_complete"``.

        Returns
        -------
        float or None
        """
        for t, _, _, _, data in self.events:
            if data and data.get("code") == code:
                return t
        return None

    def first_data(self, code: str) -> dict | None:
        """The data of the first event with an event code (None if none): e.g. a stage's ``face``.

        Parameters
        ----------
        code : str
            E.g. ``"stage.esd1"``.

        Returns
        -------
        dict or None
        """
        for _, _, _, _, data in self.events:
            if data and data.get("code") == code:
                return data
        return None

    def release_margin(self) -> float | None:
        """Time from the release complete to the flange's first crossing of a face, s (None without a
        release, or when the flange reaches no face in the run nor in the look-ahead after it).

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None or self.limit_at is None:
            return None
        return self.limit_at - t_rel

    def failures(self) -> tuple[str, ...]:
        """How the run failed the safety chain: codes of :data:`FAILURES` (empty: it held).

        An overstretch is ``overstretch_before_isolation`` when it came before the ERS valves' confirmation (or
        with none), product still live in the arm; ``missed_alarm`` is a face reached within the run before the
        release completed (the attached arm overstretched, or would have).

        Returns
        -------
        tuple of str
        """
        out = []
        confirmed = self.first_code("interlock.valves_confirmed")
        if self.overstretched_at is not None:
            live = confirmed is None or self.overstretched_at < confirmed
            out.append("overstretch_before_isolation" if live else "overstretch")
        opened = self.first_code("command.coupler_opening")
        if opened is not None and (confirmed is None or opened < confirmed):
            out.append("opened_on_live_product")
        done, limit = self.first_code("command.release_complete"), self.limit_at
        if limit is not None and limit <= float(self.signals["t"][-1]) and (done is None or done > limit) \
                and (done is not None or self._attached_at(limit)):
            # found (review): a face the flange passed after a controlled disconnection failed the run
            out.append("missed_alarm")
        return tuple(out)

    def _attached_at(self, t: float) -> bool:
        """Whether the coupler was on the flange at time ``t`` (the last cycle at or before it)."""
        s = self.signals
        k = int(np.searchsorted(s["t"], t, side="right")) - 1
        return bool(k >= 0 and s["connected"][k] > 0)

    def verdict(self) -> str:
        """``"pass"``, or ``"FAILED: "`` and what failed, in words (:data:`FAILURES`), with its times.

        Returns
        -------
        str
        """
        fails = self.failures()
        if not fails:
            return "pass"
        words = []
        for code in fails:
            text = FAILURES[code]
            if code.startswith("overstretch"):
                confirmed = self.first_code("interlock.valves_confirmed")
                text += f" at {self.overstretched_at:.2f} s" + (
                    "" if confirmed is None or code == "overstretch"
                    else f", {confirmed - self.overstretched_at:.2f} s before the confirmation")
            words.append(text)
        return "FAILED: " + "; ".join(words)

    def cleared_at(self) -> float | None:
        """First time after the release the coupler is :data:`MANIFOLD_CLEARANCE` from the flange, s.

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None:
            return None
        s = self.signals
        ok = np.flatnonzero((s["t"] >= t_rel) & (s["distance"] >= MANIFOLD_CLEARANCE))
        return float(s["t"][ok[0]]) if ok.size else None

    def retracted_at(self) -> float | None:
        """First time after the release the coupler is :data:`~loadarm.design.check.MANIFOLD_CLEARANCE` from where it was
        released, s: the arm itself moved clear (the flange may also have left on its own, :meth:`cleared_at`).

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None:
            return None
        s = self.signals
        k0 = int(np.searchsorted(s["t"], t_rel))
        p = np.stack([s["x"][k0:], s["y"][k0:], s["z"][k0:]], axis=1)
        ok = np.flatnonzero(np.linalg.norm(p - p[0], axis=1) >= MANIFOLD_CLEARANCE)
        return float(s["t"][k0 + ok[0]]) if ok.size else None

    def _figure(self):

        return run_timeline_figure(self)

    def _values(self) -> dict:
        """Headline numbers, JSON-friendly."""
        s = self.signals
        modes = [MODES[int(i)] for i in s["mode"]]
        seq = [modes[0]] + [m for a, m in zip(modes, modes[1:]) if m != a]
        return {
            "scenario": self.name,
            "verdict": self.verdict(),
            "failures": list(self.failures()),
            "duration_s": float(s["t"][-1]),
            "mode_sequence": seq,
            "final_mode": modes[-1],
            "alarm1_s": self.first_code("stage.esd1"),
            "alarm2_s": self.first_code("stage.second"),
            "release_s": self.first_code("stage.release"),
            "release_complete_s": self.first_code("command.release_complete"),
            "overstretched_s": self.overstretched_at,
            "limit_s": self.limit_at,
            "limit_face": self.limit_face,
            "release_margin_s": self.release_margin(),
            "valves_confirmed_s": self.first_code("interlock.valves_confirmed"),
            "coupler_opening_s": self.first_code("command.coupler_opening"),
            "cleared_s": self.cleared_at(),
            "retracted_s": self.retracted_at(),
            "connected_s": float(np.sum(np.diff(s["t"]) * (s["connected"][:-1] > 0))),
            "max_beta_deg": float(np.degrees(np.nanmax(s["beta"]))),
            "max_abs_slew_deg": float(np.degrees(np.nanmax(np.abs(s["phi"])))),
            "events": len(self.events),
            "cycle_us_median": float(np.median(self.cycle_us)) if self.cycle_us.size else None,
            "cycle_us_p99": float(np.percentile(self.cycle_us, 99)) if self.cycle_us.size else None,
        }


class ScriptedOperator:
    """The scenario's operator: presses start, connect, disconnect, E-stop, reset, acknowledge, manual ESD-1,
    manual ERS (and its confirmation) and the joystick on cue.

    Parameters
    ----------
    op : Operator
        The scenario's ``[operator]`` section.
    dt : float
        Guidance cycle, s (an action fires in the one cycle that contains its time).
    """

    def __init__(self, op, dt: float):
        self.op = op
        self.dt = dt
        self.standoff_since: float | None = None

    def _now_is(self, t: float | None, now: float) -> bool:
        return t is not None and t <= now < t + self.dt

    def inputs(self, now: float, mode: Mode, servo_fault: bool) -> OperatorInput:
        """The operator's actions and joystick this cycle.

        Parameters
        ----------
        now : float
            Time, s.
        mode : Mode
            The controller's mode (the operator connects after waiting at the standoff).
        servo_fault : bool
            A servo fault was reported (the operator presses the E-stop).

        Returns
        -------
        OperatorInput
        """
        op, actions = self.op, []
        if self._now_is(op.start, now):
            actions.append("start")
        if mode == Mode.STANDOFF:
            self.standoff_since = now if self.standoff_since is None else self.standoff_since
            if now - self.standoff_since >= op.connect_after:
                actions.append("connect")
        else:
            self.standoff_since = None
        confirm = (None if op.ers_at is None or op.ers_confirm_after is None else op.ers_at + op.ers_confirm_after)
        for name, t in (("disconnect", op.disconnect_at), ("estop", op.estop_at), ("reset", op.reset_at),
                        ("ack", op.ack_at), ("esd", op.esd_at), ("ers", op.ers_at), ("ers_confirm", confirm)):
            if self._now_is(t, now):
                actions.append(name)
        if servo_fault and mode != Mode.ESTOP:
            actions.append("estop")
        jog = (0.0, 0.0, 0.0)
        for t_on, t_off, vx, vy, vz in op.jog:
            if self._now_is(t_on, now):
                actions.append("manual")
            if self._now_is(t_off, now):
                actions.append("auto")
            if t_on <= now < t_off:
                jog = (vx, vy, vz)
        return OperatorInput(tuple(actions), jog)


class ArmPlant:
    """The arm between guidance cycles: attached, it follows the flange; free, it follows the rate command
    through ideal joints (``kinematic``) or the two electro-hydraulic servo drives (``hydraulic``).

    Parameters
    ----------
    model : ArmModel
        The arm.
    q : ndarray, shape (3,)
        Starting joint angles (slew, alpha, beta), rad.
    kind : {'hydraulic', 'kinematic'}
        Plant.
    emit : callable
        ``emit(t, mode, kind, reason, data)`` for the plant's own events (overstretch, servo fault, HPU trip).
    hpu_trip_at : float, optional
        Time the hydraulic power unit trips: from then on the ERS valves, the coupler's release and the drives
        run on the ERS accumulator (:func:`loadarm.design.check.design_check` sizes it), the drives until its oil is
        spent.

    Notes
    -----
    When the drives take the arm over after an emergency release, they start from its real state: the pose and
    joint rates it had on the flange, and the product still in it (fill 1: trapped between the closed ERS
    valves). After a controlled disconnection the arm has been drained (the configured fill).
    """

    def __init__(self, model: ArmModel, q: np.ndarray, kind: str, emit: Callable, *,
                 hpu_trip_at: float | None = None):
        self.arm, self.lim = model.arm, model.joint_limits
        self.q = np.asarray(q, dtype=float)
        self.attached_rates = np.zeros(3)
        self.emit = emit
        self.servo = None
        self.servo_full = None
        if kind == "hydraulic":

            self.servo = HydraulicArm(model, self.q[1], self.q[2])
            self.servo_full = HydraulicArm(model, self.q[1], self.q[2], fill=1.0)
        self.servo_fault = False
        self.was_connected = False
        self.was_released = False
        self.hpu_trip_at = hpu_trip_at
        self.hpu_tripped = False
        self.model = model

        acc = model.accumulator
        #: Oil left for the drives after an HPU trip, m^3: the accumulator's usable volume less what the ERS
        #: valves and the coupler's release take first.
        self.oil_left = accumulator_usable_volume(acc.volume, acc.precharge, acc.charged_pressure, acc.min_pressure,
                                                  acc.polytropic_index) - acc.required_volume
        self.overstretched: float | None = None

    def step(self, now: float, dt: float, cmd, f: np.ndarray) -> np.ndarray:
        """Advance one guidance cycle.

        Parameters
        ----------
        now, dt : float
            Time and cycle, s.
        cmd : Command
            The controller's command this cycle.
        f : ndarray, shape (3,)
            The flange position, m.

        Returns
        -------
        ndarray, shape (3,)
            Joint angles after the cycle, rad.
        """
        if self.hpu_trip_at is not None and now >= self.hpu_trip_at and not self.hpu_tripped:
            self.hpu_tripped = True
            self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.hpu_trip')}: the pumps have stopped; the "
                      "ERS valves, the coupler's release and the retraction run on the accumulator",
                      {"code": "fault.hpu_trip"})
        if cmd.connected:
            q_before = self.q.copy()
            self._follow_flange(now, cmd, f)
            self.attached_rates = (self.q - q_before) / dt
        elif self.hpu_tripped:
            self._drive_on_accumulator(now, dt, cmd)
        else:
            self._drive(now, dt, cmd)
        self.was_connected = cmd.connected
        self.was_released = cmd.release if cmd.connected else self.was_released
        return self.q

    def _drive_on_accumulator(self, now: float, dt: float, cmd) -> None:
        """With the HPU tripped the drives run on what the ERS left in the accumulator, metered by the oil the
        cylinders draw (:func:`loadarm.design.check.cylinder_oil`); once it is spent the arm stays where it is (brakes,
        load-holding valves). The supply pressure is taken as held above the minimum working pressure until
        then (the accumulator's usable volume is counted down to it)."""
        if self.oil_left <= 0.0:
            return

        q0 = self.q.copy()
        self._drive(now, dt, cmd)
        self.oil_left -= cylinder_oil(self.model, q0, self.q)
        if self.oil_left <= 0.0:
            self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.accumulator_spent')}: the arm stops where "
                      "it is", {"code": "fault.accumulator_spent"})

    def _follow_flange(self, now: float, cmd, f: np.ndarray) -> None:
        arm = self.arm
        inside = bool(reach_mask3d(arm, f[0], f[1], f[2]))
        if inside:
            qq = inverse3d(arm, f[0], f[1], f[2])
            q_new = np.array([float(qq.phi), float(qq.alpha), float(qq.beta)])
            inside = self.lim.contains(q_new, tol=1e-9)
            if inside:
                self.q = q_new
        if not inside and self.overstretched is None:
            self.overstretched = now
            self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.overstretched')}: the attached flange is "
                      "beyond the arm's reach or a joint / cylinder stroke limit",
                      {"code": "fault.overstretched", "flange": [float(v) for v in f]})

    def _drive(self, now: float, dt: float, cmd) -> None:
        lim, q = self.lim, self.q
        lo = (lim.phi[0], lim.alpha[0], lim.beta[0])
        hi = (lim.phi[1], lim.alpha[1], lim.beta[1])
        if self.servo is None:
            self.q = np.minimum(np.maximum(q + np.array(cmd.rates) * dt, lo), hi)
            return

        if self.was_connected:        # released: the drives take the arm over from its real state
            if self.was_released:     # emergency release: moving with the ship, full of product
                self.servo = self.servo_full
            self.servo.reset(q[1], q[2], float(self.attached_rates[1]), float(self.attached_rates[2]))
        phi = min(max(q[0] + cmd.rates[0] * dt, lo[0]), hi[0])
        try:
            a_new, b_new = self.servo.step(dt, (cmd.rates[1], cmd.rates[2]))
        except SimulationError as exc:
            if not self.servo_fault:
                self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.servo')}: {exc}", {"code": "fault.servo"})
            self.servo_fault = True
            self.servo.reset(q[1], q[2])
            a_new, b_new = q[1], q[2]
        self.q = np.array([phi, a_new, b_new])


class ErsValves:
    """The ERS double-block valves and their two independent closed limit switches (plant side).

    Parameters
    ----------
    closing_time : float
        From the close command to both limit switches made, s (the installation's ``ers_valve_time``).
    stuck : bool
        Fault: the valves never close.
    delay : float
        Fault: extra closing time, s.
    false_closed_at : float or None
        Fault: from this time the first switch reads closed whatever the valves do (the case two switches exist
        for: with one, the coupler would open on live product), s.
    """

    def __init__(self, closing_time: float, *, stuck: bool = False, delay: float = 0.0,
                 false_closed_at: float | None = None):
        self.closing_time = closing_time + delay
        self.stuck = stuck
        self.false_closed_at = false_closed_at
        self.since: float | None = None

    def step(self, now: float, close: bool) -> tuple[bool, bool]:
        """Advance to ``now`` under the command; report the limit switches.

        Parameters
        ----------
        now : float
            Time, s.
        close : bool
            Close command this cycle (False reopens them).

        Returns
        -------
        tuple of bool
            Each closed limit switch made.
        """
        if not close:
            self.since = None
            closed = False
        else:
            if self.since is None:
                self.since = now
            closed = (not self.stuck) and now - self.since >= self.closing_time - 1e-9
        false = self.false_closed_at is not None and now >= self.false_closed_at - 1e-9
        return (True if false else closed, closed)


class AngleSensors:
    """The joint-angle sensors (plant side): each axis's angle encoder (the primary channel, which the scenario's
    encoder fault strikes) and its second channel, per the installation's ``[encoder] redundancy``
    (:mod:`loadarm.guidance.voting`).

    Parameters
    ----------
    model : ArmModel
        Mounting (the cylinder channel), ``encoder`` record (redundancy, resolution).
    faults : Faults
        The scenario's ``[faults]`` (``encoder_fault``, ``encoder_fault_axis``, ``encoder_fault_at``,
        ``encoder_drift_rate_deg``).
    """

    def __init__(self, model: ArmModel, faults):


        self.mount, self.enc = model.mount, model.encoder
        self.limits = length_limits(model.mount)
        self.fault, self.at = faults.encoder_fault, faults.encoder_fault_at
        self.axis = AXES.index(faults.encoder_fault_axis)
        self.rate = math.radians(faults.encoder_drift_rate_deg)
        self.held: float | None = None

    def primary(self, now: float, q) -> np.ndarray:
        """The angle encoders' readings at ``now``, rad.

        Parameters
        ----------
        now : float
            Time, s.
        q : array_like, shape (3,)
            The true joint angles, rad.

        Returns
        -------
        ndarray, shape (3,)
        """
        out = np.array(q, dtype=float)
        if self.fault == "none" or now < self.at - 1e-9:
            return out
        j = self.axis
        if self.fault == "frozen":
            if self.held is None:
                self.held = float(out[j])
            out[j] = self.held
        elif self.fault == "drift":
            out[j] += self.rate * (now - self.at)
        else:
            out[j] = math.nan
        return out

    def second(self, q) -> tuple | None:
        """The second channel's readings, rad (None without redundancy).

        Parameters
        ----------
        q : array_like, shape (3,)
            The true joint angles, rad.

        Returns
        -------
        tuple of float or None
        """
        red = self.enc.redundancy
        if red == "none":
            return None
        if red == "dual":
            return tuple(float(v) for v in q)

        res = self.enc.resolution
        r1, r2 = cylinder_lengths(self.mount, q[1], q[2])
        lo, hi = self.limits["r_ac1"], self.limits["r_ac2"]
        # a transducer saturates at the pins' geometric ends (found: a quantised reading half a step past a flat
        # triangle made the inverse raise, which would stop the plant)
        a, b = joint_angles_from_cylinders(self.mount, min(max(float(np.round(r1 / res) * res), lo[0]), lo[1]),
                                           min(max(float(np.round(r2 / res) * res), hi[0]), hi[1]))
        return (float(q[0]), float(a), float(b))


def run_scenario(sc: Scenario, model: ArmModel, *, log: EventLog | None = None, sample_every: float = 1.0,
                 progress: Callable[[float], None] | None = None, plant: str | None = None,
                 pace: Callable[[float], None] | None = None, ship=None) -> RunResult:
    """Run a scenario in closed loop on a simulated clock.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    model : ArmModel
        The arm.
    log : EventLog, optional
        Durable event log; every event is committed as it happens, plus a
        ``sample`` event every ``sample_every`` seconds for replay.
    sample_every : float
        Period of the replay samples in the log, s.
    progress : callable, optional
        Called with the fraction done (0-1) about every 2 % of the run.
    pace : callable, optional
        Called with each cycle's time before the cycle runs; pass
        :func:`wall_clock_pacer` to run in real time (the controller code is
        the same, only the clock changes).
    plant : {'hydraulic', 'kinematic'}, optional
        Arm plant (default the scenario's ``[scenario] plant``): the two
        electro-hydraulic servo drives of :mod:`loadarm.hydraulics` on the
        arm's dynamics (slew kinematic), or ideal rate-following joints.
    ship : ShipModel, optional
        For ``[ship] model = "moored"``: the berth's ship compiled once by the caller (a campaign); default
        compiled from the berth file.

    Returns
    -------
    RunResult
    """
    loop = ClosedLoop(sc, model, log=log, sample_every=sample_every, plant=plant, ship=ship)
    report_every = max(1, loop.n // 50)
    for k in range(loop.n):
        if pace is not None:
            pace(loop.time(k))
        loop.cycle(k)
        if progress is not None and k % report_every == 0:
            progress(k / loop.n)
    if progress is not None:
        progress(1.0)
    return loop.result()


class SimulatedPlant:
    """The scenario's plant in the same process: the ship's flange, the sensor's readings, the arm
    (:class:`ArmPlant`) and the ERS valves, stepped by the controller's commands. ``loadarm plc-sim`` runs the
    same plant behind OPC UA; the controller's side of that link has the same four members
    (:meth:`arrived`, :attr:`q`, :attr:`feedback`, :meth:`step`).

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    stored : tuple of float
        The stored coupler position the arm starts at, m.
    n : int
        Cycles.
    dt : float
        Cycle, s.
    plant : {'hydraulic', 'kinematic'}
    emit : callable
        ``emit(t, mode, kind, reason, data)``.
    ship : ShipModel, optional
    """

    def __init__(self, sc: Scenario, model: ArmModel, stored, n: int, dt: float, plant: str, emit: Callable, ship=None):
        if ship is None and sc.ship.model == "moored":

            ship = moored_ship(sc)
        self.motion = flange_motion(sc, ship)
        self.readings = sensor_readings(sc, self.motion)
        self.flange = self.motion.position(np.arange(n) * dt)
        q0 = inverse3d(model.arm, *stored)
        self.arm = ArmPlant(model, np.array([float(q0.phi), float(q0.alpha), float(q0.beta)]), plant, emit,
                            hpu_trip_at=sc.faults.hpu_trip_at)
        self.valves = ErsValves(model.sequence.ers_valve_time, stuck=sc.faults.ers_valve_stuck,
                                delay=sc.faults.ers_valve_delay, false_closed_at=sc.faults.ers_switch_false_closed_at)
        self.sensors = AngleSensors(model, sc.faults)
        self.feedback = PlantFeedback(angles=self.sensors.second(self.arm.q))
        self._t = 0.0
        self._ir = 0

    @property
    def q(self) -> np.ndarray:
        """Joint angles (slew, alpha, beta), rad: the angle encoders (the primary channel; the second is in
        :attr:`feedback`)."""
        return self.sensors.primary(self._t, self.arm.q)

    @property
    def servo_fault(self) -> bool:
        return self.arm.servo_fault

    @property
    def pressures(self) -> tuple[float, float, float, float, float]:
        """Chamber pressures ``pA1, pB1, pA2, pB2`` and the supply pressure, Pa (NaN: the kinematic arm)."""
        servo = self.arm.servo
        if servo is None:
            return (math.nan,) * 5
        y = servo.state.y
        return float(y[4]), float(y[5]), float(y[6]), float(y[7]), float(y[12])

    @property
    def overstretched(self) -> float | None:
        return self.arm.overstretched

    def arrived(self, now: float):
        """The sensor readings that have arrived by ``now`` since the last call: ``(t_meas, (x, y, z))``."""
        r, out = self.readings, []
        while self._ir < r.t_arrive.size and r.t_arrive[self._ir] <= now:
            z = r.xyz[self._ir]
            out.append((float(r.t_meas[self._ir]), (float(z[0]), float(z[1]), float(z[2]))))
            self._ir += 1
        return out

    def step(self, k: int, now: float, dt: float, cmd) -> tuple[np.ndarray, np.ndarray]:
        """Apply cycle ``k``'s command: the ERS valves, then the arm; returns the true joints and the true
        flange (the sensors' readings of the new pose are the next cycle's :attr:`q` and :attr:`feedback`)."""
        switches = self.valves.step(now, cmd.close_ers_valves)
        q = self.arm.step(now, dt, cmd, self.flange[k])
        self._t = now + dt
        self.feedback = PlantFeedback(ers_switches=switches, angles=self.sensors.second(q))
        return q, self.flange[k]

    def first_limit(self, model: ArmModel, sig: dict) -> tuple[float | None, str]:
        """The first time the true flange is past a face after the connection (:func:`_first_limit`)."""
        return _first_limit(model, sig, self.flange[:sig["t"].size], self.motion)


class ClosedLoop:
    """One closed-loop run of a scenario, a guidance cycle at a time: :func:`run_scenario` drives it on a
    simulated clock, ``loadarm serve`` on the wall clock with the operator's requests
    (:mod:`loadarm.opcua.service`).

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    log : EventLog, optional
    sample_every : float
        Period of the replay samples in the log, s.
    plant : {'hydraulic', 'kinematic'}, optional
    ship : ShipModel, optional
    scripted : bool
        The scenario's operator acts (default); False: only the inputs given to :meth:`cycle`.
    io : optional
        The plant's inputs and outputs (default the scenario's :class:`SimulatedPlant`).
    continuous : bool
        Run without an end (a real plant through ``io``): the signals are kept for the last
        :data:`CONTINUOUS_WINDOW` s only, cycle ``k`` in slot ``k % n``.

    Attributes
    ----------
    n : int
        Cycles in the scenario's duration (continuous: slots of the signal window).
    dt : float
        Guidance cycle, s.
    ctrl : GuidanceController
    io : SimulatedPlant
        The plant's inputs and outputs (another with the same members: a PLC over OPC UA).
    events : list
        ``(t, mode, kind, reason, data)`` so far.
    estimate : Estimate or None
        The flange estimate of the last cycle.
    """

    def __init__(self, sc: Scenario, model: ArmModel, *, log: EventLog | None = None, sample_every: float = 1.0,
                 plant: str | None = None, ship=None, scripted: bool = True, io=None, continuous: bool = False):
        g = sc.guidance
        if continuous and io is None:
            raise ValueError("continuous needs io (a plant without an end: a PLC); a simulated plant has the "
                             "scenario's duration")
        plant = sc.scenario.plant if plant is None else plant
        if plant not in ("hydraulic", "kinematic"):
            raise ValueError(f"plant must be 'hydraulic' or 'kinematic', got {plant!r}")
        check_run_size(sc)
        self.sc, self.model, self.log = sc, model, log
        self.ctrl = GuidanceController(model, g)
        self.est = FlangeEstimator(noise=sc.sensor.noise, max_age=g.max_estimate_age)
        self.dt = 1.0 / g.rate
        self.continuous = continuous
        self.n = int(math.floor((CONTINUOUS_WINDOW if continuous else sc.scenario.duration) / self.dt)) + 1
        self.events: list = [] if not continuous else collections.deque(maxlen=CONTINUOUS_EVENTS)
        self._limiter = RateLimiter()
        self.io = SimulatedPlant(sc, model, self.ctrl.stored, self.n, self.dt, plant, self.emit, ship) if io is None \
            else io
        self.operator = ScriptedOperator(sc.operator, self.dt) if scripted else None
        self.rec = _Recorder(self.n, log, sample_every)
        self.clearance = _ClearanceWatch(self.emit)
        self.cycle_us = np.full(self.n, np.nan)
        self.estimate = None
        self._ir = 0

    def time(self, k: int) -> float:
        """The time of cycle ``k``, s (a Python float: numpy scalars make every scalar operation slower)."""
        return k * self.dt

    def slot(self, k: int) -> int:
        """Where cycle ``k``'s signals are kept: ``k``, or ``k % n`` in a continuous run."""
        return k % self.n if self.continuous else k

    def emit(self, t, mode, kind, reason, data) -> None:
        """Record an event (rate-limited alike events) and append it to the log."""
        write, suppressed = self._limiter.admit(t, kind, reason)
        if not write:
            return
        if suppressed:
            reason = f"{reason} (and {suppressed} alike in the last {self._limiter.window:g} s)"
        self.events.append((t, mode, kind, reason, data))
        if self.log is not None:
            self.log.append(t, mode, kind, reason, **data)

    def cycle(self, k: int, live: OperatorInput | None = None) -> Command:
        """Run guidance cycle ``k``: sensor, estimate, controller, valves, plant, record.

        Parameters
        ----------
        k : int
            Cycle, ``0 <= k < n``.
        live : OperatorInput, optional
            The operator's requests this cycle (added to the scripted operator's actions; its jog, if any,
            replaces the script's).

        Returns
        -------
        Command
        """
        now = self.time(k)
        ctrl, io = self.ctrl, self.io
        t0 = time.perf_counter()
        for t_meas, z in io.arrived(now):
            if not self.est.update(t_meas, z):
                self.emit(now, ctrl.state.mode.value, "sensor", "reading rejected as an outlier",
                          {"reading": [float(v) for v in z]})
        e = self.est.estimate(now)
        op = self.operator.inputs(now, ctrl.state.mode, io.servo_fault) if self.operator else OperatorInput()
        if live is not None:
            op = OperatorInput(op.actions + live.actions, live.jog if any(live.jog) else op.jog)
        cmd = ctrl.step(now, io.q, e, op, io.feedback)
        i = self.slot(k)
        self.cycle_us[i] = (time.perf_counter() - t0) * 1e6
        for kind, reason, data in cmd.events:
            self.emit(now, cmd.mode.value, kind, reason, data)
        q, flange = io.step(k, now, self.dt, cmd)
        self.rec.record(i, now, cmd, q, flange, e, self.model.arm, ctrl.state.alarms,
                        bool(io.feedback.ers_valves_closed))
        self.clearance.watch(now, cmd, self._clearance(i, e))
        self.estimate = e
        return cmd

    def _clearance(self, i: int, e) -> float:
        """The coupler's distance from the flange at slot ``i``: from the true flange where the plant knows it (a
        simulation), else from the sensor's estimate while it is healthy (a PLC: found, the watch took the NaN of
        the unknown true flange and raised a false "not clear" alarm after every release), else NaN (unknown)."""
        sig = self.rec.sig
        d = float(sig["distance"][i])
        if math.isnan(d) and e.healthy:
            d = math.dist((float(sig["x"][i]), float(sig["y"][i]), float(sig["z"][i])), e.position)
        return d

    def result(self) -> RunResult:
        """The run's result over the cycles run so far (continuous: over the signal window)."""
        t = self.rec.sig["t"]
        k = int(np.count_nonzero(np.isfinite(t)))
        idx = np.argsort(t)[:k] if self.continuous else slice(0, k)       # NaN (slots not yet run) sort last
        sig = {name: v[idx] for name, v in self.rec.sig.items()}
        al = self.model.alarms
        limit_at, limit_face = self.io.first_limit(self.model, sig)
        return RunResult(self.sc.scenario.name, sig, list(self.events), self.io.overstretched, self.cycle_us[idx],
                         tuple(math.degrees(a) for a in (al.first, al.second, al.release)), limit_at, limit_face)


#: The signals a continuous run keeps (the last hour), s.
CONTINUOUS_WINDOW = 3600.0
#: The events a continuous run keeps in memory (all go to the event log).
CONTINUOUS_EVENTS = 10_000

#: How far past the end of a run the flange's own trajectory is followed to find the face it would reach, s.
LIMIT_LOOKAHEAD = 600.0


def _first_limit(model: ArmModel, sig: dict, flange: np.ndarray, motion) -> tuple[float | None, str]:
    """First time after the first connection the true flange is past a face of the envelope: in the run, or on
    the flange's own trajectory up to :data:`LIMIT_LOOKAHEAD` s after it (a slow drift whose alarm came before
    the run ended still reaches its face)."""
    conn = np.flatnonzero(sig["connected"] > 0)
    if conn.size == 0:
        return None, ""
    k0 = int(conn[0])
    t_end = float(sig["t"][-1])
    after = t_end + np.arange(1, int(LIMIT_LOOKAHEAD / 0.1) + 1) * 0.1
    tt = np.concatenate([sig["t"][k0:], after])
    p = np.concatenate([flange[k0:], motion.position(after)])
    outside, face = first_face(face_margins(model, p[:, 0], p[:, 1], p[:, 2]))
    hit = np.flatnonzero(outside)
    if hit.size == 0:
        return None, ""
    return float(tt[hit[0]]), FACES[int(face[hit[0]])]


class _ClearanceWatch:
    """After a release the coupler must be :data:`MANIFOLD_CLEARANCE` from the flange within
    :data:`CLEARANCE_TIME`; otherwise an alarm (the arm may strike the ship's manifold). A distance of NaN is
    unknown (no flange position): unknown at the deadline raises the alarm too, saying so (the operator must see
    the coupler clear)."""

    def __init__(self, emit: Callable):
        self.emit = emit
        self.released_at: float | None = None
        self.done = False
        self.was_connected = False

    def watch(self, now: float, cmd, distance: float) -> None:
        if self.was_connected and not cmd.connected:      # released or unclamped this cycle
            self.released_at, self.done = now, False
        self.was_connected = cmd.connected
        if self.released_at is None or self.done:
            return
        if distance >= MANIFOLD_CLEARANCE:
            self.done = True
        elif now - self.released_at > CLEARANCE_TIME:
            self.done = True
            where = ("flange position unknown" if math.isnan(distance)
                     else f"{distance:.2f} m from the flange")
            self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.not_clear')}: {CLEARANCE_TIME:g} s after "
                      f"the release ({where}, {MANIFOLD_CLEARANCE:g} m needed)", {"code": "fault.not_clear"})


class _Recorder:
    """The run's signals at every cycle, and a replay sample in the event log every ``sample_every`` s."""

    def __init__(self, n: int, log: EventLog | None, sample_every: float):
        self.sig = {k: np.full(n, np.nan) for k in ("t", "mode", "phi", "alpha", "beta", "x", "y", "z", "fx", "fy",
                                                     "fz", "ex", "ey", "ez", "healthy", "distance", "severity",
                                                     "level", "ttl", "connected")}
        self.log, self.sample_every, self.next_sample = log, sample_every, 0.0

    def record(self, k: int, now: float, cmd, q: np.ndarray, f: np.ndarray, e, arm, alarms=None,
               ers_valves_closed: bool = False) -> None:
        sig = self.sig
        p = forward3d(arm, *q)
        sig["t"][k] = now
        sig["mode"][k] = MODES.index(cmd.mode.value)
        sig["phi"][k], sig["alpha"][k], sig["beta"][k] = q
        sig["x"][k], sig["y"][k], sig["z"][k] = (float(v) for v in p)
        sig["fx"][k], sig["fy"][k], sig["fz"][k] = f
        sig["ex"][k], sig["ey"][k], sig["ez"][k] = e.position
        sig["healthy"][k] = 1.0 if e.healthy else 0.0
        sig["distance"][k] = math.dist((float(p[0]), float(p[1]), float(p[2])), f)
        sig["severity"][k] = int(SEVERITY_OF_MODE.get(cmd.mode, Severity.NORMAL))
        sig["level"][k] = int(cmd.level)
        sig["ttl"][k] = cmd.time_to_limit if math.isfinite(cmd.time_to_limit) else np.nan
        sig["connected"][k] = 1.0 if cmd.connected else 0.0
        if self.log is not None and now >= self.next_sample:
            self.log.append(now, cmd.mode.value, "sample", "state sample",
                            **state_sample(cmd, q, e, sig["distance"][k], ers_valves_closed, alarms or {}))
            self.next_sample += self.sample_every
