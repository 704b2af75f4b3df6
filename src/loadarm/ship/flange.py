"""Seeded flange trajectories: tide and draft (slow), and either the moored ship of a berth file
(``[ship] model = "moored"``, :mod:`loadarm.ship`: moorings, wind, current, waves, slow drift, parted lines) or
the simple model below (``model = "simple"``, the default of older scenarios).

Simple wave model (documented simple response model): the sea is a JONSWAP spectrum
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

from loadarm.params.scenario import Scenario, scenario_environment
from loadarm.ship.loads import jonswap
from loadarm.ship.motion import simulate

__all__ = ["jonswap", "FlangeMotion", "MooredFlangeMotion", "flange_motion", "MOORED_LOOKAHEAD"]

G = 9.80665
#: Seconds of moored-ship motion simulated past a run's end (the run looks ahead for the face the flange reaches).
MOORED_LOOKAHEAD = 620.0


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


@dataclass(frozen=True)
class MooredFlangeMotion:
    """The flange of a moored ship in the installation's frame: the 10 Hz motion of
    :func:`loadarm.ship.motion.simulate`, moved so that the flange's mean position under the mean loads is the
    scenario's ``[ship] flange``, plus tide and draft; between samples a cubic Hermite interpolant (position and
    velocity both sampled: error of order ``(w dt)^4``, below 1e-4 of the motion for waves longer than 4 s).

    Attributes
    ----------
    motion : ShipMotion
    offset : ndarray (3,)
        Installation minus berth frame.
    slow_rate : ndarray (3,)
    start : float
        How long before the run's time 0 the simulated record starts, s (``[ship] history``).
    """

    motion: object
    offset: np.ndarray
    slow_rate: np.ndarray
    start: float = 0.0

    def _at(self, t: np.ndarray):
        m = self.motion
        dt = float(m.t[1] - m.t[0])
        t = np.asarray(t, dtype=float) + self.start
        if t.size and (np.min(t) < -1e-9 or np.max(t) > m.t[-1] + 1e-9):
            raise ValueError(f"times from {np.min(t) - self.start:g} to {np.max(t) - self.start:g} s lie outside "
                             f"the simulated {-self.start:g}-{m.t[-1] - self.start:g} s of the moored ship")
        k = np.clip(np.floor(t / dt).astype(int), 0, m.t.size - 2)
        s = t / dt - k
        return k, s[..., None], dt

    def position(self, t) -> np.ndarray:
        """Flange position at times ``t``, m (installation frame)."""
        k, s, dt = self._at(t)
        p, v = self.motion.flange, self.motion.flange_velocity
        h00, h10, h01, h11 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s, -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        out = h00 * p[k] + h10 * dt * v[k] + h01 * p[k + 1] + h11 * dt * v[k + 1]
        return out + self.offset + np.asarray(t, dtype=float)[..., None] * self.slow_rate

    def velocity(self, t) -> np.ndarray:
        """Flange velocity at times ``t``, m/s."""
        k, s, dt = self._at(t)
        p, v = self.motion.flange, self.motion.flange_velocity
        d00, d10, d01, d11 = 6 * s ** 2 - 6 * s, 3 * s ** 2 - 4 * s + 1, -6 * s ** 2 + 6 * s, 3 * s ** 2 - 2 * s
        return (d00 * p[k] + d01 * p[k + 1]) / dt + d10 * v[k] + d11 * v[k + 1] + self.slow_rate

    def reading(self, t: float, period: float = 1.0) -> int:
        """The number of the last mooring load reading made by run time ``t``, the monitoring reading every
        ``period`` seconds of the record's time (which starts ``start`` s before the run): the one place the
        reading times are rounded (:meth:`line_loads` reads it, the simulated plant caches on it)."""
        return math.floor((t + self.start) / period + 1e-9)

    def line_loads(self, t: float, period: float = 1.0) -> tuple:
        """What a mooring load monitoring reading every ``period`` seconds last reported by time ``t``: each
        line's tension as a share of its MBL (the record's sample at the last whole reading time).

        Parameters
        ----------
        t : float
            Run time, s.
        period : float
            The monitoring's reading period, s.

        Returns
        -------
        tuple of float
        """
        m = self.motion
        dt = float(m.t[1] - m.t[0])
        k = min(max(int(round(self.reading(t, period) * period / dt)), 0), m.t.size - 1)
        return tuple(float(v) for v in m.tension[k] / m.mbl)

    def orientation(self, t) -> np.ndarray:
        """Roll, pitch and yaw of the flange face at times ``t`` (linear between samples), rad."""
        k, s, _ = self._at(t)
        a = self.motion.flange_angles
        return (1 - s) * a[k] + s * a[k + 1]


def _moored(sc: Scenario, ship) -> MooredFlangeMotion:

    env = scenario_environment(sc, ship.environment)
    mf = sc.mooring_failure
    parted = tuple(ship.names) if mf.all_lines else tuple(mf.lines)
    start = sc.ship.history
    m = simulate(ship, env, start + sc.scenario.duration + MOORED_LOOKAHEAD, seed=sc.scenario.seed,
                 parted=parted if mf.time is not None else (), part_time=None if mf.time is None else start + mf.time)
    offset = np.asarray(sc.ship.flange, dtype=float) - m.flange_reference
    return MooredFlangeMotion(motion=m, offset=offset,
                              slow_rate=np.array([0.0, 0.0, sc.ship.tide_rate + sc.ship.draft_rate]), start=start)


def flange_motion(sc: Scenario, ship=None) -> FlangeMotion | MooredFlangeMotion:
    """Build the flange trajectory of a scenario.

    Parameters
    ----------
    sc : Scenario
        The scenario (ship, waves, drift, seed).
    ship : ShipModel, optional
        For ``model = "moored"``: the berth's ship, compiled (:func:`loadarm.ship.model.moored_ship`
        reads and compiles the scenario's berth file).

    Returns
    -------
    FlangeMotion or MooredFlangeMotion
    """
    if sc.ship.model == "moored":
        if ship is None:
            raise ValueError("a moored scenario needs its ship: loadarm.ship.model.moored_ship(scenario)")
        return _moored(sc, ship)
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
