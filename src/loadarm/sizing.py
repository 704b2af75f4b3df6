"""Arm sizing from the customer datasheet (paper Section 2, Eqs 1-3).

The first alarm must sound when the coupler reaches the worst flange position
the datasheet allows: farthest out (``|X| = A+B+C+D-C+E``) and lowest (``|Y|
= F+G-H`` below the deck). Its distance from the riser top is (Eq. 1)
``r_al = sqrt((a + |Y|)^2 + |X|^2)``; the cosine law at the first-alarm angle
(Eq. 2) gives the constraint of Eq. 3, ``b^2 + c^2 - 2bc cos(beta_al) =
r_al^2``, and the arm with the least total length ``b + c`` is chosen.

The constraint is an ellipse in the ``(b, c)`` plane on which ``b + c`` is
largest at ``b = c`` and falls towards both axes, so inside a box of bounds the
minimum always sits on a bound and there are usually two local minima (one on
each arm's bound). :func:`size_arm` scans the whole feasible arc, polishes every
local minimum with SciPy's SLSQP (the stand-in for MATLAB's ``fmincon``) and
returns the global one, whatever the starting point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from .config import Installation
from .envelope import AlarmAngles, Zone, berth_box, classify_beta
from .errors import SizingError
from .geometry import Arm
from .kinematics import inverse, reach_mask

__all__ = ["SizingResult", "CornerCheck", "first_alarm_corner", "alarm_radius", "size_arm", "check_corners",
           "size_installation", "sizing_summary"]


@dataclass(frozen=True, slots=True)
class CornerCheck:
    """One corner of the flange box checked against an arm.

    Attributes
    ----------
    name : str
        Which corner.
    x, y : float
        Flange position, m.
    r : float
        Distance from the riser top, m.
    alpha, beta : float
        Joint angles, rad (NaN if unreachable).
    zone : Zone
        Alarm zone.
    """

    name: str
    x: float
    y: float
    r: float
    alpha: float
    beta: float
    zone: Zone

    def as_dict(self) -> dict:
        """JSON-friendly row (degrees at the edge)."""
        return {
            "corner": self.name, "x_m": self.x, "y_m": self.y, "r_m": self.r,
            "alpha_deg": None if math.isnan(self.alpha) else math.degrees(self.alpha),
            "beta_deg": None if math.isnan(self.beta) else math.degrees(self.beta),
            "zone": int(self.zone), "zone_label": self.zone.label,
        }


@dataclass(frozen=True, slots=True)
class SizingResult:
    """Solution of paper Eq. 3.

    Attributes
    ----------
    inboard, outboard : float
        Optimal ``b`` and ``c``, m.
    r_alarm : float
        First-alarm radius ``r_al`` (Eq. 1), m.
    corner : tuple of float
        First-alarm corner ``(|X|, -|Y|)``, m.
    beta_alarm : float
        First-alarm angle, rad.
    active_bound : str
        Which bound the optimum sits on.
    local_minima : list of tuple
        Every local minimum ``(b, c)`` found on the feasible arc, best first.
    constraint_residual : float
        ``|b^2 + c^2 - 2bc cos(beta_al) - r_al^2|`` at the optimum, m^2.
    """

    inboard: float
    outboard: float
    r_alarm: float
    corner: tuple[float, float]
    beta_alarm: float
    active_bound: str
    local_minima: list[tuple[float, float]] = field(default_factory=list)
    constraint_residual: float = 0.0

    @property
    def total(self) -> float:
        """``b + c``, m."""
        return self.inboard + self.outboard


def first_alarm_corner(inst_or_ds) -> tuple[float, float]:
    """The paper's ``(|X|, |Y|)`` of Eq. 1.

    Parameters
    ----------
    inst_or_ds : Installation or Datasheet
        Where to read the datasheet.

    Returns
    -------
    X, Y : float
        ``A+B+C+D-C+E`` and ``F+G-H``, m (``Y`` is a depth below the deck).
    """
    ds = inst_or_ds.datasheet if isinstance(inst_or_ds, Installation) else inst_or_ds
    box = berth_box(ds)
    return box.x_far, -box.y_low


def alarm_radius(riser: float, X: float, Y: float) -> float:
    """Paper Eq. 1: ``r_al = sqrt((a + |Y|)^2 + |X|^2)``.

    Parameters
    ----------
    riser : float
        Riser length ``a``, m.
    X, Y : float
        First-alarm corner, m (signs ignored).

    Returns
    -------
    float
        First-alarm radius from the riser top, m.
    """
    return math.hypot(riser + abs(Y), abs(X))


def _constraint(beta_al: float, r_al: float):
    cb = math.cos(beta_al)

    def g(v):
        b, c = v
        return b * b + c * c - 2 * b * c * cb - r_al * r_al

    def dg(v):
        b, c = v
        return np.array([2 * b - 2 * c * cb, 2 * c - 2 * b * cb])

    return g, dg


def size_arm(riser: float, X: float, Y: float, beta_alarm: float, inboard_bounds: tuple[float, float],
             outboard_bounds: tuple[float, float], *, x0: tuple[float, float] | None = None) -> SizingResult:
    """Solve paper Eq. 3 globally: ``min b + c`` on the first-alarm ellipse.

    Parameters
    ----------
    riser : float
        Riser length ``a``, m.
    X, Y : float
        First-alarm corner ``|X|``, ``|Y|`` (Eq. 1), m.
    beta_alarm : float
        First-alarm angle ``beta_al``, rad, in (0, pi).
    inboard_bounds, outboard_bounds : tuple of float
        ``(low, high)`` for ``b`` and ``c``, m.
    x0 : tuple of float, optional
        A starting point for the local optimiser. The result does not depend
        on it: it only adds one more local search.

    Returns
    -------
    SizingResult
        The global optimum with every local minimum found.

    Raises
    ------
    SizingError
        If no ``(b, c)`` inside the bounds satisfies the constraint; the
        message says whether the arms are too short or too long.
    """
    if not (0 < beta_alarm < math.pi):
        raise SizingError(f"first-alarm angle must be in (0, 180) deg, got {math.degrees(beta_alarm):g} deg")
    (blo, bhi), (clo, chi) = inboard_bounds, outboard_bounds
    for name, lo, hi in (("inboard", blo, bhi), ("outboard", clo, chi)):
        if not (0 < lo <= hi):
            raise SizingError(f"sizing.{name} bounds must satisfy 0 < low <= high, got [{lo}, {hi}] m")
    r_al = alarm_radius(riser, X, Y)
    cb = math.cos(beta_alarm)

    def reach(b, c):
        return np.sqrt(b * b + c * c - 2 * b * c * cb)

    # Feasibility: r(b, c) is continuous on the box; the constraint is met iff r_al lies in its range.
    bb, cc = np.meshgrid(np.linspace(blo, bhi, 401), np.linspace(clo, chi, 401))
    rr = reach(bb, cc)
    if r_al > rr.max() + 1e-9:
        raise SizingError(
            f"no arm inside the bounds reaches the first-alarm corner: it needs r_al = {r_al:.3f} m at "
            f"beta = {math.degrees(beta_alarm):g} deg, but the longest arm allowed (b <= {bhi:g} m, "
            f"c <= {chi:g} m) reaches only {rr.max():.3f} m; raise sizing.inboard or sizing.outboard upper bounds")
    if r_al < rr.min() - 1e-9:
        raise SizingError(
            f"every arm inside the bounds is too long: the first-alarm corner is only r_al = {r_al:.3f} m away "
            f"but the shortest arm allowed (b >= {blo:g} m, c >= {clo:g} m) already reaches {rr.min():.3f} m "
            f"at beta = {math.degrees(beta_alarm):g} deg; lower the sizing lower bounds")

    # Global scan of the feasible arc in polar form: b = rho cos(psi), c = rho sin(psi),
    # rho(psi) = r_al / sqrt(1 - sin(2 psi) cos(beta_al)).
    psi = np.linspace(1e-6, math.pi / 2 - 1e-6, 20001)
    rho = r_al / np.sqrt(1.0 - np.sin(2 * psi) * cb)
    b_s, c_s = rho * np.cos(psi), rho * np.sin(psi)
    inside = (b_s >= blo - 1e-12) & (b_s <= bhi + 1e-12) & (c_s >= clo - 1e-12) & (c_s <= chi + 1e-12)
    g, dg = _constraint(beta_alarm, r_al)
    starts: list[np.ndarray] = []
    if inside.any():
        total = np.where(inside, b_s + c_s, np.inf)
        # local minima of the total along the arc (including the ends of each feasible piece)
        idx = np.flatnonzero(inside)
        for i in idx:
            left = total[i - 1] if i > 0 else np.inf
            right = total[i + 1] if i + 1 < total.size else np.inf
            if total[i] <= left and total[i] <= right:
                starts.append(np.array([b_s[i], c_s[i]]))
    if x0 is not None:
        starts.append(np.asarray(x0, dtype=float))
    bounds = [(blo, bhi), (clo, chi)]
    found: list[tuple[float, float]] = []
    for s in starts:
        res = minimize(lambda v: v[0] + v[1], s, jac=lambda v: np.ones(2), method="SLSQP", bounds=bounds,
                       constraints=[{"type": "eq", "fun": g, "jac": dg}], options={"ftol": 1e-14, "maxiter": 200})
        b, c = (float(v) for v in res.x)
        if res.success and abs(g(res.x)) < 1e-8 and blo - 1e-9 <= b <= bhi + 1e-9 and clo - 1e-9 <= c <= chi + 1e-9:
            if not any(abs(b - fb) < 1e-6 and abs(c - fc) < 1e-6 for fb, fc in found):
                found.append((b, c))
    if not found:  # pragma: no cover - the scan guarantees a feasible start
        raise SizingError("SLSQP found no feasible point although the bounds admit one; report this as a bug")
    found.sort(key=lambda bc: bc[0] + bc[1])
    b, c = found[0]
    # Snap to a bound the optimiser touched to within its tolerance, keeping the constraint exact.
    active = []
    for name, val, lo, hi in (("inboard", b, blo, bhi), ("outboard", c, clo, chi)):
        if abs(val - hi) < 1e-7:
            active.append(f"sizing.{name} upper bound ({hi:g} m)")
        elif abs(val - lo) < 1e-7:
            active.append(f"sizing.{name} lower bound ({lo:g} m)")
    return SizingResult(inboard=b, outboard=c, r_alarm=r_al, corner=(X, -abs(Y)), beta_alarm=beta_alarm,
                        active_bound=", ".join(active) if active else "none (interior optimum)",
                        local_minima=found, constraint_residual=abs(g(np.array([b, c]))))


def check_corners(arm: Arm, alarms: AlarmAngles, inst: Installation) -> list[CornerCheck]:
    """Zone and joint angles at each corner of the datasheet's flange box.

    Parameters
    ----------
    arm : Arm
        The arm to check (sized or configured).
    alarms : AlarmAngles
        Alarm thresholds.
    inst : Installation
        Supplies the datasheet.

    Returns
    -------
    list of CornerCheck
        One per corner; unreachable corners have NaN angles and zone
        ``UNREACHABLE``.
    """
    out = []
    for name, x, y in berth_box(inst.datasheet).corners():
        r = math.hypot(x, y - arm.a)
        if reach_mask(arm, x, y):
            q = inverse(arm, x, y)
            alpha, beta = float(q.alpha), float(q.beta)
            zone = Zone(int(classify_beta(beta, alarms)))
        else:
            alpha = beta = float("nan")
            zone = Zone.UNREACHABLE
        out.append(CornerCheck(name, x, y, r, alpha, beta, zone))
    return out


def size_installation(inst: Installation) -> SizingResult:
    """Run :func:`size_arm` with an installation's datasheet, riser, alarm and bounds.

    Parameters
    ----------
    inst : Installation
        Validated installation.

    Returns
    -------
    SizingResult
        The global optimum of Eq. 3.
    """
    X, Y = first_alarm_corner(inst)
    return size_arm(inst.arm.riser, X, Y, inst.alarms.first, inst.sizing.inboard, inst.sizing.outboard)


def sizing_summary(inst: Installation, result: SizingResult | None = None) -> dict:
    """Sizing result and corner tables (sized and configured arm), JSON-friendly.

    Parameters
    ----------
    inst : Installation
        The installation.
    result : SizingResult, optional
        An already computed :func:`size_installation` result.

    Returns
    -------
    dict
        ``inboard_m, outboard_m, total_m, r_alarm_m, first_alarm_corner_m, beta_alarm_deg, active_bound,
        local_minima_m, constraint_residual_m2, corners`` (sized arm) and ``corners_configured_arm``.
    """
    from .envelope import alarms_from_installation
    from .geometry import arm_from_installation

    res = size_installation(inst) if result is None else result
    alarms = alarms_from_installation(inst)
    sized = Arm(inst.arm.riser, res.inboard, res.outboard)
    return {
        "inboard_m": res.inboard, "outboard_m": res.outboard, "total_m": res.total, "r_alarm_m": res.r_alarm,
        "first_alarm_corner_m": list(res.corner), "beta_alarm_deg": math.degrees(res.beta_alarm),
        "active_bound": res.active_bound, "local_minima_m": [list(m) for m in res.local_minima],
        "constraint_residual_m2": float(res.constraint_residual),
        "corners": [c.as_dict() for c in check_corners(sized, alarms, inst)],
        "corners_configured_arm": [c.as_dict() for c in check_corners(arm_from_installation(inst), alarms, inst)],
    }
