"""The flange's position predicted seconds to minutes ahead, with a calibrated interval.

The connected flange moves with the moored ship: a slow drift of periods near the moorings' (40-120 s) and the
waves' first-order motion (5-20 s) on top. The slow part is predictable for a fraction of its period; the
waves' part for a fraction of theirs. Both routes here predict the flange's position, sampled at
:data:`PREDICT_PERIOD` (the mean of each second's positions), by an autoregression per axis,
``x[t] = sum_k phi_k x[t-k] + e[t]``, and differ in where the coefficients come from:

* **online AR** (:func:`fit_ar`): fitted by least squares to the flange's own track of the last
  :data:`FIT_WINDOW` seconds (data-driven: no model of the ship at all);
* **model AR** (:func:`fit_ar` on the model's records): the same least squares over the moored-ship model's own
  records of the sea state (simulated apart, with other seeds), run on the measured track (model-based: nothing
  is fitted to the track). Found: the Yule-Walker equations of the same records' autocovariance gave errors
  twice as large (the 1-s means of a slow drift are a nearly non-stationary process, for which Yule-Walker's
  estimates are known to be biased; least squares are not).

The mean and the model's standard deviation per horizon come from the AR recursion and its psi-weights
(Box & Jenkins). Neither is trusted as it is: the interval is calibrated online (:class:`Calibrator`) by the
split-conformal quantile (Vovk et al. 2005) over a sliding window: at each horizon and axis the half-width is
the 95 % quantile of the predictor's own recent normalised errors, realised as time passes. The guarantee is
approximate: the errors of successive forecasts overlap and the sea changes, so they are not exchangeable; the
coverage is per axis and per horizon (marginal), not of the joint position nor of a first passage, and is
measured on hold-out records rather than assumed. A horizon is *claimed* once enough of its errors are realised
and no further than the route's hold-out claim (:data:`CLAIMS`); beyond it the forecast says no prediction
(``nan``), never a number.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from loadarm._numba import njit

__all__ = ["PREDICT_PERIOD", "FIT_WINDOW", "ORDER", "HORIZON", "LEVEL", "MIN_ERRORS", "MEMORY", "ArModel",
           "fit_ar", "ar_forecast", "Forecast", "Calibrator",
           "block_means", "claimed_steps", "interval", "CLAIMS"]

#: Sampling period of the predicted track, s (the mean of each second's positions).
PREDICT_PERIOD = 1.0
#: Track the online route fits, s (30 minutes: about 20 periods of the slowest mooring mode).
FIT_WINDOW = 1800.0
#: Autoregression order (60 s of memory: half a period of the slowest mooring mode, two of the waves').
ORDER = 60
#: Longest horizon predicted, s.
HORIZON = 120.0
#: Two-sided level of the interval.
LEVEL = 0.95
#: The longest horizon each route claims, s: where its 95 % interval covered 93-97 % of the hold-out records at
#: every horizon on x and y (:mod:`loadarm.studies.prediction`; a slow test recomputes them).
CLAIMS = {"online AR": 120.0, "model AR": 12.0}
#: Forecasts a horizon needs realised before its interval is claimed (5 minutes at one a second).
MIN_ERRORS = 300
#: Forecasts the calibration keeps per horizon (the sliding window: 50 minutes at one a second; chosen on the
#: tuning records, seeds 0-3 of six other states: a 10-minute window under-covers at horizons past a minute, its
#: errors there being few and correlated).
MEMORY = 3000


@dataclass(frozen=True, slots=True)
class ArModel:
    """An autoregression per axis of the flange's position about its mean.

    Attributes
    ----------
    phi : ndarray (3, p)
        Coefficients per axis, lag 1 first.
    sigma2 : ndarray (3,)
        Innovation variance per axis, m^2.
    variance : ndarray (3,)
        The process's variance per axis (the climatology), m^2.
    mean : ndarray (3,) or None
        The process mean, m (None: the mean of each forecast's history).
    route : str
        ``"online AR"`` or ``"model AR"``.
    """

    phi: np.ndarray
    sigma2: np.ndarray
    variance: np.ndarray
    mean: np.ndarray | None
    route: str

    @property
    def order(self) -> int:
        return int(self.phi.shape[1])


def block_means(positions: np.ndarray, per_block: int) -> np.ndarray:
    """The means of consecutive blocks of ``per_block`` samples (a trailing partial block dropped).

    Parameters
    ----------
    positions : ndarray (n, 3)
    per_block : int

    Returns
    -------
    ndarray (n // per_block, 3)
    """
    n = positions.shape[0] // per_block
    return positions[: n * per_block].reshape(n, per_block, -1).mean(axis=1)


@njit(cache=True, nogil=True)
def _normal_equations(y, order, gram, rhs):
    """Least squares' normal equations of ``y[t] ~ sum_k phi_k y[t-k]`` (t from ``order``), added into ``gram``
    (order, order) and ``rhs`` (order,), and ``sum y[t]^2`` returned: the first row by dot products, the rest by
    the lag matrix's Toeplitz recurrence ``G[i+1, j+1] = G[i, j] + y[p-2-i] y[p-2-j] - y[n-2-i] y[n-2-j]``
    (O(n p) in all, one thread: no BLAS pool inside the guidance cycle; found: a refit by ``lagged.T @ lagged``
    took 150 ms instead of 3 when other threads of the process were busy)."""
    n, p = y.shape[0], order
    g = np.zeros((p, p))
    for j in range(p):
        acc = 0.0
        for t in range(p, n):
            acc += y[t - 1] * y[t - 1 - j]
        g[0, j] = acc
    for i in range(p - 1):
        for j in range(i, p - 1):
            g[i + 1, j + 1] = g[i, j] + y[p - 2 - i] * y[p - 2 - j] - y[n - 2 - i] * y[n - 2 - j]
    for i in range(p):
        for j in range(i, p):
            gram[i, j] += g[i, j]
            if j != i:
                gram[j, i] += g[i, j]
        acc = 0.0
        for t in range(p, n):
            acc += y[t] * y[t - 1 - i]
        rhs[i] += acc
    yy = 0.0
    for t in range(p, n):
        yy += y[t] * y[t]
    return yy


def fit_ar(tracks, order: int = ORDER, *, ridge: float = 1e-6, route: str = "online AR") -> ArModel:
    """Least squares of each axis on its own ``order`` previous values, over one track or several (their normal
    equations summed: each record about its own mean).

    Parameters
    ----------
    tracks : ndarray (n, 3) or list of them
        Block means at :data:`PREDICT_PERIOD`, m; each longer than 2 ``order``.
    order : int
    ridge : float
        Relative Tikhonov weight (keeps a flat axis, e.g. no heave, well posed).
    route : str
        ``"online AR"`` (the flange's own track) or ``"model AR"`` (the moored-ship model's records).

    Returns
    -------
    ArModel
    """
    tracks = [tracks] if isinstance(tracks, np.ndarray) else list(tracks)
    for t in tracks:
        if t.shape[0] <= 2 * order:
            raise ValueError(f"fit_ar needs more than {2 * order} samples, got {t.shape[0]}")
    centred = [np.ascontiguousarray(t - t.mean(axis=0)) for t in tracks]
    phi, s2 = np.empty((3, order)), np.empty(3)
    rows = sum(c.shape[0] - order for c in centred) - order          # residuals less the coefficients fitted
    for ax in range(3):
        gram, rhs, yy = np.zeros((order, order)), np.zeros(order), 0.0
        for c in centred:
            yy += _normal_equations(np.ascontiguousarray(c[:, ax]), order, gram, rhs)
        scale = max(float(np.trace(gram)) / order, 1e-30)
        phi[ax] = np.linalg.solve(gram + ridge * scale * np.eye(order), rhs)
        # the residual's mean square from the same sums: (y'y - 2 phi'r + phi'G phi) / rows
        s2[ax] = max((yy - 2.0 * float(phi[ax] @ rhs) + float(phi[ax] @ gram @ phi[ax])) / rows, 0.0)
    variance = np.mean([c.var(axis=0) for c in centred], axis=0)
    return ArModel(phi, s2, variance, None, route)


def _psi_variance(phi: np.ndarray, steps: int) -> np.ndarray:
    """Cumulative sums of the squared psi-weights per axis, (steps, 3): the forecast variance over sigma2."""
    p = phi.shape[1]
    psi = np.zeros((steps, 3))
    psi[0] = 1.0
    for j in range(1, steps):
        k = min(p, j)
        psi[j] = np.einsum("ak,ka->a", phi[:, :k], psi[j - 1:: -1][:k])
    return np.cumsum(psi ** 2, axis=0)


def ar_forecast(model: ArModel, history: np.ndarray, steps: int, *, extra_variance=None) \
        -> tuple[np.ndarray, np.ndarray]:
    """The mean and the model's standard deviation of the next ``steps`` block means.

    Parameters
    ----------
    model : ArModel
    history : ndarray (n >= order, 3)
        The latest block means, oldest first.
    steps : int
    extra_variance : ndarray (3,), optional
        Added to every step (the motion within a block, which the block means do not carry), m^2.

    Returns
    -------
    mean, sd : ndarray (steps, 3)
    """
    p = model.order
    mu = history.mean(axis=0) if model.mean is None else model.mean
    buf = np.zeros((3, p + steps))
    buf[:, :p] = (history[-p:] - mu).T                                   # oldest first, as the track
    phi_rev = model.phi[:, ::-1]                                          # lag p first: dot with the last p values
    for j in range(steps):
        buf[:, p + j] = np.einsum("ak,ak->a", phi_rev, buf[:, j: j + p])
    mean = buf[:, p:].T + mu
    var = _psi_variance(model.phi, steps) * model.sigma2
    if extra_variance is not None:
        var = var + np.asarray(extra_variance)
    return mean, np.sqrt(var)


@dataclass(frozen=True, slots=True)
class Forecast:
    """The flange's predicted position per horizon, with its calibrated interval.

    Attributes
    ----------
    horizon : ndarray (k,)
        s ahead of ``time``.
    mean, lo, hi : ndarray (k, 3)
        Berth frame, m; ``lo``/``hi`` are ``nan`` beyond ``claimed`` (no prediction).
    claimed : float
        The longest horizon whose interval is claimed (:func:`claimed_steps`), s (0: none yet).
    time : float
        When it was made, s.
    route : str
    """

    horizon: np.ndarray
    mean: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    claimed: float
    time: float
    route: str


class Calibrator:
    """The online calibration of one predictor's intervals (mutable state: one per predictor and run).

    Every forecast is kept until its horizons are realised; each realised error, divided by the model's standard
    deviation, joins that horizon's and axis's sliding window of the last ``memory`` forecasts; the half-width is
    the window's conformal ``level`` quantile times the model's standard deviation.

    Parameters
    ----------
    steps : int
        Horizons 1..steps (in :data:`PREDICT_PERIOD`).
    level : float
    memory, min_errors : int
        Forecasts kept per horizon; forecasts realised before a horizon is calibrated.
    """

    def __init__(self, steps: int, *, level: float = LEVEL, memory: int = MEMORY, min_errors: int = MIN_ERRORS):
        if not 0.5 < level < 1.0:
            raise ValueError(f"level = {level} outside (0.5, 1)")
        if not 0 < min_errors <= memory:
            raise ValueError(f"min_errors = {min_errors} outside (0, memory = {memory}]")
        self.steps, self.level, self.min_errors, self.memory = steps, level, min_errors, memory
        self.z = np.full((steps, 3, memory), np.inf)       # normalised errors, a ring per horizon and axis
        self.count = np.zeros(steps, dtype=np.int64)
        self.pending: deque = deque()                      # (index of the block the forecast was made after, mean, sd)
        self._cache: np.ndarray | None = None              # refreshed(): the multipliers as last computed
        self._next = 0

    def observe(self, index: int, value: np.ndarray) -> None:
        """A new block mean, the ``index``-th of the track: realise the errors of the forecasts it answers.

        Parameters
        ----------
        index : int
        value : ndarray (3,)
        """
        for made, mean, sd in self.pending:
            j = index - made - 1
            if 0 <= j < self.steps:
                with np.errstate(divide="ignore", invalid="ignore"):
                    z = np.abs(value - mean[j]) / sd[j]
                still = np.where(value == mean[j], 0.0, np.inf)          # a still axis: exact, or never covered
                self.z[j, :, self.count[j] % self.memory] = np.where(sd[j] > 0, z, still)
                self.count[j] += 1
        while self.pending and index - self.pending[0][0] >= self.steps:
            self.pending.popleft()

    def remember(self, index: int, mean: np.ndarray, sd: np.ndarray) -> None:
        """Keep a forecast made after block ``index`` until its horizons are realised."""
        self.pending.append((index, mean, sd))

    def refreshed(self, rows: int) -> np.ndarray:
        """The calibrated multipliers with ``rows`` horizons recomputed, in turn (the rest as last computed): the
        real-time form of :meth:`quantiles`, its cost bounded per call (all 120 horizons of a full window take
        about 13 ms; 12 a call, one call a second, refresh each within 10 s of a 50-minute window).

        Parameters
        ----------
        rows : int

        Returns
        -------
        ndarray (steps, 3)
        """
        if rows < 1:
            raise ValueError(f"rows = {rows}: refresh at least one horizon a call")
        if self._cache is None:
            self._cache = np.full((self.steps, 3), np.nan)
        take = (self._next + np.arange(min(rows, self.steps))) % self.steps
        self._cache[take] = self.quantiles(take)
        self._next = int((take[-1] + 1) % self.steps)
        return self._cache.copy()

    def quantiles(self, rows=None) -> np.ndarray:
        """The calibrated multiplier per horizon and axis (``nan`` where fewer than ``min_errors`` forecasts are
        realised): of ``n`` realised normalised errors, the ``ceil(level (n + 1))``-th smallest (split conformal;
        the largest while ``n`` is small).

        Parameters
        ----------
        rows : array_like of int, optional
            Which horizons (0-based; default all).

        Returns
        -------
        ndarray (len(rows), 3)
        """
        rows = np.arange(self.steps) if rows is None else np.asarray(rows)
        q = np.full((rows.size, 3), np.nan)
        count = self.count[rows]
        n = np.minimum(count, self.memory)
        for size in np.unique(n[count >= self.min_errors]):         # one partition per window length (mostly one)
            sel = np.flatnonzero((n == size) & (count >= self.min_errors))
            k = min(int(math.ceil(self.level * (size + 1))), size) - 1
            q[sel] = np.partition(self.z[rows[sel], :, :size], k, axis=2)[:, :, k]
        return q


def claimed_steps(q: np.ndarray, route: str | None = None) -> int:
    """How many horizons from the first the forecast claims: calibrated on every axis, and no further than the
    route's :data:`CLAIMS` (where its hold-out coverage held).

    Parameters
    ----------
    q : ndarray (k, 3)
        Calibrated multipliers (``nan``: not calibrated).
    route : str, optional
        A key of :data:`CLAIMS` (None: the calibration alone, as the hold-out study measures it).

    Returns
    -------
    int
    """
    bad = np.flatnonzero(~np.all(np.isfinite(q), axis=1))
    n = int(bad[0]) if bad.size else int(q.shape[0])
    return n if route is None else min(n, int(CLAIMS[route] / PREDICT_PERIOD))


def interval(mean: np.ndarray, sd: np.ndarray, q: np.ndarray, claimed: int) -> tuple[np.ndarray, np.ndarray]:
    """The calibrated interval, ``nan`` beyond the claim (no prediction).

    Parameters
    ----------
    mean, sd, q : ndarray (k, 3)
    claimed : int

    Returns
    -------
    lo, hi : ndarray (k, 3)
    """
    half = q * sd
    lo, hi = mean - half, mean + half
    lo[claimed:] = math.nan
    hi[claimed:] = math.nan
    return lo, hi
