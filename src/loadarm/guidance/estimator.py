"""The filter that turns the flange sensor's readings into a trusted estimate.

Estimator: a constant-velocity Kalman filter per axis (position and velocity,
white-acceleration process noise). Readings are applied at the instant they
describe (latency compensated by prediction). An innovation whose
Mahalanobis distance exceeds the 99.9 % chi-square bound for 3 degrees of
freedom is rejected as an outlier. The filter restarts only on agreeing
readings: three rejected readings in a row that form a consistent cluster (a
lone outlier, or a burst of scattered ones, never becomes the track), and a
restarted estimate is unhealthy until five more readings were accepted. It
reports its own health: the estimate is *fresh* only if a reading was accepted
within ``max_estimate_age``, the position uncertainty is small and it is not
converging after a restart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Estimate", "FlangeEstimator", "CHI2_3DOF_999", "NIS_WINDOW", "NIS_MEAN_999", "REJECT_WINDOW",
           "MAX_REJECT_RATE", "AMBIGUITY_SPAN", "AMBIGUITY_HOLD"]

#: 99.9 % quantile of the chi-square distribution with 3 degrees of freedom.
CHI2_3DOF_999 = 16.266


#: Accepted readings over which the innovations' consistency (NIS) is averaged.
NIS_WINDOW = 20


#: Readings over which the rejection rate is watched, and the rate above which the estimate is not trusted (a
#: second target or a flood of outliers: the track may be the wrong one).
REJECT_WINDOW = 20


MAX_REJECT_RATE = 0.3


#: Rejected readings that agree with each other within this time (s) are a second target (three of them: two
#: neighbours of the newest); the estimate is then untrusted for AMBIGUITY_HOLD s.
AMBIGUITY_SPAN = 1.0


AMBIGUITY_HOLD = 5.0


#: 99.9 % quantile of the mean of NIS_WINDOW chi-square(3) values: chi2.ppf(0.999, 60) / 20 (tested against
#: SciPy). A filter whose model explains the readings averages 3; above this bound it does not.
NIS_MEAN_999 = 4.9803


@dataclass(frozen=True, slots=True)
class Estimate:
    """The filter's answer at one instant.

    Attributes
    ----------
    t : float
        Time of the estimate, s.
    position, velocity : tuple of float
        Flange position (m) and velocity (m/s).
    sigma : float
        Largest position standard deviation, m.
    age : float
        Time since the last accepted reading, s (inf if none).
    healthy : bool
        Fresh and certain enough to move the arm on.
    reason : str
        Why not healthy ('' if healthy).
    """

    t: float
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]
    sigma: float
    age: float
    healthy: bool
    reason: str


class FlangeEstimator:
    """Constant-velocity Kalman filter on three axes with outlier gating and a health report.

    Parameters
    ----------
    noise : float
        Reading noise std, m (R = noise^2, floored at 1 mm).
    accel_psd : float
        White-acceleration spectral density, m^2/s^3 (how quickly the
        flange's velocity can change: waves need about 0.1).
    max_age : float
        Freshness limit, s.
    max_sigma : float
        Position uncertainty above which the estimate is not trusted, m.
    """

    #: Readings in a row that must agree before the filter restarts on them, and accepted readings a restarted
    #: estimate needs before it is healthy again.
    REINIT_CLUSTER = 3
    CONVERGE_READINGS = 5
    #: Fastest plausible flange motion between two readings, m/s (a moored ship: well below 1 m/s). A cluster of
    #: readings farther from the track than the flange could have moved since the last accepted reading is a
    #: second target (another flange, a reflection), never a restart.
    MAX_FLANGE_SPEED = 1.0

    def __init__(self, *, noise: float, accel_psd: float = 0.1, max_age: float = 0.5, max_sigma: float = 0.25):
        self.r = max(noise, 1e-3) ** 2
        self.pending: list = []          # the rejected readings in a row, (t, z)
        self.converging = 0              # accepted readings still needed after a restart
        self.q = accel_psd
        self.max_age = max_age
        self.max_sigma = max_sigma
        self.t = None            # time of the state
        self.x = [0.0] * 6       # p0, v0, p1, v1, p2, v2
        self.P = [(0.0, 0.0, 0.0)] * 3   # per axis (Ppp, Ppv, Pvv)
        self.last_accept = -math.inf
        self.rejected_in_row = 0
        self.accepted = 0
        self.rejected = 0
        self.restarts = 0
        self.nis: list[float] = []       # NIS of the last NIS_WINDOW accepted readings
        self.outcomes: list[bool] = []   # accepted (True) / rejected of the last REJECT_WINDOW readings
        self.recent_rejected: list = []  # (t, z) of the rejected readings of the last AMBIGUITY_SPAN s
        self.ambiguous_until = -math.inf

    def _init(self, t: float, z) -> None:
        self.t = t
        self.x = [z[0], 0.0, z[1], 0.0, z[2], 0.0]
        self.P = [(self.r, 0.0, 1.0)] * 3
        self.last_accept = t
        self.rejected_in_row = 0
        self.nis = []

    def _predict(self, dt: float):
        q = self.q
        x = self.x
        nx = [0.0] * 6
        nP = []
        for i in range(3):
            p, v = x[2 * i], x[2 * i + 1]
            nx[2 * i] = p + dt * v
            nx[2 * i + 1] = v
            a, b, c = self.P[i]
            a2 = a + 2 * dt * b + dt * dt * c + q * dt ** 3 / 3
            b2 = b + dt * c + q * dt * dt / 2
            c2 = c + q * dt
            nP.append((a2, b2, c2))
        return nx, nP

    def update(self, t_meas: float, z) -> bool:
        """Apply one reading (the instant it describes and the position).

        Parameters
        ----------
        t_meas : float
            Time the reading describes, s.
        z : sequence of 3 float
            Reported position, m.

        Returns
        -------
        bool
            True if accepted, False if rejected as an outlier (or stale).
        """
        if self.t is None:                 # acquisition: like a restart, trusted only once it has converged
            self._init(t_meas, z)
            self.converging = self.CONVERGE_READINGS
            self.accepted += 1
            self.outcomes = [True]
            return True
        if t_meas < self.t:          # out-of-order reading: ignore
            return False
        ok = self._update(t_meas, z)
        self.outcomes = (self.outcomes + [ok])[-REJECT_WINDOW:]
        return ok

    def _update(self, t_meas: float, z) -> bool:
        x, P = self._predict(t_meas - self.t)
        d2 = 0.0
        for i in range(3):
            nu = z[i] - x[2 * i]
            d2 += nu * nu / (P[i][0] + self.r)
        # gate: statistically consistent with the track, and where the flange could physically have got to since
        # the last accepted reading (the covariance grows during a gap; the flange's speed does not)
        if d2 > CHI2_3DOF_999 or not self._reachable(t_meas, z):
            spread = math.sqrt(max(P[i][0] for i in range(3)) + self.r)
            if math.dist(z, (x[0], x[2], x[4])) > 10.0 * spread:     # far off the track, not just noisy
                self._watch_second_target(t_meas, z)
            self.rejected += 1
            self.rejected_in_row += 1
            self.pending = (self.pending + [(t_meas, tuple(z))])[-self.REINIT_CLUSTER:]
            if (len(self.pending) == self.REINIT_CLUSTER and self._agree(self.pending)
                    and self._reachable(t_meas, z)):
                # lost track and the last readings agree with each other: restart on the newest, and do not
                # trust it until it has converged (a single outlier can never become the track)
                self._init(t_meas, z)
                self.pending = []
                self.converging = self.CONVERGE_READINGS
                self.restarts += 1
                return True
            return False
        for i in range(3):
            a, b, c = P[i]
            s = a + self.r
            k0, k1 = a / s, b / s
            nu = z[i] - x[2 * i]
            x[2 * i] += k0 * nu
            x[2 * i + 1] += k1 * nu
            P[i] = ((1 - k0) * a, (1 - k0) * b, c - k1 * b)
        self.nis = (self.nis + [d2])[-NIS_WINDOW:]
        if t_meas - self.last_accept > self.max_age:    # re-acquired after a gap: converge before trusting it
            self.converging = max(self.converging, self.CONVERGE_READINGS)
        self.x, self.P, self.t = x, P, t_meas
        self.last_accept = t_meas
        self.rejected_in_row = 0
        self.pending = []
        self.converging = max(self.converging - 1, 0)
        self.accepted += 1
        return True

    def _agree(self, readings) -> bool:
        """Whether rejected readings form a consistent cluster: every pair closer than six noise sigmas plus
        the distance the flange can travel between them."""
        for i in range(len(readings)):
            for j in range(i):
                (ti, zi), (tj, zj) = readings[i], readings[j]
                if math.dist(zi, zj) > self._allowed(abs(ti - tj)):
                    return False
        return True

    def _watch_second_target(self, t: float, z) -> None:
        """Rejected readings that agree with each other are a second target, not outliers: untrust the track."""
        self.recent_rejected = [(ti, zi) for ti, zi in self.recent_rejected if t - ti <= AMBIGUITY_SPAN]
        near = sum(1 for ti, zi in self.recent_rejected
                   if math.dist(zi, z) <= self._allowed(t - ti))
        self.recent_rejected.append((t, tuple(z)))
        if near >= 2:
            self.ambiguous_until = t + AMBIGUITY_HOLD

    def _reachable(self, t: float, z) -> bool:
        """Whether the flange could have moved from the track's last accepted position to ``z`` by ``t``."""
        return math.dist((self.x[0], self.x[2], self.x[4]), z) <= self._allowed(max(t - self.last_accept, 0.0))

    def _allowed(self, dt: float) -> float:
        """How far apart two readings of one flange ``dt`` seconds apart can be: six noise sigmas of their
        difference plus what the flange can travel, m."""
        return 6.0 * math.sqrt(2.0 * self.r) + self.MAX_FLANGE_SPEED * dt

    def nis_mean(self) -> float:
        """Mean normalised innovation squared of the last :data:`NIS_WINDOW` accepted readings (NaN before).

        Returns
        -------
        float
        """
        return sum(self.nis) / len(self.nis) if len(self.nis) == NIS_WINDOW else math.nan

    def estimate(self, now: float) -> Estimate:
        """The estimate at ``now`` (predicted from the last reading), with its health.

        Parameters
        ----------
        now : float
            Time, s.

        Returns
        -------
        Estimate
        """
        if self.t is None:
            return Estimate(now, (math.nan,) * 3, (math.nan,) * 3, math.inf, math.inf, False, "no reading yet")
        x, P = self._predict(max(now - self.t, 0.0))
        sigma = math.sqrt(max(p[0] for p in P))
        age = now - self.last_accept
        reason = ""
        if age > self.max_age:
            reason = f"no accepted reading for {age:.2f} s (limit {self.max_age:g} s)"
        elif sigma > self.max_sigma:
            reason = f"position uncertainty {sigma:.3f} m above {self.max_sigma:g} m"
        elif self.converging:
            reason = (f"restarted on new readings, converging ({self.CONVERGE_READINGS - self.converging} of "
                      f"{self.CONVERGE_READINGS} readings)")
        elif now < self.ambiguous_until:
            reason = ("a second target: rejected readings agree with each other (another flange or a reflection); "
                      "the track may be the wrong one")
        elif self.outcomes.count(False) > MAX_REJECT_RATE * REJECT_WINDOW:
            reason = (f"{self.outcomes.count(False)} of the last {len(self.outcomes)} readings rejected (a second "
                      f"target or a flood of outliers): the track may be the wrong one")
        elif self.nis_mean() > NIS_MEAN_999:
            reason = (f"innovations inconsistent: mean NIS {self.nis_mean():.2f} over the last {NIS_WINDOW} "
                      f"readings, above {NIS_MEAN_999:g} (the filter does not explain the readings)")
        return Estimate(now, (x[0], x[2], x[4]), (x[1], x[3], x[5]), sigma, age, reason == "", reason)
