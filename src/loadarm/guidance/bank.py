"""Connected monitoring of a bank of arms (issue 31, items 2-3): the triple swivels' travel and the clearance
between neighbouring arms, with their time to limit from the same forecast as the arm's own faces.

All the bank's flanges are on one ship. The monitor watches the ship's manifold: its centre's position (bank
frame) and the ship's roll, pitch and yaw there (:func:`loadarm.arm.swivel.ship_rotation`). Each arm's flange is
the manifold's pose at the flange's offset, rigidly; each arm's joints are the inverse kinematics of its flange
(the arm connected follows it), its swivels the closed form of :func:`loadarm.arm.swivel.swivel_angles`, its
capsules :func:`loadarm.arm.clearance.capsules`.

**The forecast is the single arm's** (:class:`loadarm.guidance.monitor.EnvelopeMonitor`, called, not copied): its
drift fit of the manifold centre, the velocity-step and break-out tests, the design drift's break-out in every
horizontal direction and the vertical, as :meth:`EnvelopeMonitor.routes` gives them; the ship's rotation is
forecast by the same least-squares fit (:class:`loadarm.guidance.drift.DriftFit` on roll, pitch and yaw, and
:func:`loadarm.guidance.monitor.measured_route`: extrapolated, widened by the wave excursion and ``k`` standard
deviations, the eight corners of its box), with a design floor beside it as the position has the design drift:
the ship's yaw turning either way at the bank file's ``swivels.design_yaw_rate_deg`` from the angles now (roll and
pitch held: the hull restores them); until the fit's window fills, the floor alone. Every position
hypothesis is paired with every rotation hypothesis, and the scan is the monitor's own
(:func:`loadarm.guidance.monitor.first_crossing`: 2 s steps, bisection to 1/16 s, early never late).

The faces (:data:`loadarm.vocab.BANK_FACE_TABLE`): each arm's six swivel stops, and the clash of each pair of
neighbouring arms (along the jetty) closer than the bank's ``clearance.min_clearance``. Their clearance is the
compiled route (:func:`loadarm.arm.clearance.capsule_gaps`, held bit for bit to the vectorised one). With
``own_faces`` (the default) each arm's own envelope (:data:`loadarm.vocab.FACE_TABLE`,
:func:`loadarm.arm.faces.face_margins` on its flange) is scanned in the same pass, from the same hypotheses: an
arm's time to limit is the nearest of its own faces, its swivels' and its clashes', one forecast (found: the
served bank forecast the swivels and the clash only, each arm's own faces left to its set-angle alarms). The bank
campaign turns it off: its arms' own faces come from the operability kernel's route (:mod:`loadarm.studies.
bank_campaign`).

The stage: :func:`loadarm.guidance.monitor.stage_leads` and :func:`loadarm.arm.sequence.stage_of` per arm (the
emergency sequence written once); ESD-1 and ERS-2 act on every arm of the bank, so the bank's stage is the most
severe arm's.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.clearance import PARTS, capsule_gaps, capsules
from loadarm.arm.sequence import stage_of
from loadarm.arm.swivel import ship_rotation
from loadarm.guidance.drift import FIT_PERIOD, DriftEstimate, DriftFit
from loadarm.guidance.monitor import EnvelopeMonitor, first_crossing, measured_route, stage_leads
from loadarm.params.bank import Bank
from loadarm.arm.faces import face_margins
from loadarm.vocab import CLASH_FACE, FACE_TABLE, SWIVEL_FACE_TABLE, Severity

__all__ = ["BankMargins", "BankForecast", "BankMonitor", "neighbours"]

_N_SWIVEL = len(SWIVEL_FACE_TABLE)


def neighbours(bank: Bank) -> tuple[tuple[int, int], ...]:
    """The pairs of neighbouring arms along the jetty (by their risers' ``y``), each as (lower, upper) indices of
    the bank's arms.

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    tuple of (int, int)
    """
    order = sorted(range(len(bank.names)), key=lambda i: bank.file.arms[i].y)
    return tuple((a, b) for a, b in zip(order, order[1:], strict=False))


@dataclass(frozen=True)
class BankMargins:
    """The bank's faces at one manifold pose.

    Attributes
    ----------
    swivel : ndarray, shape (n_arms, 6)
        Each arm's swivel margins, rad, in the order of :data:`loadarm.vocab.SWIVEL_FACE_TABLE` (NaN: the arm
        cannot reach its flange there, its own faces' matter).
    clearance : ndarray, shape (n_pairs,)
        Each pair of neighbours' clearance, m (the capsules' surfaces).
    parts : tuple of (str, str)
        The two parts closest, per pair.
    """

    swivel: np.ndarray
    clearance: np.ndarray
    parts: tuple[tuple[str, str], ...]


@dataclass(frozen=True)
class BankForecast:
    """When the bank would first reach one of its faces, and each arm's stage.

    Attributes
    ----------
    time : float
        Time to the first face, s (``inf``: none within the horizon).
    face : str
        Its code (``swivel1_max``, ..., ``clash``; ``""``: none).
    arms : tuple of str
        The arm (a swivel face) or the two arms (the clash).
    route : str
        The position's route that crossed first (``"design drift"``, ``"measured drift"``, ...).
    by_arm : tuple of float
        Each arm's time to its nearest bank face (its swivels, and the clash of a pair it belongs to), s: from the
        scan's steps, the first face's refined (early by up to a scan step, never late).
    measured_by_arm : tuple of float
        The same by the measured routes alone, s (the pre-alarm's).
    stages : tuple of Severity
        Each arm's stage (:func:`loadarm.arm.sequence.stage_of` on its leads).
    """

    time: float
    face: str
    arms: tuple[str, ...]
    route: str
    by_arm: tuple[float, ...]
    measured_by_arm: tuple[float, ...]
    stages: tuple[Severity, ...]

    @property
    def stage(self) -> Severity:
        """The bank's stage: ESD-1 and ERS-2 act on every arm, so the most severe arm's."""
        return max(self.stages, default=Severity.NORMAL)


def _design_model(bank: Bank):
    """The first arm's model with the most severe design drift of the bank's installations (one ship, one
    berth: their design drifts should agree; the largest speed, acceleration and vertical speed are kept)."""
    dds = [m.design_drift for m in bank.models]
    worst = dataclasses.replace(dds[0], speed=max(d.speed for d in dds),
                                acceleration=max(d.acceleration for d in dds),
                                vertical_speed=max(d.vertical_speed for d in dds))
    return dataclasses.replace(bank.models[0], design_drift=worst)


class BankMonitor:
    """Time to the bank's faces (the swivels' stops, the clash of neighbours) from the manifold's forecast.

    Parameters
    ----------
    bank : Bank
    window : float
        Drift-fit window, s (as the arm's monitor).
    k_sigma : float
        Standard deviations of the fit added to the forecast.
    step, resolution : float
        The scan's step and the bisection's resolution, s.
    period : float
        Sampling period of the fits, s.
    own_faces : bool
        Scan each arm's own envelope faces too (the module's text).
    """

    def __init__(self, bank: Bank, window: float = 60.0, k_sigma: float = 2.0, step: float = 2.0,
                 resolution: float = 0.0625, period: float = FIT_PERIOD, own_faces: bool = True):
        self.bank = bank
        self.position = EnvelopeMonitor(_design_model(bank), window, k_sigma, step, resolution, period)
        self.rotation = DriftFit(window, period)
        self.rot_est: DriftEstimate | None = None
        self.rot_t = math.nan
        self.k = k_sigma
        self.heading = math.radians(bank.file.manifold.heading_deg)
        self.limits = bank.file.swivels.limits()
        self.yaw_rate = math.radians(bank.file.swivels.design_yaw_rate_deg)
        self.required = float(bank.file.clearance.min_clearance)
        self.pairs = neighbours(bank)
        names = bank.names
        self.own_faces = own_faces
        own = FACE_TABLE if own_faces else ()
        self.faces = tuple(f"{names[i]}:{f.name}" for i in range(len(names)) for f in SWIVEL_FACE_TABLE) + tuple(
            f"{names[a]}/{names[b]}:{CLASH_FACE.name}" for a, b in self.pairs) + tuple(
            f"{names[i]}:{f.name}" for i in range(len(names)) for f in own)
        # the arms each face concerns, for each arm's time
        self._face_arms = ([(i,) for i in range(len(names)) for _ in SWIVEL_FACE_TABLE] + list(self.pairs)
                           + [(i,) for i in range(len(names)) for _ in own])

    def reset(self) -> None:
        """A new connection: forget the history."""
        self.position.reset()
        self.rotation.reset()
        self.rot_est, self.rot_t = None, math.nan

    def observe(self, t: float, centre, angles) -> bool:
        """Feed the manifold's pose.

        Parameters
        ----------
        t : float
            s.
        centre : sequence of float
            The manifold's centre, bank frame, m.
        angles : sequence of float
            The ship's roll, pitch and yaw at the manifold, rad.

        Returns
        -------
        bool
            True when the sample was kept (time to :meth:`refit`).
        """
        kept = self.position.observe(t, centre)
        self.rotation.push(t, angles)
        return kept

    def refit(self, alarmed: bool = False) -> None:
        """Fit the manifold's drift (with the step and break-out tests) and the ship's rotation now.

        Parameters
        ----------
        alarmed : bool
            ESD-1 is active (the fits then use whatever history there is, as the arm's monitor).
        """
        self.position.refit(alarmed)
        least = int(round(EnvelopeMonitor.ALARMED_MIN_HISTORY / self.rotation.period)) if alarmed else None
        self.rot_est, self.rot_t = self.rotation.estimate(least), self.rotation.t_last

    # ----------------------------------------------------------------------------------------------- the faces

    def flanges(self, centre, angles, rotation=None) -> np.ndarray:
        """Each arm's flange in its own frame at manifold poses: the centre, plus the flange's offset turned with
        the ship, less the arm's riser.

        Parameters
        ----------
        centre : ndarray, shape (..., 3)
            m.
        angles : ndarray, shape (..., 3)
            Roll, pitch, yaw, rad.
        rotation : ndarray, shape (..., 3, 3), optional
            Their :func:`loadarm.arm.swivel.ship_rotation`, if already computed.

        Returns
        -------
        ndarray, shape (..., n_arms, 3)
            m.
        """
        return self.bank.flanges_at(centre, angles, rotation)

    def _margins(self, centre, angles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every face's margin in the order of :attr:`faces` (swivels rad, the clash m less the required, then with
        ``own_faces`` each arm's own faces rad), shape (..., faces), and the closest parts of each pair
        (..., pairs)."""
        angles = np.asarray(angles, dtype=float)
        rot = ship_rotation(angles[..., 0], angles[..., 1], angles[..., 2], self.heading)
        flanges, iks, poses, swivels = self.bank.on_flanges(centre, angles, rot)
        own = []
        if self.own_faces:
            own = [face_margins(model, flanges[..., i, 0], flanges[..., i, 1], flanges[..., i, 2], q=q)
                   for i, (model, q) in enumerate(zip(self.bank.models, iks, strict=True))]
        gaps, best = self.clearances(poses)
        cols = swivels.reshape(*swivels.shape[:-2], -1)              # arm by arm, each arm's six
        return np.concatenate([cols, gaps - self.required] + own, axis=-1), best

    def clearances(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """The clearance of each pair of neighbours at the arms' poses, whatever holds the arms (their flanges,
        or their drives after a release): the compiled capsule distance.

        Parameters
        ----------
        poses : list of ndarray, shape (..., 3)
            Slew, inboard, elbow angles per arm, rad (as :meth:`loadarm.params.bank.Bank.on_flanges`).

        Returns
        -------
        gaps : ndarray, shape (..., pairs)
            Surface-to-surface distance, m (negative: overlapping).
        best : ndarray of int, shape (..., pairs)
            The closest two parts of each pair (``PARTS`` index times ``len(PARTS)`` plus the other's).
        """
        lead = poses[0].shape[:-1]
        caps = [capsules(s, q[..., 0], q[..., 1], q[..., 2]).reshape(-1, len(PARTS), 2, 3)
                for s, q in zip(self.bank.shapes, poses, strict=True)]
        radii = [np.asarray(s.radii, dtype=float) for s in self.bank.shapes]
        gaps, best = [], []
        for a, b in self.pairs:
            gap, k = np.empty(caps[a].shape[0]), np.empty(caps[a].shape[0], dtype=np.int64)
            capsule_gaps(caps[a], caps[b], radii[a], radii[b], gap, k)
            gaps.append(gap.reshape(lead))
            best.append(k.reshape(lead))
        if not gaps:
            return np.zeros(lead + (0,)), np.zeros(lead + (0,), dtype=np.int64)
        return np.stack(gaps, axis=-1), np.stack(best, axis=-1)

    def margins(self, centre, angles) -> BankMargins:
        """The bank's faces now.

        Parameters
        ----------
        centre : sequence of float
            The manifold's centre, m.
        angles : sequence of float
            Roll, pitch, yaw, rad.

        Returns
        -------
        BankMargins
        """
        m, best = self._margins(np.asarray(centre, dtype=float), np.asarray(angles, dtype=float))
        n = len(self.bank.names) * _N_SWIVEL
        n_parts = len(PARTS)
        parts = tuple((PARTS[int(k) // n_parts], PARTS[int(k) % n_parts]) for k in np.atleast_1d(best))
        return BankMargins(m[:n].reshape(-1, _N_SWIVEL), m[n:n + len(self.pairs)] + self.required, parts)

    def _outside(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Past a face at each hypothesis (T, K, 6: the centre, then roll, pitch, yaw), and every face's own past
        (T, K, F): several pairs can be too close at once, and each arm's time is its own faces' (found: with every
        neighbour within the clearance only the first pair's arms were given 0 s, the others 50 s)."""
        m, _ = self._margins(pts[..., :3], pts[..., 3:])
        past = m < 0.0                                          # NaN (out of the arm's reach): the arm's faces'
        return past.any(axis=-1), past

    # -------------------------------------------------------------------------------------------- the forecast

    def _rotation_route(self, angles_now, now: float | None, *, measured_only: bool = False):
        """``tau`` to the rotation's hypotheses (T, R, 3): the design floor (the angles now, the yaw turning either
        way at the design rate), and beside it the fit's box corners once there is a fit. ``measured_only``: the
        fit's corners alone, or the angles now held without a fit (the measured routes' scan, the pre-alarm's:
        found by review, the design floor had leaked into it)."""
        held = np.asarray(angles_now, dtype=float)
        turn = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]) * self.yaw_rate

        def design(tau):
            return held[None, None, :] + tau[:, None, None] * turn[None, :, :]

        def still(tau):
            return np.broadcast_to(held, (tau.shape[0], 1, 3))

        if self.rot_est is None:
            return still if measured_only else design
        measured = measured_route(self.rot_est, 0.0 if now is None else max(now - self.rot_t, 0.0), self.k)
        if measured_only:
            return measured
        return lambda tau: np.concatenate([measured(tau), design(tau)], axis=1)

    @staticmethod
    def _paired(position, rotation):
        """Every position hypothesis with every rotation hypothesis: ``tau`` to (T, P x R, 6)."""

        def points(tau):
            p, r = position(tau), rotation(tau)
            n_p, n_r = p.shape[1], r.shape[1]
            return np.concatenate([np.repeat(p, n_r, axis=1), np.tile(r, (1, n_p, 1))], axis=-1)

        return points

    def _scan(self, points, horizon: float):
        return first_crossing(points, horizon, self._outside, self.faces, step=self.position.step,
                              resolution=self.position.resolution)

    def _by_arm(self, by_face: dict) -> list[float]:
        times = [math.inf] * len(self.bank.names)
        for j, name in enumerate(self.faces):
            if name in by_face:
                for i in self._face_arms[j]:
                    times[i] = min(times[i], by_face[name])
        return times

    def time_to_limit(self, centre_now, angles_now, horizon: float, *, alarmed: bool = False,
                      now: float | None = None, valves_left=None, release_left=None) -> BankForecast:
        """Earliest time the bank could reach one of its faces within ``horizon``, and each arm's stage.

        Parameters
        ----------
        centre_now : sequence of float
            The manifold's centre now, m.
        angles_now : sequence of float
            Roll, pitch, yaw now, rad.
        horizon : float
            s (the longest stage lead).
        alarmed : bool
            ESD-1 is active (:meth:`EnvelopeMonitor.time_to_limit`).
        now : float, optional
            Time, s: the fits of the last :meth:`refit`, extrapolated to now; without it the position is fitted
            here.
        valves_left, release_left : sequence of float, optional
            Per arm, as :func:`loadarm.guidance.monitor.stage_leads` (default: the whole sequence to run).

        Returns
        -------
        BankForecast
        """
        routes = self.position.routes(centre_now, alarmed=alarmed, now=now)
        rotation = self._rotation_route(angles_now, now)
        position = routes.points if routes.measured else routes.design
        n_rot = rotation(np.zeros(1)).shape[1]
        t, face, k, by_face = self._scan(self._paired(position, rotation), horizon)
        by_arm = self._by_arm(by_face)
        measured = [math.inf] * len(by_arm)
        if face and routes.measured:
            measured_rotation = self._rotation_route(angles_now, now, measured_only=True)
            measured = self._by_arm(self._scan(self._paired(routes.measured_points, measured_rotation), horizon)[3])
        stages = self._stages(by_arm, measured, valves_left, release_left)
        if not face:
            return BankForecast(math.inf, "", (), "", tuple(by_arm), tuple(measured), stages)
        arms, _, code = face.rpartition(":")
        return BankForecast(t, code, tuple(arms.split("/")), routes.route(k // n_rot), tuple(by_arm),
                            tuple(measured), stages)

    def _stages(self, by_arm, measured, valves_left, release_left) -> tuple[Severity, ...]:
        out = []
        for i, model in enumerate(self.bank.models):
            leads = stage_leads(model.sequence, valves_left=None if valves_left is None else valves_left[i],
                                release_left=None if release_left is None else release_left[i])
            pre = leads.get(Severity.PRE_ALARM, -math.inf)
            out.append(Severity(stage_of(by_arm[i], measured[i], leads[Severity.RELEASE], leads[Severity.SECOND],
                                         leads[Severity.ESD1], pre)))
        return tuple(out)
