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
split-conformal quantile (Vovk et al. 2005) over a sliding window: at each horizon and axis each edge is its own
one-sided 97.5 % quantile of the predictor's own recent signed normalised errors, realised as time passes, so
each side's tail is the declared 2.5 % (:data:`THRESHOLD`) where the errors lean to one side (found: a
calibration of the absolute error put 4.2 % of the truth above the upper edge off the berth and 1.8 % below the
lower on the hold-out records; each edge its own quantile, 3.5 % and 2.5 % there, 2.4 % and 2.5 % on the tuning
records; adaptive conformal inference on each edge's level made the tuning records' tails wider, not closer:
docs/guidance.md section 12). The guarantee is approximate: the errors of successive forecasts overlap and the sea changes, so they are not exchangeable; the
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
           "fit_ar", "ar_forecast", "psi_variance", "Forecast", "Calibrator",
           "block_means", "claimed_steps", "interval", "gate_ratio", "CLAIMS", "FlangePredictor", "REFIT", "MIN_FIT",
           "SAMPLE_PERIOD", "MAX_GAP", "GATE_HORIZONS", "GATE_FACTOR", "GATE_PERSIST", "THRESHOLD"]

#: Sampling period of the predicted track, s (the mean of each second's positions).
PREDICT_PERIOD = 1.0
#: Track the online route fits, s (30 minutes: about 20 periods of the slowest mooring mode).
FIT_WINDOW = 1800.0
#: Autoregression order (60 s of memory: half a period of the slowest mooring mode, two of the waves').
ORDER = 60
#: Longest horizon predicted, s.
HORIZON = 120.0
#: Two-sided level of the interval (each edge calibrated apart: (1 - LEVEL) / 2 of the truth beyond each).
LEVEL = 0.95
#: The longest horizon each route claims, s: where its 95 % interval covered 93-97 % of the hold-out records at
#: every horizon on x and y (:mod:`loadarm.studies.prediction`; a slow test recomputes them).
CLAIMS = {"online AR": 120.0, "model AR": 13.0}
#: Forecasts a horizon needs realised before its interval is claimed (5 minutes at one a second).
MIN_ERRORS = 300
#: Forecasts the calibration keeps per horizon (the sliding window: 50 minutes at one a second; chosen on the
#: tuning records, seeds 0-3 of six other states: a 10-minute window under-covers at horizons past a minute, its
#: errors there being few and correlated).
MEMORY = 3000
#: Seconds between two refits of the online AR (the hold-out study's).
REFIT = 30
#: Track the online route needs before its first fit, s (ten periods of a 60 s sway; the fit window then grows to
#: :data:`FIT_WINDOW`).
MIN_FIT = 600.0
#: Period of the positions the live predictor keeps, s (five to a block: their spread about the block's mean is
#: the motion within a second that the block means do not carry).
SAMPLE_PERIOD = 0.2
#: The horizons the departure test compares each new block mean with, s.
GATE_HORIZONS = (5, 10, 20)
#: How far outside its calibrated interval a block mean must fall, on x or y, to count against the model, as a
#: multiple of its own side's edge (:func:`gate_ratio`). An edge is the calibrated one-sided 97.5 % bound, about
#: 1.96 standard deviations of a normal error, so 3 of them are about 5.9 (a chance of about 4e-9 per horizon,
#: block and axis, were the errors normal); the errors are heavier-tailed: the largest ratio on the hold-out
#: records of the sea alone is above this factor (:class:`loadarm.studies.prediction.RouteCalibration`'s
#: ``gate_ratio``, quoted in docs/guidance.md section 13 and held there by a slow test), so a single block can
#: count on the sea alone, and a departure needs :data:`GATE_PERSIST` running. A false departure stands the
#: prediction down (never less safe; campaigns count them).
GATE_FACTOR = 3.0
#: Consecutive blocks that must count before the track is taken to have left the model (a drift or break-out
#: the autoregression has not seen): connected, the predictive rule then stands down for the rest of the
#: connection; not connected (:attr:`FlangePredictor.latch` off), the calibration starts again.
GATE_PERSIST = 2
#: The longest gap in the positions the live predictor bridges (its block means filled in by a straight line), s:
#: a sensor's dropout or the seconds between the berth monitoring's record and the guidance's own track. A
#: longer gap starts the track again.
MAX_GAP = 10.0
#: The declared probability threshold of the predictive alarms: a stage is raised when the calibrated one-sided
#: bound at this level (the 95 % interval's edge, each edge calibrated apart: 2.5 % per side) reaches a face
#: within the stage's lead.
THRESHOLD = (1.0 - LEVEL) / 2.0


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


@njit(cache=True, nogil=True)
def _recursion(phi_rev, buf, p, steps):
    """The AR recursion in place: ``buf[a, p + j] = sum_k phi_rev[a, k] buf[a, j + k]`` (lag ``p`` first), one
    thread, summed in the order of the lags (a test holds it to the companion matrix's powers)."""
    for a in range(buf.shape[0]):
        for j in range(steps):
            acc = 0.0
            for k in range(p):
                acc += phi_rev[a, k] * buf[a, j + k]
            buf[a, p + j] = acc


def psi_variance(phi: np.ndarray, steps: int) -> np.ndarray:
    """Cumulative sums of the squared psi-weights per axis: the forecast variance over sigma2.

    Parameters
    ----------
    phi : ndarray (3, order)
        The AR coefficients per axis.
    steps : int

    Returns
    -------
    ndarray (steps, 3)
    """
    p = phi.shape[1]
    psi = np.zeros((steps, 3))
    psi[0] = 1.0
    for j in range(1, steps):
        k = min(p, j)
        psi[j] = np.einsum("ak,ka->a", phi[:, :k], psi[j - 1:: -1][:k])
    return np.cumsum(psi ** 2, axis=0)


def ar_forecast(model: ArModel, history: np.ndarray, steps: int, *, extra_variance=None, psi2=None) \
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
    psi2 : ndarray (>= steps, 3), optional
        ``model``'s cumulative squared psi-weights (:func:`psi_variance`), when kept between forecasts of one
        fit (the live predictor: one computation per refit instead of one per block).

    Returns
    -------
    mean, sd : ndarray (steps, 3)
    """
    p = model.order
    mu = history.mean(axis=0) if model.mean is None else model.mean
    buf = np.zeros((3, p + steps))
    buf[:, :p] = (history[-p:] - mu).T                                   # oldest first, as the track
    _recursion(np.ascontiguousarray(model.phi[:, ::-1]), buf, p, steps)
    mean = buf[:, p:].T + mu
    var = (psi_variance(model.phi, steps) if psi2 is None else psi2[:steps]) * model.sigma2
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

    Every forecast is kept until its horizons are realised; each realised error, signed and divided by the
    model's standard deviation, joins that horizon's and axis's sliding window of the last ``memory`` forecasts;
    each edge's multiplier is the window's conformal quantile of its own side (the upper edge's of the errors,
    the lower edge's of their negatives, each at ``1 - (1 - level) / 2``), so an error that leans to one side
    widens that side only.

    Parameters
    ----------
    steps : int
        Horizons 1..steps (in :data:`PREDICT_PERIOD`).
    level : float
        Two-sided: ``(1 - level) / 2`` of the truth beyond each edge.
    memory, min_errors : int
        Forecasts kept per horizon; forecasts realised before a horizon is calibrated.
    """

    def __init__(self, steps: int, *, level: float = LEVEL, memory: int = MEMORY, min_errors: int = MIN_ERRORS):
        if not 0.5 < level < 1.0:
            raise ValueError(f"level = {level} outside (0.5, 1)")
        if not 0 < min_errors <= memory:
            raise ValueError(f"min_errors = {min_errors} outside (0, memory = {memory}]")
        self.steps, self.level, self.min_errors, self.memory = steps, level, min_errors, memory
        self.z = np.full((steps, 3, memory), np.inf)       # signed normalised errors, a ring per horizon and axis
        self.count = np.zeros(steps, dtype=np.int64)
        # the forecasts not yet realised, a ring of ``steps`` by the index of the block each was made after
        self._made = np.full(steps, np.iinfo(np.int64).min // 2, dtype=np.int64)
        self._mean = np.zeros((steps, steps, 3))
        self._sd = np.ones((steps, steps, 3))
        self._js = np.arange(steps)
        self._cache: np.ndarray | None = None              # refreshed(): the multipliers as last computed
        self._next = 0

    def outstanding(self, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The forecasts a block ``index`` answers: per horizon ``j`` (0-based), the mean and model standard
        deviation the forecast made after block ``index - 1 - j`` gave for it, where that forecast was made.

        Parameters
        ----------
        index : int

        Returns
        -------
        valid : ndarray (steps,) bool
        mean, sd : ndarray (steps, 3)
        """
        made = index - 1 - self._js
        slots = made % self.steps
        valid = self._made[slots] == made
        return valid, self._mean[slots, self._js], self._sd[slots, self._js]

    def observe(self, index: int, value: np.ndarray) -> None:
        """A new block mean, the ``index``-th of the track: realise the errors of the forecasts it answers.

        Parameters
        ----------
        index : int
        value : ndarray (3,)
        """
        valid, mean, sd = self.outstanding(index)
        j = self._js[valid]
        if j.size == 0:
            return
        mean, sd = mean[valid], sd[valid]
        err = value - mean
        with np.errstate(divide="ignore", invalid="ignore"):
            z = err / sd
        still = np.where(err == 0.0, 0.0, np.copysign(np.inf, err))      # a still axis: exact, or never covered
        self.z[j, :, self.count[j] % self.memory] = np.where(sd > 0, z, still)
        self.count[j] += 1

    def remember(self, index: int, mean: np.ndarray, sd: np.ndarray) -> None:
        """Keep a forecast made after block ``index`` until its horizons are realised (the ring keeps the last
        ``steps``: a forecast older than that has no horizon left).

        Parameters
        ----------
        index : int
        mean, sd : ndarray (steps, 3)
        """
        slot = index % self.steps
        self._made[slot] = index
        self._mean[slot] = mean[: self.steps]
        self._sd[slot] = sd[: self.steps]

    def refreshed(self, rows: int) -> np.ndarray:
        """The calibrated multipliers with ``rows`` horizons recomputed, in turn (the rest as last computed): the
        real-time form of :meth:`quantiles`, its cost bounded per call (12 a call, one call a second, refresh
        each horizon within 10 s of a 50-minute window; ``make bench`` states the predictor's cost).

        Parameters
        ----------
        rows : int

        Returns
        -------
        ndarray (steps, 3, 2)
        """
        if rows < 1:
            raise ValueError(f"rows = {rows}: refresh at least one horizon a call")
        if self._cache is None:
            self._cache = np.full((self.steps, 3, 2), np.nan)
        take = (self._next + np.arange(min(rows, self.steps))) % self.steps
        self._cache[take] = self.quantiles(take)
        self._next = int((take[-1] + 1) % self.steps)
        return self._cache.copy()

    def quantiles(self, rows=None) -> np.ndarray:
        """The calibrated multipliers per horizon, axis and edge (``nan`` where fewer than ``min_errors``
        forecasts are realised). Of ``n`` realised signed normalised errors ``z``, with
        ``k = ceil(a (n + 1))`` and ``a = 1 - (1 - level) / 2`` (split conformal, one side each; the extreme
        while ``n`` is small): the upper edge's multiplier is the ``k``-th smallest ``z``, the lower edge's the
        ``k``-th smallest ``-z``, and the interval ``[mean - lower sd, mean + upper sd]``.

        Parameters
        ----------
        rows : array_like of int, optional
            Which horizons (0-based; default all).

        Returns
        -------
        ndarray (len(rows), 3, 2)
            ``[..., 0]`` the lower edge's multiplier, ``[..., 1]`` the upper's.
        """
        rows = np.arange(self.steps) if rows is None else np.asarray(rows)
        q = np.full((rows.size, 3, 2), np.nan)
        count = self.count[rows]
        n = np.minimum(count, self.memory)
        side = 1.0 - (1.0 - self.level) / 2.0
        for size in np.unique(n[count >= self.min_errors]):         # one sort per window length (mostly one)
            sel = np.flatnonzero((n == size) & (count >= self.min_errors))
            k = min(int(math.ceil(side * (size + 1))), size) - 1
            # a full sort: NumPy's vectorised sort takes half the time of a partition at two ranks here (measured)
            part = np.sort(self.z[rows[sel], :, :size], axis=2)
            q[sel, :, 0] = -part[:, :, size - 1 - k]
            q[sel, :, 1] = part[:, :, k]
        return q


def gate_ratio(err: np.ndarray, below: np.ndarray, above: np.ndarray) -> np.ndarray:
    """The departure test's measure: how far outside the calibrated interval an error lies, as a multiple of its
    own side's edge (the upper edge's distance from the mean for an error above it, the lower's below), each side
    at least half the wider (an edge at or inside the mean, where more than 97.5 % of the window's errors share
    a sign, would otherwise count every error on its side).

    Parameters
    ----------
    err : ndarray (...)
        Truth less the forecast's mean.
    below, above : ndarray (...)
        The interval's edges' distances from the mean (``mean - lo``, ``hi - mean``).

    Returns
    -------
    ndarray (...)
    """
    wide = np.maximum(below, above)
    half = np.where(err >= 0, np.maximum(above, 0.5 * wide), np.maximum(below, 0.5 * wide))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(err) / half


def claimed_steps(q: np.ndarray, route: str | None = None) -> int:
    """How many horizons from the first the forecast claims: calibrated on every axis, and no further than the
    route's :data:`CLAIMS` (where its hold-out coverage held).

    Parameters
    ----------
    q : ndarray (k, 3, 2)
        Calibrated multipliers (:meth:`Calibrator.quantiles`; ``nan``: not calibrated).
    route : str, optional
        A key of :data:`CLAIMS` (None: the calibration alone, as the hold-out study measures it).

    Returns
    -------
    int
    """
    bad = np.flatnonzero(~np.all(np.isfinite(q.reshape(q.shape[0], -1)), axis=1))
    n = int(bad[0]) if bad.size else int(q.shape[0])
    return n if route is None else min(n, int(CLAIMS[route] / PREDICT_PERIOD))


def interval(mean: np.ndarray, sd: np.ndarray, q: np.ndarray, claimed: int) -> tuple[np.ndarray, np.ndarray]:
    """The calibrated interval, ``nan`` beyond the claim (no prediction).

    Parameters
    ----------
    mean, sd : ndarray (k, 3)
    q : ndarray (k, 3, 2)
        The lower and upper edges' multipliers (:meth:`Calibrator.quantiles`).
    claimed : int

    Returns
    -------
    lo, hi : ndarray (k, 3)
    """
    lo, hi = mean - q[..., 0] * sd, mean + q[..., 1] * sd
    lo[claimed:] = math.nan
    hi[claimed:] = math.nan
    return lo, hi


class FlangePredictor:
    """The online AR route live (mutable state: one per guidance controller), fed the flange's position every
    cycle.

    Positions are kept every :data:`SAMPLE_PERIOD` and averaged into :data:`PREDICT_PERIOD` blocks. At each new
    block: the calibration realises the errors it answers, the departure test compares it with the forecasts of
    :data:`GATE_HORIZONS` ago, the AR is refitted every :data:`REFIT` s once :data:`MIN_FIT` s of track are in
    (on the last :data:`FIT_WINDOW` s), and a new forecast of :data:`HORIZON` s is made with its calibrated
    interval (:class:`Forecast`; ``None`` while no horizon is claimed). A gap in the positions (no healthy
    estimate) up to :data:`MAX_GAP` is bridged by a straight line between the blocks either side; a longer one
    starts the track again: an AR needs a contiguous history.

    Parameters
    ----------
    route : str
        ``"online AR"``.
    """

    def __init__(self, route: str = "online AR"):
        if route != "online AR":                          # the model route is fitted apart, never live
            raise ValueError(f"route {route!r}: the live predictor is the online AR")
        self.route = route
        self.steps = int(round(HORIZON / PREDICT_PERIOD))
        self.per_block = int(round(PREDICT_PERIOD / SAMPLE_PERIOD))
        self._latch = True
        self.reset()

    @property
    def latch(self) -> bool:
        """Whether a departure latches: the controller's choice while connected (the prediction stands down for
        the rest of the connection); not connected (the berth monitoring's track, the approach, after a
        disconnection) a departure starts the calibration again. Set off with a departure latched (the
        connection has ended), that departure's calibration starts again too (found: a departure while connected
        stood after the disconnection until the track restarted, so a next connection to the same ship found the
        prediction still standing down)."""
        return self._latch

    @latch.setter
    def latch(self, on: bool) -> None:
        self._latch = bool(on)
        if not self._latch and self.departed_at is not None:
            self.cleared.append(self.departed_at)
            self._restart_calibration()
            self.departed_at = None

    def reset(self) -> None:
        """Forget the track, the model, the calibration and the departure (a new ship, or a gap)."""
        self.track: deque = deque(maxlen=int(FIT_WINDOW / PREDICT_PERIOD))
        self.index = -1                                   # the last block's index
        self.block = -1                                   # the block being filled (floor(t / PREDICT_PERIOD))
        self.samples: list = []
        self.next_sample = -math.inf
        self.spread: deque = deque(maxlen=600)            # per block: the largest excursion about its mean (3,)
        self.cal = Calibrator(self.steps)
        self.model: ArModel | None = None
        self.fitted_at = -1
        self.forecast: Forecast | None = None
        self.departed_at: float | None = None
        self.recalibrated: list[float] = []               # departures found unlatched: the calibration began again
        self.cleared: list[float] = []                    # latched departures cleared by the latch set off (the
        #                                                   connection's end): the calibration began again too
        self.outside = 0
        self._q: np.ndarray | None = None                 # the calibrated multipliers of the last forecast
        self._psi2: np.ndarray | None = None              # the model's cumulative squared psi-weights

    @property
    def within(self) -> np.ndarray:
        """The motion within a block the block means do not carry: the largest excursion of a kept position about
        its block's mean over the last ten minutes, per axis, m."""
        return np.max(np.array(self.spread), axis=0) if self.spread else np.zeros(3)

    def push(self, t: float, p) -> bool:
        """Feed a position.

        Parameters
        ----------
        t : float
            Time, s.
        p : sequence of float
            Flange position, m (installation frame); one not finite is dropped, as a missing sample (found by
            review: a NaN block mean would count against one edge of the calibration only).

        Returns
        -------
        bool
            True when it closed a block (a new forecast may have been made).
        """
        if t < self.next_sample:
            return False
        p = np.asarray(p, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            return False                   # not a position: a missing sample (bridged, or a gap), never a block
        self.next_sample = (math.floor(t / SAMPLE_PERIOD + 1e-9) + 1) * SAMPLE_PERIOD
        b = int(math.floor(t / PREDICT_PERIOD + 1e-9))
        closed = False
        if b != self.block:
            closed = self._bridge(b, p) if self.samples else False
            self.block, self.samples = b, []
        self.samples.append(p)
        return closed

    def _bridge(self, b: int, p: np.ndarray) -> bool:
        """Close the block being filled, and bridge the blocks up to block ``b`` (of the new position ``p``): a
        straight line from the last block mean; or, over a gap longer than :data:`MAX_GAP`, start again."""
        full = len(self.samples) >= self.per_block - 1
        missing = b - self.block - (1 if full else 0)
        if missing * PREDICT_PERIOD > MAX_GAP or (missing and not self.track):
            self.reset()
            self.next_sample = (math.floor(b * PREDICT_PERIOD / SAMPLE_PERIOD + 1e-9) + 1) * SAMPLE_PERIOD
            return False
        if full:
            self._close(np.array(self.samples), (self.block + 1) * PREDICT_PERIOD)
        last, first = self.track[-1], b - missing
        for j in range(missing):                          # the blocks of the gap, on a line to the new position
            w = (j + 1) / (missing + 1)
            self._close(((1 - w) * last + w * p)[None], (first + j + 1) * PREDICT_PERIOD, bridged=True)
        return True

    def _close(self, samples: np.ndarray, t_end: float, bridged: bool = False) -> None:
        mean = samples.mean(axis=0)
        if not bridged:
            self.spread.append(np.max(np.abs(samples - mean), axis=0))
        self.track.append(mean)
        self.index += 1
        if not bridged:
            self._gate(mean, t_end)
        self.cal.observe(self.index, mean)
        n = len(self.track)
        if n * PREDICT_PERIOD < MIN_FIT:
            return
        history = np.array(self.track)
        if self.model is None or self.index - self.fitted_at >= REFIT / PREDICT_PERIOD:
            self.model, self.fitted_at = fit_ar(history, route=self.route), self.index
            self._psi2 = psi_variance(self.model.phi, self.steps)       # once per refit, not per block
        m, sd = ar_forecast(self.model, history, self.steps, psi2=self._psi2)
        self.cal.remember(self.index, m, sd)
        q = self.cal.refreshed(12)
        claimed = claimed_steps(q, self.route)
        lo, hi = interval(m, sd, q, claimed)
        self._q = q
        horizon = np.arange(1, self.steps + 1) * PREDICT_PERIOD
        self.forecast = Forecast(horizon, m, lo, hi, claimed * PREDICT_PERIOD, t_end, self.route) if claimed else None

    def _gate(self, value: np.ndarray, t_end: float) -> None:
        """The departure test: the new block mean against the forecasts made :data:`GATE_HORIZONS` ago."""
        if self.departed_at is not None or self.forecast is None:
            return
        q = self._q
        valid, mean, sd = self.cal.outstanding(self.index)
        j = np.array(GATE_HORIZONS) - 1
        j = j[valid[j] & np.all(np.isfinite(q[j, :2]), axis=(1, 2))]
        ratio = gate_ratio(value[:2] - mean[j, :2], q[j, :2, 0] * sd[j, :2], q[j, :2, 1] * sd[j, :2])
        out = bool(np.any(ratio > GATE_FACTOR))
        self.outside = self.outside + 1 if out else 0
        if self.outside < GATE_PERSIST:
            return
        if self._latch:
            self.departed_at = t_end
            return
        # not connected: the model keeps learning the track; the calibration starts again, so the prediction is
        # claimed (and trusted) only once its errors since are in (found: Hs 1.5-2.0 m seeds 163 and 177 departed
        # in the 35 minutes of track before the connection, on the sea alone, and lost the prediction for the run)
        self._recalibrate(t_end)

    def _recalibrate(self, departed_at: float) -> None:
        """Start the calibration again after the departure found unlatched at ``departed_at`` (kept in
        :attr:`recalibrated`); the track and the AR stay."""
        self.recalibrated.append(departed_at)
        self._restart_calibration()

    def _restart_calibration(self) -> None:
        """Forget the calibration and the forecast (the track and the AR stay): the prediction is claimed again
        only on errors realised from now."""
        self.cal = Calibrator(self.steps)
        self.forecast, self._q, self.outside = None, None, 0

    def trusted(self, lead: float) -> Forecast | None:
        """The forecast, when it may replace the measured routes for a stage of ``lead`` seconds: claimed at
        least that far, and the track has not left the model.

        Parameters
        ----------
        lead : float
            s.

        Returns
        -------
        Forecast or None
        """
        f = self.forecast
        if f is None or self.departed_at is not None or f.claimed < lead:
            return None
        return f
