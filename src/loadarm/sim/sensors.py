"""The flange sensor of the simulated world.

Sensor: readings of the true flange position at a fixed rate, each delivered
``latency`` seconds after the instant it describes, with white noise, random
and scheduled dropouts and occasional outliers (all seeded).

The filter that trusts them is :mod:`loadarm.guidance.estimator`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from loadarm.params.scenario import Scenario
from loadarm.ship.flange import FlangeMotion

__all__ = ["Readings", "sensor_readings", "history_readings"]


@dataclass(frozen=True)
class Readings:
    """All sensor readings of a run, in arrival order.

    Attributes
    ----------
    t_arrive : ndarray, shape (n,)
        When each reading becomes available, s.
    t_meas : ndarray, shape (n,)
        The instant each reading describes, s.
    xyz : ndarray, shape (n, 3)
        Reported positions, m.
    outlier : ndarray of bool, shape (n,)
        Which readings are outliers (ground truth, for tests and plots).
    """

    t_arrive: np.ndarray
    t_meas: np.ndarray
    xyz: np.ndarray
    outlier: np.ndarray


def sensor_readings(sc: Scenario, motion: FlangeMotion) -> Readings:
    """Generate every reading of a scenario (deterministic for its seed).

    Parameters
    ----------
    sc : Scenario
        Sensor settings, duration and seed.
    motion : FlangeMotion
        The true flange trajectory.

    Returns
    -------
    Readings
    """
    s = sc.sensor
    rng = np.random.default_rng(sc.scenario.seed + 1)
    t_meas = np.arange(0.0, sc.scenario.duration, 1.0 / s.rate)
    keep = rng.random(t_meas.size) >= s.dropout_probability
    for a, b in s.dropouts:
        keep &= ~((t_meas >= a) & (t_meas < b))
    t_meas = t_meas[keep]
    xyz = motion.position(t_meas) + rng.normal(0.0, s.noise, (t_meas.size, 3))
    out = rng.random(t_meas.size) < s.outlier_probability
    if out.any():
        d = rng.normal(size=(int(out.sum()), 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        xyz[out] += s.outlier_size * d
    return Readings(t_meas + s.latency, t_meas, xyz, out)


def history_readings(sc: Scenario, motion) -> tuple[np.ndarray, np.ndarray] | None:
    """The flange sensor's readings of the ship before the run starts (``[ship] history`` seconds of them): what
    a terminal's berth monitoring has seen of the moored ship by the time the arm connects, for the predictor.
    The sensor's rate and noise; no outliers or dropouts (a history is a cleaned record). Deterministic for the
    seed, and apart from the run's own readings (which stay bit for bit as without a history).

    Parameters
    ----------
    sc : Scenario
    motion : FlangeMotion or MooredFlangeMotion
        The true flange trajectory (defined from ``-history``).

    Returns
    -------
    (t, xyz) or None
        Times (s, negative) and positions (m); None without a history.
    """
    h = sc.ship.history
    if h <= 0:
        return None
    rng = np.random.default_rng(sc.scenario.seed + 2)
    t = -h + np.arange(int(round(h * sc.sensor.rate))) / sc.sensor.rate
    return t, motion.position(t) + rng.normal(0.0, sc.sensor.noise, (t.size, 3))
