"""Closed-form planar kinematics of the loading arm (paper Eqs 5-11).

Angles (paper Nomenclature): ``alpha`` is the inboard arm's angle from the
upward extension of the riser, positive towards the ship (+x); ``beta`` is the
interior angle between the inboard and the outboard arm at the elbow. The
paper's arm works *elbow up*: the inboard arm rises from the riser top and the
outboard arm hangs from its end. The mirrored *elbow down* solution is also
available for completeness.

The inverse map uses the atan2 form, which is exact on both sides of
``y = a`` and well conditioned near the reach limits; :func:`inverse_paper`
keeps the paper's literal piecewise arccos/arcsin form (Eq. 10) for
comparison. Everything is vectorised: inputs broadcast, outputs have the
broadcast shape.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from loadarm.arm.geometry import Arm
from loadarm.errors import UnreachableError

__all__ = [
    "jacobian_entries",
    "ik_cosine",
    "ik_elbow",
    "JointAngles",
    "Elbow",
    "forward",
    "elbow_position",
    "inverse",
    "inverse_paper",
    "reach_mask",
    "check_reachable",
    "jacobian",
    "joint_rates",
    "joint_accelerations",
    "ROUNDOFF_M",
    "IKSolution",
    "solve_ik",
]

Elbow = Literal["up", "down"]

#: Distance (m) beyond the reach limits still treated as on the limit. It
#: only absorbs floating-point round-off of points computed *on* a limit; it is
#: 1e-9 of a 1 km arm and far below any physical tolerance.
ROUNDOFF_M = 1e-12


@dataclass(frozen=True, slots=True)
class JointAngles:
    """Joint angles of the planar arm, rad; arrays of one shape.

    Unpacks as a tuple: ``alpha, beta = inverse(arm, x, y)``.
    """

    alpha: np.ndarray
    beta: np.ndarray

    def __iter__(self):
        return iter((self.alpha, self.beta))

    @property
    def alpha_deg(self) -> np.ndarray:
        """``alpha`` in degrees."""
        return np.degrees(self.alpha)

    @property
    def beta_deg(self) -> np.ndarray:
        """``beta`` in degrees."""
        return np.degrees(self.beta)


def _check_elbow(elbow: str) -> float:
    if elbow == "up":
        return 1.0
    if elbow == "down":
        return -1.0
    raise ValueError(f"elbow must be 'up' (the paper's configuration) or 'down', got {elbow!r}")


def elbow_position(arm: Arm, alpha: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Position of the elbow (inboard-outboard hinge).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alpha : float or ndarray
        Inboard angle from the upward riser axis, rad.

    Returns
    -------
    x, y : ndarray
        Elbow coordinates, m, shape of ``alpha``.
    """
    alpha = np.asarray(alpha, dtype=float)
    return arm.b * np.sin(alpha), arm.a + arm.b * np.cos(alpha)


def forward(arm: Arm, alpha: np.ndarray | float, beta: np.ndarray | float, *,
            elbow: Elbow = "up") -> tuple[np.ndarray, np.ndarray]:
    """Coupler position from the joint angles (forward kinematics).

    ``p = (0, a) + b (sin a, cos a) - c (sin(a - s b), cos(a - s b))`` with
    ``s = +1`` for elbow up, ``-1`` for elbow down.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alpha, beta : float or ndarray
        Joint angles, rad; broadcast together.
    elbow : {'up', 'down'}
        Assembly mode; ``'up'`` is the paper's.

    Returns
    -------
    x, y : ndarray
        Coupler position, m, broadcast shape of the inputs.
    """
    s = _check_elbow(elbow)
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    phi = alpha - s * beta
    x = arm.b * np.sin(alpha) - arm.c * np.sin(phi)
    y = arm.a + arm.b * np.cos(alpha) - arm.c * np.cos(phi)
    return x, y


def reach_mask(arm: Arm, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
    """True where a coupler position is reachable (``|b-c| <= r <= b+c``, r > 0).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y : float or ndarray
        Coupler positions, m.

    Returns
    -------
    ndarray of bool
        Broadcast shape of ``x`` and ``y``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    r = np.hypot(x, y - arm.a)
    return (r >= arm.r_min - ROUNDOFF_M) & (r <= arm.r_max + ROUNDOFF_M) & (r > 0) & np.isfinite(r)


def check_reachable(arm: Arm, x: np.ndarray | float, y: np.ndarray | float) -> None:
    """Raise :class:`UnreachableError` naming the first unreachable point, if any.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y : float or ndarray
        Coupler positions, m.

    Raises
    ------
    UnreachableError
        With the point, its radius from the riser top and the reachable radii.
    """
    xb, yb = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    ok = reach_mask(arm, xb, yb)
    if ok.all():
        return
    idx = np.unravel_index(int(np.argmin(ok)), ok.shape)
    px, py = float(xb[idx]), float(yb[idx])
    r = float(np.hypot(px, py - arm.a))
    if not np.isfinite(r):
        raise UnreachableError(f"coupler position ({px}, {py}) m is not a finite number",
                               point=(px, py), r=r, r_min=arm.r_min, r_max=arm.r_max)
    side = "beyond the arm's reach" if r > arm.r_max else "too close to the riser top"
    raise UnreachableError(
        f"coupler position ({px:.4f}, {py:.4f}) m is {side}: distance from the riser top "
        f"r = {r:.4f} m, reachable range [{arm.r_min:.4f}, {arm.r_max:.4f}] m (|b-c|, b+c)",
        point=(px, py), r=r, r_min=arm.r_min, r_max=arm.r_max)


def inverse(arm: Arm, x: np.ndarray | float, y: np.ndarray | float, *, elbow: Elbow = "up",
            check: bool = True) -> JointAngles:
    """Joint angles that put the coupler at ``(x, y)`` (closed form, Eqs 5-11).

    Uses ``theta = atan2(x, a - y)`` (Eq. 10 in one formula, valid on both
    sides of ``y = a``), ``beta`` from the cosine law (Eq. 7) and ``gamma =
    atan2(c sin(beta), b - c cos(beta))`` (Eq. 9 without its arccos
    ill-conditioning), then ``alpha = pi - (gamma + theta)`` (Eq. 11).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y : float or ndarray
        Coupler positions, m; broadcast together.
    elbow : {'up', 'down'}
        Assembly mode; ``'up'`` is the paper's.
    check : bool
        If True (default) raise on any unreachable point; if False the
        unreachable points give NaN (for masks over a grid).

    Returns
    -------
    JointAngles
        ``alpha`` in (-pi, pi] and ``beta`` in [0, pi], rad, broadcast shape.

    Raises
    ------
    UnreachableError
        If ``check`` and a point lies outside ``|b-c| <= r <= b+c``.
    """
    s = _check_elbow(elbow)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if check:
        check_reachable(arm, x, y)
    with np.errstate(invalid="ignore", divide="ignore"):
        dy, r, cb = ik_cosine(arm.a, arm.b, arm.c, x, y)
        if check:
            cb = np.clip(cb, -1.0, 1.0)  # only round-off: reachability was checked
        sb, sa, ca = ik_elbow(arm.b, arm.c, s, x, dy, r, cb)
        beta = np.arctan2(sb, cb)
        alpha = np.arctan2(sa, ca)
    return JointAngles(alpha, beta)


def ik_cosine(a, b, c, x, y):
    """The inverse kinematics' first half (Eqs 5-7), on floats or arrays, and compiled as it is by the operability
    kernel (one formula): the offset below the riser top, the distance to the coupler and ``cos(beta)`` by the
    cosine law.

    Parameters
    ----------
    a, b, c : float
        Riser, inboard and outboard lengths, m.
    x, y : float or ndarray
        The coupler's radius from the riser centre line and height, m.

    Returns
    -------
    dy, r, cos_beta : float or ndarray
    """
    dy = a - y
    r2 = x * x + dy * dy
    r = np.sqrt(r2)
    return dy, r, (b * b + c * c - r2) / (2.0 * b * c)


def ik_elbow(b, c, s, x, dy, r, cb):
    """The inverse kinematics' second half (Eqs 8-11 without the arccos' ill-conditioning): the arguments of the
    arctangents of ``beta`` and ``alpha``, ``alpha = pi - (s*gamma + theta)`` with ``gamma`` the angle at the riser
    top between the inboard arm and ``r``; on floats or arrays, and compiled as it is by the operability kernel.

    Parameters
    ----------
    b, c : float
        Inboard and outboard lengths, m.
    s : float
        +1 elbow up (the paper's), -1 elbow down.
    x, dy, r, cb : float or ndarray
        Radius, offset below the riser top, distance and ``cos(beta)`` (:func:`ik_cosine`).

    Returns
    -------
    sin_beta, sin_alpha_arg, cos_alpha_arg : float or ndarray
        ``beta = atan2(sin_beta, cb)``, ``alpha = atan2(sin_alpha_arg, cos_alpha_arg)``.
    """
    sb = np.sqrt((1.0 - cb) * (1.0 + cb))
    sg = c * sb / r
    cg = (b - c * cb) / r
    st = x / r
    ct = dy / r
    return sb, s * sg * ct + cg * st, s * sg * st - cg * ct


def inverse_paper(arm: Arm, x: np.ndarray | float, y: np.ndarray | float) -> JointAngles:
    """The paper's literal inverse kinematics, Eqs 5, 7, 9, 10 and 11.

    Kept as an independent route for tests and for the docs; prefer
    :func:`inverse`, which is better conditioned near the reach limits.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y : float or ndarray
        Reachable coupler positions, m.

    Returns
    -------
    JointAngles
        ``alpha``, ``beta`` in rad.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    check_reachable(arm, x, y)
    a, b, c = arm.a, arm.b, arm.c
    r = np.sqrt(x**2 + (y - a) ** 2)                                          # Eq. 5
    beta = np.arccos(np.clip((b**2 + c**2 - r**2) / (2 * b * c), -1, 1))      # Eq. 7
    gamma = np.arccos(np.clip((b - c * np.cos(beta)) / r, -1, 1))            # Eq. 9
    theta = np.where(y >= a, np.arccos(np.clip(x / r, -1, 1)) + np.pi / 2,    # Eq. 10
                     np.arcsin(np.clip(x / r, -1, 1)))
    alpha = np.pi - (gamma + theta)                                           # Eq. 11
    return JointAngles(alpha, beta)


def jacobian(arm: Arm, alpha: np.ndarray | float, beta: np.ndarray | float, *,
             elbow: Elbow = "up") -> np.ndarray:
    """Jacobian ``d(x, y) / d(alpha, beta)`` of :func:`forward`.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alpha, beta : float or ndarray
        Joint angles, rad.
    elbow : {'up', 'down'}
        Assembly mode.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``J[..., i, j]``: derivative of coordinate i (x, y) by joint j
        (alpha, beta), m/rad.
    """
    s = _check_elbow(elbow)
    alpha, beta = np.broadcast_arrays(np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float))
    phi = alpha - s * beta
    J = np.empty(alpha.shape + (2, 2))
    J[..., 0, 0], J[..., 0, 1], J[..., 1, 0], J[..., 1, 1] = jacobian_entries(
        arm.b, arm.c, s, np.cos(alpha), np.sin(alpha), np.cos(phi), np.sin(phi))
    return J


def jacobian_entries(b, c, s, ca, sa, cphi, sphi):
    """The four entries of :func:`jacobian` from the sines and cosines: the one formula.

    :func:`jacobian` calls it on arrays; the guidance controller calls it on floats every cycle (the same
    +, -, * on the same inputs give the same bits, which a test checks).

    Parameters
    ----------
    b, c : float
        Inboard and outboard lengths, m.
    s : float
        Elbow sign (+1 up, -1 down).
    ca, sa : float or ndarray
        ``cos(alpha)``, ``sin(alpha)``.
    cphi, sphi : float or ndarray
        ``cos(alpha - s beta)``, ``sin(alpha - s beta)``.

    Returns
    -------
    dx_da, dx_db, dy_da, dy_db : float or ndarray
        m/rad.
    """
    return b * ca - c * cphi, s * c * cphi, -b * sa + c * sphi, -s * c * sphi


def joint_rates(arm: Arm, alpha: np.ndarray, beta: np.ndarray, vx: np.ndarray, vy: np.ndarray, *,
                elbow: Elbow = "up") -> tuple[np.ndarray, np.ndarray]:
    """Joint rates that give a coupler velocity (``J qdot = v``).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alpha, beta : ndarray
        Joint angles, rad.
    vx, vy : ndarray
        Coupler velocity, m/s.
    elbow : {'up', 'down'}
        Assembly mode.

    Returns
    -------
    alpha_dot, beta_dot : ndarray
        Joint rates, rad/s.

    Raises
    ------
    UnreachableError
        If the arm is singular (fully stretched or folded, ``sin(beta) = 0``)
        at any sample where a nonzero velocity is asked for.
    """
    J = jacobian(arm, alpha, beta, elbow=elbow)
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]   # = -s b c sin(beta)
    vx, vy = np.broadcast_arrays(np.asarray(vx, dtype=float), np.asarray(vy, dtype=float))
    bad = (np.abs(det) < 1e-12 * arm.b * arm.c) & ((vx != 0) | (vy != 0))
    if np.any(bad):
        i = int(np.argmax(bad.ravel()))
        raise UnreachableError(
            f"arm is singular (beta = {np.degrees(np.ravel(beta)[i]):.6f} deg, fully stretched or folded): "
            "no joint rate gives the requested coupler velocity",
            point=(float("nan"), float("nan")), r=float("nan"), r_min=arm.r_min, r_max=arm.r_max)
    with np.errstate(divide="ignore", invalid="ignore"):
        ad = (J[..., 1, 1] * vx - J[..., 0, 1] * vy) / det
        bd = (-J[..., 1, 0] * vx + J[..., 0, 0] * vy) / det
    ad = np.where((vx == 0) & (vy == 0), 0.0, ad)
    bd = np.where((vx == 0) & (vy == 0), 0.0, bd)
    return ad, bd


def joint_accelerations(arm: Arm, alpha: np.ndarray, beta: np.ndarray, alpha_dot: np.ndarray, beta_dot: np.ndarray,
                        ax: np.ndarray, ay: np.ndarray, *, elbow: Elbow = "up") -> tuple[np.ndarray, np.ndarray]:
    """Joint accelerations that give a coupler acceleration (``J qddot = a - Jdot qdot``).

    Differentiating :func:`forward` twice (``u(psi) = (sin psi, cos psi)``,
    ``u'' = -u``) gives the velocity-product term
    ``Jdot qdot = -b u(alpha) alpha_dot^2 + c u(phi) phi_dot^2`` with
    ``phi = alpha - s beta``.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alpha, beta : ndarray
        Joint angles, rad.
    alpha_dot, beta_dot : ndarray
        Joint rates, rad/s.
    ax, ay : ndarray
        Coupler acceleration, m/s^2.
    elbow : {'up', 'down'}
        Assembly mode.

    Returns
    -------
    alpha_ddot, beta_ddot : ndarray
        Joint accelerations, rad/s^2.

    Raises
    ------
    UnreachableError
        At a singular pose (see :func:`joint_rates`).
    """
    s = _check_elbow(elbow)
    alpha, beta, ad, bd = (np.asarray(v, dtype=float) for v in (alpha, beta, alpha_dot, beta_dot))
    phi = alpha - s * beta
    phid = ad - s * bd
    cx = -arm.b * np.sin(alpha) * ad ** 2 + arm.c * np.sin(phi) * phid ** 2
    cy = -arm.b * np.cos(alpha) * ad ** 2 + arm.c * np.cos(phi) * phid ** 2
    return joint_rates(arm, alpha, beta, np.asarray(ax) - cx, np.asarray(ay) - cy, elbow=elbow)


@dataclass(frozen=True, slots=True)
class IKSolution:
    """Inverse kinematics that reports instead of raising (for monitoring loops and grids).

    Unpacks as ``alpha, beta, success``. Failed points have NaN angles.

    Attributes
    ----------
    alpha, beta : ndarray
        Joint angles, rad (NaN where ``success`` is False).
    success : ndarray of bool
        Whether each point is reachable.
    reason : ndarray of str
        ``'ok'``, ``'beyond reach: r > b + c'``, ``'too close: r < |b - c|'``
        or ``'not finite'`` per point.
    elbow : str
        Assembly mode used.
    """

    alpha: np.ndarray
    beta: np.ndarray
    success: np.ndarray
    reason: np.ndarray
    elbow: str

    def __iter__(self):
        return iter((self.alpha, self.beta, self.success))

    @property
    def all_ok(self) -> bool:
        """True if every point was solved."""
        return bool(np.all(self.success))


def solve_ik(arm: Arm, x: np.ndarray | float, y: np.ndarray | float, *, elbow: Elbow = "up") -> IKSolution:
    """Inverse kinematics for every point, with success and a reason per point.

    Same mathematics as :func:`inverse`; unreachable points are reported, not
    raised, which suits code that must keep running (monitoring, envelope
    maps).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y : float or ndarray
        Coupler positions, m.
    elbow : {'up', 'down'}
        Assembly mode.

    Returns
    -------
    IKSolution
        Angles, success mask and reasons, broadcast shape of ``x`` and ``y``.
    """
    _check_elbow(elbow)
    xb, yb = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    ok = reach_mask(arm, xb, yb)
    q = inverse(arm, xb, yb, elbow=elbow, check=False)
    r = np.hypot(xb, yb - arm.a)
    reason = np.select([~np.isfinite(r), r > arm.r_max + ROUNDOFF_M, ~ok],
                       ["not finite", "beyond reach: r > b + c", "too close: r < |b - c|"], "ok")
    alpha = np.where(ok, q.alpha, np.nan)
    beta = np.where(ok, np.clip(q.beta, 0.0, np.pi), np.nan)
    return IKSolution(alpha, beta, ok, reason, elbow)
