"""Environmental loads on the moored ship (issue 12, item 4): wind, current, waves, gusts and slow drift.

All formulas vectorised over their angle or frequency arguments; angles in rad inside.

Wind (Blendermann 1994)
    Open coefficients with five parameters per ship type (transverse drag ``CDt``, longitudinal drag over the
    frontal area from ahead and astern, cross-force parameter ``delta``), published in Blendermann (1994) and
    tabulated in Fossen (2021), *Handbook of Marine Craft Hydrodynamics and Motion Control*, 2nd ed., Table 10.x.
    OCIMF's tables are proprietary and not used. With ``theta`` the direction the relative wind blows towards,
    from the bow towards port::

        den = 1 - delta/2 (1 - CDl/CDt) sin^2(2 theta),   CDl = CDl_AF A_F / A_L
        X = q A_F CDl_AF cos(theta) / den,   Y = q A_L CDt sin(theta) / den,
        N = q A_L L (s_L / L + 0.18 (pi/2 - gamma)) CDt sin(theta) / den,   gamma = pi - |theta| (off the bow)

    with ``q = rho_air V^2 / 2``; ``CDl_AF`` takes its "ahead" value when the wind comes from forward of the beam.

Gusts (NPD / Froya spectrum, ISO 19901-1, DNV-RP-C205 eq. 2.3.x)
    ``S(f) = 320 (U0/10)^2 (z/10)^0.45 / (1 + f~^n)^(5/(3n))``, ``f~ = 172 f (z/10)^(2/3) (U0/10)^-0.75``,
    ``n = 0.468``, m^2/s^2/Hz, ``U0`` the 1-hour mean at 10 m.

Current (UFC 4-159-03, ch. 4)
    Transverse ``F_y = rho/2 V^2 L T C_yc sin(theta)``, ``C_yc = C0 + (C1 - C0) (T/d)^K``,
    ``C0 = 0.22 sqrt(chi)``, ``chi = L^2 A_m / (B Vol)``, ``C1 = 3.2``, ``K = 2``: the shallow-water rise (three
    times the deep-water value and more as the keel clearance closes). Longitudinal: form drag
    ``rho/2 V^2 B T 0.1 cos``, skin friction ``rho/2 V^2 S C_f cos`` (ITTC-57 ``C_f``, ``S = 1.7 L T + Vol/T``),
    locked-propeller drag ``rho/2 V^2 A_p 1.0 cos``. Yaw: the transverse force at an eccentricity
    ``e/L = E_C cos(theta)`` (UFC's eccentricity curve peaks towards head and stern currents and vanishes
    abeam; its shape is taken as a cosine, :data:`E_C`).

Waves
    JONSWAP with cos-2s directional spreading (``D = C(s) cos^{2s}((theta - theta0) / 2)``), realised as one
    direction per frequency component (drawn from ``D``: no phase-locked crossing seas).

Slow drift (Newman 1974)
    ``F_j(t) = sgn(m_j) 2 (sum_i a_i sqrt|T_j(w_i, b_i)| cos(w_i t + e_i))^2`` from the mean drift coefficients
    ``T_j`` of :func:`loadarm.ship.hydro.mean_drift``; its mean is ``sum_i a_i^2 T_j`` (the mean drift) and
    its spectrum has the difference frequencies that excite the moored ship's 30-300 s motion.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["BLENDERMANN", "RHO_AIR", "NU_SEA", "E_C", "wind_coefficients", "wind_force", "npd_spectrum",
           "current_coefficients", "current_force", "jonswap", "spreading", "spreading_norm", "sample_directions",
           "uniform_draws"]

#: Density of air, kg/m^3 (ISO 2533 at 15 deg C: 1.225).
RHO_AIR = 1.225
#: Kinematic viscosity of sea water at 15 deg C, m^2/s (ITTC 7.5-02-01-03).
NU_SEA = 1.19e-6
#: Eccentricity of the transverse current force towards head and stern currents, fraction of L.
E_C = 0.2
#: Blendermann (1994) parameters (CDt, CDl_AF ahead, CDl_AF astern, delta), by ship type.
BLENDERMANN = {
    "lng_carrier": (0.70, 0.60, 0.65, 0.50),       # "LNG tanker"
    "tanker": (0.70, 0.90, 0.55, 0.40),            # "tanker, loaded"
}


def wind_coefficients(kind: str, theta, frontal_area: float, lateral_area: float, centroid_x: float,
                      length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blendermann's coefficients for the wind blowing towards ``theta`` (ship frame, from the bow to port).

    Parameters
    ----------
    kind : {'lng_carrier', 'tanker'}
    theta : array_like
        rad.
    frontal_area, lateral_area : float
        A_F, A_L, m^2.
    centroid_x : float
        s_L, m forward of midships.
    length : float
        m.

    Returns
    -------
    cx, cy, cn : ndarray
        Force coefficients over A_F and A_L, moment over A_L L (signs: along ship x, y; moment to port).
    """
    cdt, ahead, astern, delta = BLENDERMANN[kind]
    th = np.angle(np.exp(1j * np.asarray(theta, dtype=float)))           # (-pi, pi]
    cdl_af = np.where(np.cos(th) < 0, ahead, astern)                       # from forward of the beam: ahead
    cdl = cdl_af * frontal_area / lateral_area if lateral_area > 0 else cdl_af
    den = 1.0 - 0.5 * delta * (1.0 - cdl / cdt) * np.sin(2 * th) ** 2
    cx = cdl_af * np.cos(th) / den
    cy = cdt * np.sin(th) / den
    gamma = math.pi - np.abs(th)
    cn = (centroid_x / length + 0.18 * (math.pi / 2 - gamma)) * cy
    return cx, cy, cn


def wind_force(kind: str, speed, theta, frontal_area: float, lateral_area: float, centroid_x: float,
               length: float) -> np.ndarray:
    """Wind force and moment, ship frame.

    Parameters
    ----------
    kind : str
    speed : array_like
        Relative wind speed, m/s.
    theta : array_like
        Direction it blows towards, rad (ship frame).
    frontal_area, lateral_area, centroid_x, length : float

    Returns
    -------
    ndarray (..., 3)
        X, Y (N), N (N m about midships).
    """
    cx, cy, cn = wind_coefficients(kind, theta, frontal_area, lateral_area, centroid_x, length)
    q = 0.5 * RHO_AIR * np.asarray(speed, dtype=float) ** 2
    return np.stack([q * frontal_area * cx, q * lateral_area * cy, q * lateral_area * length * cn], axis=-1)


def npd_spectrum(f, mean_speed: float, z: float = 10.0) -> np.ndarray:
    """NPD (Froya) wind spectrum of the along-wind gust, m^2/s^2/Hz.

    Parameters
    ----------
    f : array_like
        Frequency, Hz (> 0).
    mean_speed : float
        1-hour mean at 10 m, m/s.
    z : float
        Height, m.

    Returns
    -------
    ndarray
    """
    f = np.asarray(f, dtype=float)
    if mean_speed <= 0:
        return np.zeros_like(f)
    n = 0.468
    ft = 172.0 * f * (z / 10.0) ** (2 / 3) * (mean_speed / 10.0) ** -0.75
    return 320.0 * (mean_speed / 10.0) ** 2 * (z / 10.0) ** 0.45 / (1.0 + ft ** n) ** (5.0 / (3.0 * n))


def current_coefficients(length: float, beam: float, draft: float, volume: float, water_depth: float,
                         midship_area: float, propeller_area: float, speed: float, rho: float):
    """UFC 4-159-03 current-load factors, so that the load is ``k * V^2`` per direction.

    Parameters
    ----------
    length, beam, draft, volume, water_depth, midship_area, propeller_area : float
        L, B, T (m), displaced volume (m^3), d (m), A_m (m^2), A_p (m^2).
    speed : float
        Design current speed (for the skin friction's Reynolds number), m/s.
    rho : float

    Returns
    -------
    kx : float
        Longitudinal factor, N s^2/m^2 (times V^2 cos(theta)).
    ky : float
        Transverse factor (times V^2 sin(theta)), with the shallow-water rise.
    cyc : float
        The transverse coefficient C_yc.
    """
    chi = length ** 2 * midship_area / (beam * volume)
    c0 = 0.22 * math.sqrt(chi)
    cyc = c0 + (3.2 - c0) * (draft / water_depth) ** 2
    ky = 0.5 * rho * length * draft * cyc
    rn = max(abs(speed), 0.05) * length / NU_SEA
    cf = 0.075 / (math.log10(rn) - 2.0) ** 2
    wetted = 1.7 * length * draft + volume / draft
    kx = 0.5 * rho * (beam * draft * 0.1 + wetted * cf + propeller_area * 1.0)
    return kx, ky, cyc


def current_force(kx: float, ky: float, length: float, speed, theta) -> np.ndarray:
    """Current force and moment, ship frame.

    Parameters
    ----------
    kx, ky : float
        From :func:`current_coefficients`.
    length : float
    speed : array_like
        Relative current speed, m/s.
    theta : array_like
        Direction it flows towards, rad (ship frame).

    Returns
    -------
    ndarray (..., 3)
    """
    v2 = np.asarray(speed, dtype=float) ** 2
    c, s = np.cos(theta), np.sin(theta)
    fy = ky * v2 * s
    return np.stack([kx * v2 * c, fy, fy * E_C * length * c], axis=-1)


def jonswap(w, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """JONSWAP spectral density, m^2 s/rad, normalised so that ``4 sqrt(m0) = Hs`` over a wide band.

    ``S(w) = a g^2 w^-5 exp(-5/4 (wp/w)^4) gamma^exp(-(w - wp)^2 / (2 s^2 wp^2))``, ``s = 0.07`` below the
    peak, ``0.09`` above.

    Parameters
    ----------
    w : array_like
        rad/s (> 0).
    hs, tp, gamma : float

    Returns
    -------
    ndarray
    """
    w = np.asarray(w, dtype=float)
    if hs <= 0:
        return np.zeros_like(w)
    wp = 2 * math.pi / tp
    m0 = _jonswap_unit_m0(float(gamma)) * wp ** -4.0       # the shape's area scales as wp^-4
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        out = (hs / 4.0) ** 2 / m0 * _jonswap_shape(w, wp, gamma)
    return np.where(w > 0, out, 0.0)


def _jonswap_shape(x, wp: float, gamma: float):
    """The unnormalised JONSWAP shape ``x^-5 exp(-5/4 (wp/x)^4) gamma^r(x)``."""
    s = np.where(x <= wp, 0.07, 0.09)
    return x ** -5.0 * np.exp(-1.25 * (wp / x) ** 4) * gamma ** np.exp(-((x - wp) ** 2) / (2 * s * s * wp * wp))


@functools.lru_cache(maxsize=32)
def _jonswap_unit_m0(gamma: float) -> float:
    """Area of the JONSWAP shape with ``wp = 1`` over 0.2-8 (trapezoid, 8000 points): the spectrum's
    normalisation, once per peakedness (found: integrated again for every sea state, 0.2 ms each)."""
    u = np.linspace(0.2, 8.0, 8000)
    return float(np.trapezoid(_jonswap_shape(u, 1.0, gamma), u))


def spreading_norm(s: float) -> float:
    """``C(s) = Gamma(s + 1) / (2 sqrt(pi) Gamma(s + 1/2))``, so that ``D`` integrates to 1 over a circle.

    Parameters
    ----------
    s : float

    Returns
    -------
    float
    """
    return math.exp(math.lgamma(s + 1) - math.lgamma(s + 0.5)) / (2 * math.sqrt(math.pi))


def spreading(theta, mean: float, s: float) -> np.ndarray:
    """cos-2s directional spreading function, 1/rad.

    Parameters
    ----------
    theta : array_like
        rad.
    mean : float
        Mean direction, rad.
    s : float
        Spreading exponent.

    Returns
    -------
    ndarray
    """
    return spreading_norm(s) * np.abs(np.cos((np.asarray(theta, dtype=float) - mean) / 2)) ** (2 * s)


def uniform_draws(rng: np.random.Generator, n: int, keep: int | None = None) -> np.ndarray:
    """The first ``keep`` of ``n`` uniform draws on [0, 1), the generator left as after all ``n``.

    With a generator that can skip ahead (PCG64, NumPy's default), the ``n - keep`` draws not kept are skipped
    instead of computed (bit for bit the same draws and the same state after; found: the sea's two unused tails
    were a tenth of its draws' cost); any other generator draws them.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
    keep : int, optional
        Default ``n``.

    Returns
    -------
    ndarray (keep,)
    """
    keep = n if keep is None else keep
    if keep < n and hasattr(rng.bit_generator, "advance"):
        u = rng.random(keep)
        rng.bit_generator.advance(n - keep)               # one 64-bit output per double drawn
        return u
    return rng.random(n)[:keep]


@functools.lru_cache(maxsize=64)
def _direction_cdf(s: float) -> tuple[np.ndarray, np.ndarray]:
    """The cos-2s distribution's CDF on 4001 directions over the circle (read-only; a pure function of ``s``,
    memoised: a record holds few spreading values, and the table was a quarter of a sea's draws)."""
    grid = np.linspace(-math.pi, math.pi, 4001)
    pdf = spreading(grid, 0.0, s)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (pdf[1:] + pdf[:-1]) * np.diff(grid))])
    cdf /= cdf[-1]
    grid.setflags(write=False)
    cdf.setflags(write=False)
    return grid, cdf


def sample_directions(rng: np.random.Generator, n: int, mean: float, s: float, keep: int | None = None) \
        -> np.ndarray:
    """Draw ``n`` directions from the cos-2s distribution (inverse of its tabulated CDF).

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
    mean, s : float
    keep : int, optional
        Return only the first ``keep`` of the ``n`` draws (the generator advances by ``n`` all the same).

    Returns
    -------
    ndarray (n,) or (keep,)
        rad.
    """
    grid, cdf = _direction_cdf(float(s))
    return mean + np.interp(uniform_draws(rng, n, keep), cdf, grid)
