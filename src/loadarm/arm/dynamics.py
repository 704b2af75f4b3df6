"""Rigid-body dynamics of the counterweighted arm: joint torques, cylinder forces, pressures.

The mass model (:class:`MassModel`, from ``[masses]``) lumps the arm into
bodies carried by three *links*, each a rigid line through a hinge:

``inboard``
    hinge at the riser top ``T``, absolute angle ``psi = alpha`` (measured
    clockwise from up, like ``alpha``); carries the inboard pipe, the elbow
    swivel and the primary counterweight (negative offset: behind the hinge).
``outboard``
    hinge at the elbow ``E``, ``psi = alpha - beta + pi``; carries the
    outboard pipe and the coupler.
``lever``
    the pantograph lever, hinge at ``T``, ``psi = alpha - beta`` (kept
    parallel to the outboard arm, pointing away from it, by an ideal
    massless parallelogram linkage); carries the secondary counterweight.

A lump at offset ``d`` on a link sits at ``base + d (sin psi, cos psi)``.
The joint torques needed to move the arm along ``q(t) = (alpha, beta)`` follow
from Kane's form of Newton-Euler, exact for this tree of rigid bodies:

    tau = sum_i  J_i^T m_i (a_i - g)  +  j_i^T I_i psi_i''

with ``J_i = d p_i / d q`` (2x2), ``a_i`` the lump's acceleration, ``g = (0,
-9.80665) m/s^2``, ``j_i = d psi_i / d q`` and ``I_i`` the lump's own moment of
inertia about its centre of mass. ``tau = (tau_alpha, tau_beta)`` is what the
actuators must supply (positive increases the angle). This is checked against
MuJoCo's ``mj_inverse`` in the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.actuators import moment_arms  # re-exported: the moment arms are geometry (Eqs 12-13), owned there
from loadarm.arm.geometry import Arm, Mounting

__all__ = ["G", "Lump", "MassModel", "mass_model", "joint_torques", "lagrange_terms", "LagrangeConstants", "lagrange_constants",
           "lagrange_torques", "static_torques", "moment_arms",
           "cylinder_forces", "chamber_pressures", "cylinder_areas"]

#: Standard gravity, m/s^2 (ISO 80000-3).
G = 9.80665

_LINKS = ("inboard", "outboard", "lever")


@dataclass(frozen=True, slots=True)
class Lump:
    """One rigid body of the mass model.

    Attributes
    ----------
    name : str
        What it is.
    link : {'inboard', 'outboard', 'lever'}
        The link that carries it.
    offset : float
        Distance of its centre of mass from the link's hinge along the link, m
        (negative: behind the hinge).
    mass : float
        Mass, kg.
    inertia : float
        Moment of inertia about its centre of mass, about the hinge axis, kg m^2.
    """

    name: str
    link: str
    offset: float
    mass: float
    inertia: float

    def __post_init__(self) -> None:
        if self.link not in _LINKS:
            raise ValueError(f"lump link must be one of {_LINKS}, got {self.link!r}")
        if not (self.mass >= 0 and self.inertia >= 0 and math.isfinite(self.offset)):
            raise ValueError(f"lump {self.name!r}: mass and inertia must be >= 0 and offset finite")


@dataclass(frozen=True, slots=True)
class MassModel:
    """The arm's lumps together with its geometry.

    Attributes
    ----------
    arm : Arm
        Link lengths.
    lumps : tuple of Lump
        Every rigid body.
    """

    arm: Arm
    lumps: tuple[Lump, ...]

    @property
    def total_mass(self) -> float:
        """Sum of all lumps, kg."""
        return sum(l.mass for l in self.lumps)

    def by_name(self, name: str) -> Lump:
        """The lump called ``name``."""
        for lump in self.lumps:
            if lump.name == name:
                return lump
        raise KeyError(f"no lump named {name!r}; have {[l.name for l in self.lumps]}")

    def with_counterweights(self, inboard_kg: float, outboard_kg: float) -> "MassModel":
        """A copy with other counterweight masses (same positions).

        Parameters
        ----------
        inboard_kg, outboard_kg : float
            Primary and secondary counterweight masses, kg.

        Returns
        -------
        MassModel
        """
        out = []
        for l in self.lumps:
            if l.name in ("counterweight_inboard", "counterweight_outboard"):
                m = inboard_kg if l.name == "counterweight_inboard" else outboard_kg
                scale = m / l.mass if l.mass > 0 else 0.0
                out.append(Lump(l.name, l.link, l.offset, m, l.inertia * scale if l.mass > 0 else 0.0))
            else:
                out.append(l)
        return MassModel(self.arm, tuple(out))


def _sphere(m: float, r: float) -> float:
    return 0.4 * m * r * r


def mass_model(model, *, fill: float | None = None, arm: Arm | None = None) -> MassModel:
    """Build the lumped mass model from ``[masses]``.

    Parameters
    ----------
    model : ArmModel
        Validated installation.
    fill : float, optional
        Product fill fraction in [0, 1]; default ``masses.fill``.
    arm : Arm, optional
        Geometry to use (default the configured arm).

    Returns
    -------
    MassModel
        Pipes as uniform rods (``I = m L^2 / 12``), lumps as solid spheres of
        radius ``masses.lump_radius`` (``I = 2/5 m r^2``).
    """
    if fill is None and arm is None and getattr(model, "mass", None) is not None:
        return model.mass                      # compiled once with the model
    ms = model.masses
    arm = arm or model.arm
    f = ms.fill if fill is None else float(fill)
    if not (0.0 <= f <= 1.0):
        raise ValueError(f"fill must be in [0, 1], got {fill!r}")
    product_per_m = f * ms.product_density * math.pi * ms.pipe_inner_diameter ** 2 / 4.0
    m_in = (ms.inboard_kg_per_m + product_per_m) * arm.b
    m_out = (ms.outboard_kg_per_m + product_per_m) * arm.c
    r = ms.lump_radius
    lumps = (
        Lump("inboard_pipe", "inboard", arm.b / 2, m_in, m_in * arm.b ** 2 / 12),
        Lump("elbow", "inboard", arm.b, ms.elbow_kg, _sphere(ms.elbow_kg, r)),
        Lump("counterweight_inboard", "inboard", -ms.counterweight_inboard_distance, ms.counterweight_inboard_kg,
             _sphere(ms.counterweight_inboard_kg, r)),
        Lump("outboard_pipe", "outboard", arm.c / 2, m_out, m_out * arm.c ** 2 / 12),
        Lump("coupler", "outboard", arm.c, ms.coupler_kg, _sphere(ms.coupler_kg, r)),
        Lump("counterweight_outboard", "lever", ms.counterweight_outboard_distance, ms.counterweight_outboard_kg,
             _sphere(ms.counterweight_outboard_kg, r)),
    )
    return MassModel(arm, lumps)


def joint_torques(model: MassModel, alpha, beta, alpha_dot=0.0, beta_dot=0.0, alpha_ddot=0.0, beta_ddot=0.0,
                  *, gravity: float = G) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques needed to follow a motion (inverse dynamics).

    Parameters
    ----------
    model : MassModel
        Mass model.
    alpha, beta : float or ndarray
        Joint angles, rad.
    alpha_dot, beta_dot : float or ndarray
        Joint rates, rad/s.
    alpha_ddot, beta_ddot : float or ndarray
        Joint accelerations, rad/s^2.
    gravity : float
        Gravitational acceleration, m/s^2 (0 for inertia alone).

    Returns
    -------
    tau_alpha, tau_beta : ndarray
        Torques the actuators must supply about the inboard hinge and the
        elbow, N m, broadcast shape of the inputs.
    """
    q = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (alpha, beta, alpha_dot, beta_dot, alpha_ddot,
                                                                     beta_ddot)))
    a, b, ad, bd, add, bdd = q
    L = model.arm
    # absolute angles, rates and accelerations of the three links, and d psi / d(alpha, beta)
    links = {
        "inboard": (a, ad, add, (1.0, 0.0)),
        "outboard": (a - b + np.pi, ad - bd, add - bdd, (1.0, -1.0)),
        "lever": (a - b, ad - bd, add - bdd, (1.0, -1.0)),
    }
    sa, ca = np.sin(a), np.cos(a)
    # elbow acceleration (base of the outboard link), and its Jacobian (only through alpha)
    e_acc = (L.b * (ca * add - sa * ad * ad), L.b * (-sa * add - ca * ad * ad))
    e_jac = (L.b * ca, -L.b * sa)
    ta = np.zeros_like(a)
    tb = np.zeros_like(a)
    for lump in model.lumps:
        psi, w, wd, (ja, jb) = links[lump.link]
        s, c = np.sin(psi), np.cos(psi)
        d, m = lump.offset, lump.mass
        ax = d * (c * wd - s * w * w)
        ay = d * (-s * wd - c * w * w)
        jx, jy = d * c, -d * s               # d p / d psi
        if lump.link == "outboard":
            ax = ax + e_acc[0]
            ay = ay + e_acc[1]
            jxa, jya = e_jac[0] + jx * ja, e_jac[1] + jy * ja
        else:
            jxa, jya = jx * ja, jy * ja
        jxb, jyb = jx * jb, jy * jb
        fx = m * ax
        fy = m * (ay + gravity)
        ta = ta + jxa * fx + jya * fy + ja * lump.inertia * wd
        tb = tb + jxb * fx + jyb * fy + jb * lump.inertia * wd
    return ta, tb


def static_torques(model: MassModel, alpha, beta, *, gravity: float = G) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques needed to hold the arm still (gravity and counterweights only).

    Parameters
    ----------
    model : MassModel
        Mass model.
    alpha, beta : float or ndarray
        Joint angles, rad.
    gravity : float
        Gravitational acceleration, m/s^2.

    Returns
    -------
    tau_alpha, tau_beta : ndarray
        Holding torques, N m.
    """
    return joint_torques(model, alpha, beta, gravity=gravity)


def cylinder_forces(mount: Mounting, alpha, beta, tau_alpha, tau_beta, *,
                    min_moment_arm: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder forces that produce given joint torques (positive = pushing).

    Parameters
    ----------
    mount : Mounting
        Pin distances, m.
    alpha, beta : ndarray
        Joint angles, rad.
    tau_alpha, tau_beta : ndarray
        Required joint torques, N m.
    min_moment_arm : float
        Smallest usable moment arm, m: a pose where a cylinder's line passes
        (almost) through its hinge cannot be driven by it.

    Returns
    -------
    F1, F2 : ndarray
        Cylinder forces, N.

    Raises
    ------
    ValueError
        If a moment arm is below ``min_moment_arm`` at any sample.
    """
    h1, h2 = moment_arms(mount, alpha, beta)
    for name, h in (("cylinder 1", h1), ("cylinder 2", h2)):
        bad = np.abs(h) < min_moment_arm
        if np.any(bad):
            v = float(np.ravel(h)[int(np.argmax(np.ravel(bad)))])
            raise ValueError(f"{name} moment arm {v:.2e} m is below {min_moment_arm:g} m: its line passes through "
                             "the hinge and it cannot drive the joint in this pose")
    return np.asarray(tau_alpha) / h1, np.asarray(tau_beta) / h2


def cylinder_areas(bore: float, rod: float) -> tuple[float, float]:
    """Piston and annulus areas of a single-rod cylinder, m^2.

    Parameters
    ----------
    bore, rod : float
        Diameters, m (``rod < bore``).

    Returns
    -------
    A_piston, A_annulus : float
        ``pi bore^2 / 4`` and ``pi (bore^2 - rod^2) / 4``.
    """
    if not (0 < rod < bore):
        raise ValueError(f"need 0 < rod < bore, got rod = {rod} m, bore = {bore} m")
    return math.pi * bore ** 2 / 4, math.pi * (bore ** 2 - rod ** 2) / 4


def chamber_pressures(force, bore: float, rod: float, return_pressure: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Chamber pressures that produce a cylinder force with one chamber at return pressure.

    Force balance ``F = p_A A_piston - p_B A_annulus``. With both chambers at
    return pressure ``p_r`` the cylinder already pushes with ``p_r (A_piston -
    A_annulus)``; above that force the piston side is pressurised (annulus at
    ``p_r``), below it the annulus side (piston side at ``p_r``). The working
    chamber is therefore never below return pressure.

    Parameters
    ----------
    force : float or ndarray
        Cylinder force, N (positive = pushing).
    bore, rod : float
        Diameters, m.
    return_pressure : float
        Pressure of the chamber open to tank, Pa.

    Returns
    -------
    p_A, p_B : ndarray
        Piston-side and rod-side pressures, Pa.
    """
    Ap, Aa = cylinder_areas(bore, rod)
    F = np.asarray(force, dtype=float)
    pr = float(return_pressure)
    push = F >= pr * (Ap - Aa)
    pA = np.where(push, (F + pr * Aa) / Ap, pr)
    pB = np.where(push, pr, (-F + pr * Ap) / Aa)
    return pA, pB


@dataclass(frozen=True, slots=True)
class LagrangeConstants:
    """The mass model reduced to the five constants of the arm's Lagrangian.

    With ``T = sum(m d^2 + I)`` and ``D = sum(m d)`` over the inboard (``in``),
    outboard (``out``) and lever (``lev``) lumps and ``m_out`` the outboard
    mass, the kinetic and potential energies are

    * ``M11 = k11 - 2 k_c cos(beta)``, ``M12 = -k22 + k_c cos(beta)``, ``M22 = k22``
      with ``k11 = T_in + T_lev + m_out b^2 + T_out``, ``k22 = T_lev + T_out``,
      ``k_c = b D_out``;
    * ``V = g (g_a cos(alpha) + g_ab cos(alpha - beta))`` with
      ``g_a = D_in + m_out b`` and ``g_ab = D_lev - D_out``.

    This is a second, independent derivation of :func:`joint_torques`
    (Lagrange instead of Newton-Euler); the tests compare the two.
    """

    k11: float
    k22: float
    k_c: float
    g_a: float
    g_ab: float


def lagrange_constants(model: MassModel) -> LagrangeConstants:
    """Reduce a mass model to its Lagrangian constants.

    Parameters
    ----------
    model : MassModel
        Mass model.

    Returns
    -------
    LagrangeConstants
    """
    b = model.arm.b
    T = {k: 0.0 for k in _LINKS}
    D = {k: 0.0 for k in _LINKS}
    m_out = 0.0
    for l in model.lumps:
        T[l.link] += l.mass * l.offset ** 2 + l.inertia
        D[l.link] += l.mass * l.offset
        if l.link == "outboard":
            m_out += l.mass
    return LagrangeConstants(k11=T["inboard"] + T["lever"] + m_out * b * b + T["outboard"],
                             k22=T["lever"] + T["outboard"], k_c=b * D["outboard"],
                             g_a=D["inboard"] + m_out * b, g_ab=D["lever"] - D["outboard"])


def lagrange_torques(k: LagrangeConstants, alpha, beta, alpha_dot=0.0, beta_dot=0.0, alpha_ddot=0.0,
                     beta_ddot=0.0, *, gravity: float = G) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques from the closed-form Lagrangian, ``tau = M qdd + c(q, qd) + dV/dq``.

    Parameters
    ----------
    k : LagrangeConstants
        From :func:`lagrange_constants`.
    alpha, beta, alpha_dot, beta_dot, alpha_ddot, beta_ddot : float or ndarray
        Motion (rad, rad/s, rad/s^2).
    gravity : float
        m/s^2.

    Returns
    -------
    tau_alpha, tau_beta : ndarray
        N m.
    """
    a, b, ad, bd, add, bdd = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (
        alpha, beta, alpha_dot, beta_dot, alpha_ddot, beta_ddot)))
    m11, m12, m22, c1, c2, g1, g2 = lagrange_terms(k.k11, k.k22, k.k_c, k.g_a, k.g_ab, gravity, np.sin(a),
                                                    np.sin(a - b), np.sin(b), np.cos(b), ad, bd)
    return m11 * add + m12 * bdd + c1 + g1, m12 * add + m22 * bdd + c2 + g2


def lagrange_terms(k11, k22, k_c, g_a, g_ab, gravity, sa, sab, sb, cb, ad, bd):
    """The Lagrangian's terms at one state, on floats or arrays: the one formula of the arm's dynamics, also
    compiled as it is for the 1 kHz plant (:mod:`loadarm.hydraulics.circuit`).

    ``tau = M(beta) q'' + c(q, q') + g(q)`` with ``M = [[m11, m12], [m12, m22]]``.

    Parameters
    ----------
    k11, k22, k_c, g_a, g_ab : float
        :class:`LagrangeConstants`.
    gravity : float
        m/s^2.
    sa, sab, sb, cb : float or ndarray
        ``sin(alpha)``, ``sin(alpha - beta)``, ``sin(beta)``, ``cos(beta)`` (each caller's own way to them).
    ad, bd : float or ndarray
        Joint rates, rad/s.

    Returns
    -------
    m11, m12, m22, c1, c2, g1, g2 : float or ndarray
        The mass matrix, kg m^2; the Coriolis and centrifugal and the gravity torques, N m.
    """
    m11 = k11 - 2.0 * k_c * cb
    m12 = -k22 + k_c * cb
    d11 = 2.0 * k_c * sb            # d M11 / d beta
    d12 = -k_c * sb                 # d M12 / d beta
    c1 = d11 * ad * bd + d12 * bd * bd
    c2 = -0.5 * d11 * ad * ad
    g1 = -gravity * (g_a * sa + g_ab * sab)
    g2 = gravity * g_ab * sab
    return m11, m12, k22, c1, c2, g1, g2
