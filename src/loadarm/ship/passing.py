"""Loads on the moored ship from a ship passing along the berth (issue 28, item 3).

The model is the slender-body theory of **Wang (1975)**: S. Wang, *Dynamic effects of ship passage on moored
vessels*, Journal of the Waterways, Harbors and Coastal Engineering Division, ASCE, 101 (WW3), 247-258. Both
hulls are slender bodies at zero Froude number (the free surface a rigid plane: no waves), the passing ship a
line of sources of strength ``-U dA/dx`` along its track, the moored ship held in the unsteady flow they make.
With ``S_1(x_1)`` and ``S_2(x_2)`` the sectional area curves of the moored and of the passing ship, ``xi`` the
passing ship's midships ahead of the moored ship's (the stagger), ``eta`` the lateral distance between their
centre lines and ``U`` the passing speed, Wang's loads on the moored ship (surge force, sway force towards the
passing ship, yaw moment about midships) are the double integrals over the two hulls::

    F_x = -rho U^2 / (2 pi)    int int S1'(x1) S2'(x2) (x1 - x2 - xi) / R^3 dx2 dx1
    F_y =  rho U^2 eta / pi    int int S1'(x1) S2'(x2) / R^3 dx2 dx1
    N   =  rho U^2 eta / pi    int int [S1(x1) + x1 S1'(x1)] S2'(x2) / R^3 dx2 dx1
    R^2 = (x1 - x2 - xi)^2 + eta^2

(Wang's equations for F_xi, F_eta and M; the surge force is the pressure ``-rho dphi/dt`` of the passing ship's
potential on the moored ship's sections, the sway force and the yaw moment its cross flow's acceleration on the
sections' displaced and added mass, integrated by parts.) The sectional area curves are Wang's parabolas
``S(x) = A_m (1 - (2 x / L)^2)``, ``A_m`` the midship section's area.

**Finite depth**, by images: between the rigid free surface and a flat bottom at depth ``h`` the passing ship's
source line has images ``2 n h`` above and below it (``n = +-1, +-2, ...``), so ``R^-3`` becomes
``Q = sum_n (R^2 + (2 n h)^2)^(-3/2)`` in all three integrals. In deep water (``h`` far beyond ``eta`` and the
lengths) this is Wang's; where ``eta`` is many depths ``Q -> 1 / (h R^2)``, the flow of Tuck (1966, *Shallow-water
flows past slender bodies*, J. Fluid Mech. 26, 81-95) spread over the depth, which raises the loads and slows
their decay with separation (``eta^-3`` instead of ``eta^-4``). The images do not see the keel's blockage (a
draft near the depth); the range of validity below leaves it out.

**Range of validity** (refused outside, :class:`PassingShipRangeError`, one line naming the parameter, its value
and the range; :func:`check_range`, declared with the berth file's ``[passing_ship]`` in
:mod:`loadarm.params.berth`, which refuses them as it reads the file):

* separation: at least the sum of the two beams and at least 0.2 of the moored ship's length (slender bodies,
  a gap between them), at most 5 moored-ship lengths (beyond, the loads are negligible);
* water depth: at least 1.5 times either ship's draft (keel clearance half the draft or more: the images'
  line sources stand for the hulls);
* speed: depth Froude number ``U / sqrt(g h)`` at most 0.5 (no waves: Wang's zero Froude number), above 0.

The loads are deterministic and slow: a passing ship's time scale is ``eta / U`` and ``(L1 + L2) / U``, a minute
and more at berth-side speeds, well below :data:`loadarm.ship.motion.LF_CUTOFF`, so the low-frequency
integration takes them without a low-pass (``tests/test_passing.py`` checks the spectrum of the scenario's).

Checks (``tests/test_passing.py``): the Gauss-Legendre quadrature against scipy's adaptive quadrature of the
integrals before integration by parts; the image sum against its deep and shallow limits; the symmetries about
closest approach and the speed squared; the far-field decay of two dipoles; and a worked example of the
finite-depth formula (N. Barczak's MathCAD sheet of Wang's formula: 7.644e4 lbf, reproduced within 0.1 %).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.interpolate import CubicSpline

from loadarm.params.berth import RHO_SEA, PassingShipRangeError
from loadarm.params.berth import check_passing_range as check_range

__all__ = [
    "MOORED_MIDSHIP_COEFFICIENT",
    "PassingShipRangeError",
    "add_passing_load",
    "check_range",
    "kernel_sum",
    "passing_load",
    "wang_loads",
]

#: The moored ship's midship section coefficient (its midship area is ``0.98 B T``, as the current load's).
MOORED_MIDSHIP_COEFFICIENT = 0.98
#: Gauss-Legendre points along each hull (the kernel's width is the separation, at least 0.2 of a length).
N_GAUSS = 48
#: Images summed term by term each side; beyond them the sum's tail is its integral from ``N_IMAGES + 1/2``.
N_IMAGES = 24


def kernel_sum(a2, depth: float, n_images: int = N_IMAGES):
    """``Q(a^2) = sum_n (a^2 + (2 n h)^2)^(-3/2)`` over the passing ship's images in the bottom and the surface
    (``n`` all integers; deep water, ``h`` infinite: ``a^-3``). Terms to ``|n| = n_images``, the tail beyond as
    its integral from ``m = n_images + 1/2`` (midpoint rule, with its first Euler-Maclaurin correction
    ``f'(m) / 24``), ``1 / (8 h^3 m^2 sqrt(1 + x) (1 + sqrt(1 + x)))`` with ``x = a^2 / (2 h m)^2``, written
    without cancellation: within 1e-7 of the sum to 2000 images.

    Parameters
    ----------
    a2 : array_like
        Squared horizontal distance, m^2 (positive).
    depth : float
        m (``inf``: deep water).
    n_images : int

    Returns
    -------
    ndarray
        m^-3.
    """
    a2 = np.asarray(a2, dtype=float)
    q = a2 ** -1.5
    if not math.isfinite(depth):
        return q
    h2 = 4.0 * depth * depth
    for n in range(1, n_images + 1):
        q += 2.0 * (a2 + h2 * n * n) ** -1.5
    m = n_images + 0.5
    r = np.sqrt(1.0 + a2 / (h2 * m * m))
    q += 2.0 / (8.0 * depth ** 3 * m * m * r * (1.0 + r))
    q -= depth * depth * m * (a2 + h2 * m * m) ** -2.5          # the midpoint rule's first correction, f'(m) / 24
    return q


def _hull(length: float, area: float, n: int):
    """Gauss-Legendre nodes along a parabolic hull (midships at 0), weights, ``S`` and ``S'``."""
    u, w = np.polynomial.legendre.leggauss(n)
    x = 0.5 * length * u
    return x, 0.5 * length * w, area * (1.0 - (2.0 * x / length) ** 2), -8.0 * area * x / length ** 2


def wang_loads(stagger, separation: float, speed: float, moored: tuple[float, float], passing: tuple[float, float],
               depth: float = math.inf, rho: float = RHO_SEA, n_gauss: int = N_GAUSS):
    """Wang's (1975) surge force, sway force and yaw moment on the moored ship, in its frame, for the passing
    ship's midships ``stagger`` ahead of the moored ship's (vectorised over ``stagger``; the formulas are the
    module's). No range check (:func:`check_range`).

    Parameters
    ----------
    stagger : array_like
        Passing ship's midships along the moored ship's x from its midships, m.
    separation : float
        The passing ship's centre line along the moored ship's y, m (signed: positive to port).
    speed : float
        Along the moored ship's x, m/s (signed; the loads go with its square).
    moored, passing : tuple of float
        Length between perpendiculars and midship section area of each, m and m^2.
    depth : float
        m (``inf``: Wang's deep water).
    rho : float
        kg/m^3.
    n_gauss : int
        Quadrature points along each hull.

    Returns
    -------
    ndarray (..., 3)
        Surge force (N, along x), sway force (N, along y), yaw moment about midships (N m, z up).
    """
    xi = np.asarray(stagger, dtype=float)
    x1, w1, s1, ds1 = _hull(moored[0], moored[1], n_gauss)
    x2, w2, _, ds2 = _hull(passing[0], passing[1], n_gauss)
    d0 = (x1[:, None] - x2[None, :]).ravel()
    wf = ((w1 * ds1)[:, None] * (w2 * ds2)[None, :]).ravel()
    wm = ((w1 * (s1 + x1 * ds1))[:, None] * (w2 * ds2)[None, :]).ravel()
    k = rho * speed * speed / math.pi
    flat = xi.reshape(-1)
    out = np.empty((flat.size, 3))
    for i in range(0, flat.size, 128):                    # in blocks: a few MB of pairs at a time
        d = d0 - flat[i:i + 128, None]
        q = kernel_sum(d * d + separation * separation, depth)
        out[i:i + 128] = np.stack([-0.5 * k * ((d * q) @ wf), k * separation * (q @ wf),
                                   k * separation * (q @ wm)], axis=-1)
    return out.reshape(xi.shape + (3,))


@lru_cache(maxsize=16)
def _profile(separation: float, moored: tuple[float, float], passing: tuple[float, float], depth: float):
    """The loads per ``rho U^2`` as cubic splines of the stagger, and the stagger beyond which they are left out
    (10 combined lengths and 10 separations: below 1e-3 of the peak, ``tests/test_passing.py``)."""
    reach = 10.0 * (moored[0] + passing[0] + abs(separation))
    xi = np.linspace(-reach, reach, 2001)
    f = wang_loads(xi, separation, 1.0, moored, passing, depth, rho=1.0)
    f[0] = f[-1] = 0.0
    return CubicSpline(xi, f, axis=0), reach


def passing_load(t, ship, passing) -> np.ndarray:
    """The passing ship's load on the moored ship at times ``t`` (ship frame at the reference heading, about
    midships, as :func:`loadarm.ship.motion._lf_load`'s): the declared passing ship's track is along the berth
    at ``separation`` off the moored ship's centre line on the sea side (berth +x), heading the moored ship's
    way (``same``) or against it, abreast (midships to midships) at ``closest_approach_time``.

    Parameters
    ----------
    t : array_like
        s from the start of the run.
    ship : ShipModel
    passing : loadarm.params.berth.PassingShip

    Returns
    -------
    ndarray (..., 3)
        N, N, N m.

    Raises
    ------
    PassingShipRangeError
        Outside the model's range of validity.
    """
    p = passing
    check_range((ship.length, ship.beam, ship.draft), (p.length, p.beam, p.draft), p.speed, p.separation,
                ship.water_depth)
    y_p = -math.sin(ship.psi0) * p.separation         # the sea side (berth +x) in the ship frame
    u = p.speed if p.heading == "same" else -p.speed
    moored = (float(ship.length), MOORED_MIDSHIP_COEFFICIENT * ship.beam * ship.draft)
    spline, reach = _profile(float(y_p), moored, (p.length, p.midship_coefficient * p.beam * p.draft),
                             float(ship.water_depth))
    xi = u * (np.asarray(t, dtype=float) - p.closest_approach_time)
    return np.where((np.abs(xi) < reach)[..., None], spline(np.clip(xi, -reach, reach)), 0.0) * (RHO_SEA * u * u)


def add_passing_load(f_ship: np.ndarray, ship, every: int, dt: float) -> np.ndarray:
    """``f_ship`` (the low-frequency load, every ``every``-th output sample ``dt`` apart) with the ship's
    declared passing ship's load added; ``f_ship`` itself (the same array) when it has none.

    Parameters
    ----------
    f_ship : ndarray (samples, 3)
    ship : ShipModel
    every : int
    dt : float
        s.

    Returns
    -------
    ndarray (samples, 3)
    """
    passing = getattr(ship, "passing", None)
    if passing is None:
        return f_ship
    t = np.arange(f_ship.shape[0]) * (every * dt)
    return np.ascontiguousarray(f_ship + passing_load(t, ship, passing))
