"""Component equations of the electro-hydraulic circuit (paper Fig. 11).

Each function is one component's law, compiled with numba so that the same
code serves the fast fixed-step simulator, the SciPy ``solve_ivp`` reference
and the unit tests. Pressures are gauge, Pa; flows m^3/s; the valve spool
position is normalised to [-1, 1] (full stroke). See ``docs/hydraulics.md``
for the equations and the reasoning behind every default.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

from loadarm._numba import njit

__all__ = ["orifice_flow", "orifice_slope", "valve_flows", "effective_opening", "pump_flow", "relief_flow",
           "cylinder_friction", "end_stop_force", "valve_coefficient", "spool_discretisation"]


@njit(cache=True)
def orifice_flow(k, dp, p_lam):
    """Turbulent orifice flow with a laminar region: ``k dp / (dp^2 + p_lam^2)^(1/4)``.

    For ``|dp| >> p_lam`` this is the square-root law ``k sign(dp) sqrt(|dp|)``;
    near zero it is linear, so the derivative stays finite.

    Parameters
    ----------
    k : float
        Flow coefficient times opening, m^3/(s Pa^0.5).
    dp : float
        Pressure drop across the orifice, Pa.
    p_lam : float
        Transition pressure, Pa.

    Returns
    -------
    float
        Flow in the direction of the drop, m^3/s.
    """
    return k * dp / math.sqrt(math.sqrt(dp * dp + p_lam * p_lam))


@njit(cache=True)
def orifice_slope(k, dp, p_lam):
    """Derivative of :func:`orifice_flow` with respect to ``dp``, m^3/(s Pa).

    Parameters
    ----------
    k : float
        Flow coefficient times opening, m^3/(s Pa^0.5).
    dp : float
        Pressure drop, Pa.
    p_lam : float
        Transition pressure, Pa.

    Returns
    -------
    float
        ``d Q / d dp`` (>= 0).
    """
    s = dp * dp + p_lam * p_lam
    return k * (s - 0.5 * dp * dp) / (s * math.sqrt(math.sqrt(s)))


@njit(cache=True)
def effective_opening(x, overlap):
    """Opening of a land after the spool overlap: ``sign(x) max(|x| - o, 0) / (1 - o)``.

    Parameters
    ----------
    x : float
        Spool position, normalised (-1..1).
    overlap : float
        Overlap as a fraction of stroke (0 = critical centre).

    Returns
    -------
    float
        Effective opening, -1..1.
    """
    a = abs(x) - overlap
    if a <= 0.0:
        return 0.0
    return math.copysign(a / (1.0 - overlap), x)


@njit(cache=True)
def valve_flows(x, ps, pt, pA, pB, kv, overlap, p_lam):
    """Flows of a 4/3-way critical-centre valve into the cylinder chambers.

    ``x > 0`` connects P->A and B->T, ``x < 0`` connects P->B and A->T, each
    land a turbulent orifice of coefficient ``kv |x_eff|``.

    Parameters
    ----------
    x : float
        Spool position, normalised.
    ps, pt : float
        Supply and tank pressure, Pa.
    pA, pB : float
        Chamber pressures, Pa.
    kv : float
        Land flow coefficient at full opening, m^3/(s Pa^0.5).
    overlap : float
        Spool overlap fraction.
    p_lam : float
        Laminar transition pressure, Pa.

    Returns
    -------
    qA, qB, qP, dqA_dpA, dqB_dpB, dqP_dps, loss : float
        Flow into A and into B, flow drawn from supply (m^3/s), the
        derivatives of those flows with respect to their own node pressure
        (m^3/(s Pa), all <= 0 or >= 0 as signed), and the throttling power
        lost in the open lands (W).
    """
    xe = effective_opening(x, overlap)
    k = kv * abs(xe)
    if xe > 0.0:
        qpa = orifice_flow(k, ps - pA, p_lam)
        qbt = orifice_flow(k, pB - pt, p_lam)
        loss = qpa * (ps - pA) + qbt * (pB - pt)
        return (qpa, -qbt, qpa, -orifice_slope(k, ps - pA, p_lam), -orifice_slope(k, pB - pt, p_lam),
                orifice_slope(k, ps - pA, p_lam), loss)
    if xe < 0.0:
        qpb = orifice_flow(k, ps - pB, p_lam)
        qat = orifice_flow(k, pA - pt, p_lam)
        loss = qpb * (ps - pB) + qat * (pA - pt)
        return (-qat, qpb, qpb, -orifice_slope(k, pA - pt, p_lam), -orifice_slope(k, ps - pB, p_lam),
                orifice_slope(k, ps - pB, p_lam), loss)
    return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@njit(cache=True)
def pump_flow(ps, q_max, p_comp, band):
    """Pressure-compensated pump: full flow below ``p_comp - band``, none at ``p_comp``.

    Parameters
    ----------
    ps : float
        Supply pressure, Pa.
    q_max : float
        Flow at full displacement, m^3/s.
    p_comp : float
        Compensator setting, Pa.
    band : float
        Regulation band, Pa.

    Returns
    -------
    q, dq_dps : float
        Pump flow (m^3/s) and its slope (m^3/(s Pa)).
    """
    f = (p_comp - ps) / band
    if f >= 1.0:
        return q_max, 0.0
    if f <= 0.0:
        return 0.0, 0.0
    return q_max * f, -q_max / band


@njit(cache=True)
def relief_flow(ps, q_max, p_relief, band):
    """Relief valve: linear from cracking to full pump flow ``band`` above it.

    Parameters
    ----------
    ps : float
        Supply pressure, Pa.
    q_max : float
        Flow at ``p_relief + band``, m^3/s.
    p_relief : float
        Cracking pressure, Pa.
    band : float
        Override, Pa.

    Returns
    -------
    q, dq_dps : float
        Relief flow to tank (m^3/s) and its slope.
    """
    if ps <= p_relief:
        return 0.0, 0.0
    return q_max * (ps - p_relief) / band, q_max / band


@njit(cache=True)
def cylinder_friction(v, b, fc, vs):
    """Viscous plus smoothed Coulomb friction ``b v + fc tanh(v / vs)``, N (opposes motion).

    Parameters
    ----------
    v : float
        Extension speed, m/s.
    b : float
        Viscous coefficient, N s/m.
    fc : float
        Coulomb force, N.
    vs : float
        Smoothing velocity, m/s.

    Returns
    -------
    float
        Friction force, N, in the direction of ``v``.
    """
    return b * v + fc * math.tanh(v / vs)


@njit(cache=True)
def end_stop_force(x, v, stroke, k, c):
    """Force of the end stops on the piston, N (positive = pushing towards extension).

    Parameters
    ----------
    x : float
        Piston position from fully retracted, m.
    v : float
        Extension speed, m/s.
    stroke : float
        Usable stroke, m.
    k, c : float
        Stop stiffness (N/m) and damping (N s/m); damping only while pressing.

    Returns
    -------
    float
        Contact force, N.
    """
    if x < 0.0:
        f = -k * x - c * v
        return f if f > 0.0 else 0.0
    if x > stroke:
        f = -k * (x - stroke) - c * v
        return f if f < 0.0 else 0.0
    return 0.0


def valve_coefficient(nominal_flow: float, nominal_drop: float) -> float:
    """Land flow coefficient ``kv = Q_N / sqrt(dp_N / 2)``, m^3/(s Pa^0.5).

    Parameters
    ----------
    nominal_flow : float
        Rated flow at full opening, m^3/s.
    nominal_drop : float
        Rated drop over both lands, Pa (half per land).

    Returns
    -------
    float
    """
    return nominal_flow / math.sqrt(nominal_drop / 2.0)


def spool_discretisation(omega: float, zeta: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of the spool's second-order model.

    ``x'' = omega^2 (u - x) - 2 zeta omega x'`` with the input ``u`` held over
    ``dt``: ``[x, x']_{n+1} = Phi [x, x']_n + Gamma u_n``, from the matrix
    exponential (no integration error at any step size).

    Parameters
    ----------
    omega : float
        Natural frequency, rad/s.
    zeta : float
        Damping ratio.
    dt : float
        Step, s.

    Returns
    -------
    Phi : ndarray, shape (2, 2)
    Gamma : ndarray, shape (2,)
    """
    A = np.array([[0.0, 1.0], [-omega ** 2, -2.0 * zeta * omega]])
    B = np.array([0.0, omega ** 2])
    big = np.zeros((3, 3))
    big[:2, :2] = A * dt
    big[:2, 2] = B * dt
    E = expm(big)
    return E[:2, :2].copy(), E[:2, 2].copy()
