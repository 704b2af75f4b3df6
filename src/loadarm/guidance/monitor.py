"""Connected-mode monitoring: time to the nearest face of the envelope, against the sequence still to run.

While the coupler is on the flange the arm's encoders give the flange position (the forward kinematics of the
measured joint angles). The monitor keeps a window of those positions and fits, per axis, a constant-
acceleration drift ``p + v t + a t^2 / 2`` by least squares (:class:`DriftFit`): exact for a drift at constant
acceleration (no lag, unlike a low-pass filter), with the waves averaged out over the window; the residual
gives the wave excursion and the fit's uncertainty. From it :meth:`EnvelopeMonitor.time_to_limit` predicts
when the flange would first cross a face of the arm's envelope (:mod:`loadarm.faces`), two ways, and keeps the
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

import math
from dataclasses import dataclass

import numpy as np

from ..alarms import Severity
from ..check import esd_lead
from ..faces import FACES, breakout_distance, face_margins, first_face

__all__ = ["stage_leads", "DriftEstimate", "DriftFit", "LimitForecast", "EnvelopeMonitor"]


def stage_leads(seq, *, valves_left: float | None = None, release_left: float | None = None) -> dict:
    """The time each alarm stage needs before the flange reaches a face of the envelope, s.

    Parameters
    ----------
    seq : record
        The installation's ``[sequence]`` (``esd_time``, ``ers_valve_time``, ``erc_release_time``, ``margin``,
        ``pre_alarm_lead``).
    valves_left : float, optional
        Time until the ERS valves are confirmed closed, s (default: the whole ``ers_valve_time``, ESD-1 not yet
        commanded; 0 once confirmed).
    release_left : float, optional
        Time until the coupler is free, s (default: the whole ``erc_release_time``, not yet opening).

    Returns
    -------
    dict of Severity to float
        ``RELEASE``: the ERS valves still to close, the release and the margin; ``SECOND``: that plus the
        margin again; ``ESD1``: the whole sequence (ESD-1 complete, valves closed, release) plus the margin;
        ``PRE_ALARM``: that plus ``pre_alarm_lead`` (only when it is > 0).
    """
    v = seq.ers_valve_time if valves_left is None else max(valves_left, 0.0)
    r = seq.erc_release_time if release_left is None else max(release_left, 0.0)
    release = v + r + seq.margin
    leads = {Severity.RELEASE: release, Severity.SECOND: release + seq.margin, Severity.ESD1: esd_lead(seq)}
    leads[Severity.ESD1] = max(leads[Severity.ESD1], leads[Severity.SECOND])
    if seq.pre_alarm_lead > 0:
        leads[Severity.PRE_ALARM] = leads[Severity.ESD1] + seq.pre_alarm_lead
    return leads


@dataclass(frozen=True, slots=True)
class DriftEstimate:
    """The fitted drift at the end of the window (per axis x, y, z).

    Attributes
    ----------
    p, v, a : ndarray, shape (3,)
        Drift position (m), velocity (m/s) and acceleration (m/s^2) now.
    sigma_p, sigma_v, sigma_a : ndarray, shape (3,)
        Their standard deviations, inflated for the waves' correlation.
    wave : ndarray, shape (3,)
        Largest wave excursion about the drift in the window, m.
    """

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    sigma_p: np.ndarray
    sigma_v: np.ndarray
    sigma_a: np.ndarray
    wave: np.ndarray


class DriftFit:
    """Least-squares constant-acceleration fit over a sliding window of flange positions.

    Parameters
    ----------
    window : float
        Window length, s (``guidance.drift_window``).
    period : float
        Sampling period of the window, s.
    correlation : float
        Factor on the fit's formal standard deviations: wave residuals are correlated over a wave period, so
        the formal (white-noise) values are too small. Measured on the Hs 1.5 m scenario (seed 7, 60 s window
        sampled at 5 Hz): the spread of the fitted velocity and acceleration is 1.3-1.4 times the formal value;
        2 is used.

    Notes
    -----
    With ``tau_i`` the sample times relative to the newest, the design matrix ``X = [1, tau, tau^2 / 2]`` is
    fixed, so its pseudo-inverse is computed once and each fit is a (3 x N) @ (N x 3) product.
    """

    def __init__(self, window: float, period: float = 0.2, correlation: float = 2.0):
        self.n = max(int(round(window / period)), 8)
        self.period = period
        tau = (np.arange(self.n) - (self.n - 1)) * period
        self.X = np.stack([np.ones(self.n), tau, 0.5 * tau * tau], axis=1)
        self.pinv = np.linalg.pinv(self.X)
        self.cov_unit = np.linalg.inv(self.X.T @ self.X)
        self.correlation = correlation
        self.buf = np.zeros((self.n, 3))
        self.count = 0
        self.next_t: float | None = None
        self.t_last = math.nan

    def reset(self) -> None:
        """Forget every sample (a new connection)."""
        self.count = 0
        self.next_t = None
        self.t_last = math.nan

    def due(self, t: float) -> bool:
        """Whether :meth:`push` would keep a sample at ``t`` (so the caller computes the position only then).

        Parameters
        ----------
        t : float
            Time, s.

        Returns
        -------
        bool
        """
        return self.next_t is None or t >= self.next_t - 1e-9

    def push(self, t: float, p) -> bool:
        """Offer a position; it is kept if a sampling period has passed since the last kept one.

        Parameters
        ----------
        t : float
            Time, s.
        p : sequence of float
            Position, m.

        Returns
        -------
        bool
            True when the sample was kept.
        """
        if not self.due(t):
            return False
        self.next_t = t + self.period if self.next_t is None else self.next_t + self.period
        if self.next_t <= t:                    # a gap in the samples: restart the grid here
            self.next_t = t + self.period
        self.buf[:-1] = self.buf[1:]
        self.buf[-1] = p
        self.count += 1
        self.t_last = t
        return True

    def estimate(self, min_samples: int | None = None) -> DriftEstimate | None:
        """The fit over the full window, or over the samples there are if at least ``min_samples``.

        Parameters
        ----------
        min_samples : int, optional
            Accept a partial window of at least this many samples (default: only a full window). Its standard
            deviations are those of the shorter fit, so they are larger.

        Returns
        -------
        DriftEstimate or None
        """
        m = min(self.count, self.n)
        if m < (self.n if min_samples is None else max(min_samples, 8)):
            return None
        if m == self.n:
            X, pinv, cov = self.X, self.pinv, self.cov_unit
        else:
            X = self.X[-m:]
            pinv = np.linalg.pinv(X)
            cov = np.linalg.inv(X.T @ X)
        y = self.buf[-m:]
        c = pinv @ y                                 # (3, 3): rows p, v, a; columns x, y, z
        res = y - X @ c
        s = np.sqrt(np.sum(res * res, axis=0) / (m - 3))
        sd = self.correlation * s[None, :] * np.sqrt(np.diag(cov))[:, None]
        return DriftEstimate(c[0], c[1], c[2], sd[0], sd[1], sd[2], np.max(np.abs(res), axis=0))


@dataclass(frozen=True, slots=True)
class LimitForecast:
    """When the flange would first cross a face, and how that was found.

    Attributes
    ----------
    time : float
        Time to the first face, s (``inf`` beyond the horizon).
    face : str
        The face (:data:`loadarm.faces.FACES`), ``""`` if none.
    route : str
        ``"measured drift"`` or ``"design drift"``.
    """

    time: float
    face: str
    route: str


_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


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
    """

    #: History the measured route needs once ESD-1 is active, s.
    ALARMED_MIN_HISTORY = 10.0

    def __init__(self, model, window: float, k_sigma: float = 2.0, step: float = 2.0, resolution: float = 0.0625):
        self.model = model
        self.fit = DriftFit(window)
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

    def reset(self) -> None:
        """A new connection: forget the drift history."""
        self.fit.reset()
        self.est, self.est_t, self.est_alarmed = None, math.nan, False

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

    def refit(self, alarmed: bool = False) -> DriftEstimate | None:
        """Fit the drift now and keep it for the forecasts until the next refit (the guidance cycle does the
        fit and the forecast in different cycles, so that neither cycle does both).

        Parameters
        ----------
        alarmed : bool
            ESD-1 is active (see :meth:`time_to_limit`).

        Returns
        -------
        DriftEstimate or None
        """
        if alarmed:
            est = self.fit.estimate(int(round(self.ALARMED_MIN_HISTORY / self.fit.period)))
        else:
            est = self.fit.estimate()
        self.est, self.est_t, self.est_alarmed = est, self.fit.t_last, alarmed
        return est

    def _outside(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = face_margins(self.model, pts[..., 0], pts[..., 1], pts[..., 2])
        return first_face(m)

    def _first_crossing(self, points, horizon: float) -> tuple[float, str, int]:
        """First time any of ``points(tau)`` (shape (T, K, 3) for times ``tau``) lies past a face: a coarse scan
        at :attr:`step`, then bisection to :attr:`resolution`; returns the last time found inside, the face and
        the index of the point that crossed it (``inf, "", -1`` if none within the horizon)."""
        tau = np.arange(0.0, horizon + self.step, self.step)
        outside, face = self._outside(points(tau))
        rows = np.flatnonzero(outside.any(axis=1))
        if rows.size == 0:
            return math.inf, "", -1
        i = int(rows[0])
        k = int(np.flatnonzero(outside[i])[0])
        hit = (FACES[int(face[i, k])], k)
        if i == 0:
            return 0.0, hit[0], hit[1]
        lo, hi = float(tau[i - 1]), float(tau[i])
        while hi - lo > self.resolution + 1e-12:
            mid = 0.5 * (lo + hi)
            out, f = self._outside(points(np.array([mid])))
            if out.any():
                hi = mid
                k = int(np.flatnonzero(out[0])[0])
                hit = (FACES[int(f[0, k])], k)
            else:
                lo = mid
        return lo, hit[0], hit[1]

    def time_to_limit(self, p_now, horizon: float, *, alarmed: bool = False, now: float | None = None) -> LimitForecast:
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

        Returns
        -------
        LimitForecast
        """
        if now is None or alarmed != self.est_alarmed or (self.est is None and self.fit.count):
            self.refit(alarmed)
        est = self.est
        age = 0.0 if (now is None or est is None) else max(now - self.est_t, 0.0)
        base = np.asarray(p_now, dtype=float) if est is None else est.p + est.v * age
        dd = self.dd
        dirs_v = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])

        def design(tau):
            # a break-out from where the flange is, every horizontal direction, and vertically
            d_h = breakout_distance(tau, dd.speed, dd.acceleration)
            d_v = dd.vertical_speed * tau
            return np.concatenate([base + d_h[:, None, None] * self.dirs_h[None],
                                   base + d_v[:, None, None] * dirs_v[None]], axis=1)

        n_design = self.dirs_h.shape[0] + 2
        if est is None:
            points = design
        else:
            # measured drift: the fit extrapolated (its acceleration only where it is significant: an
            # acceleration too small to tell from the waves is the design floor's to cover, from rest), a
            # decelerating drift stopping at its vertex, widened by the wave excursion and k standard deviations
            # of the position and velocity
            a = np.where(np.abs(est.a) > self.k * est.sigma_a, est.a, 0.0)
            t_stop = np.where(est.v * a < 0, -est.v / np.where(a == 0, 1.0, a), np.inf)

            def points(tau):
                t = np.minimum(tau[:, None] + age, t_stop)             # from the fit's newest sample
                centre = est.p + est.v * t + 0.5 * a * t * t
                half = est.wave + self.k * (est.sigma_p + est.sigma_v * (tau[:, None] + age))
                measured = centre[:, None, :] + half[:, None, :] * _CORNERS[None]
                return np.concatenate([design(tau), measured], axis=1)      # one evaluation for both routes

        t, face, k = self._first_crossing(points, horizon)
        if not face:
            return LimitForecast(math.inf, "", "")
        return LimitForecast(t, face, "design drift" if k < n_design else "measured drift")
