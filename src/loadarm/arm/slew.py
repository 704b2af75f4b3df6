"""Three-dimensional kinematics: the slew joint about the riser axis plus the planar arm.

Frame (right-handed): origin at the riser base on the jetty deck, ``x``
horizontal away from the jetty towards the ship (the planar model's ``x``),
``y`` horizontal along the berth, ``z`` up (the planar model's ``y``). The
arm's vertical plane turns about the riser axis by the slew angle ``phi``
(positive from ``+x`` towards ``+y``). In that plane the coupler is at radius
``rho = sqrt(x^2 + y^2)`` from the riser axis and height ``z``, which the
planar closed form (:mod:`loadarm.arm.kinematics`) solves. With ``phi = 0`` and
``y = 0`` everything reduces exactly to the paper's 2D case.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import forward, inverse, jacobian_entries, reach_mask
from loadarm.errors import UnreachableError

__all__ = ["JointAngles3D", "forward3d", "inverse3d", "reach_mask3d", "slew_angle", "jacobian3d"]


@dataclass(frozen=True, slots=True)
class JointAngles3D:
    """Slew, inboard and elbow angles, rad; unpacks as ``phi, alpha, beta``."""

    phi: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray

    def __iter__(self):
        return iter((self.phi, self.alpha, self.beta))


def slew_angle(x, y) -> np.ndarray:
    """Slew angle of a point, ``atan2(y, x)``, rad.

    Parameters
    ----------
    x, y : float or ndarray
        Horizontal coordinates, m.

    Returns
    -------
    ndarray
        In (-pi, pi].
    """
    return np.arctan2(np.asarray(y, dtype=float), np.asarray(x, dtype=float))


def forward3d(arm: Arm, phi, alpha, beta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coupler position from slew and joint angles.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    phi, alpha, beta : float or ndarray
        Slew (rad, about the riser axis) and planar joint angles (rad).

    Returns
    -------
    x, y, z : ndarray
        Coupler position, m.
    """
    rho, z = forward(arm, alpha, beta)
    phi = np.asarray(phi, dtype=float)
    return rho * np.cos(phi), rho * np.sin(phi), z


def reach_mask3d(arm: Arm, x, y, z) -> np.ndarray:
    """True where a 3D coupler position is reachable (planar annulus in the slewed plane).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y, z : float or ndarray
        Positions, m.

    Returns
    -------
    ndarray of bool
    """
    return reach_mask(arm, np.hypot(x, y), z)


def inverse3d(arm: Arm, x, y, z, *, check: bool = True) -> JointAngles3D:
    """Slew and joint angles that put the coupler at ``(x, y, z)``.

    The arm works on the ship's side, so the planar radius ``rho`` is taken
    positive and the slew is ``atan2(y, x)``.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    x, y, z : float or ndarray
        Positions, m.
    check : bool
        Raise on unreachable points (default) or return NaN there.

    Returns
    -------
    JointAngles3D

    Raises
    ------
    UnreachableError
        Naming the first unreachable point in 3D.
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    rho = np.hypot(x, y)
    if check:
        ok = reach_mask(arm, rho, z)
        if not ok.all():
            i = np.unravel_index(int(np.argmin(ok)), ok.shape)
            r = float(np.hypot(rho[i], z[i] - arm.a))
            raise UnreachableError(
                f"coupler position ({float(x[i]):.4f}, {float(y[i]):.4f}, {float(z[i]):.4f}) m is out of reach: "
                f"distance from the riser top r = {r:.4f} m, reachable range [{arm.r_min:.4f}, {arm.r_max:.4f}] m",
                point=(float(rho[i]), float(z[i])), r=r, r_min=arm.r_min, r_max=arm.r_max)
    q = inverse(arm, rho, z, check=False)
    return JointAngles3D(slew_angle(x, y), q.alpha, q.beta)


def jacobian3d(arm: Arm, phi: float, alpha: float, beta: float) -> np.ndarray:
    """The 3D Jacobian of the coupler position with respect to (slew, alpha, beta), at one configuration.

    Its planar entries (rows of the radius and the height) are :func:`loadarm.arm.kinematics.jacobian_entries` on
    floats: the same formula as :func:`loadarm.arm.kinematics.jacobian`, without NumPy's per-call cost in the
    guidance cycle; the slew rotates them about the riser.

    Parameters
    ----------
    arm : Arm
    phi, alpha, beta : float
        Slew, inboard and elbow angles, rad.

    Returns
    -------
    ndarray, shape (3, 3)
        ``d(x, y, z) / d(phi, alpha, beta)``, m/rad.
    """
    b, c = arm.b, arm.c
    sa, ca = math.sin(alpha), math.cos(alpha)
    sab, cab = math.sin(alpha - beta), math.cos(alpha - beta)
    rho = b * sa - c * sab
    drho_da, drho_db, dz_da, dz_db = jacobian_entries(b, c, 1.0, ca, sa, cab, sab)
    cp, sp = math.cos(phi), math.sin(phi)
    return np.array([[-rho * sp, drho_da * cp, drho_db * cp],
                     [rho * cp, drho_da * sp, drho_db * sp],
                     [0.0, dz_da, dz_db]])
