"""Design check before operation: can this installation's alarms absorb its own design drift?

From the nominal flange (the installation's ``[approach] flange``, on the arm's centre line) the check walks
straight out in each direction a ship can drift (off the berth, towards the jetty, along it both ways, up,
down) and finds, per direction:

* ``available``: the distance to the first face of the attached envelope (:mod:`loadarm.faces`);
* ``alarm_at``: where the first alarm (ESD-1) fires at the latest: at the customer's position alarm (beta or
  slew first-alarm angle) or at the design-drift floor, ``needed`` before the face, whichever comes first;
  ``needed = D(esd_lead)`` is the distance the ship covers breaking out from rest at the design acceleration
  up to the design speed during the first alarm's lead ``max(esd_time, ers_valve_time) + erc_release_time +
  margin`` (vertically: the design vertical speed times the lead);
* ``max_speed``: the largest drift speed, already reached when the ship passes ``alarm_at``, whose release
  still completes with the margin before the face: ``(available - alarm_at) / (ers_valve_time +
  erc_release_time + margin)``;
* ``max_accel``: the largest break-out acceleration (from rest at ``alarm_at``, up to the design speed) for
  which the same holds.

These are guarantees of the floor alone: a faster drift that the monitor measures raises the alarm earlier
still. The installation is refused when the nominal flange is already in alarm in some direction (its alarm
settings cannot absorb its own design drift there), when the design drift speed exceeds ``max_speed`` in
some direction, or when the ERS accumulator cannot close the ERS valves and release the coupler after an HPU
trip (:func:`accumulator_usable_volume`); :func:`loadarm.compiler.compile_model` already refuses a release
angle past a stroke end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .alarms import UNREACHABLE, Severity, beta_severity, slew_severity
from .faces import FACE_LABELS, FACES, breakout_distance, face_margins, first_face, past_a_face_at
from .results import Metric, Result
from .slew import inverse3d

__all__ = ["DIRECTIONS", "DirectionCheck", "CheckResult", "CHECK_METRICS", "design_check", "esd_lead",
           "release_lead", "accumulator_usable_volume"]

#: Directions a ship can drift, as (name, unit vector, horizontal).
DIRECTIONS = (
    ("off the berth (+x)", (1.0, 0.0, 0.0), True),
    ("towards the jetty (-x)", (-1.0, 0.0, 0.0), True),
    ("along the berth (+y)", (0.0, 1.0, 0.0), True),
    ("along the berth (-y)", (0.0, -1.0, 0.0), True),
    ("up (+z)", (0.0, 0.0, 1.0), False),
    ("down (-z)", (0.0, 0.0, -1.0), False),
)

_REACH = 40.0          # m: the farthest a ray is walked (beyond any arm's reach)
_STEP = 0.01           # m: ray sampling before the bisection


def esd_lead(seq) -> float:
    """Time the first alarm (ESD-1) must leave before any face, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``max(esd_time, ers_valve_time) + erc_release_time + margin``.
    """
    return max(seq.esd_time, seq.ers_valve_time) + seq.erc_release_time + seq.margin


def release_lead(seq) -> float:
    """Time from ESD-1 to the coupler free, with the margin, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]``.

    Returns
    -------
    float
        ``ers_valve_time + erc_release_time + margin``.
    """
    return seq.ers_valve_time + seq.erc_release_time + seq.margin


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


@dataclass(frozen=True, slots=True)
class DirectionCheck:
    """The check along one drift direction (distances from the nominal flange, m).

    Attributes
    ----------
    direction : str
        Its name.
    face : str
        First face reached (:data:`loadarm.faces.FACES`), ``""`` if none within 40 m.
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
        Oil the ERS accumulator delivers after an HPU trip, and what the ERS needs with its safety factor,
        m^3.
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

    METRICS = CHECK_METRICS

    @property
    def ok(self) -> bool:
        """Whether the installation passes."""
        return not self.problems

    def _values(self) -> dict:
        return {
            "verdict": "pass" if self.ok else "refused",
            "flange": list(self.flange),
            "esd_lead_s": self.esd_lead,
            "release_lead_s": self.release_lead,
            "design_speed": self.design_speed,
            "design_accel": self.design_accel,
            "design_vertical_speed": self.design_vertical_speed,
            "min_max_speed": min(r.max_speed for r in self.rows),
            "accumulator_usable_l": self.accumulator_usable,
            "accumulator_needed_l": self.accumulator_needed,
            "directions": [{"direction": r.direction, "face": r.face, "available_m": r.available,
                            "angle_alarm_m": r.angle_alarm, "needed_m": r.needed, "alarm_at_m": r.alarm_at,
                            "max_speed": r.max_speed,
                            "max_accel": r.max_accel if math.isfinite(r.max_accel) else None,
                            "design_speed": r.design_speed, "ok": r.ok} for r in self.rows],
            "problems": list(self.problems),
        }

    def _figure(self):
        from .plotting import check_figure

        return check_figure(self)


def _first_crossing(model, p0: np.ndarray, d: np.ndarray, outside) -> float | None:
    """Smallest s in [0, 40] m with ``outside(p0 + s d)``, to 1e-6 m (None if none)."""
    s = np.arange(0.0, _REACH + _STEP, _STEP)
    pts = p0 + s[:, None] * d
    hit = np.flatnonzero(outside(pts))
    if hit.size == 0:
        return None
    i = int(hit[0])
    if i == 0:
        return 0.0
    lo, hi = float(s[i - 1]), float(s[i])
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        if bool(outside((p0 + mid * d)[None])[0]):
            hi = mid
        else:
            lo = mid
    return hi


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
        avail = _first_crossing(model, p0, d, past_face)
        face = ""
        if avail is None:
            avail = _REACH
        else:
            face = FACES[int(first_face(face_margins(model, *(p0 + (avail + 1e-6) * d)))[1])]
        angle = _first_crossing(model, p0, d, in_first_alarm)
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
    needed = acc.required_volume * acc.safety_factor
    if usable < needed:
        problems.append(f"the ERS accumulator delivers {usable * 1e3:.2f} L from {acc.charged_pressure / 1e5:g} to "
                        f"{acc.min_pressure / 1e5:g} bar, the ERS needs {needed * 1e3:.2f} L with its safety factor: "
                        "after an HPU trip the release could not complete")
    return CheckResult(tuple(float(v) for v in p0), tuple(rows), L1, Lr, dd.speed, dd.acceleration,
                       dd.vertical_speed, tuple(problems), usable, needed)
