"""Seeded flange trajectories: tide and draft (slow), waves (JONSWAP), drift-off.

Wave model (documented simple response model): the sea is a JONSWAP spectrum
``S(w)`` with significant height ``Hs`` and peak period ``Tp``,

    S(w) = a g^2 w^-5 exp(-5/4 (wp/w)^4) gamma^exp(-(w - wp)^2 / (2 s^2 wp^2)),  s = 0.07 (w <= wp), 0.09

scaled so that ``4 sqrt(m0) = Hs``. It is realised as a sum of ``N``
components with random phases (seeded). Each flange degree of freedom (sway
off the berth = x, surge along it = y, heave = z) responds to each component
with a gain times a second-order low-pass ``1 / sqrt(1 + (w / wc)^4)`` (a long
ship ignores short waves) and an independent random phase. This is not a
seakeeping code; it gives flange motions of the right size and period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .scenario import Scenario

__all__ = ["jonswap", "FlangeMotion", "flange_motion"]

G = 9.80665


def jonswap(w: np.ndarray, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """JONSWAP spectral density, m^2 s/rad, normalised to ``Hs``.

    Parameters
    ----------
    w : ndarray
        Angular frequencies, rad/s (> 0).
    hs : float
        Significant wave height, m.
    tp : float
        Peak period, s.
    gamma : float
        Peak enhancement.

    Returns
    -------
    ndarray
        ``S(w)`` with ``4 sqrt(int S dw) = hs`` over a wide band.
    """
    w = np.asarray(w, dtype=float)
    wp = 2 * math.pi / tp

    def shape(x):
        s = np.where(x <= wp, 0.07, 0.09)
        return x ** -5.0 * np.exp(-1.25 * (wp / x) ** 4) * gamma ** np.exp(-((x - wp) ** 2) / (2 * s * s * wp * wp))

    wide = np.linspace(0.2 * wp, 8 * wp, 8000)
    m0 = np.trapezoid(shape(wide), wide)
    scale = (hs / 4.0) ** 2 / m0 if m0 > 0 else 0.0
    return scale * shape(w)


#: Elements of the phase array evaluated at once by :meth:`FlangeMotion.position` (8 MB of float64).
WAVE_CHUNK = 1 << 20


@dataclass(frozen=True)
class FlangeMotion:
    """The true flange trajectory of a scenario (vectorised, deterministic for a seed).

    Call :meth:`position` and :meth:`velocity` with times in s; they return
    arrays of shape ``t.shape + (3,)`` in m and m/s (x off the berth, y along
    it, z up).
    """

    base: np.ndarray
    slow_rate: np.ndarray
    w: np.ndarray
    amp: np.ndarray       # (3, n) amplitude per DOF and component
    phase: np.ndarray     # (3, n)
    drift_start: float | None
    drift_speed: float
    drift_accel: float
    drift_dir: np.ndarray

    def _drift(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.drift_start is None:
            return np.zeros_like(t), np.zeros_like(t)
        tau = np.maximum(t - self.drift_start, 0.0)
        t_acc = self.drift_speed / self.drift_accel
        s = np.where(tau < t_acc, 0.5 * self.drift_accel * tau ** 2,
                     0.5 * self.drift_speed * t_acc + self.drift_speed * (tau - t_acc))
        v = np.where(tau < t_acc, self.drift_accel * tau, self.drift_speed)
        return s, v

    def position(self, t) -> np.ndarray:
        """Flange position at times ``t``, m."""
        t = np.asarray(t, dtype=float)
        waves = self._waves(t, 0)
        s, _ = self._drift(t)
        return self.base + t[..., None] * self.slow_rate + s[..., None] * self.drift_dir + waves

    def velocity(self, t) -> np.ndarray:
        """Flange velocity at times ``t``, m/s."""
        t = np.asarray(t, dtype=float)
        _, v = self._drift(t)
        return self.slow_rate + v[..., None] * self.drift_dir + self._waves(t, 1)

    def _waves(self, t: np.ndarray, order: int) -> np.ndarray:
        if self.w.size == 0:
            return np.zeros(t.shape + (3,))
        # in chunks: the (times, 3, components) phase array of a day at 1 kHz would need tens of gigabytes
        # (found: an OOM kill); each row's sum is the same whatever the chunk, so the result is too
        flat = t.reshape(-1)
        out = np.empty((flat.size, 3))
        step = max(1, WAVE_CHUNK // (3 * self.w.size))
        for i in range(0, flat.size, step):
            arg = flat[i:i + step, None, None] * self.w + self.phase          # (chunk, 3, n)
            if order == 0:
                out[i:i + step] = np.sum(self.amp * np.cos(arg), axis=-1)
            else:
                out[i:i + step] = np.sum(-self.amp * self.w * np.sin(arg), axis=-1)
        return out.reshape(t.shape + (3,))


def flange_motion(sc: Scenario) -> FlangeMotion:
    """Build the flange trajectory of a scenario.

    Parameters
    ----------
    sc : Scenario
        The scenario (ship, waves, drift, seed).

    Returns
    -------
    FlangeMotion
    """
    rng = np.random.default_rng(sc.scenario.seed)
    wv = sc.waves
    if wv.hs > 0:
        wp = 2 * math.pi / wv.tp
        edges = np.linspace(0.3 * wp, 4.0 * wp, wv.components + 1)
        w = 0.5 * (edges[1:] + edges[:-1]) + rng.uniform(-0.5, 0.5, wv.components) * np.diff(edges)
        dw = np.diff(edges)
        a = np.sqrt(2.0 * jonswap(w, wv.hs, wv.tp, wv.gamma) * dw)
        wc = 2 * math.pi / wv.cutoff_period
        h = 1.0 / np.sqrt(1.0 + (w / wc) ** 4)
        gains = np.array([wv.sway_gain, wv.surge_gain, wv.heave_gain])
        amp = gains[:, None] * (a * h)[None, :]
        phase = rng.uniform(0, 2 * math.pi, (3, wv.components))
    else:
        w = np.zeros(0)
        amp = np.zeros((3, 0))
        phase = np.zeros((3, 0))
    d = sc.drift
    ang = math.radians(d.direction_deg)
    return FlangeMotion(base=np.array(sc.ship.flange, dtype=float),
                        slow_rate=np.array([0.0, 0.0, sc.ship.tide_rate + sc.ship.draft_rate]),
                        w=w, amp=amp, phase=phase, drift_start=d.start, drift_speed=d.speed,
                        drift_accel=d.acceleration, drift_dir=np.array([math.cos(ang), math.sin(ang), 0.0]))
