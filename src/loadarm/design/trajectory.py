"""Joint trajectory of the straight-line approach: path + timing + kinematics + actuators.

:func:`plan_approach` is the one call that turns an installation into
everything the valves need: for each sample time the coupler position and
velocity, the joint angles and rates (Eqs 5-11), the cylinder lengths and
speeds (Eqs 12-13), the valve voltages (Section 5) and the alarm zone.
Everything is checked *before* a sample is produced: the whole segment must
lie in the reachable annulus (exact test, not sampled) and the valve
voltages must fit the valve range on a dense check grid as well as at the
requested samples.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.actuators import cylinder_lengths, cylinder_rates, valve_voltages
from loadarm.arm.alarms import beta_severity, slew_severity
from loadarm.arm.kinematics import check_reachable, inverse, joint_accelerations, joint_rates
from loadarm.arm.slew import inverse3d
from loadarm.design.path import StraightPath
from loadarm.design.plots import cylinders_figure, plan3d_figure
from loadarm.design.timing import ToppraTiming, make_timing
from loadarm.errors import PathError
from loadarm.files import atomic_open
from loadarm.results import Metric, Result
from loadarm.vocab import Severity, severity_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["PLAN_METRICS", "PLAN3D_METRICS", "Plan", "plan_approach", "optimal_timing", "Plan3D", "plan_approach_3d",
           "plan_warnings", "CHECK_SAMPLES", "MAX_SAMPLES"]

#: Samples of the dense grid on which voltage limits are re-checked.
CHECK_SAMPLES = 4001
#: Largest sample count accepted from a user.
MAX_SAMPLES = 1_000_000

_FIELDS = ("t_s", "x_m", "y_m", "alpha_deg", "beta_deg", "r_ac1_m", "r_ac2_m", "u1_V", "u2_V", "zone")


#: The headline numbers of a planned approach, declared once (CLI table, JSON, report).
PLAN_METRICS = (
    Metric("duration_s", "duration", "s", ".2f"),
    Metric("path_length_m", "path length", "m", ".3f"),
    Metric("peak_path_speed_m_s", "peak path speed", "m/s", ".4f"),
    Metric("alpha_range_deg", "alpha", "deg", ".2f", sep=" .. "),
    Metric("beta_range_deg", "beta", "deg", ".2f", sep=" .. "),
    Metric("stroke_ac1_m", "stroke r_ac1", "m", ".4f"),
    Metric("stroke_ac2_m", "stroke r_ac2", "m", ".4f"),
    Metric("u1_range_V", "u1", "V", "+.3f", sep=" .. "),
    Metric("u2_range_V", "u2", "V", "+.3f", sep=" .. "),
    Metric("worst_zone", "worst zone"),
)


@dataclass(frozen=True)
class Plan(Result):
    """A timed straight-line approach, sampled. Arrays have shape ``(n,)``.

    Attributes
    ----------
    timing : str
        Timing-law name.
    start, target : tuple of float
        Path end points, m.
    duration : float
        Traversal time, s.
    t : ndarray
        Sample times, s.
    x, y, vx, vy : ndarray
        Coupler position (m) and velocity (m/s).
    alpha, beta, alpha_dot, beta_dot, alpha_ddot, beta_ddot : ndarray
        Joint angles (rad), rates (rad/s) and accelerations (rad/s^2). The
        paper law's speed steps at the ends are impulses, not represented.
    r_ac1, r_ac2, v_ac1, v_ac2 : ndarray
        Cylinder lengths (m) and extension speeds (m/s).
    u1, u2 : ndarray
        Valve voltages, V.
    zone : ndarray of int
        Alarm severity per sample (:class:`loadarm.vocab.Severity`).
    stored_lengths : tuple of float
        Cylinder lengths in the stored pose, m (voltage reference).
    """

    timing: str
    start: tuple[float, float]
    target: tuple[float, float]
    duration: float
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    alpha_dot: np.ndarray
    beta_dot: np.ndarray
    alpha_ddot: np.ndarray
    beta_ddot: np.ndarray
    r_ac1: np.ndarray
    r_ac2: np.ndarray
    v_ac1: np.ndarray
    v_ac2: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    zone: np.ndarray
    stored_lengths: tuple[float, float]

    @property
    def path_length(self) -> float:
        """Straight-line length, m."""
        return math.hypot(self.target[0] - self.start[0], self.target[1] - self.start[1])

    METRICS = PLAN_METRICS

    def _values(self) -> dict:
        """Headline numbers, JSON-friendly (degrees at the edge)."""
        speed = np.hypot(self.vx, self.vy)
        return {
            "timing": self.timing,
            "start_m": list(self.start),
            "target_m": list(self.target),
            "path_length_m": self.path_length,
            "duration_s": self.duration,
            "peak_path_speed_m_s": float(speed.max()),
            "alpha_range_deg": [float(np.degrees(self.alpha.min())), float(np.degrees(self.alpha.max()))],
            "beta_range_deg": [float(np.degrees(self.beta.min())), float(np.degrees(self.beta.max()))],
            "stroke_ac1_m": float(self.r_ac1.max() - self.r_ac1.min()),
            "stroke_ac2_m": float(self.r_ac2.max() - self.r_ac2.min()),
            "peak_cylinder_speed_m_s": [float(np.abs(self.v_ac1).max()), float(np.abs(self.v_ac2).max())],
            "u1_range_V": [float(self.u1.min()), float(self.u1.max())],
            "u2_range_V": [float(self.u2.min()), float(self.u2.max())],
            "worst_zone": severity_label(int(self.zone.max())),
        }

    def _figure(self):

        return cylinders_figure({self.timing: self})

    def records(self) -> list[dict]:
        """One dict per sample with the keys ``t_s, x_m, y_m, alpha_deg, beta_deg,
        r_ac1_m, r_ac2_m, u1_V, u2_V, zone``."""
        cols = (self.t, self.x, self.y, np.degrees(self.alpha), np.degrees(self.beta), self.r_ac1, self.r_ac2,
                self.u1, self.u2)
        rows = np.column_stack(cols).tolist()
        zones = self.zone.tolist()
        return [dict(zip(_FIELDS, row + [z])) for row, z in zip(rows, zones)]

    def write_csv(self, path: str | Path) -> Path:
        """Write :meth:`records` as CSV (header = the record keys).

        Parameters
        ----------
        path : str or Path
            Output file; parent directories are created.

        Returns
        -------
        Path
            The file written.
        """
        return _write_csv(path, self.records())


def _write_csv(path: str | Path, records: list[dict]) -> Path:
    """Write records (dicts with the same keys) as CSV, atomically, creating parent directories."""

    p = Path(path)
    with atomic_open(p, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(records[0]))
        w.writeheader()
        w.writerows(records)
    return p


def _check_samples(samples) -> int:
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not (2 <= samples <= MAX_SAMPLES):
        raise PathError(f"samples must be an integer in [2, {MAX_SAMPLES}], got {samples!r}")
    return int(samples)


def _planar(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates in the arm's (slewed) plane of path points ``(n, 2)`` or ``(n, 3)``: radius and height."""
    if p.shape[-1] == 2:
        return p[..., 0], p[..., 1]
    return np.hypot(p[..., 0], p[..., 1]), p[..., 2]


def _stored_lengths(model: ArmModel, arm, mount) -> tuple[float, float]:
    """Cylinder lengths in the stored pose (the valve voltages' reference), m."""
    q = inverse(arm, *model.approach.stored)
    return tuple(float(v) for v in cylinder_lengths(mount, q.alpha, q.beta))


def _check_valve_range(model: ArmModel, arm, mount, path: StraightPath, law, stored_len) -> None:
    """Re-check the valve range on a dense time grid along the whole path, not only at the output samples."""
    t_chk = np.linspace(0.0, law.duration, CHECK_SAMPLES)
    q_chk = inverse(arm, *_planar(path(law(t_chk, 0))))
    valve_voltages(*cylinder_lengths(mount, q_chk.alpha, q_chk.beta), stored_len,
                   volts_per_metre=model.actuators.volts_per_metre, valve_range=model.actuators.valve_range_V,
                   times=t_chk)


def optimal_timing(model: ArmModel, path: StraightPath) -> ToppraTiming:
    """Time-optimal timing of a straight path under the coupler and cylinder limits (toppra).

    Parameters
    ----------
    model : ArmModel
        Limits: ``approach.max_speed``, ``approach.max_accel``,
        ``approach.max_cylinder_accel`` and the model's ``cylinder_speed_limit``.
    path : StraightPath
        The path (already checked reachable), in the arm plane or in 3D; in
        3D the slew angle is a further channel limited by ``slew.max_rate_deg``.

    Returns
    -------
    ToppraTiming
    """
    arm = model.arm
    mount = model.mount

    def lengths(s):
        q = inverse(arm, *_planar(path(s)))
        return cylinder_lengths(mount, q.alpha, q.beta)

    def slew(s):
        p = path(s)
        return np.arctan2(p[:, 1], p[:, 0])

    extra = ((slew, model.slew.max_rate, math.radians(5.0)),) if path.dim == 3 else ()
    a_cyl = model.approach.max_cylinder_accel
    return ToppraTiming.build(path.length, lengths, v_max=model.approach.max_speed, a_max=model.approach.max_accel,
                              v_cyl=model.cylinder_speed_limit, a_cyl=(a_cyl, a_cyl), extra=extra)


def plan_approach(model: ArmModel, *, start: tuple[float, float] | None = None,
                  target: tuple[float, float] | None = None, timing: str = "smooth",
                  samples: int = 201) -> Plan:
    """Plan the coupler's straight-line approach (paper Sections 3 and 5).

    Parameters
    ----------
    model : ArmModel
        Validated installation.
    start, target : tuple of float, optional
        Path end points ``(x, y)``, m; default the configured stored position
        and flange.
    timing : {'paper', 'smooth', 'optimal'}
        Timing law (see :mod:`loadarm.design.timing`).
    samples : int
        Number of samples, evenly spaced in time, end points included
        (2 to 1,000,000).

    Returns
    -------
    Plan
        The sampled, checked plan.

    Raises
    ------
    PathError
        Degenerate path or bad sample count.
    UnreachableError
        The stored position or any point of the segment is out of reach
        (checked exactly, before anything is sampled).
    TimingError
        Timing law not applicable.
    ValveRangeError
        A voltage beyond the valve range anywhere along the path.
    """
    samples = _check_samples(samples)
    arm = model.arm
    mount = model.mount
    alarms = model.alarms
    start = tuple(model.approach.stored) if start is None else start
    target = tuple(model.approach.flange) if target is None else target
    path = StraightPath(start, target)
    path.check_reachable(arm)
    stored = model.approach.stored
    check_reachable(arm, *stored)
    if timing == "optimal":
        law = optimal_timing(model, path)
    else:
        law = make_timing(timing, path, max_speed=model.approach.max_speed, max_accel=model.approach.max_accel)
    T = law.duration
    stored_len = _stored_lengths(model, arm, mount)
    _check_valve_range(model, arm, mount, path, law, stored_len)

    t = np.linspace(0.0, T, samples)
    s = law(t, 0)
    sd = law(t, 1)
    sdd = law(t, 2)
    p = path(s)
    tangent = path(s, 1)
    vx, vy = tangent[:, 0] * sd, tangent[:, 1] * sd
    q = inverse(arm, p[:, 0], p[:, 1])
    ad, bd = joint_rates(arm, q.alpha, q.beta, vx, vy)
    # straight line: no curvature, the coupler acceleration is along the tangent
    add, bdd = joint_accelerations(arm, q.alpha, q.beta, ad, bd, tangent[:, 0] * sdd, tangent[:, 1] * sdd)
    r1, r2 = cylinder_lengths(mount, q.alpha, q.beta)
    v1, v2 = cylinder_rates(mount, q.alpha, q.beta, ad, bd)
    u = valve_voltages(r1, r2, stored_len, volts_per_metre=model.actuators.volts_per_metre,
                       valve_range=model.actuators.valve_range_V, times=t)
    zone = beta_severity(q.beta, alarms)
    return Plan(timing=timing, start=path.start, target=path.end, duration=T, t=t, x=p[:, 0], y=p[:, 1],
                vx=vx, vy=vy, alpha=q.alpha, beta=q.beta, alpha_dot=ad, beta_dot=bd,
                alpha_ddot=add, beta_ddot=bdd, r_ac1=r1, r_ac2=r2,
                v_ac1=v1, v_ac2=v2, u1=u.u1, u2=u.u2, zone=zone, stored_lengths=stored_len)


#: The headline numbers of a 3D approach, declared once.
PLAN3D_METRICS = (
    Metric("duration_s", "duration", "s", ".2f"),
    Metric("slew_range_deg", "slew", "deg", ".2f", sep=" .. "),
    Metric("peak_slew_rate_deg_s", "peak slew rate", "deg/s", ".3f"),
    Metric("alpha_range_deg", "alpha", "deg", ".2f", sep=" .. "),
    Metric("beta_range_deg", "beta", "deg", ".2f", sep=" .. "),
    Metric("worst_zone", "worst zone"),
)


@dataclass(frozen=True)
class Plan3D(Result):
    """A timed straight-line approach in 3D (slew plus the planar arm), sampled; arrays ``(n,)``.

    Attributes
    ----------
    timing : str
        Timing-law name.
    start, target : tuple of float
        End points ``(x, y, z)``, m (``y`` along the berth, ``z`` up).
    duration : float
        s.
    t : ndarray
        s.
    x, y, z : ndarray
        Coupler position, m.
    phi, alpha, beta : ndarray
        Slew and joint angles, rad.
    phi_dot, alpha_dot, beta_dot : ndarray
        Rates, rad/s.
    r_ac1, r_ac2, v_ac1, v_ac2 : ndarray
        Cylinder lengths (m) and speeds (m/s).
    u1, u2 : ndarray
        Valve voltages, V.
    zone : ndarray of int
        The worse of the beta zone and the slew zone.
    """

    timing: str
    start: tuple
    target: tuple
    duration: float
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    phi: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    phi_dot: np.ndarray
    alpha_dot: np.ndarray
    beta_dot: np.ndarray
    r_ac1: np.ndarray
    r_ac2: np.ndarray
    v_ac1: np.ndarray
    v_ac2: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    zone: np.ndarray

    METRICS = PLAN3D_METRICS

    def _figure(self):

        return plan3d_figure(self)

    def _values(self) -> dict:
        """Headline numbers, JSON-friendly (degrees at the edge)."""
        return {
            "timing": self.timing, "start_m": list(self.start), "target_m": list(self.target),
            "path_length_m": math.dist(self.start, self.target), "duration_s": self.duration,
            "slew_range_deg": [float(np.degrees(self.phi.min())), float(np.degrees(self.phi.max()))],
            "peak_slew_rate_deg_s": float(np.degrees(np.abs(self.phi_dot).max())),
            "alpha_range_deg": [float(np.degrees(self.alpha.min())), float(np.degrees(self.alpha.max()))],
            "beta_range_deg": [float(np.degrees(self.beta.min())), float(np.degrees(self.beta.max()))],
            "u1_range_V": [float(self.u1.min()), float(self.u1.max())],
            "u2_range_V": [float(self.u2.min()), float(self.u2.max())],
            "worst_zone": severity_label(int(self.zone.max())),
        }

    def records(self) -> list[dict]:
        """One dict per sample: ``t_s, x_m, y_m, z_m, slew_deg, alpha_deg, beta_deg, r_ac1_m, r_ac2_m, u1_V, u2_V,
        zone``."""
        keys = ("t_s", "x_m", "y_m", "z_m", "slew_deg", "alpha_deg", "beta_deg", "r_ac1_m", "r_ac2_m", "u1_V", "u2_V")
        cols = (self.t, self.x, self.y, self.z, np.degrees(self.phi), np.degrees(self.alpha), np.degrees(self.beta),
                self.r_ac1, self.r_ac2, self.u1, self.u2)
        rows = np.column_stack(cols).tolist()
        return [dict(zip(keys, r), zone=z) for r, z in zip(rows, self.zone.tolist())]

    def write_csv(self, path: str | Path) -> Path:
        """Write :meth:`records` as CSV (header = the record keys).

        Parameters
        ----------
        path : str or Path
            Output file; parent directories are created.

        Returns
        -------
        Path
            The file written.
        """
        return _write_csv(path, self.records())


def plan_approach_3d(model: ArmModel, *, start: tuple | None = None, target: tuple | None = None,
                     timing: str = "smooth", samples: int = 201) -> Plan3D:
    """Plan a straight-line approach in 3D: the coupler on a line, the arm slewing as it goes.

    With ``y = 0`` at both ends this is exactly :func:`plan_approach` with
    ``(x, y) -> (x, z)`` (tested).

    Parameters
    ----------
    model : ArmModel
        Arm, mounting, limits, slew settings.
    start, target : tuple of 3 float, optional
        ``(x, y, z)``, m; default the stored position and the flange at ``y = 0``.
    timing : {'paper', 'smooth', 'optimal'}
        Timing law; ``optimal`` also respects the slew drive's rate limit.
    samples : int
        Number of samples.

    Returns
    -------
    Plan3D

    Raises
    ------
    PathError, UnreachableError, TimingError, ValveRangeError
        As :func:`plan_approach`; also if an end point needs a slew beyond
        ``slew.limit_deg``.
    """
    samples = _check_samples(samples)

    arm = model.arm
    mount = model.mount
    alarms = model.alarms
    sx, sz = model.approach.stored
    fx, fz = model.approach.flange
    start = (sx, 0.0, sz) if start is None else tuple(start)
    target = (fx, 0.0, fz) if target is None else tuple(target)
    path = StraightPath(start, target)
    if path.dim != 3:
        raise PathError("plan_approach_3d needs (x, y, z) end points")
    path.check_reachable(arm)
    lim = model.slew.limit
    s_chk = np.linspace(0.0, path.length, CHECK_SAMPLES)
    p_chk = path(s_chk)
    rho_chk, _ = _planar(p_chk)
    if np.min(rho_chk) < 1e-3:
        raise PathError("the straight path passes over the riser axis, where the slew angle is undefined")
    phi_chk = np.arctan2(p_chk[:, 1], p_chk[:, 0])
    if np.max(np.abs(phi_chk)) > lim:
        i = int(np.argmax(np.abs(phi_chk)))
        raise PathError(f"the path needs a slew of {math.degrees(phi_chk[i]):.1f} deg at "
                        f"({', '.join(f'{v:.2f}' for v in p_chk[i])}) m, beyond the slew limit +/-{math.degrees(model.slew.limit):g} deg")
    if timing == "optimal":
        law = optimal_timing(model, path)
    else:
        law = make_timing(timing, path, max_speed=model.approach.max_speed, max_accel=model.approach.max_accel)
    T = law.duration
    stored_len = _stored_lengths(model, arm, mount)
    _check_valve_range(model, arm, mount, path, law, stored_len)
    t = np.linspace(0.0, T, samples)
    s, sd = law(t, 0), law(t, 1)
    p = path(s)
    tan = path(s, 1)
    v = tan * sd[:, None]
    q = inverse3d(arm, p[:, 0], p[:, 1], p[:, 2])
    rho, _ = _planar(p)
    rho_dot = (p[:, 0] * v[:, 0] + p[:, 1] * v[:, 1]) / rho
    phi_dot = (p[:, 0] * v[:, 1] - p[:, 1] * v[:, 0]) / rho ** 2
    ad, bd = joint_rates(arm, q.alpha, q.beta, rho_dot, v[:, 2])
    r1, r2 = cylinder_lengths(mount, q.alpha, q.beta)
    v1, v2 = cylinder_rates(mount, q.alpha, q.beta, ad, bd)
    u = valve_voltages(r1, r2, stored_len, volts_per_metre=model.actuators.volts_per_metre,
                       valve_range=model.actuators.valve_range_V, times=t)
    zone = np.maximum(beta_severity(q.beta, alarms), slew_severity(q.phi, model.slew))
    return Plan3D(timing, path.start, path.end, T, t, p[:, 0], p[:, 1], p[:, 2], q.phi, q.alpha, q.beta, phi_dot,
                  ad, bd, r1, r2, v1, v2, u.u1, u.u2, zone)


def plan_warnings(model: ArmModel, plan: "Plan | Plan3D") -> list[str]:
    """What a planned approach does that an operator must know before it runs.

    The planners refuse what cannot be done (out of reach, valve range); this reports what can be done but
    should not be done silently: a path that enters an alarm zone, and a cylinder that would have to pass
    its end stop (the cylinder's length range in ``[cylinders]``).

    Parameters
    ----------
    model : ArmModel
        Supplies the cylinder length ranges.
    plan : Plan or Plan3D
        A planned approach.

    Returns
    -------
    list of str
        One sentence per finding, in time order of first occurrence; empty when the plan is clean.
    """
    found: list[tuple[float, str]] = []
    worst = int(plan.zone.max())
    if worst > int(Severity.NORMAL):
        k = int(np.argmax(plan.zone > int(Severity.NORMAL)))
        found.append((float(plan.t[k]), f"the path enters the {severity_label(worst)} zone (first at t = {plan.t[k]:.2f} s, "
                                        f"beta {math.degrees(plan.beta[k]):.2f} deg)"))
    for i, (r, (lo, hi)) in enumerate(((plan.r_ac1, model.cylinders.length_range_1),
                                       (plan.r_ac2, model.cylinders.length_range_2)), start=1):
        for bad, end, limit, word in ((r < lo, "retracted", lo, "shorter"), (r > hi, "extended", hi, "longer")):
            if bad.any():
                k = int(np.argmax(bad))
                extreme = float(r.min() if word == "shorter" else r.max())
                found.append((float(plan.t[k]), f"cylinder {i} passes its end stop: the path needs it {word} than its "
                                                f"{end} length {limit:g} m ({extreme:.4f} m; first at "
                                                f"t = {plan.t[k]:.2f} s)"))
    return [msg for _, msg in sorted(found, key=lambda f: f[0])]
