"""Bound long waves (set-down) on the moored ship in shallow water (issue 28, item 3).

Newman's approximation builds the slow-drift load from the mean drift coefficients alone. In deep water that is
most of it; at a jetty in 20 m of water (depth over draft 1.74) the wave groups carry a second-order long wave
bound to them, the set-down, lowest under the highest waves, travelling with the groups at their group velocity.
Its slope pushes the ship like any long wave: the pressure gradient (Froude-Krylov) plus the diffraction of the
fluid's acceleration, ``F = -(rho V + A(0)) g grad(eta2)`` on a hull short against the long wave (Pinkster 1980,
*Low frequency second order wave exciting forces on floating structures*, ch. 4; the long-wave limit).

The set-down's transfer function
--------------------------------
* For a narrow band the bound wave is ``eta2 = -S_xx / (rho (g h - c_g^2))`` (Longuet-Higgins & Stewart 1962,
  *Radiation stress and mass transport in gravity waves*, J. Fluid Mech. 13, eq. 3.12 with the radiation
  stress ``S_xx = E (2 c_g / c - 1/2)``, ``E = rho g a^2 / 2``): per pair of components of amplitudes ``a_i, a_j``
  at nearly the same frequency, ``-G(w) a_i a_j cos(psi_i - psi_j)`` with
  ``G(w) = g (2 c_g / c - 1/2) / (g h - c_g^2)`` (:func:`setdown_coefficient`).
* For any pair, Hasselmann's (1962) interaction coefficient, *On the non-linear energy transfer in a
  gravity-wave spectrum*, J. Fluid Mech. 12, eqs. 4.2-4.4, for the difference frequency
  (:func:`difference_qtf`): the reference route, ``O(K^2)`` in the components.
* The load in the motion (:func:`setdown_load`) factorises the transfer function as Newman's approximation does
  the drift's, ``G_ij ~ sqrt(G_i G_j)`` (the squared sum of components weighted by ``sqrt(G)``, low-passed),
  times Hasselmann's growth with the difference frequency about the sea's peak (:func:`difference_correction`).
  ``tests/test_longwave.py`` holds it to the pairwise sum with Hasselmann's coefficient.

Left out, and said so: the free (unbound) infragravity waves a coast reflects (they depend on the coast; a
berth with measured infragravity energy needs them as a record); the bound wave's yaw moment (the slope is
uniform along a ship short against waves of 0.5-2 km); the long wave's first-order motion of the ship in heave
and pitch.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.fft import irfft, rfft

from loadarm.ship.hydro import G

__all__ = ["wavenumber", "group_velocity", "setdown_coefficient", "difference_qtf", "setdown_slope", "difference_correction",
           "hull_factor",
           "setdown_load"]


def wavenumber(omega, depth: float) -> np.ndarray:
    """The linear dispersion relation ``w^2 = g k tanh(k h)`` solved for ``k`` (Newton from Eckart's guess, to
    machine precision).

    Parameters
    ----------
    omega : array_like
        rad/s, positive.
    depth : float
        m.

    Returns
    -------
    ndarray
        rad/m.
    """
    w = np.asarray(omega, dtype=float)
    k0 = w * w / G
    k = k0 / np.sqrt(np.tanh(k0 * depth))              # Eckart (1951): within 5 % everywhere
    for _ in range(50):
        t = np.tanh(k * depth)
        f = G * k * t - w * w
        df = G * t + G * k * depth * (1.0 - t * t)
        step = f / df
        k = k - step
        if np.all(np.abs(step) <= 1e-14 * np.abs(k)):
            break
    return k


def group_velocity(omega, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase and group velocity of linear waves in water of depth ``depth``.

    Parameters
    ----------
    omega : array_like
        rad/s.
    depth : float
        m.

    Returns
    -------
    c, c_g : ndarray
        m/s.
    """
    w = np.asarray(omega, dtype=float)
    k = wavenumber(w, depth)
    kh = k * depth
    c = w / k
    x = 2.0 * kh
    return c, 0.5 * c * (1.0 + x / np.sinh(np.minimum(x, 700.0)))      # deep water: the ratio's 0, no overflow


def setdown_coefficient(omega, depth: float) -> np.ndarray:
    """Longuet-Higgins & Stewart's narrow-band set-down per square metre of amplitude, ``G(w) = g (2 c_g / c -
    1/2) / (g h - c_g^2)``, 1/m (positive: the bound wave is ``-G a_i a_j cos(psi_i - psi_j)``).

    Parameters
    ----------
    omega : array_like
        rad/s.
    depth : float
        m.

    Returns
    -------
    ndarray
        1/m.
    """
    c, cg = group_velocity(omega, depth)
    return G * (2.0 * cg / c - 0.5) / (G * depth - cg * cg)


def difference_qtf(w1, w2, theta1, theta2, depth: float) -> np.ndarray:
    """Hasselmann's (1962) second-order elevation per unit amplitudes at the difference frequency ``w1 - w2``
    of two components travelling towards ``theta1`` and ``theta2``: the bound wave is ``D a_1 a_2 cos(psi_1 -
    psi_2)`` (negative ``D``: a set-down). Eqs. 4.2-4.4 of the paper with the second component's frequency and
    wave vector reversed (the difference interaction), the potential's term turned into elevation through the
    linear free-surface condition.

    Parameters
    ----------
    w1, w2 : array_like
        rad/s, ``w1 != w2``.
    theta1, theta2 : array_like
        rad.
    depth : float
        m.

    Returns
    -------
    ndarray
        1/m.
    """
    w1 = np.asarray(w1, dtype=float)
    w2 = -np.asarray(w2, dtype=float)                   # the difference interaction: the second one reversed
    k1, k2 = wavenumber(np.abs(w1), depth), wavenumber(np.abs(w2), depth)
    cos12 = -np.cos(np.asarray(theta1) - np.asarray(theta2))    # and its wave vector too
    k3 = np.sqrt(np.maximum(k1 * k1 + k2 * k2 + 2.0 * k1 * k2 * cos12, 0.0))
    w3 = w1 + w2
    dp = (w3 * ((w1 * w2) ** 2 / G ** 2 - k1 * k2 * cos12)
          - 0.5 * (w1 * k2 * k2 / np.cosh(k2 * depth) ** 2 + w2 * k1 * k1 / np.cosh(k1 * depth) ** 2))
    t1 = dp * G * w3 / (w1 * w2) / (G * k3 * np.tanh(k3 * depth) - w3 * w3)
    t2 = -G * k1 * k2 * cos12 / (2.0 * w1 * w2) + 0.5 * (w1 * w1 + w1 * w2 + w2 * w2) / G
    return t1 + t2


def setdown_slope(omega, amplitude, phase, depth: float, m: int, k_cut: int) -> np.ndarray:
    """The set-down's slope along the waves' mean direction at the origin, low-passed: the first ``k_cut`` FFT
    bins (on ``m`` samples of the record's period) of ``d eta2 / d xi`` for a long-crested sea.

    With ``b = a sqrt(G)`` and ``s = sum b cos(w t + phi - k xi)``, the bound wave is ``-LP(s^2)`` and its
    slope ``-2 LP(s ds/dxi)`` (the product rule; on a pair it is exactly the slope of ``-b_i b_j cos(psi_i -
    psi_j)``, whose wavenumber is ``k_i - k_j``).

    Parameters
    ----------
    omega, amplitude, phase : ndarray
        The components (K each): rad/s, m, rad, on the record's frequency grid's first ``K`` bins (``1 .. K``,
        as :func:`loadarm.ship.motion.wave_components` draws them; a zero amplitude where there is none).
    depth : float
        m.
    m : int
        FFT length over the record's period, at least ``2 K + k_cut`` (no alias of the square falls into the
        band).
    k_cut : int
        Bins kept.

    Returns
    -------
    ndarray
        (k_cut,) complex: the slope's bins as :func:`numpy.fft.rfft` gives them on ``m`` samples.
    """
    b = amplitude * np.sqrt(setdown_coefficient(omega, depth))
    k = wavenumber(omega, depth)
    coef = b * np.exp(-1j * phase)                      # Re sum coef e^{-i w t} = s at the origin
    c = np.zeros((2, m // 2 + 1), dtype=complex)
    c[0, 1:coef.size + 1] = np.conj(coef) * 0.5
    c[1, 1:coef.size + 1] = np.conj(1j * k * coef) * 0.5     # ds/dxi: sum b k sin(w t + phi)
    s = irfft(c, m, axis=-1, norm="forward")
    return -2.0 * rfft(s[0] * s[1])[:k_cut]


def difference_correction(omega_bins, w_peak: float, depth: float) -> np.ndarray:
    """What the factorisation ``sqrt(G_i G_j)`` misses as the difference frequency grows: Hasselmann's
    coefficient over Longuet-Higgins & Stewart's, for a pair about the sea's peak ``w_peak`` at each difference
    frequency (1 at 0; 1.07 at 0.2 rad/s and 1.3 at 0.4 for a 9.3 s sea in 20 m), applied per bin.

    Parameters
    ----------
    omega_bins : ndarray
        The difference frequencies, rad/s.
    w_peak : float
        rad/s.
    depth : float
        m.

    Returns
    -------
    ndarray
    """
    dw = np.asarray(omega_bins, dtype=float)
    half = np.minimum(dw, 1.9 * w_peak) / 2                   # the pair stays at positive frequencies
    out = np.ones_like(dw)
    nz = half > 0
    out[nz] = -difference_qtf(w_peak + half[nz], w_peak - half[nz], 0.0, 0.0, depth) / setdown_coefficient(
        w_peak, depth)
    return out


def hull_factor(omega_bins, cg: float, heading: float, length: float, beam: float) -> np.ndarray:
    """How much of a long wave's slope a box-shaped hull of ``length`` by ``beam`` feels: the pressure gradient
    averaged over the waterplane, ``sinc(dk L cos(beta) / 2) sinc(dk B sin(beta) / 2)`` with the bound wave's
    wavenumber ``dk = dw / c_g`` (it travels with the groups).

    Parameters
    ----------
    omega_bins : ndarray
        The difference frequencies, rad/s.
    cg : float
        The groups' speed, m/s.
    heading : float
        The waves' direction relative to the bow, rad.
    length, beam : float
        m.

    Returns
    -------
    ndarray
    """
    dk = np.asarray(omega_bins, dtype=float) / cg
    return (np.sinc(dk * length * math.cos(heading) / (2 * math.pi))
            * np.sinc(dk * beam * math.sin(heading) / (2 * math.pi)))


def setdown_load(mass_ship: np.ndarray, omega, amplitude, phase, heading: float, depth: float, size, m: int,
                 n: int, dt: float, k_cut: int) -> np.ndarray:
    """The set-down's load on the ship (surge, sway, yaw about midships), ship frame, as FFT bins on ``n``
    samples ``dt`` apart: ``F = -(M + A(0)) g grad(eta2)`` with the low-frequency mass (the displaced water's
    and the added mass at the lowest frequency), averaged over the hull (:func:`hull_factor`), no yaw moment.
    The sea taken long-crested in its mean direction ``heading`` (a spread sea's bound waves are smaller:
    Herbers, Elgar & Guza 1994, *Infragravity-frequency (0.005-0.05 Hz) motions on the shelf. Part I*, J. Phys.
    Oceanogr. 24: conservative).

    Parameters
    ----------
    mass_ship : ndarray (3, 3)
        Low-frequency mass matrix in the ship frame about midships (surge, sway, yaw).
    omega, amplitude, phase : ndarray
        The components.
    heading : float
        Their mean direction relative to the bow (towards), rad.
    depth : float
        m.
    size : tuple of float
        The hull's length and beam, m.
    m : int
        As :func:`setdown_slope`.
    n : int
        The record's FFT length (the bins' scale).
    dt : float
        s.
    k_cut : int
        Bins kept.

    Returns
    -------
    ndarray
        (3, k_cut) complex.
    """
    slope = setdown_slope(omega, amplitude, phase, depth, m, k_cut) * (n / m)
    if amplitude.size:
        w_peak = float(omega[int(np.argmax(amplitude))])
        bins = 2 * math.pi * np.arange(k_cut) / (n * dt)
        cg = float(group_velocity(w_peak, depth)[1])
        slope = slope * difference_correction(bins, w_peak, depth) * hull_factor(bins, cg, heading, *size)
    out = np.zeros((3, k_cut), dtype=complex)
    out[:2] = -G * (mass_ship[:2, :2] @ np.array([math.cos(heading), math.sin(heading)]))[:, None] * slope[None, :]
    return out
