"""One alarm severity for every stage, and the one place that maps angles, distances and drift to it.

The envelope (elbow-angle zones), the slew, the guidance controller, the event log and the report all speak
:class:`Severity`: normal, pre-alarm, first alarm (ESD-1: stop the transfer pumps, close the ERS valves),
second alarm, release (ERS-2: the coupler lets go). A coupler position outside the arm's reach is not a
severity: classifications mark it :data:`UNREACHABLE`.

* :func:`beta_severity` and :func:`slew_severity`: position (angles) against the configured thresholds;
* :class:`AlarmThresholds`: position and drift speed of the attached coupler (the guidance controller's
  connected-mode monitoring).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Severity", "UNREACHABLE", "severity_label", "AlarmAngles", "beta_severity", "slew_severity",
           "AlarmThresholds", "BETA_TOL_RAD"]

#: Angular tolerance (rad) when comparing beta with a threshold: 1e-9 rad is
#: 2e-8 m at the tip of a 20 m arm, so a point computed exactly on a boundary
#: (like the sized arm's first-alarm corner) stays in the lower stage.
BETA_TOL_RAD = 1e-9

#: Classification of a position the arm cannot reach (not a severity).
UNREACHABLE = -1


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


_LABELS = {UNREACHABLE: "unreachable", 0: "normal", 1: "pre-alarm", 2: "first alarm (ESD-1)", 3: "second alarm",
           4: "release (ERS-2)"}


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


@dataclass(frozen=True, slots=True)
class AlarmAngles:
    """Alarm thresholds on ``beta``, rad, strictly increasing in (0, pi)."""

    first: float
    second: float
    release: float

    def __post_init__(self) -> None:
        vals = (self.first, self.second, self.release)
        if not all(math.isfinite(v) for v in vals) or not (0 < self.first < self.second < self.release < math.pi):
            raise ValueError(
                "alarm angles must satisfy 0 < first < second < release < 180 deg, got "
                + ", ".join(f"{math.degrees(v):.3f}" for v in vals) + " deg")


def beta_severity(beta: np.ndarray | float, alarms: AlarmAngles) -> np.ndarray:
    """Severity of each elbow angle (the envelope's zones).

    Parameters
    ----------
    beta : float or ndarray
        Inboard-outboard angle, rad; NaN means unreachable.
    alarms : AlarmAngles
        Thresholds.

    Returns
    -------
    ndarray of int
        :class:`Severity` values (``NORMAL``, ``ESD1``, ``SECOND``, ``RELEASE``; the paper's zones have no
        pre-alarm), :data:`UNREACHABLE` where ``beta`` is NaN; shape of ``beta``.
    """
    beta = np.asarray(beta, dtype=float)
    sev = np.select([beta >= alarms.release - BETA_TOL_RAD, beta > alarms.second + BETA_TOL_RAD,
                     beta > alarms.first + BETA_TOL_RAD],
                    [int(Severity.RELEASE), int(Severity.SECOND), int(Severity.ESD1)], int(Severity.NORMAL))
    return np.where(np.isnan(beta), UNREACHABLE, sev).astype(int)


def slew_severity(phi, slew) -> np.ndarray:
    """Severity of slew angles against the slew thresholds (either side of the centre line).

    Parameters
    ----------
    phi : float or ndarray
        Slew angle, rad.
    slew : SlewLimits
        Thresholds ``first``, ``second``, ``release``, rad (:class:`loadarm.model.SlewLimits`).

    Returns
    -------
    ndarray of int
        :class:`Severity` values.
    """
    a = np.abs(np.asarray(phi, dtype=float))
    return np.select([a >= slew.release, a > slew.second, a > slew.first],
                     [int(Severity.RELEASE), int(Severity.SECOND), int(Severity.ESD1)], int(Severity.NORMAL))



@dataclass(frozen=True, slots=True)
class AlarmThresholds:
    """Alarm and release conditions, on position and on drift speed.

    Position: the elbow angle ``beta`` against the configured first/second/
    release angles, the slew angle against its own three.

    Speed: with ``r`` the coupler's distance from the riser top and ``v_r``
    its filtered outward speed (the drift; waves average out), the time left
    before the release radius is ``T_rel = (r_release - r) / v_r``. The ESD-1
    sequence must finish and the release must still complete before the arm
    gets there, so

    * ALARM1 when ``T_rel <= t_esd + t_ers + margin``,
    * ALARM2 when ``T_rel <= t_ers + margin``,
    * RELEASE when ``(r_max - r) / v_r <= t_ers + margin`` (the release must be
      complete before the arm is fully stretched or cylinder 2 bottoms out:
      ``r_max`` is the radius at the smaller of 180 deg and the stroke's end),

    and the same on the slew angle with its rate. A faster drift therefore
    raises the alarms earlier, at smaller angles.
    """

    beta_first: float
    beta_second: float
    beta_release: float
    r_release: float
    r_max: float
    slew_first: float
    slew_second: float
    slew_release: float
    slew_limit: float
    t_alarm1: float
    t_alarm2: float
    t_release: float

    @staticmethod
    def from_settings(model, g) -> "AlarmThresholds":
        """Thresholds from the model's alarm angles and joint limits and the guidance sequence times.

        Parameters
        ----------
        model : ArmModel
            Alarm angles, slew limits, joint limits and arm.
        g : Guidance
            Sequence times and margin (``esd_time``, ``ers_time``, ``margin``).

        Returns
        -------
        AlarmThresholds
        """
        arm = model.arm
        al = model.alarms
        # the hard limit is the fully stretched arm or the end of cylinder 2's stroke, whichever comes first
        beta_stop = model.joint_limits.beta[1]
        return AlarmThresholds(
            beta_first=al.first, beta_second=al.second, beta_release=al.release,
            r_release=float(arm.radius_at_beta(al.release)), r_max=float(arm.radius_at_beta(min(beta_stop, math.pi))),
            slew_first=model.slew.first, slew_second=model.slew.second,
            slew_release=model.slew.release, slew_limit=model.slew.limit,
            t_alarm1=g.esd_time + g.ers_time + g.margin, t_alarm2=g.ers_time + g.margin,
            t_release=g.ers_time + g.margin)

    def level(self, beta: float, phi: float, r: float, v_r: float, v_phi: float) -> tuple[Severity, str]:
        """Severity of the attached coupler and its cause (position or drift).

        Parameters
        ----------
        beta, phi : float
            Elbow and slew angles, rad.
        r : float
            Distance of the coupler from the riser top, m.
        v_r : float
            Filtered outward speed, m/s.
        v_phi : float
            Filtered slew rate, rad/s.

        Returns
        -------
        level : Severity
            ``NORMAL``, ``ESD1``, ``SECOND`` or ``RELEASE``.
        reason : str
        """
        a_phi = abs(phi)
        w_phi = v_phi if phi >= 0 else -v_phi   # rate away from the centre line
        ttl_r = (self.r_release - r) / v_r if v_r > 1e-6 else math.inf
        ttl_max = (self.r_max - r) / v_r if v_r > 1e-6 else math.inf
        ttl_phi = (self.slew_release - a_phi) / w_phi if w_phi > 1e-6 else math.inf
        ttl_phimax = (self.slew_limit - a_phi) / w_phi if w_phi > 1e-6 else math.inf
        if beta >= self.beta_release:
            return Severity.RELEASE, f"beta {math.degrees(beta):.1f} deg reached the release angle"
        if a_phi >= self.slew_release:
            return Severity.RELEASE, f"slew {math.degrees(phi):.1f} deg reached the release angle"
        if min(ttl_max, ttl_phimax) <= self.t_release:
            return Severity.RELEASE, f"drift would reach the arm's limit in {min(ttl_max, ttl_phimax):.1f} s"
        if beta > self.beta_second or a_phi > self.slew_second:
            return Severity.SECOND, f"beta {math.degrees(beta):.1f} deg / slew {math.degrees(phi):.1f} deg beyond the second alarm"
        if min(ttl_r, ttl_phi) <= self.t_alarm2:
            return Severity.SECOND, f"drift would reach the release angle in {min(ttl_r, ttl_phi):.1f} s"
        if beta > self.beta_first or a_phi > self.slew_first:
            return Severity.ESD1, f"beta {math.degrees(beta):.1f} deg / slew {math.degrees(phi):.1f} deg beyond the first alarm"
        if min(ttl_r, ttl_phi) <= self.t_alarm1:
            return Severity.ESD1, f"drift would reach the release angle in {min(ttl_r, ttl_phi):.1f} s"
        return Severity.NORMAL, ""
