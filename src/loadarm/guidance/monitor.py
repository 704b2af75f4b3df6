"""Connected-mode monitoring: time to the nearest face of the envelope, against the sequence still to run.

While the coupler is on the flange the arm's encoders give the flange position (the forward kinematics of the
measured joint angles). The monitor keeps a window of those positions and fits, per axis, a constant-
acceleration drift ``p + v t + a t^2 / 2`` by least squares (:class:`DriftFit`): exact for a drift at constant
acceleration (no lag, unlike a low-pass filter), with the waves averaged out over the window; the residual
gives the wave excursion and the fit's uncertainty. From it :meth:`EnvelopeMonitor.time_to_limit` predicts
when the flange would first cross a face of the arm's envelope (:mod:`loadarm.arm.faces`), two ways, and keeps the
earlier:

* **measured drift**: the fitted drift extrapolated (a decelerating drift stops at its vertex), widened by the
  wave excursion and ``k`` standard deviations of the fit's position and velocity;
* **design drift** (Lanquetin): from where the flange is, a break-out at the berth's design acceleration up to
  its design speed in every horizontal direction, and the design vertical speed up and down. This is the
  floor under the speed alarm: it needs no measurement history, so it covers the first seconds after the
  connection and a break-out the fit has not seen yet.

:func:`stage_leads` turns the sequence times into the lead each alarm stage needs; the stage raised is the most
severe whose lead is at least the time to the limit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.faces import FACES, breakout_distance, face_margins, first_face
from loadarm.arm.sequence import esd_lead, lead_values, valve_worst_time
from loadarm.guidance.drift import FIT_PERIOD, DriftEstimate, DriftFit
from loadarm.vocab import ROUTE_BREAKOUT, ROUTE_DESIGN, ROUTE_MEASURED, ROUTE_STEP, Severity

__all__ = ["stage_leads", "LimitForecast", "ForecastRoutes", "EnvelopeMonitor", "first_crossing", "measured_route",
           "predicted_crossing", "prediction_times", "CORNERS"]


def stage_leads(seq, *, valves_left: float | None = None, release_left: float | None = None) -> dict:
    """The time each alarm stage needs before the flange reaches a face of the envelope, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]`` (``esd_time``, ``ers_valve_time``, ``erc_release_time``, ``margin``,
        ``pre_alarm_lead``).
    valves_left : float, optional
        Time until the ERS valves are confirmed closed at the latest, s (default: the whole
        ``ers_valve_time + ers_valve_timeout``, ESD-1 not yet commanded; 0 once confirmed).
    release_left : float, optional
        Time until the coupler is free, s (default: the whole ``erc_release_time``, not yet opening).

    Returns
    -------
    dict of Severity to float
        ``RELEASE``: the ERS valves still to close (at their worst), the release and the margin; ``SECOND``: that plus the
        margin again; ``ESD1``: the whole sequence (ESD-1 complete, valves closed, release) plus the margin;
        ``PRE_ALARM``: that plus ``pre_alarm_lead`` (only when it is > 0).
    """
    v = valve_worst_time(seq) if valves_left is None else valves_left
    r = seq.erc_release_time if release_left is None else release_left
    release, second, esd1, pre = lead_values(v, r, seq.margin, esd_lead(seq), seq.pre_alarm_lead)
    leads = {Severity.RELEASE: release, Severity.SECOND: second, Severity.ESD1: esd1}
    if seq.pre_alarm_lead > 0:
        leads[Severity.PRE_ALARM] = pre
    return leads


@dataclass(frozen=True, slots=True)
class LimitForecast:
    """When the flange would first cross a face, and how that was found.

    Attributes
    ----------
    time : float
        Time to the first face, s (``inf`` beyond the horizon).
    face : str
        The face (:data:`loadarm.vocab.FACES`), ``""`` if none.
    route : str
        ``"design drift"``, ``"measured drift"``, ``"velocity step"`` or ``"break-out"``.
    by_face : tuple of (str, float)
        The time to each face crossed within the horizon, s, from the same scan: the nearest one's to the
        resolution, the others' the last scan time still inside (at most the scan's step early: never late).
    measured : float
        The time to the first face by the measured routes alone (drift, velocity step, break-out), s (``inf``
        when none crosses within the horizon): what the pre-alarm, a warning of a drift actually seen, is
        raised on (the design floor alone would make it a standing alarm at the nominal flange).
    design : float
        The time to the first face by the design drift alone, s (``inf``: none within the horizon; ``nan``: not
        computed, when the forecast was not asked for it): the floor under the predictive alarms.
    """

    time: float
    face: str
    route: str
    by_face: tuple = ()
    measured: float = math.inf
    design: float = math.nan


#: The eight corners of a forecast's box, in the order of a measured route's points.
CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def first_crossing(points, horizon: float, outside, faces, *, step: float, resolution: float) \
        -> tuple[float, str, int, dict]:
    """First time any of the forecast's points lies past a face: a coarse scan at ``step``, then bisection to
    ``resolution``, reported at the last time found inside (early by up to ``resolution``, never late within the
    scan). The one scan of every time to a face: the arm's faces (:class:`EnvelopeMonitor`) and the bank's
    (:class:`loadarm.guidance.bank.BankMonitor`).

    Parameters
    ----------
    points : callable
        ``tau`` (shape (T,), s) to the forecast's points, shape (T, K, ...).
    horizon : float
        s.
    outside : callable
        Points (T, K, ...) to ``(past, face)``: past a face (T, K), and which: an index of ``faces`` (T, K), or
        every face's own past (T, K, F) where several faces can be past at one point (the bank's: each face's
        time is then its own, not only the first past's).
    faces : sequence of str
        The faces' names.
    step, resolution : float
        s.

    Returns
    -------
    time : float
        The last time found inside, s (``inf``: none within the horizon).
    face : str
        ``""`` if none.
    index : int
        The point (of K) that crossed it (-1: none).
    by_face : dict of str to float
        From the coarse scan, the last time inside before each face crossed (the first face's refined).
    """
    tau = np.arange(0.0, horizon + step, step)
    past, face = outside(points(tau))
    rows = np.flatnonzero(past.any(axis=1))
    if rows.size == 0:
        return math.inf, "", -1, {}
    multi = face.ndim == past.ndim + 1

    def which(f) -> int:                                          # the face of one point
        return int(np.argmax(f)) if multi else int(f)

    by_face = {}
    for j, name in enumerate(faces):
        crossed = np.flatnonzero((face[..., j] if multi else past & (face == j)).any(axis=1))
        if crossed.size:
            r = int(crossed[0])
            by_face[name] = float(tau[r - 1]) if r > 0 else 0.0
    i = int(rows[0])
    k = int(np.flatnonzero(past[i])[0])
    hit = (faces[which(face[i, k])], k)
    if i == 0:
        by_face[hit[0]] = 0.0
        return 0.0, hit[0], hit[1], by_face
    lo, hi = float(tau[i - 1]), float(tau[i])
    while hi - lo > resolution + 1e-12:
        mid = 0.5 * (lo + hi)
        out, f = outside(points(np.array([mid])))
        if out.any():
            hi = mid
            k = int(np.flatnonzero(out[0])[0])
            hit = (faces[which(f[0, k])], k)
        else:
            lo = mid
    by_face = {f: max(t, lo) for f, t in by_face.items()}   # no face is crossed before the first one
    by_face[hit[0]] = lo
    return lo, hit[0], hit[1], by_face


def measured_route(est: DriftEstimate, age: float, k_sigma: float):
    """The measured route of one drift estimate: ``tau`` (shape (T,)) to the corners of its box (T, 8, d).

    The fit extrapolated from its newest sample (its acceleration only where it is significant: an acceleration
    too small to tell from the waves is the design floor's to cover, from rest), a decelerating drift stopping at
    its vertex, widened by the wave excursion and ``k_sigma`` standard deviations of the position and velocity.

    Parameters
    ----------
    est : DriftEstimate
        Of any three channels (the flange's position, m; the ship's roll, pitch and yaw, rad).
    age : float
        From the estimate's newest sample to now, s.
    k_sigma : float

    Returns
    -------
    callable
    """
    a = np.where(np.abs(est.a) > k_sigma * est.sigma_a, est.a, 0.0)
    t_stop = np.where(est.v * a < 0, -est.v / np.where(a == 0, 1.0, a), np.inf)

    def points(tau):
        t = np.minimum(tau[:, None] + age, t_stop)
        centre = est.p + est.v * t + 0.5 * a * t * t
        half = est.wave + k_sigma * (est.sigma_p + est.sigma_v * (tau[:, None] + age))
        return centre[:, None, :] + half[:, None, :] * CORNERS[None]

    return points


@dataclass(frozen=True)
class ForecastRoutes:
    """The forecast of the flange's position by every route, as functions of the time ahead.

    Attributes
    ----------
    design : callable
        ``tau`` (T,) to the design drift's points (T, :attr:`n_design`, 3): a break-out from where the flange is
        in every horizontal direction, and the design vertical speed up and down.
    measured : tuple of callable
        Each measured route's ``tau`` to its box's corners (T, 8, 3).
    names : tuple of str
        The measured routes' names (``"measured drift"``, ``"velocity step"``, ``"break-out"``).
    n_design : int
    """

    design: object
    measured: tuple
    names: tuple[str, ...]
    n_design: int

    def points(self, tau) -> np.ndarray:
        """Every route's points, the design drift's first: (T, K, 3).

        Parameters
        ----------
        tau : ndarray (T,)
            s ahead.

        Returns
        -------
        ndarray
        """
        return np.concatenate([self.design(tau)] + [r(tau) for r in self.measured], axis=1)   # one evaluation

    def measured_points(self, tau) -> np.ndarray:
        """The measured routes' points alone: (T, 8 x routes, 3).

        Parameters
        ----------
        tau : ndarray (T,)

        Returns
        -------
        ndarray
        """
        return np.concatenate([r(tau) for r in self.measured], axis=1)

    def route(self, k: int) -> str:
        """The route of point ``k`` of :meth:`points`.

        Parameters
        ----------
        k : int

        Returns
        -------
        str
        """
        return ROUTE_DESIGN if k < self.n_design else self.names[(k - self.n_design) // len(CORNERS)]


class EnvelopeMonitor:
    """Time-to-limit of the attached flange from the measured drift and the berth's design drift.

    Parameters
    ----------
    model : ArmModel
        Arm, joint limits and ``design_drift``.
    window : float
        Drift-fit window, s.
    k_sigma : float
        Standard deviations of the fit added to the prediction (2: about 97.5 % one-sided).
    step : float
        Time step of the coarse scan of the prediction, s.
    resolution : float
        The crossing is then bisected to this, s, and reported at the last time found inside: early by up to
        ``resolution``, never late (within the scan: a face crossed and left between two scan steps is missed,
        which 2 s steps at drift speeds below 1 m/s make a decimetre-scale corner effect).
    period : float
        Sampling period of the drift fit, s (:class:`DriftFit`); the controller makes it a whole number of its
        cycles.
    """

    #: History the measured route needs once ESD-1 is active, s.
    ALARMED_MIN_HISTORY = 10.0

    def __init__(self, model, window: float, k_sigma: float = 2.0, step: float = 2.0, resolution: float = 0.0625,
                 period: float = FIT_PERIOD):
        self.model = model
        self.fit = DriftFit(window, period)
        self.k = k_sigma
        self.step = step
        self.resolution = resolution
        dd = model.design_drift
        ang = np.arange(8) * (math.pi / 4)
        self.dirs_h = np.stack([np.cos(ang), np.sin(ang), np.zeros(8)], axis=1)
        self.dd = dd
        self.est: DriftEstimate | None = None
        self.est_t = math.nan
        self.est_alarmed = False
        self.step_est: DriftEstimate | None = None
        self.breakout_est: DriftEstimate | None = None
        self.step_t = math.nan
        self.step_pending = False

    def reset(self) -> None:
        """A new connection: forget the drift history."""
        self.fit.reset()
        self.est, self.est_t, self.est_alarmed = None, math.nan, False
        self.step_est, self.breakout_est, self.step_t, self.step_pending = None, None, math.nan, False

    def observe(self, t: float, p) -> bool:
        """Feed the attached flange position (from the encoders).

        Parameters
        ----------
        t : float
            Time, s.
        p : sequence of float
            Coupler (= flange) position, m.

        Returns
        -------
        bool
            True when the sample was kept (one per fit period): time to :meth:`refit`.
        """
        return self.fit.push(t, p)

    def refit(self, alarmed: bool = False, *, step: bool = True) -> DriftEstimate | None:
        """Fit the drift now and keep it for the forecasts until the next refit (the guidance cycle does the
        fit, the velocity-step test and the forecast in different cycles, so that no cycle does two).

        Parameters
        ----------
        alarmed : bool
            ESD-1 is active (see :meth:`time_to_limit`).
        step : bool
            Also test for a velocity step (:meth:`test_step`); with False the step test is left pending for a
            later call of :meth:`test_step`.

        Returns
        -------
        DriftEstimate or None
        """
        if alarmed:
            est = self.fit.estimate(int(round(self.ALARMED_MIN_HISTORY / self.fit.period)))
        else:
            est = self.fit.estimate()
        self.est, self.est_t, self.est_alarmed = est, self.fit.t_last, alarmed
        self.step_pending = True
        if step:
            self.test_step()
        return est

    def test_step(self) -> DriftEstimate | None:
        """Test the window for a velocity step (:meth:`DriftFit.step_estimate`) and for a break-out
        (:meth:`DriftFit.breakout_estimate`) and keep the results for the forecasts, as of the window's newest
        sample.

        Returns
        -------
        DriftEstimate or None
            The velocity step's estimate (the break-out's is :attr:`breakout_est`).
        """
        self.step_est, self.step_t, self.step_pending = self.fit.step_estimate(), self.fit.t_last, False
        self.breakout_est = self.fit.breakout_estimate()
        return self.step_est

    def _outside(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = face_margins(self.model, pts[..., 0], pts[..., 1], pts[..., 2])
        return first_face(m)

    def _first_crossing(self, points, horizon: float) -> tuple[float, str, int, dict]:
        """:func:`first_crossing` of the arm's faces at this monitor's step and resolution."""
        return first_crossing(points, horizon, self._outside, FACES, step=self.step, resolution=self.resolution)

    def time_to_limit(self, p_now, horizon: float, *, alarmed: bool = False, now: float | None = None,
                      design_too: bool = False) -> LimitForecast:
        """Earliest time the flange could cross a face within ``horizon`` seconds.

        Parameters
        ----------
        p_now : sequence of float
            Flange position now, m.
        horizon : float
            How far ahead to look, s (the longest stage lead).
        alarmed : bool
            ESD-1 is already active: the measured route then fits whatever history there is (at least
            :attr:`ALARMED_MIN_HISTORY` s), so that a drift faster than the design one, which started soon after
            the connection, still gets its release in time. Before ESD-1 only a full window counts (no false
            alarm from a short, wave-dominated fit).
        now : float, optional
            Time, s: use the fit of the last :meth:`refit` (made for the same ``alarmed``), extrapolated from the
            time of its newest sample to ``now``. Without it the drift is fitted here.
        design_too : bool
            Also give the design drift's own time (:attr:`LimitForecast.design`) when a measured route crosses
            first (one more scan).

        Returns
        -------
        LimitForecast
        """
        routes = self.routes(p_now, alarmed=alarmed, now=now)
        points = routes.points if routes.measured else routes.design
        t, face, k, by_face = self._first_crossing(points, horizon)
        if not face:
            return LimitForecast(math.inf, "", "", design=math.inf)
        faces = tuple(sorted(by_face.items(), key=lambda kv: kv[1]))
        if k < routes.n_design:
            t_m = self._first_crossing(routes.measured_points, horizon)[0] if routes.measured else math.inf
            return LimitForecast(t, face, ROUTE_DESIGN, faces, t_m, t)
        t_d = self._first_crossing(routes.design, horizon)[0] if design_too else math.nan
        return LimitForecast(t, face, routes.route(k), faces, t, t_d)

    def routes(self, p_now, *, alarmed: bool = False, now: float | None = None) -> ForecastRoutes:
        """The forecast of the flange by every route, as :meth:`time_to_limit` scans it (one forecast for the
        arm's faces and the bank's: :class:`loadarm.guidance.bank.BankMonitor`).

        Parameters
        ----------
        p_now : sequence of float
            Flange position now, m.
        alarmed : bool
            ESD-1 is already active (:meth:`time_to_limit`).
        now : float, optional
            Time, s: use the fit of the last :meth:`refit` (made for the same ``alarmed``); without it the drift
            is fitted here.

        Returns
        -------
        ForecastRoutes
        """
        if now is None or alarmed != self.est_alarmed or (self.est is None and self.fit.count):
            self.refit(alarmed)
        est = self.est
        age = 0.0 if (now is None or est is None) else max(now - self.est_t, 0.0)
        base = np.asarray(p_now, dtype=float) if est is None else est.p + est.v * age
        dd = self.dd
        dirs_h = self.dirs_h
        dirs_v = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])

        def design(tau):
            # a break-out from where the flange is, every horizontal direction, and vertically
            d_h = breakout_distance(tau, dd.speed, dd.acceleration)
            d_v = dd.vertical_speed * tau
            return np.concatenate([base + d_h[:, None, None] * dirs_h[None],
                                   base + d_v[:, None, None] * dirs_v[None]], axis=1)

        routes, names = [], []
        if est is not None:
            routes.append(self._measured(est, age))
            names.append(ROUTE_MEASURED)
            step_age = 0.0 if now is None else max(now - self.step_t, 0.0)
            for name, e in ((ROUTE_STEP, self.step_est), (ROUTE_BREAKOUT, self.breakout_est)):
                if e is not None:
                    routes.append(self._measured(e, step_age))
                    names.append(name)
        return ForecastRoutes(design, tuple(routes), tuple(names), dirs_h.shape[0] + 2)

    def _measured(self, est: DriftEstimate, age: float):
        """:func:`measured_route` at this monitor's ``k``."""
        return measured_route(est, age, self.k)


def predicted_crossing(model, forecast, within, now: float, lead: float) -> tuple[float, str]:
    """The predictive alarms' time to a face: the first horizon, within ``lead`` of now, at which the box of the
    calibrated interval (widened by the motion within a block) reaches a face.

    The interval's edges are the declared threshold's one-sided bounds (:data:`loadarm.guidance.predict.THRESHOLD`),
    each edge calibrated on its own side's errors: a box corner past a face at a horizon means a probability of
    being past it then of at least about that much (per axis, marginal), so the probability of reaching the face
    by then is at least as large. Measured, the tails are near their share but not at it everywhere (off the
    berth the upper edge's was 3.5 % on the hold-out records: docs/guidance.md section 13). A block
    mean of horizon ``h`` covers ``(t + h - 1, t + h]`` after the forecast's time ``t``: its crossing is dated at
    the block's start (early, never late).

    Parameters
    ----------
    model : ArmModel
    forecast : Forecast
        :class:`loadarm.guidance.predict.Forecast` (its claimed horizons only).
    within : ndarray (3,)
        The motion within a block about its mean, m (:attr:`FlangePredictor.within`).
    now : float
        s.
    lead : float
        How far ahead to look, s (the longest stage lead).

    Returns
    -------
    time : float
        s from ``now`` (``inf``: none within the claimed horizons and the lead).
    face : str
        ``""`` when none.
    """
    age = now - forecast.time
    start = forecast.horizon - forecast.horizon[0] - age                    # each block's start, s from now
    keep = np.flatnonzero((np.arange(start.size) < int(round(forecast.claimed / forecast.horizon[0])))
                          & (start <= lead))
    if keep.size == 0:
        return math.inf, ""
    # the box holds the mean too: an edge calibrated inside the mean (more than 97.5 % of a window's errors of one
    # sign) must not put the bound past the mean track's crossing (found by review)
    lo = np.minimum(forecast.lo[keep], forecast.mean[keep])
    hi = np.maximum(forecast.hi[keep], forecast.mean[keep])
    centre = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo) + np.asarray(within)
    pts = centre[:, None, :] + half[:, None, :] * CORNERS[None]
    m = face_margins(model, pts[..., 0], pts[..., 1], pts[..., 2])
    outside, face = first_face(m)
    rows = np.flatnonzero(outside.any(axis=1))
    if rows.size == 0:
        return math.inf, ""
    i = int(rows[0])
    k = int(np.flatnonzero(outside[i])[0])
    return max(float(start[keep[i]]), 0.0), FACES[int(face[i, k])]


def prediction_times(model, forecast, within, now: float, lead: float) -> tuple[float, float, str]:
    """The prediction's time to the nearest face with its interval: by the calibrated bound (widened by the
    motion within a block: what the predictive alarms use) and by the mean track alone.

    Parameters
    ----------
    model, forecast, within, now, lead
        As :func:`predicted_crossing`.

    Returns
    -------
    bound, mean : float
        s from ``now`` (``inf``: none within the claim and the lead).
    face : str
        The bound's face (``""``: none).
    """
    bound, face = predicted_crossing(model, forecast, within, now, lead)
    centre = dataclasses.replace(forecast, lo=forecast.mean, hi=forecast.mean)
    return bound, predicted_crossing(model, centre, np.zeros(3), now, lead)[0], face
