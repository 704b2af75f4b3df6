"""The drift fit of the connected-mode monitor: the flange's recent positions sampled on a fixed period, fitted for a
drift (position, velocity, acceleration and their uncertainty, inflated for the waves' correlation), and the
velocity-step and break-out statistics on the same window."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["FIT_PERIOD", "DriftEstimate", "DriftFit"]


#: Sampling period of the drift fit, s: 5 Hz resolves a drift and its wave excursion (wave periods of 5-20 s).
FIT_PERIOD = 0.2


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
    step_age : float
        For a velocity-step estimate (:meth:`DriftFit.step_estimate`): how long ago the step was, s; ``nan`` for
        the plain fit.
    """

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    sigma_p: np.ndarray
    sigma_v: np.ndarray
    sigma_a: np.ndarray
    wave: np.ndarray
    step_age: float = math.nan


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

    A smooth fit over a long window follows a *velocity step* (a mooring line parting, the ship breaking out
    within a second) late: 1.7 s late for 0.3 m/s reached at 0.5 m/s^2. :meth:`step_estimate` tests for one: the
    window refitted with a hinge ``dv max(0, tau + c)`` added, for each candidate age ``c`` of the step
    (:attr:`STEP_AGES`), a segmented regression whose largest standardised ``dv`` is the generalised likelihood
    ratio statistic of a slope change.
    """

    #: Candidate ages of a velocity step, s: from 1 s (fewer samples cannot tell a step from a wave) to 20 s
    #: (older steps the smooth fit has absorbed), every 0.4 s.
    STEP_AGES = np.arange(1.0, 20.0 + 1e-9, 0.4)
    #: Standardised slope change above which a step is taken as real. Without a step the statistic's largest
    #: value is 5.3 over 10 seeds of the Hs 1.5 m sea (600 s each) and 4.4 at Hs 0.5 m; a 0.3 m/s step at
    #: Hs 0.5 m passes 10 within 3.6 s (tests/test_guidance.py: ``test_waves_alone_make_no_velocity_step``,
    #: ``test_a_velocity_step_is_seen_within_seconds_and_never_forecast_late``). Waves long against the window
    #: (Tp 25 s and more) pass it: docs/guidance.md section 5.
    STEP_Z = 10.0
    #: Smallest velocity change taken as a step, m/s: a smaller one is the smooth fit's to follow (and a window
    #: without waves would otherwise divide rounding noise by rounding noise).
    STEP_MIN = 0.02

    #: Candidate ages of a break-out (an acceleration change: every line parted, the ship accelerating from its
    #: drift), s: from 2 s to 30 s, every 0.4 s.
    BREAKOUT_AGES = np.arange(2.0, 30.0 + 1e-9, 0.4)
    #: Standardised acceleration change above which a break-out is taken as real (:meth:`breakout_statistic`;
    #: calibrated on seas without one, docs/guidance.md section 5).
    BREAKOUT_Z = 12.0
    #: Smallest acceleration change taken as a break-out, m/s^2 (a fifth of the example berth's design 0.01).
    BREAKOUT_MIN = 0.002
    #: The waves' share of a hinge's curvature over a segment of age ``c``: ``k s_x / c^2`` for the test's
    #: curvature-only hinge and for the estimate's velocity-and-curvature hinge (whose curvature the free
    #: velocity change makes wander more). Calibrated on seas without a drift (Hs 0.5-1.5 m, the kinematic and
    #: the moored ship): with these the largest no-drift statistic is about 5 on the kinematic ship (docs/guidance.md).
    BREAKOUT_WAVE_K = (2.0 * math.sqrt(2.0), 8.0 * math.sqrt(2.0))

    def __init__(self, window: float, period: float = FIT_PERIOD, correlation: float = 2.0):
        self.n = max(int(round(window / period)), 8)
        self.period = period
        tau = (np.arange(self.n) - (self.n - 1)) * period
        self.X = np.stack([np.ones(self.n), tau, 0.5 * tau * tau], axis=1)
        self.pinv = np.linalg.pinv(self.X)
        self.cov_unit = np.linalg.inv(self.X.T @ self.X)
        self.correlation = correlation
        self.buf = np.zeros((self.n, 3))
        # velocity-step candidates, in whole samples so that the hinge is exact on the grid
        m = np.unique(np.round(self.STEP_AGES / period).astype(int))
        self.step_m = m[(m >= 2) & (m <= self.n // 2)]
        self.step_ages = self.step_m * period
        hinge = period * np.maximum(0, np.arange(self.n)[None, :] - (self.n - 1 - self.step_m[:, None]))
        Xs = np.concatenate([np.broadcast_to(self.X, (self.step_m.size, self.n, 3)), hinge[:, :, None]], axis=2)
        self.step_X = Xs                                        # (C, N, 4)
        self.step_cov = np.linalg.inv(np.einsum("cni,cnj->cij", Xs, Xs))
        self.step_dX = np.diff(self.X, axis=0)                  # (N - 1, 3)
        dXs = np.diff(Xs, axis=1)
        self.step_dgram = np.einsum("cni,cnj->cij", dXs, dXs)   # (C, 4, 4)
        self.step_ends = np.ascontiguousarray(Xs[:, [0, -1], :])  # (C, 2, 4): rows at both ends of the window
        # break-out candidates: an acceleration change at age c, tested with the curvature hinge
        # ``da h^2 / 2`` (h = max(0, tau + c)), estimated with ``dv h + da h^2 / 2``
        mb = np.unique(np.round(self.BREAKOUT_AGES / period).astype(int))
        self.bo_m = mb[(mb >= 3) & (mb <= self.n // 2)]
        self.bo_ages = self.bo_m * period
        h = period * np.maximum(0, np.arange(self.n)[None, :] - (self.n - 1 - self.bo_m[:, None]))
        base = np.broadcast_to(self.X, (self.bo_m.size, self.n, 3))
        Xb = np.concatenate([base, 0.5 * (h * h)[:, :, None]], axis=2)                  # (C, N, 4): the test
        self.bo_XT = np.ascontiguousarray(np.swapaxes(Xb, 1, 2))                        # (C, 4, N)
        self.bo_cov = np.linalg.inv(self.bo_XT @ Xb)
        ddX = np.diff(Xb, n=2, axis=1)                          # (C, N - 2, 4): the second differences
        self.bo_ddXT = np.ascontiguousarray(np.swapaxes(ddX, 1, 2))
        self.bo_ddgram = self.bo_ddXT @ ddX
        self.bo_X5 = np.concatenate([base, h[:, :, None], 0.5 * (h * h)[:, :, None]], axis=2)  # (C, N, 5)
        self.bo_cov5 = np.linalg.inv(np.swapaxes(self.bo_X5, 1, 2) @ self.bo_X5)
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

    def step_statistic(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The slope-change test over the full window, for every candidate age (needs a full window).

        Returns
        -------
        z : ndarray, shape (C, 3)
            Standardised slope change per candidate age and axis.
        coef : ndarray, shape (C, 4, 3)
            The hinge fits: rows position, velocity, acceleration before the step, velocity change.
        sdv : ndarray, shape (C, 3)
            The standard deviation the velocity change was divided by, m/s.
        rss : ndarray, shape (C, 3)
            The hinge fits' residual sums of squares, m^2.

        Notes
        -----
        Waves make the slope of a short segment wander far more than white noise would: over a segment of age
        ``c`` short against the wave period it is the wave velocity, over a longer one about the difference of
        two wave positions over ``c``. So the velocity change is divided by the larger of the formal standard
        deviation (times :attr:`correlation`) and ``min(s_v, sqrt(2) s_x / c)``, with ``s_x`` and ``s_v`` the
        standard deviations of the hinge fit's residuals and of their rate.

        The hinge fits are of the plain fit's residuals (the hinge model contains the plain one, so the
        coefficients simply add), and their residual sums come from the normal equations (``r'r = y'y - b'X'y``
        and likewise for the differenced residuals), so no (C, N, 3) residual array is formed: 1.4 ms per test
        with it, about 0.1 ms without (tests/test_guidance.py checks the sums against the residuals themselves).
        """
        base = self.pinv @ self.buf                             # the plain fit; the hinge fit is of its residuals
        y = self.buf - self.X @ base                            # (the sums then have no cancellation to speak of)
        dy = np.diff(y, axis=0)
        C, m, P = self.step_m.size, self.step_m, self.period
        # the hinge column's products in closed form: with r the window newest first, sum_{j<m} (m - j) P r_j
        # and, differenced, P (y_newest - y_{newest - m})
        r = y[::-1]
        c0 = np.cumsum(r, axis=0)
        c1 = np.cumsum(np.arange(self.n)[:, None] * r, axis=0)
        hy = P * (m[:, None] * c0[m - 1] - c1[m - 1])            # (C, 3)
        dhy = P * (y[-1] - y[-1 - m])
        xty = np.empty((C, 4, 3))
        xty[:, :3] = self.X.T @ y
        xty[:, 3] = hy
        dxty = np.empty((C, 4, 3))
        dxty[:, :3] = self.step_dX.T @ dy
        dxty[:, 3] = dhy
        coef = self.step_cov @ xty                              # (C, 4, 3), on the residuals
        rss = np.maximum(np.sum(y * y, axis=0) - np.sum(coef * xty, axis=1), 0.0)       # (C, 3)
        ssd = np.sum(dy * dy, axis=0) + np.sum(coef * (self.step_dgram @ coef - 2.0 * dxty), axis=1)
        ends = y[[0, -1]][None] - self.step_ends @ coef         # (C, 2, 3): residuals at both ends
        first, last = ends[:, 0], ends[:, 1]
        coef[:, :3] += base                                     # the hinge fit of the positions themselves
        m = self.n - 1
        s_v = np.sqrt(np.maximum(ssd / m - ((last - first) / m) ** 2, 0.0)) / self.period
        s_x = np.sqrt(rss / (self.n - 4))
        formal = self.correlation * s_x * np.sqrt(self.step_cov[:, 3, 3])[:, None]
        wave = np.minimum(s_v, math.sqrt(2.0) * s_x / self.step_ages[:, None])
        sdv = np.maximum(formal, wave)
        return np.abs(coef[:, 3, :]) / np.where(sdv > 0, sdv, np.inf), coef, sdv, rss

    def step_estimate(self) -> DriftEstimate | None:
        """The drift after a velocity step, if the window shows one (:attr:`STEP_Z`); else None.

        Per axis where the step is significant, the hinge fit of the most significant age gives the position
        and velocity now (the velocity before the step plus its change) and the acceleration; the other axes
        keep the plain fit. The velocity's standard deviation is the larger of its formal value and the
        wave-based one of :meth:`step_statistic`.

        Returns
        -------
        DriftEstimate or None
            With ``step_age`` set.
        """
        if self.count < self.n or self.step_ages.size == 0:
            return None
        z, coef, sdv, _ = self.step_statistic()
        best = np.argmax(z, axis=0)                             # per axis
        axes = np.flatnonzero((z[best, np.arange(3)] > self.STEP_Z)
                              & (np.abs(coef[best, 3, np.arange(3)]) > self.STEP_MIN))
        if axes.size == 0:
            return None
        y = self.buf
        plain = self.estimate()
        p, v, a = plain.p.copy(), plain.v.copy(), plain.a.copy()
        sp, sv, sa, wave = plain.sigma_p.copy(), plain.sigma_v.copy(), plain.sigma_a.copy(), plain.wave.copy()
        x_now = np.array([1.0, 0.0, 0.0, 0.0])                  # the hinge fit at tau = 0 (the hinge is c there)
        age = 0.0
        for ax in axes:
            i = int(best[ax])
            c = float(self.step_ages[i])
            cov = self.step_cov[i]
            x_now[3] = c
            g_v = np.array([0.0, 1.0, 0.0, 1.0])                # d(velocity now)/d(coef)
            res = y[:, ax] - self.step_X[i] @ coef[i, :, ax]
            s = math.sqrt(float(res @ res) / (self.n - 4))
            p[ax] = float(x_now @ coef[i, :, ax])
            v[ax] = float(coef[i, 1, ax] + coef[i, 3, ax])
            a[ax] = float(coef[i, 2, ax])
            sp[ax] = self.correlation * s * math.sqrt(float(x_now @ cov @ x_now))
            sv[ax] = max(self.correlation * s * math.sqrt(float(g_v @ cov @ g_v)), float(sdv[i, ax]))
            sa[ax] = self.correlation * s * math.sqrt(float(cov[2, 2]))
            wave[ax] = float(np.max(np.abs(res)))
            age = max(age, c)
        return DriftEstimate(p, v, a, sp, sv, sa, wave, step_age=age)

    def breakout_statistic(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The acceleration-change test over the full window, for every candidate age (needs a full window).

        The window refitted with a hinge ``da h^2 / 2``, ``h = max(0, tau + c)``, added (a break-out: the ship
        accelerating from its drift since ``c`` seconds ago); the velocity-step test's hinge is linear and sees a
        break-out from rest late and too slow (found: at 0.01 m/s^2 to 0.27 m/s it estimated 0.08 m/s 15 s in,
        where the ship made 0.15 m/s, and ESD-1 came 17 s before the face). A velocity step passes this test
        too; :meth:`breakout_estimate` then fits the velocity change beside the curvature, so that a step is not
        extrapolated as a large acceleration (found: it was, and the stock drift-off released 24 s early).

        Returns
        -------
        z : ndarray, shape (C, 3)
            Standardised acceleration change per candidate age and axis.
        coef : ndarray, shape (C, 4, 3)
            The curvature-hinge fits: rows position, velocity, acceleration before the change, acceleration
            change.
        sda : ndarray, shape (C, 3)
            The standard deviation the acceleration change was divided by, m/s^2.
        rss : ndarray, shape (C, 3)
            The hinge fits' residual sums of squares, m^2.

        Notes
        -----
        As for velocity steps, waves make a short segment's curvature wander far more than white noise: over a
        segment of age ``c`` short against the wave period it is the wave's own acceleration, over a longer one
        about ``2 sqrt(2) s_x / c^2`` (a parabola through two wave positions ``c`` apart). The change is divided
        by the larger of the formal standard deviation (times :attr:`correlation`) and ``min(s_a, 2 sqrt(2) s_x
        / c^2)``, with ``s_x`` and ``s_a`` the standard deviations of the hinge fit's residuals and of their
        second rate. The residual sums come from the normal equations, as in :meth:`step_statistic`.
        """
        y = self.buf
        xty = self.bo_XT @ y                                    # (C, 4, 3)
        coef = self.bo_cov @ xty
        rss = np.maximum(np.sum(y * y, axis=0) - np.sum(coef * xty, axis=1), 0.0)
        ddy = np.diff(y, n=2, axis=0)
        ddxty = self.bo_ddXT @ ddy
        ssdd = np.maximum(np.sum(ddy * ddy, axis=0)
                          + np.sum(coef * (self.bo_ddgram @ coef - 2.0 * ddxty), axis=1), 0.0)
        s_x = np.sqrt(rss / (self.n - 4))
        s_a = np.sqrt(ssdd / (self.n - 2)) / (self.period * self.period)
        formal = self.correlation * s_x * np.sqrt(self.bo_cov[:, 3, 3])[:, None]
        wave = np.minimum(s_a, self.BREAKOUT_WAVE_K[0] * s_x / (self.bo_ages[:, None] ** 2))
        sda = np.maximum(formal, wave)
        return np.abs(coef[:, 3, :]) / np.where(sda > 0, sda, np.inf), coef, sda, rss

    def breakout_estimate(self) -> DriftEstimate | None:
        """The drift after a break-out, if the window shows one (:attr:`BREAKOUT_Z`); else None.

        Per axis where the acceleration change is significant, the hinge fit of the most significant age gives
        the position, velocity and acceleration now; the other axes keep the plain fit.

        Returns
        -------
        DriftEstimate or None
            With ``step_age`` set to the break-out's age.
        """
        if self.count < self.n or self.bo_ages.size == 0:
            return None
        z, coef, _, rss = self.breakout_statistic()
        best = np.argmax(z, axis=0)
        cols = np.arange(3)
        axes = np.flatnonzero((z[best, cols] > self.BREAKOUT_Z) & (np.abs(coef[best, 3, cols]) > self.BREAKOUT_MIN))
        if axes.size == 0:
            return None
        # the onset's age: the best-fitting candidate (least squares; the most significant one is biased young,
        # found: 8 s for a break-out 11.8 s old, and the acceleration twice the true one)
        best = np.argmin(rss, axis=0)
        plain = self.estimate()
        p, v, a = plain.p.copy(), plain.v.copy(), plain.a.copy()
        sp, sv, sa, wave = plain.sigma_p.copy(), plain.sigma_v.copy(), plain.sigma_a.copy(), plain.wave.copy()
        age = 0.0
        for ax in axes:
            i = int(best[ax])
            c = float(self.bo_ages[i])
            X, cov = self.bo_X5[i], self.bo_cov5[i]
            y = self.buf[:, ax]
            b = cov @ (X.T @ y)                                 # the velocity and acceleration change at age c
            res = y - X @ b
            s = math.sqrt(float(res @ res) / (self.n - 5))
            dd = np.diff(res, n=2)
            s_a = math.sqrt(float(dd @ dd) / (self.n - 2)) / (self.period * self.period)
            g_p = np.array([1.0, 0.0, 0.0, c, 0.5 * c * c])     # d(position now)/d(coef)
            g_v = np.array([0.0, 1.0, 0.0, 1.0, c])
            g_a = np.array([0.0, 0.0, 1.0, 0.0, 1.0])
            p[ax], v[ax], a[ax] = float(g_p @ b), float(g_v @ b), float(g_a @ b)
            sp[ax] = self.correlation * s * math.sqrt(float(g_p @ cov @ g_p))
            sv[ax] = self.correlation * s * math.sqrt(float(g_v @ cov @ g_v))
            sa[ax] = max(self.correlation * s * math.sqrt(float(g_a @ cov @ g_a)),
                         min(s_a, self.BREAKOUT_WAVE_K[1] * s / (c * c)))
            wave[ax] = float(np.max(np.abs(res)))
            age = max(age, c)
        return DriftEstimate(p, v, a, sp, sv, sa, wave, step_age=age)
