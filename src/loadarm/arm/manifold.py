"""The loads a connected, free-wheeling arm puts on the ship's presentation flange (issue 31, item 4).

Once connected, the arm's hydraulics free-wheel: its joints pass no torque, and the arm follows the ship's flange.
What the counterweights leave unbalanced, the product's weight, the wind on the pipes, the inertia of the arm
swept by the ship's motion and the swivels' friction are carried by the flange.

**The chain.** Six revolute joints carry the coupler from the riser: the slew ``phi`` (about the riser's vertical
axis), the inboard ``alpha`` and the outboard ``beta`` (about the hinge axis ``y_phi = Rz(phi) e_y``), and the
style-80 triple swivel's ``s1, s2, s3`` (:mod:`loadarm.arm.swivel`, concentric at the arm's tip ``P``). The
coupler's twist at ``P`` per joint rate is the chain's Jacobian ``J`` (6 x 6, :func:`chain_jacobian`): its linear
rows are the arm's position Jacobian (:func:`loadarm.arm.kinematics.jacobian_entries`, the one formula) and zero
for the swivels, its angular rows the joint axes: ``e_z``, ``y_phi``, ``-y_phi``, ``y_phi``,
``R_tip Ry(s1) e_z`` and the flange's normal.

**The arm's dynamics** are its Lagrangian (:func:`loadarm.arm.dynamics.lagrange_terms`, the one formula of the
planar arm: ``M(q) q'' + c(q, q') + g(q)``) with the slew added. Every lump lies in the arm's vertical plane,
and its own inertia ``I`` (about the hinge axis) is taken as a rod's along its link, so that about the vertical it
is ``I sin^2 psi``; the kinetic energy gains ``I_phi(alpha, beta) phi'^2 / 2`` with
``I_phi = sum(m rho^2 + I sin^2 psi)`` (``rho``: the lump's distance from the riser's axis) and no cross term
(the plane's motion and the slew's are orthogonal), so

    tau_phi = I_phi phi'' + (dI_phi/dalpha alpha' + dI_phi/dbeta beta') phi'
    tau_q   = M q'' + c + g - dI_phi/dq phi'^2 / 2          (q = alpha, beta)

**Equilibrium.** With no joint torque, the wrench ``W_arm = (F, M)`` the flange exerts on the coupler at ``P``
balances the arm's generalised forces less the wind's and the friction's (virtual work):

    J^T W_arm = tau - Q_wind - Q_friction,       tau = (tau_phi, tau_alpha, tau_beta, 0, 0, 0)

(the swivels carry no mass; their torque is their friction alone). The load on the manifold is ``-W_arm``, its
moment carried from ``P`` to the flange's face, ``coupler_length`` ahead along the flange's normal ``n``:
``M_face = M_P - coupler_length n x F``. The six joints' axes are independent away from the swivel chain's
singularity (``s2 = +-90 deg``) and the arm's reach limits, so ``J`` is invertible wherever the arm connects.

**Wind** on each pipe (inboard ``T -> E``, outboard ``E -> P``) is the cross-flow drag ``k |U_n| U_n`` per metre,
``U_n`` the wind's component normal to the pipe and ``k = rho_air C_d D / 2``; uniform along a straight pipe, its
generalised force is its resultant at the pipe's midpoint through that point's Jacobian. The counterweights, the
swivels and the riser are left out of the wind (the riser is fixed; the others are compact).

**Friction**: each joint's Coulomb torque against its motion, ``-mu sign(rate)``; at rest it can hold either way
(:func:`friction_signs` enumerates its extremes).

The flange's axes are the coupler's (:func:`loadarm.arm.swivel.coupler_rotation`): ``x`` the normal towards the
ship (axial, positive: the arm pushes the flange towards the ship), ``y`` across it, horizontal at rest (lateral),
``z`` up at rest (vertical, positive: the arm lifts the flange). The bending moment is the resultant about ``y``
and ``z``, the torsion the moment about ``x``. SI units throughout.

The independent route is MuJoCo (:mod:`loadarm.design.manifold`): the same chain as hinge joints, its inverse
dynamics and its own Jacobian at the flange.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from loadarm.arm.dynamics import G, MassModel, lagrange_constants, lagrange_terms
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import jacobian_entries
from loadarm.arm.swivel import coupler_rotation, rot_y, rot_z

__all__ = [
    "LOAD_NAMES",
    "STILL",
    "FlangeWrench",
    "arm_forces",
    "chain_jacobian",
    "coulomb",
    "flange_axes_loads",
    "flange_wrench",
    "friction_signs",
    "pipe_wind",
    "slew_inertia",
]

#: The five loads at the flange, in the order of every array of them: axial, lateral and vertical force (N),
#: bending and torsion moment (N m); the names of :class:`loadarm.params.bank.ManifoldLoads`' allowables.
LOAD_NAMES = ("axial_force", "lateral_force", "vertical_force", "bending_moment", "torsion_moment")

#: A joint slower than this is at a standstill (its friction holds whatever it must, up to its torque; a record's
#: differences of a still flange are round-off, 1e-15 rad/s): 1e-6 rad/s moves a 20 m arm's tip 20 um/s, far below
#: any moored ship's motion.
STILL = 1e-6

#: Each link's absolute angle from up, ``psi = u alpha + v beta + w``, and the horizontal offset of its hinge
#: from the riser's axis (``b sin alpha`` for the outboard link's, at the elbow; 0 at the riser's top).
_LINK_ANGLE = {"inboard": (1.0, 0.0, 0.0), "outboard": (1.0, -1.0, np.pi), "lever": (1.0, -1.0, 0.0)}


def _f(x):
    return np.asarray(x, dtype=float)


def slew_inertia(masses: MassModel, alpha, beta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arm's moment of inertia about the riser's vertical axis and its derivatives.

    ``I_phi = sum(m rho^2 + I sin^2 psi)`` over the lumps: ``rho`` the lump's horizontal distance from the
    riser's axis, ``psi`` its link's angle from up, ``I`` its own inertia (about axes across its link).

    Parameters
    ----------
    masses : MassModel
    alpha, beta : float or ndarray
        rad.

    Returns
    -------
    i_phi, di_dalpha, di_dbeta : ndarray
        kg m^2, broadcast shape of the inputs.
    """
    a, b = np.broadcast_arrays(_f(alpha), _f(beta))
    length = masses.arm.b
    out = [np.zeros(a.shape) for _ in range(3)]
    for lump in masses.lumps:
        u, v, w = _LINK_ANGLE[lump.link]
        psi = u * a + v * b + w
        s, c = np.sin(psi), np.cos(psi)
        outboard = lump.link == "outboard"
        rho = lump.offset * s + (length * np.sin(a) if outboard else 0.0)
        drho_da = lump.offset * c * u + (length * np.cos(a) if outboard else 0.0)
        drho_db = lump.offset * c * v
        out[0] = out[0] + lump.mass * rho * rho + lump.inertia * s * s
        out[1] = out[1] + 2.0 * lump.mass * rho * drho_da + 2.0 * lump.inertia * s * c * u
        out[2] = out[2] + 2.0 * lump.mass * rho * drho_db + 2.0 * lump.inertia * s * c * v
    return out[0], out[1], out[2]


def arm_forces(masses: MassModel, q, qd, qdd, *, gravity: float = G) -> np.ndarray:
    """The generalised forces the arm's motion and weight ask of its three joints (slew, inboard, outboard).

    Parameters
    ----------
    masses : MassModel
    q, qd, qdd : array_like, shape (..., 3)
        ``(phi, alpha, beta)``, their rates and accelerations: rad, rad/s, rad/s^2.
    gravity : float
        m/s^2.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(tau_phi, tau_alpha, tau_beta)``, N m: what actuators would supply to follow the motion.
    """
    q, qd, qdd = np.broadcast_arrays(_f(q), _f(qd), _f(qdd))
    a, b = q[..., 1], q[..., 2]
    pd, ad, bd = qd[..., 0], qd[..., 1], qd[..., 2]
    k = lagrange_constants(masses)
    m11, m12, m22, c1, c2, g1, g2 = lagrange_terms(k.k11, k.k22, k.k_c, k.g_a, k.g_ab, gravity, np.sin(a),
                                                    np.sin(a - b), np.sin(b), np.cos(b), ad, bd)
    inertia, di_da, di_db = slew_inertia(masses, a, b)
    tau_phi = inertia * qdd[..., 0] + (di_da * ad + di_db * bd) * pd
    tau_a = m11 * qdd[..., 1] + m12 * qdd[..., 2] + c1 + g1 - 0.5 * di_da * pd * pd
    tau_b = m12 * qdd[..., 1] + m22 * qdd[..., 2] + c2 + g2 - 0.5 * di_db * pd * pd
    return np.stack([tau_phi, tau_a, tau_b], axis=-1)


def _linear_jacobian(arm: Arm, q) -> tuple[np.ndarray, np.ndarray]:
    """The tip's and the elbow's position Jacobians, ``(..., 3, 3)`` each (columns: phi, alpha, beta)."""
    phi, a, b = q[..., 0], q[..., 1], q[..., 2]
    sa, ca, sab, cab = np.sin(a), np.cos(a), np.sin(a - b), np.cos(a - b)
    sp, cp = np.sin(phi), np.cos(phi)
    rho = arm.b * sa - arm.c * sab
    drho_da, drho_db, dz_da, dz_db = jacobian_entries(arm.b, arm.c, 1.0, ca, sa, cab, sab)
    zero = np.zeros_like(a)
    tip = np.stack([np.stack([-rho * sp, drho_da * cp, drho_db * cp], axis=-1),
                    np.stack([rho * cp, drho_da * sp, drho_db * sp], axis=-1),
                    np.stack([zero, dz_da, dz_db], axis=-1)], axis=-2)
    elbow = np.stack([np.stack([-arm.b * sa * sp, arm.b * ca * cp, zero], axis=-1),
                      np.stack([arm.b * sa * cp, arm.b * ca * sp, zero], axis=-1),
                      np.stack([zero, -arm.b * sa, zero], axis=-1)], axis=-2)
    return tip, elbow


def chain_jacobian(arm: Arm, q, s) -> np.ndarray:
    """The coupler's twist at the arm's tip per joint rate: the six-joint chain's Jacobian.

    Parameters
    ----------
    arm : Arm
    q : array_like, shape (..., 3)
        ``(phi, alpha, beta)``, rad.
    s : array_like, shape (..., 3)
        The triple swivel's angles, rad.

    Returns
    -------
    ndarray, shape (..., 6, 6)
        Rows: the tip's velocity (3, m/s) and the coupler's angular velocity (3, rad/s); columns: slew, inboard,
        outboard, swivels 1, 2, 3.
    """
    q, s = np.broadcast_arrays(_f(q), _f(s))
    phi, gamma = q[..., 0], q[..., 1] - q[..., 2]
    tip, _ = _linear_jacobian(arm, q)
    j = np.zeros(q.shape[:-1] + (6, 6))
    j[..., :3, :3] = tip
    sp, cp = np.sin(phi), np.cos(phi)
    hinge = np.stack([-sp, cp, np.zeros_like(sp)], axis=-1)
    after1 = rot_z(phi) @ rot_y(gamma + s[..., 0])
    j[..., 5, 0] = 1.0
    j[..., 3:, 1] = hinge
    j[..., 3:, 2] = -hinge
    j[..., 3:, 3] = hinge
    j[..., 3:, 4] = after1[..., :, 2]
    j[..., 3:, 5] = (after1 @ rot_z(s[..., 1]))[..., :, 0]
    return j


def _drag(k: float, wind: np.ndarray, axis: np.ndarray, length: float) -> np.ndarray:
    """Cross-flow drag on a straight pipe of unit ``axis``: ``k L |U_n| U_n``, N."""
    un = wind - np.sum(wind * axis, axis=-1, keepdims=True) * axis
    return k * length * np.linalg.norm(un, axis=-1, keepdims=True) * un


def pipe_wind(arm: Arm, q, wind, k: float) -> np.ndarray:
    """The wind's generalised forces on the slew, inboard and outboard joints, from the drag on the two pipes.

    Parameters
    ----------
    arm : Arm
    q : array_like, shape (..., 3)
        ``(phi, alpha, beta)``, rad.
    wind : array_like, shape (..., 3)
        The wind's velocity in the arm's frame, m/s.
    k : float
        ``rho_air C_d D / 2``, kg/m^2 (N per metre of pipe per (m/s)^2).

    Returns
    -------
    ndarray, shape (..., 3)
        N m.
    """
    q, wind = np.broadcast_arrays(_f(q), _f(wind))
    phi, a, b = q[..., 0], q[..., 1], q[..., 2]
    sp, cp = np.sin(phi), np.cos(phi)
    inboard = np.stack([np.sin(a) * cp, np.sin(a) * sp, np.cos(a)], axis=-1)
    outboard = -np.stack([np.sin(a - b) * cp, np.sin(a - b) * sp, np.cos(a - b)], axis=-1)
    tip, elbow = _linear_jacobian(arm, q)
    f_in = _drag(k, wind, inboard, arm.b)
    f_out = _drag(k, wind, outboard, arm.c)
    mid_in = 0.5 * elbow
    mid_out = 0.5 * (elbow + tip)
    return (np.swapaxes(mid_in, -1, -2) @ f_in[..., None])[..., 0] + \
        (np.swapaxes(mid_out, -1, -2) @ f_out[..., None])[..., 0]


def coulomb(mu, rates, *, still: float = STILL) -> np.ndarray:
    """Coulomb friction on the joints: ``-mu sign(rate)``, none for a joint slower than ``still``.

    Parameters
    ----------
    mu : float or array_like
        Friction torque of each joint, N m.
    rates : array_like, shape (..., 6)
        The six joints' rates, rad/s.
    still : float
        rad/s.

    Returns
    -------
    ndarray, shape (..., 6)
        N m.
    """
    r = _f(rates)
    return np.where(np.abs(r) < still, 0.0, -_f(mu) * np.sign(r))


def friction_signs() -> np.ndarray:
    """The 64 extremes of the six joints' friction at rest (each at ``+mu`` or ``-mu``).

    Returns
    -------
    ndarray, shape (64, 6)
        Each row a choice of signs.
    """
    return np.array(list(itertools.product((-1.0, 1.0), repeat=6)))


@dataclass(frozen=True, slots=True)
class FlangeWrench:
    """The load a connected arm puts on the ship's flange.

    Attributes
    ----------
    force : ndarray, shape (..., 3)
        N, the arm's frame.
    moment : ndarray, shape (..., 3)
        N m, about the flange's face, the arm's frame.
    loads : ndarray, shape (..., 5)
        In the flange's axes, in the order of :data:`LOAD_NAMES`: axial, lateral, vertical force (N, signed),
        bending (N m, >= 0) and torsion (N m, signed).
    """

    force: np.ndarray
    moment: np.ndarray
    loads: np.ndarray


def flange_axes_loads(rotation, force, moment, coupler_length: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A wrench at the arm's tip carried to the flange's face and read in the flange's axes.

    Parameters
    ----------
    rotation : array_like, shape (..., 3, 3)
        The coupler's orientation (columns: normal, lateral, up), the arm's frame.
    force, moment : array_like, shape (..., 3)
        The load on the flange at the arm's tip, N and N m, the arm's frame.
    coupler_length : float
        The face ahead of the tip along the normal, m.

    Returns
    -------
    moment_face : ndarray, shape (..., 3)
        N m, about the face, the arm's frame.
    loads : ndarray, shape (..., 5)
        In the order of :data:`LOAD_NAMES`.
    """
    rotation, force, moment = _f(rotation), _f(force), _f(moment)
    normal = rotation[..., :, 0]
    moment_face = moment - coupler_length * np.cross(normal, force)
    rt = np.swapaxes(rotation, -1, -2)
    f = (rt @ force[..., None])[..., 0]
    m = (rt @ moment_face[..., None])[..., 0]
    loads = np.stack([f[..., 0], f[..., 1], f[..., 2], np.hypot(m[..., 1], m[..., 2]), m[..., 0]], axis=-1)
    return moment_face, loads


def flange_wrench(masses: MassModel, q, qd, qdd, s, *, wind=(0.0, 0.0, 0.0), wind_k: float = 0.0, friction=0.0,
                  coupler_length: float = 0.0, gravity: float = G) -> FlangeWrench:
    """The load of a connected, free-wheeling arm on the ship's flange (vectorised over any leading shape).

    Parameters
    ----------
    masses : MassModel
        The arm's mass model, the product in its pipes included (:func:`loadarm.arm.dynamics.mass_model`).
    q, qd, qdd : array_like, shape (..., 3)
        ``(phi, alpha, beta)``, rates and accelerations: rad, rad/s, rad/s^2.
    s : array_like, shape (..., 3)
        The triple swivel's angles, rad (:func:`loadarm.arm.swivel.swivel_angles`).
    wind : array_like, shape (..., 3)
        The wind's velocity, arm's frame, m/s.
    wind_k : float
        ``rho_air C_d D / 2`` of the pipes, kg/m^2.
    friction : float or array_like, shape (..., 6)
        The friction torques on the six joints (slew, inboard, outboard, swivels 1-3), N m, signed as they act on
        the arm (:func:`coulomb`; ``-mu`` against a positive rate).
    coupler_length : float
        The flange's face ahead of the tip, m.
    gravity : float
        m/s^2.

    Returns
    -------
    FlangeWrench

    Raises
    ------
    ValueError
        Given a non-finite input or a negative ``wind_k`` or ``coupler_length``.
    """
    q, qd, qdd, s = np.broadcast_arrays(_f(q), _f(qd), _f(qdd), _f(s))
    if q.shape[-1] != 3:
        raise ValueError(f"q, qd, qdd and s take 3 angles on their last axis, got shape {q.shape}")
    if not all(np.isfinite(v).all() for v in (q, qd, qdd, s, _f(wind), _f(friction))):
        raise ValueError("flange_wrench: every angle, rate, acceleration, wind and friction must be finite")
    if wind_k < 0 or coupler_length < 0:
        raise ValueError(f"wind_k ({wind_k:g} kg/m^2) and coupler_length ({coupler_length:g} m) must be >= 0")
    tau = np.zeros(q.shape[:-1] + (6,))
    tau[..., :3] = arm_forces(masses, q, qd, qdd, gravity=gravity)
    if wind_k > 0:
        tau[..., :3] -= pipe_wind(masses.arm, q, wind, wind_k)
    tau = tau - _f(friction)
    jt = np.swapaxes(chain_jacobian(masses.arm, q, s), -1, -2)
    on_arm = np.linalg.solve(jt, tau[..., None])[..., 0]
    force, moment = -on_arm[..., :3], -on_arm[..., 3:]
    rotation = coupler_rotation(q[..., 0], q[..., 1], q[..., 2], s[..., 0], s[..., 1], s[..., 2])
    moment_face, loads = flange_axes_loads(rotation, force, moment, coupler_length)
    return FlangeWrench(force, moment_face, loads)
