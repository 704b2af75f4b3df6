"""Arm sizing from the customer datasheet (paper Section 2, Eqs 1-3).

The first alarm must sound when the coupler reaches the worst flange position
the datasheet allows: farthest out (``|X| = A+B+C+D-C+E``) and lowest (``|Y|
= F+G-H`` below the deck). Its distance from the riser top is (Eq. 1)
``r_al = sqrt((a + |Y|)^2 + |X|^2)``; the cosine law at the first-alarm angle
(Eq. 2) gives the constraint of Eq. 3, ``b^2 + c^2 - 2bc cos(beta_al) =
r_al^2``, and the arm with the least total length ``b + c`` is chosen.

The constraint is an ellipse in the ``(b, c)`` plane on which ``b + c`` is
largest at ``b = c`` and falls towards both axes, so inside a box of bounds the
minimum always sits on a bound and there can be several local minima (one on
each arm's bound). :func:`size_arm` computes every point where the ellipse
meets a bound in closed form and returns the best: no iterative optimiser (the
paper's MATLAB ``fmincon``, SciPy's SLSQP) and no starting point, so no
convergence flag can hide the optimum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from loadarm.arm.alarms import AlarmAngles, beta_severity
from loadarm.arm.envelope import berth_box
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import inverse, reach_mask
from loadarm.design.plots import sizing_figure
from loadarm.errors import SizingError
from loadarm.results import Metric, Result
from loadarm.vocab import UNREACHABLE, severity_label

__all__ = ["SIZING_METRICS", "SizingResult", "CornerCheck", "first_alarm_corner", "alarm_radius", "size_arm", "check_corners",
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
    zone : int
        :class:`loadarm.vocab.Severity` value, or :data:`loadarm.vocab.UNREACHABLE`.
    """

    name: str
    x: float
    y: float
    r: float
    alpha: float
    beta: float
    zone: int

    def as_dict(self) -> dict:
        """JSON-friendly row (degrees at the edge)."""
        return {
            "corner": self.name, "x_m": self.x, "y_m": self.y, "r_m": self.r,
            "alpha_deg": None if math.isnan(self.alpha) else math.degrees(self.alpha),
            "beta_deg": None if math.isnan(self.beta) else math.degrees(self.beta),
            "zone": int(self.zone), "zone_label": severity_label(self.zone),
        }


#: The headline numbers of a sizing, declared once.
SIZING_METRICS = (
    Metric("inboard_m", "inboard arm b", "m", ".4f"),
    Metric("outboard_m", "outboard arm c", "m", ".4f"),
    Metric("total_m", "b + c", "m", ".4f"),
    Metric("r_alarm_m", "first-alarm radius r_al", "m", ".4f"),
    Metric("beta_alarm_deg", "first-alarm angle", "deg", "g"),
    Metric("active_bound", "active bound"),
    Metric("constraint_residual_m2", "constraint residual", "m^2", ".1e"),
)


@dataclass(frozen=True)
class SizingResult(Result):
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
    bounds : tuple of tuple of float
        The ``(low, high)`` bounds of ``b`` and ``c`` searched, m.
    """

    METRICS = SIZING_METRICS

    inboard: float
    outboard: float
    r_alarm: float
    corner: tuple[float, float]
    beta_alarm: float
    active_bound: str
    local_minima: list[tuple[float, float]] = field(default_factory=list)
    constraint_residual: float = 0.0
    bounds: tuple = ()

    @property
    def total(self) -> float:
        """``b + c``, m."""
        return self.inboard + self.outboard

    def _values(self) -> dict:
        return {"inboard_m": self.inboard, "outboard_m": self.outboard, "total_m": self.total,
                "r_alarm_m": self.r_alarm, "first_alarm_corner_m": list(self.corner),
                "beta_alarm_deg": math.degrees(self.beta_alarm), "active_bound": self.active_bound,
                "local_minima_m": [list(m) for m in self.local_minima],
                "constraint_residual_m2": float(self.constraint_residual)}

    def _figure(self):

        return sizing_figure(self)


def first_alarm_corner(inst_or_ds) -> tuple[float, float]:
    """The paper's ``(|X|, |Y|)`` of Eq. 1.

    Parameters
    ----------
    inst_or_ds : Installation, SizingCase or Datasheet
        Where to read the datasheet.

    Returns
    -------
    X, Y : float
        ``A+B+C+D-C+E`` and ``F+G-H``, m (``Y`` is a depth below the deck).
    """
    ds = getattr(inst_or_ds, "datasheet", inst_or_ds)
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


def _reach_range(cb: float, blo: float, bhi: float, clo: float, chi: float) -> tuple[float, float]:
    """Exact least and greatest ``r(b, c) = sqrt(b^2 + c^2 - 2 b c cos(beta_al))`` over the box.

    ``r^2`` is a convex quadratic (Hessian ``[[2, -2cb], [-2cb, 2]]``), so its maximum is at a corner;
    its only stationary point is the origin, outside the box, so its minimum is on an edge, where it is a
    1-D quadratic minimised at its clamped vertex.
    """
    def r2(b, c):
        return b * b + c * c - 2.0 * b * c * cb

    corners = [r2(b, c) for b in (blo, bhi) for c in (clo, chi)]
    edges = [r2(b, min(max(b * cb, clo), chi)) for b in (blo, bhi)]
    edges += [r2(min(max(c * cb, blo), bhi), c) for c in (clo, chi)]
    return math.sqrt(max(min(corners + edges), 0.0)), math.sqrt(max(corners))


def _arc_ends(r_al: float, cb: float, blo: float, bhi: float, clo: float,
              chi: float) -> list[tuple[float, float]]:
    """Every point where the Eq. 2 ellipse meets a bound of the box, inside the box.

    With ``b`` on a bound, Eq. 2 is a quadratic in ``c``:
    ``c = b cos(beta_al) +- sqrt(r_al^2 - b^2 sin^2(beta_al))``; likewise with ``c`` on a bound. A tangent
    touch (discriminant within rounding of zero) counts once; a root that lands within rounding of the
    other arm's bound is put on it.
    """
    s2 = 1.0 - cb * cb
    out: list[tuple[float, float]] = []
    for fixed_first, (flo, fhi), (olo, ohi) in ((True, (blo, bhi), (clo, chi)), (False, (clo, chi), (blo, bhi))):
        tol = 1e-12 * max(ohi, r_al)
        for f in (flo, fhi):
            disc = r_al * r_al - f * f * s2
            if disc < -1e-12 * r_al * r_al:
                continue
            root = math.sqrt(max(disc, 0.0))
            for o in (f * cb - root, f * cb + root):
                if olo - tol <= o <= ohi + tol:
                    o = min(max(o, olo), ohi)
                    out.append((f, o) if fixed_first else (o, f))
    return out


def size_arm(riser: float, X: float, Y: float, beta_alarm: float, inboard_bounds: tuple[float, float],
             outboard_bounds: tuple[float, float]) -> SizingResult:
    """Solve paper Eq. 3 globally and exactly: ``min b + c`` on the first-alarm ellipse.

    Along the ellipse ``b + c`` has a single maximum (at ``b = c``) and no interior minimum, so on every
    piece of the ellipse inside the bounds the least ``b + c`` is at an end of the piece, and every end
    lies on a bound. The ends are the roots of Eq. 2 with one arm on a bound (a quadratic in the other);
    all of them are computed in closed form and the best is returned. No iterative optimiser is involved,
    so no convergence flag can hide the optimum.

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

    Returns
    -------
    SizingResult
        The global optimum with every local minimum (every end of a feasible piece where ``b + c`` is
        smaller than on the piece next to it).

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
        if not (0 < lo <= hi < math.inf):
            raise SizingError(f"sizing.{name} bounds must satisfy 0 < low <= high, got [{lo}, {hi}] m")
    r_al = alarm_radius(riser, X, Y)
    cb = math.cos(beta_alarm)
    r_min, r_max = _reach_range(cb, blo, bhi, clo, chi)
    if r_al > r_max * (1 + 1e-12):
        raise SizingError(
            f"no arm inside the bounds reaches the first-alarm corner: it needs r_al = {r_al:.3f} m at "
            f"beta = {math.degrees(beta_alarm):g} deg, but the longest arm allowed (b <= {bhi:g} m, "
            f"c <= {chi:g} m) reaches only {r_max:.3f} m; raise sizing.inboard or sizing.outboard upper bounds")
    if r_al < r_min * (1 - 1e-12):
        raise SizingError(
            f"every arm inside the bounds is too long: the first-alarm corner is only r_al = {r_al:.3f} m away "
            f"but the shortest arm allowed (b >= {blo:g} m, c >= {clo:g} m) already reaches {r_min:.3f} m "
            f"at beta = {math.degrees(beta_alarm):g} deg; lower the sizing lower bounds")
    ends = _arc_ends(r_al, cb, blo, bhi, clo, chi)
    if not ends:  # pragma: no cover - r_min <= r_al <= r_max means the ellipse crosses the box's boundary
        raise SizingError("the bounds admit an arm but no crossing of the box was found; report this as a bug")

    # Order the ends along the ellipse by polar angle; a piece between two neighbours is feasible when its
    # middle is inside the box. An end is a local minimum when b + c rises onto each feasible piece next to it
    # (b + c increases with psi below pi/4 and decreases above).
    psi = np.array([math.atan2(c, b) for b, c in ends])
    order = np.argsort(psi, kind="stable")
    pts, psi = [ends[i] for i in order], psi[order]
    keep = np.concatenate(([True], np.diff(psi) > 1e-13))
    pts, psi = [p for p, k in zip(pts, keep) if k], psi[keep]
    inside_next = []
    for k in range(len(pts) - 1):
        mid = 0.5 * (psi[k] + psi[k + 1])
        rho = r_al / math.sqrt(1.0 - math.sin(2.0 * mid) * cb)
        b_m, c_m = rho * math.cos(mid), rho * math.sin(mid)
        inside_next.append(blo <= b_m <= bhi and clo <= c_m <= chi)
    minima = []
    for k, (b, c) in enumerate(pts):
        right = k < len(pts) - 1 and inside_next[k]
        left = k > 0 and inside_next[k - 1]
        if (not right or psi[k] < math.pi / 4) and (not left or psi[k] > math.pi / 4):
            minima.append((b, c))
    minima.sort(key=lambda bc: bc[0] + bc[1])
    b, c = min(pts, key=lambda bc: bc[0] + bc[1])
    active = []
    for name, val, lo, hi in (("inboard", b, blo, bhi), ("outboard", c, clo, chi)):
        if val == hi:
            active.append(f"sizing.{name} upper bound ({hi:g} m)")
        elif val == lo:
            active.append(f"sizing.{name} lower bound ({lo:g} m)")
    return SizingResult(inboard=b, outboard=c, r_alarm=r_al, corner=(X, -abs(Y)), beta_alarm=beta_alarm,
                        active_bound=", ".join(active), local_minima=minima,
                        constraint_residual=abs(b * b + c * c - 2.0 * b * c * cb - r_al * r_al),
                        bounds=((blo, bhi), (clo, chi)))


def check_corners(arm: Arm, alarms: AlarmAngles, inst) -> list[CornerCheck]:
    """Alarm severity and joint angles at each corner of the datasheet's flange box.

    Parameters
    ----------
    arm : Arm
        The arm to check (sized or configured).
    alarms : AlarmAngles
        Alarm thresholds.
    inst : Installation or SizingCase
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
            zone = int(beta_severity(beta, alarms))
        else:
            alpha = beta = float("nan")
            zone = UNREACHABLE
        out.append(CornerCheck(name, x, y, r, alpha, beta, zone))
    return out


def size_installation(inst) -> SizingResult:
    """Run :func:`size_arm` with an installation's datasheet, riser, alarm and bounds.

    Parameters
    ----------
    inst : Installation or SizingCase
        Validated installation, or the sizing sections alone (:func:`loadarm.params.config.load_sizing_case`).

    Returns
    -------
    SizingResult
        The global optimum of Eq. 3.
    """
    X, Y = first_alarm_corner(inst)
    return size_arm(inst.arm.riser, X, Y, inst.alarms.first, inst.sizing.inboard, inst.sizing.outboard)


def sizing_summary(inst, result: SizingResult | None = None) -> dict:
    """Sizing result and corner tables (sized and configured arm), JSON-friendly.

    Parameters
    ----------
    inst : Installation or SizingCase
        The installation, or the sizing sections alone; the configured arm's table is ``None`` when the
        file gives no arm lengths.
    result : SizingResult, optional
        An already computed :func:`size_installation` result.

    Returns
    -------
    dict
        ``inboard_m, outboard_m, total_m, r_alarm_m, first_alarm_corner_m, beta_alarm_deg, active_bound,
        local_minima_m, constraint_residual_m2, corners`` (sized arm) and ``corners_configured_arm``.
    """
    res = size_installation(inst) if result is None else result
    alarms = AlarmAngles(inst.alarms.first, inst.alarms.second, inst.alarms.release)
    sized = Arm(inst.arm.riser, res.inboard, res.outboard)
    return {
        **res.to_dict(),
        "corners": [c.as_dict() for c in check_corners(sized, alarms, inst)],
        "corners_configured_arm": None if inst.arm.inboard is None else [
            c.as_dict() for c in check_corners(Arm(inst.arm.riser, inst.arm.inboard, inst.arm.outboard), alarms, inst)],
    }
