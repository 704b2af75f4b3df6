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
* The load in the motion (:func:`setdown_load`) sums the pairs of the sea's components that hold its energy,
  each with Hasselmann's coefficient for its frequencies and directions (a spread sea binds less than a
  long-crested one) and its own difference wave vector, averaged over the hull's waterplane.
* A closed route for a long-crested sea, the check of the pairs: :func:`setdown_slope` factorises the transfer
  function as Newman's approximation does the drift's, ``G_ij ~ sqrt(G_i G_j)`` (the squared sum of
  components weighted by ``sqrt(G)``, low-passed, one FFT), times Hasselmann's growth with the difference
  frequency about the sea's peak (:func:`difference_correction`).

Left out, and said so: the free (unbound) infragravity waves a coast reflects (they depend on the coast; a
berth with measured infragravity energy needs them as a record); the bound wave's yaw moment; the long wave's
motion of the ship in heave and pitch.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.fft import irfft, rfft

from loadarm._numba import njit

from loadarm.ship.hydro import G

__all__ = ["wavenumber", "group_velocity", "setdown_coefficient", "difference_qtf", "setdown_slope", "difference_correction",
           "hull_factor", "ENERGY_KEPT",
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
    w1, w2 = np.asarray(w1, dtype=float), np.asarray(w2, dtype=float)
    return _qtf(w1, w2, wavenumber(w1, depth), wavenumber(w2, depth),
                np.cos(np.asarray(theta1) - np.asarray(theta2)), depth)


def _qtf(w1, w2, k1, k2, cos_angle, depth: float):
    """:func:`difference_qtf` on the pairs' frequencies, wavenumbers and the cosine of their angle."""
    w2 = -w2                                            # the difference interaction: the second one reversed
    cos12 = -cos_angle                                  # and its wave vector too
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


#: The components kept for the pairwise set-down: the largest, until this fraction of the sea's energy (the
#: bound wave of the rest, below 1e-3 of the energy, is below 1e-3 of the set-down's variance).
ENERGY_KEPT = 0.999


def _strongest(amplitude: np.ndarray) -> np.ndarray:
    """Indices (ascending) of the fewest components that hold :data:`ENERGY_KEPT` of the energy."""
    e = amplitude * amplitude
    order = np.argsort(e)[::-1]
    n = int(np.searchsorted(np.cumsum(e[order]), ENERGY_KEPT * e.sum())) + 1
    return np.sort(order[:min(n, order.size)])


def setdown_load(mass_ship: np.ndarray, omega, amplitude, phase, heading, depth: float, size, n: int,
                 k_cut: int, *, compiled: bool = True) -> np.ndarray:
    """The set-down's load on the ship (surge, sway, yaw about midships), ship frame, as FFT bins on ``n``
    samples: every pair of the sea's components (those holding :data:`ENERGY_KEPT` of its energy) with its
    difference frequency below the cut-off, each with Hasselmann's coefficient for its two frequencies and
    directions (a spread sea's pairs at an angle bind less) and its own difference wave vector, the force
    ``F = -(M + A(0)) g grad(eta2)`` of the low-frequency mass (the displaced water's and the added mass at the
    lowest frequency) averaged over the waterplane as a box's (``sinc(dk_x L / 2) sinc(dk_y B / 2)``: a
    bound wave shorter than the ship pushes it less); no yaw moment.

    Parameters
    ----------
    mass_ship : ndarray (3, 3)
        Low-frequency mass matrix in the ship frame about midships (surge, sway, yaw).
    omega, amplitude, phase : ndarray
        The components, on the record's grid's bins ``1 .. K`` (as
        :func:`loadarm.ship.motion.wave_components` draws them): rad/s, m, rad.
    heading : ndarray
        Each component's direction relative to the bow (towards), rad.
    depth : float
        m.
    size : tuple of float
        The hull's length and beam, m.
    n : int
        The record's FFT length (the bins' scale, :func:`numpy.fft.rfft`'s convention).
    k_cut : int
        Bins kept.
    compiled : bool
        The numba loop over the pairs (:func:`_pairs_kernel`, allocation-free) or, False, the NumPy route
        over arrays of pairs (the reference; ``tests/test_longwave.py`` holds the two together).

    Returns
    -------
    ndarray
        (3, k_cut) complex.
    """
    out = np.zeros((3, k_cut), dtype=complex)
    if compiled:
        keep = _strongest(np.asarray(amplitude, dtype=float)) if np.any(amplitude) else np.zeros(0, dtype=np.int64)
        th = np.asarray(heading, dtype=float) * np.ones(len(omega))
        sx, sy = np.zeros(k_cut, dtype=complex), np.zeros(k_cut, dtype=complex)
        k = wavenumber(omega, depth)
        _pairs_kernel(keep.astype(np.int64), omega, k, 1.0 / np.cosh(np.minimum(k * depth, 350.0)) ** 2, amplitude,
                      phase, np.cos(th),
                      np.sin(th), depth, float(size[0]), float(size[1]), 0.5 * n, sx, sy)
        out[:2] = -G * (mass_ship[:2, :2] @ np.stack([sx, sy]))
        return out
    keep = _strongest(np.asarray(amplitude, dtype=float)) if np.any(amplitude) else np.zeros(0, dtype=int)
    if keep.size < 2:
        return out
    i, j = np.triu_indices(keep.size, 1)
    i, j = keep[j], keep[i]                                 # i the higher frequency of each pair
    i, j = i[i - j < k_cut], j[i - j < k_cut]
    w, a, ph, th = omega, amplitude, phase, np.asarray(heading, dtype=float) * np.ones(len(omega))
    k = wavenumber(w, depth)
    c, sn = np.cos(th), np.sin(th)
    d = _qtf(w[i], w[j], k[i], k[j], c[i] * c[j] + sn[i] * sn[j], depth) * a[i] * a[j]
    dkx = k[i] * c[i] - k[j] * c[j]
    dky = k[i] * sn[i] - k[j] * sn[j]
    length, beam = size
    d = d * np.sinc(dkx * length / (2 * math.pi)) * np.sinc(dky * beam / (2 * math.pi))
    # the pair's bound wave d cos(dw t + phi_i - phi_j - dk.x): its slope at midships d dk sin(...), as the bin
    # -i (n / 2) d dk e^{i (phi_i - phi_j)}
    z = d * np.exp(1j * (ph[i] - ph[j])) * (-0.5j * n)
    sx = np.bincount(i - j, weights=(dkx * z).real, minlength=k_cut) + 1j * np.bincount(
        i - j, weights=(dkx * z).imag, minlength=k_cut)
    sy = np.bincount(i - j, weights=(dky * z).real, minlength=k_cut) + 1j * np.bincount(
        i - j, weights=(dky * z).imag, minlength=k_cut)
    out[:2] = -G * (mass_ship[:2, :2] @ np.stack([sx[:k_cut], sy[:k_cut]]))
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _sinc(x):
    return 1.0 if x == 0.0 else math.sin(x) / x


@njit(cache=True, nogil=True, error_model="numpy")
def _pairs_kernel(keep, w, k, sech2, a, ph, c, sn, depth, length, beam, half_n, sx, sy):
    """:func:`setdown_load`'s pairs, compiled: for each kept pair below the cut-off, Hasselmann's coefficient
    (:func:`difference_qtf`'s formula; ``sech2`` each component's ``1 / cosh(k h)^2``), the hull's average and
    the slope's bin, added into ``sx, sy``."""
    k_cut = sx.size
    for p in range(keep.size):
        i = keep[p]
        for q in range(p - 1, -1, -1):                   # nearest first: stop at the cut-off
            j = keep[q]
            b = i - j
            if b >= k_cut:
                break
            w1, w2 = w[i], -w[j]
            k1, k2 = k[i], k[j]
            cos12 = -(c[i] * c[j] + sn[i] * sn[j])
            k3 = math.sqrt(max(k1 * k1 + k2 * k2 + 2.0 * k1 * k2 * cos12, 0.0))
            w3 = w1 + w2
            dp = (w3 * ((w1 * w2) ** 2 / G ** 2 - k1 * k2 * cos12)
                  - 0.5 * (w1 * k2 * k2 * sech2[j] + w2 * k1 * k1 * sech2[i]))
            t1 = dp * G * w3 / (w1 * w2) / (G * k3 * math.tanh(k3 * depth) - w3 * w3)
            t2 = -G * k1 * k2 * cos12 / (2.0 * w1 * w2) + 0.5 * (w1 * w1 + w1 * w2 + w2 * w2) / G
            dkx = k1 * c[i] - k2 * c[j]
            dky = k1 * sn[i] - k2 * sn[j]
            d = (t1 + t2) * a[i] * a[j] * _sinc(0.5 * dkx * length) * _sinc(0.5 * dky * beam)
            dphi = ph[i] - ph[j]
            zr, zi = d * half_n * math.sin(dphi), -d * half_n * math.cos(dphi)     # d e^{i dphi} (-i n / 2)
            sx[b] += complex(dkx * zr, dkx * zi)
            sy[b] += complex(dky * zr, dky * zi)
