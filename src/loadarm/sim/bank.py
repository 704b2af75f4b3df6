"""The bank's simulated world, kinematic (issue 31, item 6): every arm of a bank connected to one moored ship.

The ship is a rigid body: its manifold's centre moves as a scenario's flange (:func:`loadarm.ship.flange.flange_motion`:
the moored ship's 10 Hz motion, or the simple ship's), and each presentation flange follows it at its offset along
the manifold, turned by the ship's roll, pitch and yaw at the manifold. Each arm's coupler is on its flange: its
joints are the closed-form inverse kinematics (:func:`loadarm.arm.slew.inverse3d`), its triple swivel's angles the
closed form of :func:`loadarm.arm.swivel.swivel_angles`, its faces' margins :func:`loadarm.arm.faces.face_margins`,
its position alarm the customer's angles (:class:`loadarm.arm.alarms.AlarmThresholds`), and the clearance of
every pair of arms the capsules of :mod:`loadarm.arm.clearance`.

No arm here runs its own closed loop: there is no controller, valve or ERS sequence in this world, only the
connected bank's geometry on the ship's motion (what ``loadarm serve --bank`` serves and the bank's screen draws).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from loadarm.arm.alarms import AlarmThresholds
from loadarm.arm.clearance import PARTS, capsules, segment_distance
from loadarm.arm.faces import face_margins
from loadarm.arm.slew import inverse3d
from loadarm.arm.swivel import ship_rotation, swivel_angles, swivel_margins
from loadarm.design.manifold import berth_wind
from loadarm.params.bank import Bank
from loadarm.params.scenario import scenario_environment
from loadarm.ship.flange import flange_motion
from loadarm.vocab import Severity

__all__ = ["BankState", "BankWorld", "bank_pairs", "bank_state"]


def bank_pairs(n: int) -> tuple[tuple[int, int], ...]:
    """Every pair of ``n`` arms, in order: (0, 1), (0, 2), ... (the order of :attr:`BankState.pair_clearance`).

    Parameters
    ----------
    n : int

    Returns
    -------
    tuple of (int, int)
    """
    return tuple((i, j) for i in range(n) for j in range(i + 1, n))


@dataclass(frozen=True)
class BankState:
    """The connected bank at one time.

    Attributes
    ----------
    t : float
        s.
    names : tuple of str
        The arms, in the bank's order.
    flanges : ndarray, shape (n, 3)
        Each arm's flange (its coupler), bank frame, m.
    q : ndarray, shape (n, 3)
        Each arm's slew, inboard and elbow angles, rad (NaN: its flange out of reach).
    margins : ndarray, shape (n, 6)
        Each arm's margins to its faces (:data:`loadarm.vocab.FACES`), rad.
    swivels : ndarray, shape (n, 3)
        Each arm's three swivel angles, rad.
    swivel_margins : ndarray, shape (n, 6)
        Their margins to the stops (:data:`loadarm.vocab.SWIVEL_FACE_TABLE`), rad.
    stages : tuple of int
        Each arm's position alarm (:class:`loadarm.vocab.Severity`).
    capsules : ndarray, shape (n, 6, 2, 3)
        Each arm's capsules (:data:`loadarm.arm.clearance.PARTS`), bank frame, m.
    radii : ndarray, shape (n, 6)
        Their radii, m.
    pairs : tuple of (int, int)
        :func:`bank_pairs`.
    pair_clearance : ndarray, shape (n_pairs,)
        Each pair's clearance, m.
    pair_parts : ndarray of int, shape (n_pairs, 2)
        The two parts that come closest in each pair.
    pair_points : ndarray, shape (n_pairs, 2, 3)
        The closest points of those two parts' axes, bank frame, m.
    required : float
        The bank's minimum clearance, m.
    manifold : ndarray, shape (3,)
        The manifold's centre, bank frame, m.
    ship_angles : ndarray, shape (3,)
        The ship's roll, pitch and yaw at the manifold, rad.
    """

    t: float
    names: tuple[str, ...]
    flanges: np.ndarray
    q: np.ndarray
    margins: np.ndarray
    swivels: np.ndarray
    swivel_margins: np.ndarray
    stages: tuple[int, ...]
    capsules: np.ndarray
    radii: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    pair_clearance: np.ndarray
    pair_parts: np.ndarray
    pair_points: np.ndarray
    required: float
    manifold: np.ndarray
    ship_angles: np.ndarray

    @property
    def nearest_pair(self) -> int:
        """The index (into :attr:`pairs`) of the pair of arms closest to each other (NaN clearances last)."""
        c = np.where(np.isnan(self.pair_clearance), np.inf, self.pair_clearance)
        return int(np.argmin(c))

    def nearest_of(self, i: int) -> int:
        """The index (into :attr:`pairs`) of arm ``i``'s nearest pair: its closest neighbour.

        Parameters
        ----------
        i : int

        Returns
        -------
        int
        """
        mine = [k for k, p in enumerate(self.pairs) if i in p]
        c = [math.inf if math.isnan(self.pair_clearance[k]) else float(self.pair_clearance[k]) for k in mine]
        return mine[int(np.argmin(c))]

    def clash(self, k: int) -> dict:
        """Pair ``k`` of :attr:`pairs` in words and numbers.

        Parameters
        ----------
        k : int

        Returns
        -------
        dict
            ``arms`` (two names), ``parts`` (two of :data:`loadarm.arm.clearance.PARTS`), ``clearance`` (m),
            ``abnormal`` (below :attr:`required`), ``points`` (two closest points, m).
        """
        a, b = self.pairs[k]
        gap = float(self.pair_clearance[k])
        return {"arms": [self.names[a], self.names[b]],
                "parts": [PARTS[int(self.pair_parts[k, 0])], PARTS[int(self.pair_parts[k, 1])]],
                "clearance": gap, "abnormal": not gap >= self.required,
                "points": self.pair_points[k].tolist()}


def _pair_geometry(caps: np.ndarray, radii: np.ndarray, pairs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each pair's clearance, its two closest parts and their axes' closest points: every arm's capsules once,
    every pair of arms and of parts in one call."""
    first, second = (np.array(v) for v in zip(*pairs, strict=True))
    ca, cb = caps[first][:, :, None], caps[second][:, None, :]
    dist, s, u = segment_distance(ca[..., 0, :], ca[..., 1, :], cb[..., 0, :], cb[..., 1, :])
    gap = dist - (radii[first][:, :, None] + radii[second][:, None, :])
    k = len(PARTS)
    flat = gap.reshape(len(pairs), k * k)
    best = np.argmin(np.where(np.isnan(flat), np.inf, flat), axis=-1)
    rows = np.arange(len(pairs))
    pa, pb = best // k, best % k
    p0 = ca[rows, pa, 0, 0] + s[rows, pa, pb][:, None] * (ca[rows, pa, 0, 1] - ca[rows, pa, 0, 0])
    p1 = cb[rows, 0, pb, 0] + u[rows, pa, pb][:, None] * (cb[rows, 0, pb, 1] - cb[rows, 0, pb, 0])
    return flat[rows, best], np.stack((pa, pb), axis=-1), np.stack((p0, p1), axis=1)


def bank_state(bank: Bank, flanges, angles=(0.0, 0.0, 0.0), *, t: float = 0.0, manifold=None) -> BankState:
    """The connected bank with each coupler on its flange.

    Parameters
    ----------
    bank : Bank
    flanges : array_like, shape (n_arms, 3)
        Each arm's flange, bank frame, m.
    angles : sequence of float
        The ship's roll, pitch and yaw at the manifold, rad.
    t : float
        The time, s.
    manifold : array_like, shape (3,), optional
        The manifold's centre (default its design position).

    Returns
    -------
    BankState
    """
    flanges = np.asarray(flanges, dtype=float)
    heading = math.radians(bank.file.manifold.heading_deg)
    q, margins, sw, swm, stages = [], [], [], [], []
    for i, model in enumerate(bank.models):
        base = np.asarray(bank.shapes[i].base)
        x, y, z = flanges[i] - base
        j = inverse3d(model.arm, x, y, z, check=False)
        qi = np.array([float(j.phi), float(j.alpha), float(j.beta)])
        q.append(qi)
        margins.append(face_margins(model, x, y, z, q=j))
        s = swivel_angles(*qi, *angles, heading=heading)
        sw.append([float(v) for v in s])
        swm.append(swivel_margins(s, bank.file.swivels.limits()))
        level = AlarmThresholds.from_model(model).level(qi[2], qi[0])[0] if np.all(np.isfinite(qi)) \
            else Severity.RELEASE
        stages.append(int(level))
    q = np.array(q)
    caps = np.stack([capsules(shape, *qi) for shape, qi in zip(bank.shapes, q, strict=True)])
    radii = np.array([shape.radii for shape in bank.shapes], dtype=float)
    pairs = bank_pairs(len(bank.shapes))
    gap, parts, points = _pair_geometry(caps, radii, pairs)
    centre = np.asarray(bank.file.manifold.position if manifold is None else manifold, dtype=float)
    return BankState(float(t), bank.names, flanges, q, np.array(margins), np.array(sw), np.array(swm),
                     tuple(stages), caps, radii, pairs, gap, parts, points, float(bank.file.clearance.min_clearance),
                     centre, np.asarray(angles, dtype=float))


@dataclass(frozen=True)
class BankWorld:
    """Every arm of a bank connected to one ship whose manifold moves as a scenario's flange.

    Attributes
    ----------
    bank : Bank
    motion : object
        The scenario's flange motion (:func:`loadarm.ship.flange.flange_motion`): ``position(t)`` and, for a
        moored ship, ``orientation(t)`` (roll, pitch, yaw at the manifold); the simple ship does not turn.
    reference : ndarray, shape (3,)
        The motion's mean position (the scenario's ``[ship] flange``), m: the manifold's centre is the bank's
        ``manifold.position`` moved by ``position(t) - reference``.
    duration : float
        How long the motion lasts, s.
    wind : ndarray, shape (3,)
        The mean wind's velocity, bank frame, m/s (the moored scenario's environment; none on the simple ship):
        what the manifold-load alarm gives the pipes.
    """

    bank: Bank
    motion: object
    reference: np.ndarray
    duration: float
    wind: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def ship(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The manifold's displacement from its design position and the ship's rotation at ``t``.

        Parameters
        ----------
        t : float
            s.

        Returns
        -------
        displacement : ndarray, shape (3,)
            m.
        angles : ndarray, shape (3,)
            Roll, pitch, yaw, rad.
        """
        d = np.asarray(self.motion.position(float(t)), dtype=float) - self.reference
        turn = getattr(self.motion, "orientation", None)
        angles = np.zeros(3) if turn is None else np.asarray(turn(float(t)), dtype=float)
        return d, angles

    def flanges(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every flange at ``t``: the manifold's centre moved, each flange's offset turned with the ship.

        Parameters
        ----------
        t : float
            s.

        Returns
        -------
        flanges : ndarray, shape (n_arms, 3)
            Bank frame, m.
        manifold : ndarray, shape (3,)
            The manifold's centre, m.
        angles : ndarray, shape (3,)
            The ship's roll, pitch, yaw, rad.
        """
        d, angles = self.ship(t)
        m = self.bank.file.manifold
        heading = math.radians(m.heading_deg)
        turn = ship_rotation(*angles, heading) @ ship_rotation(0.0, 0.0, 0.0, heading).T
        centre = np.asarray(m.position, dtype=float) + d
        offsets = np.array([[0.0, f.offset, f.height] for f in self.bank.flanges])
        return centre + offsets @ turn.T, centre, angles

    def state(self, t: float) -> BankState:
        """The connected bank at ``t``.

        Parameters
        ----------
        t : float
            s.

        Returns
        -------
        BankState
        """
        flanges, centre, angles = self.flanges(t)
        return bank_state(self.bank, flanges, angles, t=t, manifold=centre)

    @staticmethod
    def from_scenario(bank: Bank, sc, ship=None) -> BankWorld:
        """The world of a bank on a scenario's ship.

        Parameters
        ----------
        bank : Bank
        sc : Scenario
            Its ship, sea and length (``[scenario] duration``).
        ship : ShipModel, optional
            A moored scenario's ship, compiled (:func:`loadarm.ship.model.moored_ship`).

        Returns
        -------
        BankWorld
        """
        motion = flange_motion(sc, ship)
        wind = np.zeros(3)
        if sc.ship.model == "moored":                   # flange_motion needs its ship: compiled by then
            wind = berth_wind(scenario_environment(sc, ship.environment, source=str(sc.ship.berth)))
        return BankWorld(bank, motion, np.asarray(sc.ship.flange, dtype=float), float(sc.scenario.duration), wind)
