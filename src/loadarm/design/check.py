"""Design check before operation: can this installation's alarms absorb its own design drift?

From the nominal flange (the installation's ``[approach] flange``, on the arm's centre line) the check walks
straight out in each direction a ship can drift (off the berth, towards the jetty, along it both ways, up,
down) and finds, per direction:

* ``available``: the distance to the first face of the attached envelope (:mod:`loadarm.arm.faces`);
* ``alarm_at``: where the first alarm (ESD-1) fires at the latest: at the customer's position alarm (beta or
  slew first-alarm angle) or at the design-drift floor, ``needed`` before the face, whichever comes first;
  ``needed = D(esd_lead)`` is the distance the ship covers breaking out from rest at the design acceleration
  up to the design speed during the first alarm's lead ``max(esd_time, ers_valve_time + ers_valve_timeout) +
  erc_release_time + margin`` (vertically: the design vertical speed times the lead);
* ``max_speed``: the largest drift speed, already reached when the ship passes ``alarm_at``, whose release
  still completes with the margin before the face: ``(available - alarm_at) / (ers_valve_time +
  ers_valve_timeout + erc_release_time + margin)``.

The ERS valves count at their worst: the coupler waits for their limit switches, which may confirm as late as
the fault timeout allows (``ers_valve_time + ers_valve_timeout``, :func:`valve_worst_time`); a guarantee that
took the nominal closing time was lost to a slow valve inside its timeout (issue 25: 0.27 m/s, a valve 4 s
slow, the arm overstretched 0.34 s before the coupler was free);
* ``max_accel``: the largest break-out acceleration (from rest at ``alarm_at``, up to the design speed) for
  which the same holds.

These are guarantees of the floor alone: a faster drift that the monitor measures raises the alarm earlier
still. The installation is refused when the nominal flange is already in alarm in some direction (its alarm
settings cannot absorb its own design drift there), when the design drift speed exceeds ``max_speed`` in
some direction, or when the ERS accumulator cannot close the ERS valves and release the coupler after an HPU
trip (:func:`accumulator_usable_volume`); :func:`loadarm.params.compiler.compile_model` already refuses a release
angle past a stroke end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.actuators import cylinder_lengths
from loadarm.arm.alarms import beta_severity, slew_severity
from loadarm.arm.envelope import berth_box
from loadarm.arm.faces import (
    FACE_LABELS,
    FACES,
    breakout_distance,
    face_margins,
    first_face,
    past_a_face_at,
    ray_crossing,
)
from loadarm.arm.faces import RAY_REACH as _REACH
from loadarm.arm.sequence import esd_lead, release_lead, valve_worst_time
from loadarm.arm.slew import inverse3d
from loadarm.design.plots import check_figure
from loadarm.design.surge import surge_check
from loadarm.results import Metric, Result
from loadarm.vocab import UNREACHABLE, Severity

__all__ = ["DIRECTIONS", "DirectionCheck", "CheckResult", "check_verdict", "CHECK_METRICS", "design_check", "esd_lead",
           "release_lead", "valve_worst_time", "accumulator_usable_volume", "retraction_oil", "MANIFOLD_CLEARANCE"]

#: Directions a ship can drift, as (name, unit vector, horizontal).
DIRECTIONS = (
    ("off the berth (+x)", (1.0, 0.0, 0.0), True),
    ("towards the jetty (-x)", (-1.0, 0.0, 0.0), True),
    ("along the berth (+y)", (0.0, 1.0, 0.0), True),
    ("along the berth (-y)", (0.0, -1.0, 0.0), True),
    ("up (+z)", (0.0, 0.0, 1.0), False),
    ("down (-z)", (0.0, 0.0, -1.0), False),
)

#: Distance the coupler must put between itself and the ship's flange after a release, m (clear of the
#: manifold's spool piece and the ship's rail); with the HPU tripped the accumulator drives that retraction.
MANIFOLD_CLEARANCE = 1.0


def accumulator_usable_volume(volume: float, precharge: float, charged: float, minimum: float,
                              n: float = 1.4) -> float:
    """Oil an accumulator delivers from its charged pressure down to the minimum working pressure, m^3.

    The gas is charged slowly (isothermal: ``V1 = V0 p0 / p1``) and discharged fast (polytropic:
    ``V2 = V1 (p1 / p2)^(1/n)``); the oil delivered is ``V2 - V1``.

    Parameters
    ----------
    volume : float
        Gas volume at precharge, m^3.
    precharge, charged, minimum : float
        Precharge, charged and minimum working pressures, Pa (``precharge < minimum < charged``).
    n : float
        Polytropic index of the discharge.

    Returns
    -------
    float
    """
    v1 = volume * precharge / charged
    return v1 * (charged / minimum) ** (1.0 / n) - v1


def cylinder_oil(model, q0, q1) -> float:
    """Oil the two cylinders draw from the supply to move the arm from joints ``q0`` to ``q1``, m^3: the filling
    chamber's swept volume (the piston side extending, the annulus retracting).

    Parameters
    ----------
    model : ArmModel
        Mounting and ``cylinder_area`` (piston, annulus).
    q0, q1 : sequence of float
        Joint angles (slew, alpha, beta), rad.

    Returns
    -------
    float
    """

    r0 = np.array(cylinder_lengths(model.mount, q0[1], q0[2]), dtype=float)
    r1 = np.array(cylinder_lengths(model.mount, q1[1], q1[2]), dtype=float)
    piston, annulus = model.cylinder_area
    dr = r1 - r0
    return float(np.sum(np.where(dr > 0, piston * dr, -annulus * dr)))


def retraction_oil(model, clearance: float = MANIFOLD_CLEARANCE) -> float:
    """Oil the drives need to retract the coupler ``clearance`` metres from the flange along its return path
    (straight towards the stored position), from the worst flange the arm may be released at, m^3.

    The flanges tried are the nominal one and the datasheet box's corners inside the arm's joint limits; the
    retraction runs on the ERS accumulator when the HPU has tripped (the ship may not carry itself away: a drift
    along the berth leaves the manifold under the coupler).

    Parameters
    ----------
    model : ArmModel
    clearance : float
        Retraction, m.

    Returns
    -------
    float
    """

    box = berth_box(model.datasheet)
    fx, fz = model.approach.flange
    sx, sz = model.approach.stored
    stored = np.array([sx, 0.0, sz])
    worst = 0.0
    for x, z in ((fx, fz), (box.x_near, box.y_low), (box.x_near, box.y_high), (box.x_far, box.y_low),
                 (box.x_far, box.y_high)):
        p0 = np.array([x, 0.0, z])
        d = stored - p0
        p1 = p0 + clearance * d / max(float(np.linalg.norm(d)), 1e-9)
        q0, q1 = (inverse3d(model.arm, *p, check=False) for p in (p0, p1))
        qs = [(float(q.phi), float(q.alpha), float(q.beta)) for q in (q0, q1)]
        if all(np.all(np.isfinite(q)) and model.joint_limits.contains(q) for q in qs):
            worst = max(worst, cylinder_oil(model, *qs))
    return worst


@dataclass(frozen=True, slots=True)
class DirectionCheck:
    """The check along one drift direction (distances from the nominal flange, m).

    Attributes
    ----------
    direction : str
        Its name.
    face : str
        First face reached (:data:`loadarm.vocab.FACES`), ``""`` if none within 40 m.
    available : float
        Distance to that face, m.
    angle_alarm : float or None
        Where the customer's position alarm (ESD-1) fires, m (None if not before the face).
    needed : float
        Design-drift distance during the first alarm's lead, m.
    alarm_at : float
        Where ESD-1 fires at the latest, m.
    max_speed : float
        Largest drift speed absorbed, m/s.
    max_accel : float
        Largest break-out acceleration absorbed at the design speed, m/s^2 (``inf``: any).
    design_speed : float
        The design drift speed in this direction, m/s.
    """

    direction: str
    face: str
    available: float
    angle_alarm: float | None
    needed: float
    alarm_at: float
    max_speed: float
    max_accel: float
    design_speed: float

    @property
    def ok(self) -> bool:
        """Whether the design drift is absorbed in this direction."""
        return self.alarm_at > 0 and self.max_speed >= self.design_speed

    @property
    def angle_late(self) -> bool:
        """Whether the customer's first-alarm angle fires past where the design drift needs ESD-1 at the latest
        (only the design-drift floor of the monitor then fires in time)."""
        return self.angle_alarm is not None and self.angle_alarm > self.alarm_at


def check_verdict(rows, refused: bool) -> str:
    """The design check's verdict as the figure and the report show it: ``REFUSED``, ``pass``, or ``holds by
    the floor alone`` when some customer's first-alarm angle fires past the latest point (found: the figure drew
    the 123 deg marker 2.8 m out, past the 1.03 m bar, under "pass"). Never ``pass`` with a late angle.

    Parameters
    ----------
    rows : sequence of DirectionCheck
    refused : bool
        The check found problems.

    Returns
    -------
    str
        ``refused``, ``holds by the floor alone`` or ``pass``.
    """
    if refused:
        return "refused"
    return "holds by the floor alone" if any(r.angle_late for r in rows) else "pass"


#: The headline numbers of a design check, declared once.
CHECK_METRICS = (
    Metric("verdict", "verdict"),
    Metric("esd_lead_s", "first alarm's lead", "s", ".1f"),
    Metric("release_lead_s", "ESD-1 to coupler free, with margin", "s", ".1f"),
    Metric("design_speed", "design drift speed", "m/s", ".3f"),
    Metric("design_accel", "design break-out acceleration", "m/s^2", ".3f"),
    Metric("min_max_speed", "largest drift absorbed in every direction", "m/s", ".3f"),
    Metric("accumulator_usable_l", "ERS accumulator, usable oil", "L", ".2f", scale=1e3),
    Metric("accumulator_needed_l", "ERS accumulator, needed (with safety factor)", "L", ".2f", scale=1e3),
    Metric("retraction_oil_l", "of which the retraction clear of the manifold", "L", ".2f", scale=1e3),
    Metric("surge_peak_bar", "ERS valve closure at design flow, peak pressure", "bar g", ".2f", scale=1e-5),
    Metric("surge_route", "surge decided by"),
    Metric("design_pressure_bar", "the arm's design pressure", "bar g", ".1f", scale=1e-5),
)


@dataclass(frozen=True)
class CheckResult(Result):
    """The design check of one installation.

    Attributes
    ----------
    flange : tuple of float
        The nominal flange, m.
    rows : tuple of DirectionCheck
        One per direction of :data:`DIRECTIONS`.
    esd_lead, release_lead : float
        The sequence's leads, s.
    design_speed, design_accel, design_vertical_speed : float
        The berth's design drift.
    problems : tuple of str
        Why the installation is refused (empty when it passes).
    accumulator_usable, accumulator_needed : float
        Oil the ERS accumulator delivers after an HPU trip, and what the ERS and the retraction clear of the
        manifold need with its safety factor, m^3.
    retraction_oil : float
        Of that (before the factor), the retraction's own, m^3 (:func:`retraction_oil`).
    surge : SurgeResult or None
        The surge of the ERS valves' closure at design flow (:func:`loadarm.design.surge.surge_check`).
    """

    flange: tuple
    rows: tuple
    esd_lead: float
    release_lead: float
    design_speed: float
    design_accel: float
    design_vertical_speed: float
    problems: tuple
    accumulator_usable: float = math.nan
    accumulator_needed: float = math.nan
    retraction_oil: float = math.nan
    surge: object = None

    METRICS = CHECK_METRICS

    @property
    def ok(self) -> bool:
        """Whether the installation passes."""
        return not self.problems

    @property
    def verdict(self) -> str:
        """:func:`check_verdict` of this check."""
        return check_verdict(self.rows, not self.ok)

    def _values(self) -> dict:
        return {
            "verdict": self.verdict,
            "flange": list(self.flange),
            "esd_lead_s": self.esd_lead,
            "release_lead_s": self.release_lead,
            "design_speed": self.design_speed,
            "design_accel": self.design_accel,
            "design_vertical_speed": self.design_vertical_speed,
            "min_max_speed": min(r.max_speed for r in self.rows),
            "accumulator_usable_l": self.accumulator_usable,
            "accumulator_needed_l": self.accumulator_needed,
            "retraction_oil_l": self.retraction_oil,
            "surge_peak_bar": None if self.surge is None else self.surge.judged_pressure,
            "surge_route": None if self.surge is None else self.surge.route,
            "design_pressure_bar": None if self.surge is None else self.surge.design_pressure,
            "surge": None if self.surge is None else self.surge.to_dict(),
            "directions": [{"direction": r.direction, "face": r.face, "available_m": r.available,
                            "angle_alarm_m": r.angle_alarm, "needed_m": r.needed, "alarm_at_m": r.alarm_at,
                            "max_speed": r.max_speed,
                            "max_accel": r.max_accel if math.isfinite(r.max_accel) else None,
                            "design_speed": r.design_speed, "ok": r.ok} for r in self.rows],
            "problems": list(self.problems),
        }

    def _figure(self):

        return check_figure(self)


def design_check(model) -> CheckResult:
    """Check the installation's alarm settings against its design drift, per direction.

    Parameters
    ----------
    model : ArmModel
        The compiled installation (``sequence``, ``design_drift``, alarms, limits, nominal flange).

    Returns
    -------
    CheckResult
    """
    seq, dd = model.sequence, model.design_drift
    fx, fz = model.approach.flange
    p0 = np.array([fx, 0.0, fz], dtype=float)
    L1, Lr = esd_lead(seq), release_lead(seq)

    def past_face(pts):
        return past_a_face_at(model, pts[:, 0], pts[:, 1], pts[:, 2])

    def in_first_alarm(pts):               # the customer's position alarms, as the envelope and monitor classify
        q = inverse3d(model.arm, pts[:, 0], pts[:, 1], pts[:, 2], check=False)
        sev = beta_severity(q.beta, model.alarms)
        return (sev == UNREACHABLE) | (np.maximum(sev, slew_severity(q.phi, model.slew)) >= Severity.ESD1)

    rows, problems = [], []
    for name, vec, horizontal in DIRECTIONS:
        d = np.array(vec)
        avail = ray_crossing(p0, d, past_face)
        face = ""
        if avail is None:
            avail = _REACH
        else:
            face = FACES[int(first_face(face_margins(model, *(p0 + (avail + 1e-6) * d)))[1])]
        angle = ray_crossing(p0, d, in_first_alarm)
        angle = angle if angle is not None and angle < avail else None
        if horizontal:
            needed = float(breakout_distance(L1, dd.speed, dd.acceleration))
            design = dd.speed
        else:
            needed = dd.vertical_speed * L1
            design = dd.vertical_speed
        alarm_at = min(avail - needed, angle if angle is not None else math.inf)
        d_alarm = avail - max(alarm_at, 0.0)
        max_speed = d_alarm / Lr
        t_seq = Lr
        if not horizontal or design == 0:
            max_accel = math.inf
        elif design * t_seq <= d_alarm:
            max_accel = math.inf
        else:
            max_accel = design * design / (2.0 * (design * t_seq - d_alarm))
        row = DirectionCheck(name, face, avail, angle, needed, alarm_at, max_speed, max_accel, design)
        rows.append(row)
        if alarm_at <= 0:
            problems.append(f"{name}: the nominal flange is already in alarm: the face "
                            f"({FACE_LABELS.get(face, face)}) is {avail:.2f} m away, the design drift needs "
                            f"{needed:.2f} m" + (f", the first-alarm angle fires at {angle:.2f} m"
                                                 if angle is not None and angle <= 0 else ""))
        elif max_speed < design:
            problems.append(f"{name}: the alarms absorb {max_speed:.3f} m/s, below the design drift "
                            f"{design:.3f} m/s")
    acc = model.accumulator
    usable = accumulator_usable_volume(acc.volume, acc.precharge, acc.charged_pressure, acc.min_pressure,
                                       acc.polytropic_index)
    retract = retraction_oil(model)
    needed = (acc.required_volume + retract) * acc.safety_factor
    if usable < needed:
        problems.append(f"the ERS accumulator delivers {usable * 1e3:.2f} L from {acc.charged_pressure / 1e5:g} to "
                        f"{acc.min_pressure / 1e5:g} bar, the ERS and the retraction clear of the manifold need "
                        f"{needed * 1e3:.2f} L with its safety factor ({retract * 1e3:.2f} L the retraction): after an "
                        "HPU trip the arm could not release and retract")
    surge = None
    if model.transfer is not None:

        surge = surge_check(model.transfer, seq.ers_valve_time)
        if not surge.ok:
            problems.append(f"the ERS valves closing in {seq.ers_valve_time:g} s at the design flow "
                            f"({model.transfer.design_flow * 3600:.0f} m^3/h, the ship's ESD valves open, {surge.route}): "
                            + "; ".join(surge.problems))
    return CheckResult(tuple(float(v) for v in p0), tuple(rows), L1, Lr, dd.speed, dd.acceleration,
                       dd.vertical_speed, tuple(problems), usable, needed, retract, surge)
