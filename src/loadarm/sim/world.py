"""The simulated world around the controller: the scripted operator, the arm (kinematic, or the hydraulic servo;
carried by the flange while attached, its overstretch measured), the ERS valves with their limit switches and
injected faults, and the joints' two angle channels.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.actuators import cylinder_lengths, joint_angles_from_cylinders, length_limits
from loadarm.arm.slew import inverse3d, reach_mask3d
from loadarm.design.check import accumulator_usable_volume, cylinder_oil
from loadarm.guidance.modes import Mode, OperatorInput
from loadarm.guidance.voting import AXES
from loadarm.hydraulics.servo import HydraulicArm
from loadarm.hydraulics.simulate import SimulationError
from loadarm.vocab import event_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["ScriptedOperator", "ArmPlant", "ErsValves", "AngleSensors"]


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

    def warm_up(self) -> None:
        """Compile the hydraulic servos (if any) before a real-time run (:meth:`HydraulicArm.warm_up`)."""
        for servo in (self.servo, self.servo_full):
            if servo is not None:
                servo.warm_up()

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
