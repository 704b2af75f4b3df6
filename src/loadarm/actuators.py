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

from .errors import ActuatorError, ValveRangeError
from .geometry import Mounting

__all__ = [
    "cylinder_lengths",
    "cylinder_rates",
    "joint_angles_from_cylinders",
    "length_limits",
    "ValveCommand",
    "valve_voltages",
]


def cylinder_lengths(mount: Mounting, alpha: np.ndarray | float, beta: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Pin-to-pin lengths of both cylinders (paper Eqs 12 and 13).

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
    a1, b1, b2, c2 = mount.a1, mount.b1, mount.b2, mount.c2
    # Eqs 12-13 in the cancellation-free form b^2 + c^2 - 2bc cos(g) = (b - c)^2 + 4bc sin^2(g/2),
    # exact to round-off even for a nearly closed triangle (g -> 0); 1 - cos(pi - alpha) = 2 cos^2(alpha/2).
    r1 = np.sqrt((a1 - b1) ** 2 + 4.0 * a1 * b1 * np.cos(0.5 * alpha) ** 2)
    r2 = np.sqrt((c2 - b2) ** 2 + 4.0 * c2 * b2 * np.sin(0.5 * beta) ** 2)
    return r1, r2


def cylinder_rates(mount: Mounting, alpha: np.ndarray, beta: np.ndarray, alpha_dot: np.ndarray,
                   beta_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder extension speeds from joint rates (time derivative of Eqs 12-13).

    ``d r_ac1/dt = -a1 b1 sin(alpha) alpha_dot / r_ac1`` and
    ``d r_ac2/dt = b2 c2 sin(beta) beta_dot / r_ac2``.

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
    r1, r2 = cylinder_lengths(mount, alpha, beta)
    v1 = -mount.a1 * mount.b1 * np.sin(alpha) * alpha_dot / r1
    v2 = mount.b2 * mount.c2 * np.sin(beta) * beta_dot / r2
    return v1, v2


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

    With the angles, :func:`loadarm.kinematics.forward` turns an encoder
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
