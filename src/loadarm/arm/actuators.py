"""Hydraulic cylinder lengths and proportional-valve commands (paper Eqs 12-13, Section 5).

Cylinder 1 spans the angle ``pi - alpha`` between the riser (pin ``a1`` below
the inboard hinge) and the inboard arm (pin ``b1`` from the hinge), cylinder 2
the angle ``beta`` at the elbow (pins ``b2`` on the inboard and ``c2`` on the
outboard arm). The cosine law gives their pin-to-pin lengths:

* Eq. 12: ``r_ac1 = sqrt(a1^2 + b1^2 - 2 a1 b1 cos(pi - alpha))``
* Eq. 13: ``r_ac2 = sqrt(c2^2 + b2^2 - 2 c2 b2 cos(beta))``

The valve command is the displacement from the stored pose times a scale
(paper Section 5): ``u = k (r_ac - r_ac,stored)``, positive for extension.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.geometry import Arm, Mounting
from loadarm.arm.kinematics import ROUNDOFF_M, check_reachable, forward
from loadarm.errors import ActuatorError, ValveRangeError

__all__ = [
    "pin_lengths",
    "pin_moment_arms",
    "cylinder_lengths",
    "moment_arms",
    "cylinder_rates",
    "joint_angles_from_cylinders",
    "length_limits",
    "ValveCommand",
    "valve_voltages",
    "solve_ik_cylinders",
    "coupler_from_cylinders",
    "IK_CHUNK",
]

#: Points per block in :func:`solve_ik_cylinders`: 16k float64 arrays keep the ~10
#: working arrays inside the L2 cache, which doubles throughput against one big block.
IK_CHUNK = 16384


def pin_lengths(a1, b1, b2, c2, ch, sh):
    """Eqs 12-13: both cylinders' pin-to-pin lengths from the half angles; the one formula.

    The cancellation-free form ``b^2 + c^2 - 2bc cos(g) = (b - c)^2 + 4bc sin^2(g/2)`` is exact to
    round-off even for a nearly closed triangle of pins (``1 - cos(pi - alpha) = 2 cos^2(alpha/2)``). Only
    +, * and a correctly rounded sqrt: NumPy on arrays and numba on scalars (the 1 kHz plant compiles this
    same function) give the same bits for the same inputs, which a test checks.

    Parameters
    ----------
    a1, b1, b2, c2 : float
        Pin distances (paper Fig. 5), m.
    ch, sh : float or ndarray
        ``cos(alpha / 2)`` and ``sin(beta / 2)``.

    Returns
    -------
    r1, r2 : float or ndarray
        Cylinder pin-to-pin lengths, m.
    """
    d1 = a1 - b1
    d2 = c2 - b2
    return np.sqrt(d1 * d1 + 4.0 * a1 * b1 * (ch * ch)), np.sqrt(d2 * d2 + 4.0 * c2 * b2 * (sh * sh))


def pin_moment_arms(a1, b1, b2, c2, sa, sb, r1, r2):
    """Derivatives of Eqs 12-13: ``d r_ac1 / d alpha = -a1 b1 sin(alpha) / r_ac1``,
    ``d r_ac2 / d beta = b2 c2 sin(beta) / r_ac2``; the one formula (NumPy and the compiled plant).

    Parameters
    ----------
    a1, b1, b2, c2 : float
        Pin distances, m.
    sa, sb : float or ndarray
        ``sin(alpha)`` and ``sin(beta)``.
    r1, r2 : float or ndarray
        Cylinder lengths from :func:`pin_lengths`, m.

    Returns
    -------
    h1, h2 : float or ndarray
        Moment arms, m (signed).
    """
    return -a1 * b1 * sa / r1, b2 * c2 * sb / r2


def cylinder_lengths(mount: Mounting, alpha: np.ndarray | float, beta: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Pin-to-pin lengths of both cylinders (paper Eqs 12 and 13), by :func:`pin_lengths`.

    Parameters
    ----------
    mount : Mounting
        Pin distances a1, b1, b2, c2, m.
    alpha, beta : float or ndarray
        Joint angles, rad.

    Returns
    -------
    r_ac1, r_ac2 : ndarray
        Cylinder lengths, m, shapes of ``alpha`` and ``beta``.
    """
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    return pin_lengths(mount.a1, mount.b1, mount.b2, mount.c2, np.cos(0.5 * alpha), np.sin(0.5 * beta))


def moment_arms(mount: Mounting, alpha, beta) -> tuple[np.ndarray, np.ndarray]:
    """Exact moment arm of each cylinder about its joint: ``d r_ac / d q``, by :func:`pin_moment_arms`.

    A cylinder pushing with force ``F`` applies the joint torque ``F * d r / d q``.

    Parameters
    ----------
    mount : Mounting
        Pin distances, m.
    alpha, beta : float or ndarray
        Joint angles, rad.

    Returns
    -------
    h1, h2 : ndarray
        Moment arms, m (signed).
    """
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    r1, r2 = cylinder_lengths(mount, alpha, beta)
    return pin_moment_arms(mount.a1, mount.b1, mount.b2, mount.c2, np.sin(alpha), np.sin(beta), r1, r2)


def cylinder_rates(mount: Mounting, alpha: np.ndarray, beta: np.ndarray, alpha_dot: np.ndarray,
                   beta_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder extension speeds from joint rates: the moment arms times the joint rates.

    Parameters
    ----------
    mount : Mounting
        Pin distances, m.
    alpha, beta : ndarray
        Joint angles, rad.
    alpha_dot, beta_dot : ndarray
        Joint rates, rad/s.

    Returns
    -------
    v1, v2 : ndarray
        Extension speeds, m/s (positive = extending).
    """
    h1, h2 = moment_arms(mount, alpha, beta)
    return h1 * alpha_dot, h2 * beta_dot


def length_limits(mount: Mounting) -> dict[str, tuple[float, float]]:
    """Geometrically possible length range of each cylinder, m.

    Parameters
    ----------
    mount : Mounting
        Pin distances, m.

    Returns
    -------
    dict
        ``{'r_ac1': (|a1-b1|, a1+b1), 'r_ac2': (|b2-c2|, b2+c2)}``.
    """
    return {"r_ac1": (abs(mount.a1 - mount.b1), mount.a1 + mount.b1),
            "r_ac2": (abs(mount.b2 - mount.c2), mount.b2 + mount.c2)}


def joint_angles_from_cylinders(mount: Mounting, r_ac1: np.ndarray | float,
                                r_ac2: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Invert Eqs 12-13: joint angles from measured cylinder lengths.

    With the angles, :func:`loadarm.arm.kinematics.forward` turns an encoder
    reading into a coupler position. ``alpha`` is returned in ``[0, pi]`` and
    ``beta`` in ``[0, pi]``: the range over which Eqs 12-13 are one-to-one.

    Parameters
    ----------
    mount : Mounting
        Pin distances, m.
    r_ac1, r_ac2 : float or ndarray
        Cylinder pin-to-pin lengths, m.

    Returns
    -------
    alpha, beta : ndarray
        Joint angles, rad.

    Raises
    ------
    ActuatorError
        If a length lies outside what the triangle of pins allows.
    """
    r1 = np.asarray(r_ac1, dtype=float)
    r2 = np.asarray(r_ac2, dtype=float)
    lim = length_limits(mount)
    tol = 1e-12
    for name, r, (lo, hi) in (("r_ac1", r1, lim["r_ac1"]), ("r_ac2", r2, lim["r_ac2"])):
        bad = ~np.isfinite(r) | (r < lo - tol) | (r > hi + tol)
        if np.any(bad):
            v = float(np.ravel(r)[int(np.argmax(np.ravel(bad)))])
            raise ActuatorError(f"cylinder length {name} = {v!r} m is impossible for this mounting: "
                                f"valid range [{lo:.6g}, {hi:.6g}] m")
    a1, b1, b2, c2 = mount.a1, mount.b1, mount.b2, mount.c2
    cos_pa = np.clip((a1 * a1 + b1 * b1 - r1 * r1) / (2 * a1 * b1), -1.0, 1.0)   # cos(pi - alpha)
    cos_b = np.clip((c2 * c2 + b2 * b2 - r2 * r2) / (2 * c2 * b2), -1.0, 1.0)
    return np.pi - np.arccos(cos_pa), np.arccos(cos_b)


@dataclass(frozen=True, slots=True)
class ValveCommand:
    """Valve voltages of a plan, V; ``u1``, ``u2`` have the plan's sample shape."""

    u1: np.ndarray
    u2: np.ndarray
    volts_per_metre: float
    valve_range: float

    def __iter__(self):
        return iter((self.u1, self.u2))


def valve_voltages(r_ac1: np.ndarray, r_ac2: np.ndarray, stored: tuple[float, float], *, volts_per_metre: float,
                   valve_range: float, times: np.ndarray | None = None) -> ValveCommand:
    """Proportional-valve command: displacement from the stored pose times a scale (paper Section 5).

    Parameters
    ----------
    r_ac1, r_ac2 : ndarray
        Cylinder lengths along the plan, m.
    stored : tuple of float
        Cylinder lengths ``(r_ac1, r_ac2)`` in the stored pose, m.
    volts_per_metre : float
        Scale ``k``, V/m (> 0).
    valve_range : float
        Symmetric command range, V (> 0).
    times : ndarray, optional
        Sample times, s, used only to say *when* a limit is exceeded.

    Returns
    -------
    ValveCommand
        ``u = k (r_ac - r_ac,stored)``, V; positive means extension.

    Raises
    ------
    ValveRangeError
        If any sample would need more than ``valve_range`` volts: never a
        silent clip.
    """
    if not (math.isfinite(volts_per_metre) and volts_per_metre > 0):
        raise ValveRangeError(f"volts_per_metre must be > 0 V/m, got {volts_per_metre!r}")
    if not (math.isfinite(valve_range) and valve_range > 0):
        raise ValveRangeError(f"valve_range_V must be > 0 V, got {valve_range!r}")
    u1 = volts_per_metre * (np.asarray(r_ac1, dtype=float) - stored[0])
    u2 = volts_per_metre * (np.asarray(r_ac2, dtype=float) - stored[1])
    for name, u in (("u1 (cylinder 1)", u1), ("u2 (cylinder 2)", u2)):
        peak = int(np.argmax(np.abs(u))) if u.size else 0
        if u.size and abs(float(u.flat[peak])) > valve_range:
            when = f" at t = {float(times.flat[peak]):.2f} s" if times is not None else f" at sample {peak}"
            raise ValveRangeError(
                f"valve command {name} would reach {float(u.flat[peak]):+.3f} V{when}, beyond the valve range "
                f"+/-{valve_range:g} V; lower actuators.volts_per_metre ({volts_per_metre:g} V/m) or raise "
                "actuators.valve_range_V")
    return ValveCommand(u1, u2, volts_per_metre, valve_range)


def solve_ik_cylinders(arm: Arm, mount: Mounting, x: np.ndarray, y: np.ndarray, *,
                       chunk: int = IK_CHUNK) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Joint angles and cylinder lengths for many coupler positions at once (fused Eqs 5-13).

    The same mathematics as :func:`loadarm.arm.kinematics.inverse` followed by
    :func:`cylinder_lengths`, fused so that no trigonometric function is
    evaluated except the two ``atan2`` that return the angles, and processed
    in cache-sized blocks with preallocated buffers. The cylinder lengths use
    ``1 - cos(beta) = (r - (b - c)) (r + (b - c)) / (2bc)`` and ``1 + cos(alpha)``
    from the sine/cosine products, so they need no angle at all.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    mount : Mounting
        Cylinder pin distances.
    x, y : ndarray, shape (n,)
        Coupler positions, m.
    chunk : int
        Block size (points).

    Returns
    -------
    alpha, beta, r_ac1, r_ac2 : ndarray, shape (n,)
        Joint angles (rad) and cylinder lengths (m).

    Raises
    ------
    UnreachableError
        If any point is out of reach (checked before any result is produced).
    """
    x = np.ascontiguousarray(x, dtype=float).ravel()
    y = np.ascontiguousarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError(f"x and y must have the same length, got {x.size} and {y.size}")
    n = x.size
    a, b, c = arm.a, arm.b, arm.c
    lo2 = max(arm.r_min - ROUNDOFF_M, 0.0) ** 2
    hi2 = (arm.r_max + ROUNDOFF_M) ** 2
    d, S, k = b - c, b + c, 1.0 / (2.0 * b * c)
    e1, f1 = (mount.a1 - mount.b1) ** 2, 2.0 * mount.a1 * mount.b1
    e2, f2 = (mount.c2 - mount.b2) ** 2, 2.0 * mount.b2 * mount.c2
    alpha, beta, r1, r2 = (np.empty(n) for _ in range(4))
    m = min(chunk, max(n, 1))
    dy, rr, r, om, op, sb, sg, cg, t1, t2 = (np.empty(m) for _ in range(10))
    for i in range(0, n, chunk):
        j = min(i + chunk, n)
        w = j - i
        xs = x[i:j]
        Dy, RR, R, OM, OP, SB, SG, CG, T1, T2 = (v[:w] for v in (dy, rr, r, om, op, sb, sg, cg, t1, t2))
        np.subtract(a, y[i:j], out=Dy)
        np.multiply(xs, xs, out=RR)
        np.multiply(Dy, Dy, out=T1)
        np.add(RR, T1, out=RR)
        if not (RR.min() >= lo2 and RR.max() <= hi2 and RR.min() > 0):   # also catches NaN
            check_reachable(arm, xs, y[i:j])   # raises, naming the first bad point (NaN included)
        np.sqrt(RR, out=R)
        # 1 - cos(beta) and 1 + cos(beta), both without cancellation
        np.subtract(R, d, out=T1)
        np.add(R, d, out=T2)
        np.multiply(T1, T2, out=OM)
        np.multiply(OM, k, out=OM)
        np.subtract(S, R, out=T1)
        np.add(S, R, out=T2)
        np.multiply(T1, T2, out=OP)
        np.multiply(OP, k, out=OP)
        np.maximum(OM, 0.0, out=OM)   # round-off only: the radii were checked above
        np.maximum(OP, 0.0, out=OP)
        np.multiply(OM, OP, out=SB)
        np.sqrt(SB, out=SB)                       # sin(beta)
        np.subtract(OP, OM, out=T1)
        np.multiply(T1, 0.5, out=T1)              # cos(beta)
        np.arctan2(SB, T1, out=beta[i:j])
        # gamma terms scaled by r: r sin(gamma) = c sin(beta), r cos(gamma) = b - c cos(beta)
        np.multiply(SB, c, out=SG)
        np.multiply(T1, -c, out=CG)
        np.add(CG, b, out=CG)
        # r^2 sin(alpha) = (r sg) dy + (r cg) x ; r^2 cos(alpha) = (r sg) x - (r cg) dy
        np.multiply(SG, Dy, out=T1)
        np.multiply(CG, xs, out=T2)
        np.add(T1, T2, out=T1)
        np.multiply(SG, xs, out=T2)
        np.multiply(CG, Dy, out=SB)
        np.subtract(T2, SB, out=T2)
        np.arctan2(T1, T2, out=alpha[i:j])
        # 1 + cos(alpha) = (r^2 + r^2 cos(alpha)) / r^2
        np.add(RR, T2, out=T2)
        np.divide(T2, RR, out=T2)
        np.maximum(T2, 0.0, out=T2)
        np.multiply(T2, f1, out=T2)
        np.add(T2, e1, out=T2)
        np.sqrt(T2, out=r1[i:j])
        np.multiply(OM, f2, out=OM)
        np.add(OM, e2, out=OM)
        np.sqrt(OM, out=r2[i:j])
    return alpha, beta, r1, r2


def coupler_from_cylinders(arm: Arm, mount: Mounting, r_ac1, r_ac2) -> tuple[np.ndarray, np.ndarray]:
    """Coupler position from two encoder readings: cylinder lengths -> joint angles -> position.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    mount : Mounting
        Pin distances.
    r_ac1, r_ac2 : float or ndarray
        Cylinder pin-to-pin lengths, m.

    Returns
    -------
    x, y : ndarray
        Coupler position, m (arm plane).

    Raises
    ------
    ActuatorError
        If a length is impossible for the mounting.
    """

    alpha, beta = joint_angles_from_cylinders(mount, r_ac1, r_ac2)
    return forward(arm, alpha, beta)
