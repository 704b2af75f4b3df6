"""One alarm severity for every stage, and the one place that maps angles, distances and drift to it.

The envelope (elbow-angle zones), the slew, the guidance controller, the event log and the report all speak
:class:`Severity`: normal, pre-alarm, first alarm (ESD-1: stop the transfer pumps, close the ERS valves),
second alarm, release (ERS-2: the coupler lets go). A coupler position outside the arm's reach is not a
severity: classifications mark it :data:`UNREACHABLE`.

* :func:`beta_severity` and :func:`slew_severity`: position (angles) against the configured thresholds;
* :class:`AlarmThresholds`: the customer's position alarms of the attached coupler (the static half of the
  guidance controller's connected-mode monitoring);
* :class:`AlarmState` and :func:`next_alarm_state`: ISA-18.2 states (unacknowledged, acknowledged,
  returned to normal) of each annunciated alarm.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from loadarm.vocab import UNREACHABLE, Severity

__all__ = ["AlarmAngles", "beta_severity", "slew_severity", "zone_level",
           "AlarmThresholds", "AlarmState", "next_alarm_state", "BETA_TOL_RAD"]

#: Angular tolerance (rad) when comparing beta with a threshold: 1e-9 rad is 2e-8 m at the tip of a 20 m arm,
#: so a point computed on a boundary (like the sized arm's first-alarm corner, 123.00000000000003 deg or
#: 122.99999999999997 deg by rounding) is at it: its alarm sounds (:func:`zone_level`).
BETA_TOL_RAD = 1e-9


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


def zone_level(value, first: float, second: float, release: float, tol: float):
    """The boundary rule of every position alarm, written once: **at its threshold an alarm sounds**
    (``value >= threshold - tol``; the thresholds inclusive, the stage below ends just short of it). A NaN
    value (no pose: unreachable) is :data:`UNREACHABLE`.

    Written with comparisons and arithmetic only, so that one body serves a float, a NumPy array
    (:func:`beta_severity`, :func:`slew_severity`), the controller's position alarms
    (:meth:`AlarmThresholds.level`) and the operability kernel, which compiles it with numba.

    Parameters
    ----------
    value : float or ndarray
        The elbow angle, or the absolute slew, rad.
    first, second, release : float
        Thresholds, rad, increasing.
    tol : float
        :data:`BETA_TOL_RAD` for beta, 0 for the slew.

    Returns
    -------
    int or ndarray of int
        A :class:`Severity` value (``NORMAL``, ``ESD1``, ``SECOND``, ``RELEASE``: the position alarms have no
        pre-alarm), or :data:`UNREACHABLE` for NaN.
    """
    reached = (value >= first - tol) * 1 + (value >= second - tol) * 1 + (value >= release - tol) * 1
    level = reached + (LEVEL_ESD1 - 1) * (reached > 0)          # 0 -> NORMAL, 1 -> ESD1, 2 -> SECOND, 3 -> RELEASE
    nan = (value != value) * 1
    return level * (1 - nan) + UNREACHABLE * nan


def beta_severity(beta: np.ndarray | float, alarms: AlarmAngles) -> np.ndarray:
    """Severity of each elbow angle (the envelope's zones), by :func:`zone_level`.

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
    return np.asarray(zone_level(beta, alarms.first, alarms.second, alarms.release, BETA_TOL_RAD), dtype=int)


#: :class:`Severity` values as plain ints, for compiled code.
LEVEL_NORMAL, LEVEL_ESD1, LEVEL_SECOND, LEVEL_RELEASE = (int(Severity.NORMAL), int(Severity.ESD1),
                                                         int(Severity.SECOND), int(Severity.RELEASE))


def slew_severity(phi, slew) -> np.ndarray:
    """Severity of slew angles against the slew thresholds (either side of the centre line), by :func:`zone_level`.

    Parameters
    ----------
    phi : float or ndarray
        Slew angle, rad.
    slew : SlewLimits
        Thresholds ``first``, ``second``, ``release``, rad (:class:`loadarm.arm.model.SlewLimits`).

    Returns
    -------
    ndarray of int
        :class:`Severity` values.
    """
    a = np.abs(np.asarray(phi, dtype=float))
    return np.asarray(zone_level(a, slew.first, slew.second, slew.release, 0.0), dtype=int)


@dataclass(frozen=True, slots=True)
class AlarmThresholds:
    """The customer's position alarms of the attached coupler: the elbow angle ``beta`` against the first,
    second and release angles, the slew angle against its own three, either side.

    These are the static half of the connected-mode alarms; the dynamic half (time to the nearest face of the
    envelope from the measured and the design drift, against the sequence still to run) is
    :class:`loadarm.guidance.monitor.EnvelopeMonitor`. The controller raises whichever is more severe.
    """

    beta_first: float
    beta_second: float
    beta_release: float
    slew_first: float
    slew_second: float
    slew_release: float

    @staticmethod
    def from_model(model) -> "AlarmThresholds":
        """Thresholds from the model's alarm angles and slew alarms.

        Parameters
        ----------
        model : ArmModel
            Alarm angles and slew limits.

        Returns
        -------
        AlarmThresholds
        """
        al = model.alarms
        return AlarmThresholds(al.first, al.second, al.release, model.slew.first, model.slew.second,
                               model.slew.release)

    def level(self, beta: float, phi: float) -> tuple[Severity, str]:
        """Severity of the attached coupler's position and its cause.

        Parameters
        ----------
        beta, phi : float
            Elbow and slew angles, rad.

        Returns
        -------
        level : Severity
            ``NORMAL``, ``ESD1``, ``SECOND`` or ``RELEASE``.
        reason : str
        """
        level = Severity(max(self._beta_level(beta), zone_level(abs(phi), self.slew_first, self.slew_second,
                                                                self.slew_release, 0.0), LEVEL_NORMAL))
        why = {Severity.ESD1: "at or beyond the first alarm", Severity.SECOND: "at or beyond the second alarm",
               Severity.RELEASE: "at the release angle"}.get(level)
        return (level, f"{_where(beta, phi)}: {why}") if why else (Severity.NORMAL, "")

    def face(self, beta: float, phi: float, level: Severity) -> str:
        """The face a position alarm of ``level`` guards: ``beta_max`` when the elbow angle is at or past that
        level's threshold, else the slew's side (:data:`loadarm.vocab.FACES`); ``""`` for no alarm.

        Parameters
        ----------
        beta, phi : float
            Elbow and slew angles, rad.
        level : Severity
            The level :meth:`level` gave.

        Returns
        -------
        str
        """
        if level < Severity.ESD1:
            return ""
        if self._beta_level(beta) >= level:
            return "beta_max"
        return "slew_pos" if phi > 0 else "slew_neg"

    def _beta_level(self, beta: float) -> int:
        return int(zone_level(beta, self.beta_first, self.beta_second, self.beta_release, BETA_TOL_RAD))


def _where(beta: float, phi: float) -> str:
    return f"beta {math.degrees(beta):.1f} deg, slew {math.degrees(phi):.1f} deg"


class AlarmState(str, enum.Enum):
    """ISA-18.2 alarm states of one annunciated alarm."""

    NORMAL = "normal"
    UNACKED = "unacknowledged"
    ACKED = "acknowledged"
    RTN_UNACKED = "returned to normal, unacknowledged"


def next_alarm_state(state: AlarmState, active: bool, acknowledge: bool) -> AlarmState:
    """ISA-18.2 state transition of one alarm (no shelving, suppression or latching).

    Parameters
    ----------
    state : AlarmState
        State before.
    active : bool
        Whether the alarm condition is present now.
    acknowledge : bool
        Whether the operator acknowledged this cycle.

    Returns
    -------
    AlarmState
        ``NORMAL -> UNACKED`` when the condition appears; ``UNACKED -> ACKED`` on acknowledgement;
        ``UNACKED -> RTN_UNACKED`` when it clears first; ``ACKED -> NORMAL`` when it clears;
        ``RTN_UNACKED -> NORMAL`` on acknowledgement (``-> UNACKED`` if it comes back).
    """
    if state == AlarmState.NORMAL:
        return AlarmState.UNACKED if active else state
    if state == AlarmState.UNACKED:
        if acknowledge:
            return AlarmState.ACKED if active else AlarmState.NORMAL
        return state if active else AlarmState.RTN_UNACKED
    if state == AlarmState.ACKED:
        return state if active else AlarmState.NORMAL
    # returned to normal, unacknowledged
    if active:
        return AlarmState.UNACKED
    return AlarmState.NORMAL if acknowledge else state
