"""The bank's planned approaches checked for clearance along their whole path, and the order they run in (issue
31, item 3).

Each arm's approach is its own straight-line plan (:func:`loadarm.design.trajectory.plan_approach_3d`) from its
stowed position to its flange at the manifold's design position; the bank's arms run them on one time base, all
at once, one after another in a given order, or in waves (the arms of a wave together, each wave once the last
finished); an arm waiting holds its stowed pose, an arm connected holds its flange, and
:func:`loadarm.arm.clearance.path_clearance` checks every pair of arms at every sample.

:func:`order_bank_approaches` decides the order: the clearance is a property of pairs, so three checks of each
pair decide it (one arm's approach past the other stowed, past it connected, and both approaching together); the
waves are then formed greedily, in the bank's order: an arm joins the current wave when its approach keeps the
clearance to every arm still stowed, to every arm connected and to every arm of the wave moving with it; an arm
that cannot waits for the arms it would clash with. The schedule is checked as a whole at the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from loadarm.arm.actuators import cylinder_lengths
from loadarm.arm.envelope import berth_box, flanging_x_far
from loadarm.arm.clearance import ClearanceResult, path_clearance
from loadarm.arm.swivel import swivel_angles, swivel_margins
from loadarm.design.plots import bank_order_figure, swivel_envelope_figure
from loadarm.design.trajectory import plan_approach_3d
from loadarm.errors import LoadarmError, PathError
from loadarm.params.bank import Bank
from loadarm.results import Metric, Result
from loadarm.vocab import SWIVEL_FACE_TABLE

__all__ = ["bank_approaches", "check_bank_approaches", "BankOrder", "order_bank_approaches",
           "design_swivel_margins", "approach_flows", "POWER_UNIT", "SwivelEnvelope", "swivel_envelope",
           "flanging_moves", "flanging_points", "order_over_flanging_area"]


#: What an arm waits for when the duty pumps' flow, not a neighbour, holds it back.
POWER_UNIT = "the power unit's flow"


def design_swivel_margins(bank: Bank) -> np.ndarray:
    """Each arm's swivels' margins to their stops connected at the manifold's design position, the ship at rest
    (what ``loadarm check --bank`` and the report's bank section show).

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    ndarray, shape (arms, 6)
        rad, in the order of :data:`loadarm.vocab.SWIVEL_FACE_TABLE`.
    """
    q = bank.connected
    heading = np.radians(bank.file.manifold.heading_deg)
    return swivel_margins(swivel_angles(q[:, 0], q[:, 1], q[:, 2], heading=heading), bank.file.swivels.limits())


@dataclass(frozen=True)
class SwivelEnvelope(Result):
    """The swivels' margins over the manifold's flanging area and the ship's rotation while connected.

    Attributes
    ----------
    names : tuple of str
    cases : tuple of (tuple of float, tuple of float)
        Each case: the manifold's displacement from its design position (m: the flanging area's corners, the
        datasheet's near and far connecting edges ``A + B + C`` and ``A + B + D`` at its lowest and highest
        flange, and no displacement) and the ship's roll, pitch and yaw (deg: every sign of the terminal's
        ``[operability]`` limits, and none).
    margins : ndarray, shape (cases, arms, 6)
        rad (NaN: that arm cannot reach its flange there; its own faces' matter, :mod:`loadarm.design.check`).
    clearance : ClearanceResult or None
        The connected arms' clearance over the cases every arm reaches (its ``t``: the case's index), the clash
        face's (None: no such case).
    """

    METRICS = (
        Metric("least_deg", "swivel margin, least over the flanging area and the ship's motions", "deg", ".1f"),
        Metric("where", "which, where", ""),
        Metric("out_of_reach", "cases an arm cannot reach (its own faces' matter)", "", "d"),
        Metric("connected_clearance_m", "connected clearance, least over them", "m", ".3f", none="n/a"),
        Metric("connected_where", "between, where", "", none="n/a"),
    )

    names: tuple[str, ...]
    cases: tuple
    margins: np.ndarray
    clearance: ClearanceResult | None = None

    def least(self) -> tuple[float, int, int, int]:
        """The least margin (rad) and its case, arm and face (index into :data:`loadarm.vocab.SWIVEL_FACE_TABLE`).

        Returns
        -------
        tuple
        """
        m = np.where(np.isnan(self.margins), np.inf, self.margins)
        k, i, j = np.unravel_index(int(np.argmin(m)), m.shape)
        return float(m[k, i, j]), int(k), int(i), int(j)

    def by_arm(self) -> np.ndarray:
        """Each arm's least margin over the cases it can reach, rad (NaN: none)."""
        m = np.where(np.isnan(self.margins), np.inf, self.margins).min(axis=(0, 2))
        return np.where(np.isinf(m), np.nan, m)

    def words(self, k: int, i: int, j: int) -> str:
        """Case ``k``, arm ``i``, face ``j`` in words."""
        return f"arm '{self.names[i]}' {SWIVEL_FACE_TABLE[j].words}, {self.case_words(k)}"

    def case_words(self, k: int) -> str:
        """Case ``k`` in words: where the manifold is and how the ship is turned."""
        (d, rpy) = self.cases[k]
        return (f"manifold moved by ({d[0]:+.2f}, {d[1]:+.2f}, {d[2]:+.2f}) m, ship at roll {rpy[0]:+.2f}, "
                f"pitch {rpy[1]:+.2f}, yaw {rpy[2]:+.2f} deg")

    def clash_words(self) -> str | None:
        """The connected arms' least clearance in words (None: no case every arm reaches)."""
        c = self.clearance
        if c is None:
            return None
        a, b = c.pair
        return (f"{c.min_clearance:.3f} m between the {c.parts[0]} of {c.names[a]} and the {c.parts[1]} of "
                f"{c.names[b]}, {self.case_words(int(c.t[c.index]))}")

    def _figure(self):
        return swivel_envelope_figure(self)

    def _values(self) -> dict:
        least, k, i, j = self.least()
        by_arm = self.by_arm()
        return {"least_deg": math.degrees(least), "where": self.words(k, i, j),
                "out_of_reach": int(np.isnan(self.margins).any(axis=2).sum()),
                "connected_clearance_m": None if self.clearance is None else self.clearance.min_clearance,
                "connected_where": self.clash_words(),
                "by_arm_deg": {n: math.degrees(float(v)) if v == v else None
                               for n, v in zip(self.names, by_arm, strict=True)}}


def flanging_moves(bank: Bank) -> list[tuple[float, float, float]]:
    """The manifold's displacements from its design position to the flanging area's corners (the first arm's
    datasheet about its own design flange: the near and far connecting edges ``A + B + C`` and ``A + B + D`` at the
    lowest and highest flange; along the berth, ``[manifold] tolerance`` either way), the design position first,
    m. (Found by review: the corners were taken about the installation's ``[approach] flange``, not the bank's
    flange, and had no width along the berth.)

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    list of (float, float, float)
    """
    model = bank.models[0]
    box = berth_box(model.datasheet)
    fx, _, fz = bank.flange_position(0)
    tol = bank.file.manifold.tolerance
    return [(0.0, 0.0, 0.0)] + [(float(x - fx), y, float(z - fz))
                                for x in (box.x_near, flanging_x_far(model.datasheet))
                                for z in (box.y_low, box.y_high) for y in sorted({-tol, tol})]


#: Heights of the flanging area's vertical edges the approaches are ordered to (the corners among them). Found: an
#: approach comes closest to a neighbour with the flange between the corners' heights (the example's 1.688 m with
#: the manifold 4.24 m above its design height, against 1.721 m at the corners; 1.385 m against 1.473 m with its
#: flanges 3.0 m apart: docs/bank.md, test-held).
FLANGING_LEVELS = 9


def flanging_points(bank: Bank, levels: int = FLANGING_LEVELS) -> list[tuple[float, float, float]]:
    """The design position, then the flanging area's vertical edges (:func:`flanging_moves`' corners, and
    ``levels`` heights from the lowest to the highest flange on each edge), as displacements, m.

    Parameters
    ----------
    bank : Bank
    levels : int
        At least 2 (the corners only).

    Returns
    -------
    list of (float, float, float)
    """
    corners = np.array(flanging_moves(bank)[1:])
    xs, ys = sorted(set(corners[:, 0])), sorted(set(corners[:, 1]))
    zs = np.linspace(corners[:, 2].min(), corners[:, 2].max(), levels)
    return [(0.0, 0.0, 0.0)] + [(float(x), float(y), float(z)) for x in xs for z in zs for y in ys]


def order_over_flanging_area(bank: Bank, design: BankOrder | None = None) \
        -> list[tuple[tuple[float, float, float], BankOrder]]:
    """:func:`order_bank_approaches` with the manifold at the design position and along the flanging area's
    vertical edges (:func:`flanging_points`): the approaches planned to wherever the ship presents its flanges.

    Parameters
    ----------
    bank : Bank
    design : BankOrder, optional
        The design position's order, if already made.

    Returns
    -------
    list of (displacement, BankOrder)

    Raises
    ------
    PathError
        One line naming the point where no order keeps the clearance (or an arm cannot reach its flange).
    """
    moves = flanging_points(bank)
    corners = set(flanging_moves(bank)[1:])
    out = [(moves[0], design or order_bank_approaches(bank))]     # the design position: its own errors as they are
    for d in moves[1:]:
        try:
            out.append((d, order_bank_approaches(bank, displacement=d)))
        except LoadarmError as exc:
            where = "corner" if d in corners else "edge"
            raise PathError(f"with the manifold at the flanging area's {where} ({d[0]:+.2f}, {d[1]:+.2f}, "
                            f"{d[2]:+.2f}) m from its design position: {exc}") from None
    return out


#: Points of the flanging area and the ship's motions sampled inside, besides the corners (a scrambled Sobol
#: sequence, seeded: the same every run). Found: the connected arms' clearance is least inside the flanging area,
#: not at a corner (the example's 1.942 m at mid-height against 1.956 m at the corners; 1.604 m against 1.748 m
#: with its flanges 3.0 m apart: docs/bank.md, test-held).
ENVELOPE_SAMPLES = 1024
#: The sampled cases each least (the swivels', the clearance) is refined from, by a bounded local search.
ENVELOPE_REFINED = 4


def _envelope_cases(bank: Bank, cases) -> tuple[np.ndarray, list[np.ndarray]]:
    """Every arm's swivel margins (cases, arms, 6) and poses (per arm, (cases, 3)) at (displacement, rpy deg)
    cases."""
    centre = np.asarray(bank.file.manifold.position, dtype=float)
    centres = np.array([centre + np.asarray(d) for d, _ in cases]).reshape(-1, 3)
    angles = np.radians(np.array([r for _, r in cases], dtype=float)).reshape(-1, 3)
    _, _, poses, swivels = bank.on_flanges(centres, angles)
    return swivels, poses


def _as_cases(x: np.ndarray) -> list:
    """Rows (displacement m, roll, pitch, yaw deg) as cases."""
    return [(tuple(float(v) for v in row[:3]), tuple(float(v) for v in row[3:])) for row in x]


def _least_swivel(bank: Bank, x: np.ndarray) -> np.ndarray:
    """Each row's least swivel margin, rad (inf: an arm cannot reach)."""
    m, _ = _envelope_cases(bank, _as_cases(x))
    return np.where(np.isnan(m), np.inf, m).min(axis=(1, 2))


def _least_gap(bank: Bank, x: np.ndarray) -> np.ndarray:
    """Each row's least clearance between the connected arms, m (inf: an arm cannot reach)."""
    m, poses = _envelope_cases(bank, _as_cases(x))
    gaps = path_clearance(bank.shapes, poses).minimum
    return np.where(np.isnan(m).any(axis=(1, 2)), np.inf, gaps)


#: Points of each line of the refining search.
LINE_POINTS = 41


def _refined(bank: Bank, cost, starts: np.ndarray, lo: np.ndarray, hi: np.ndarray, sweeps: int = 3) -> np.ndarray:
    """Each start moved to a local least of ``cost`` inside the box: along each axis in turn, the least of
    :data:`LINE_POINTS` points across the box's whole width (the leasts lie on the box's faces in some axes and
    inside it in others), until a sweep gains nothing. Found: a derivative-free local search stalled on the
    clearance's corners (the least of many parts' distances)."""
    out = []
    for x in np.clip(np.asarray(starts, dtype=float), lo, hi):
        best = float(cost(bank, x[None])[0])
        for _ in range(sweeps):
            gained = False
            for j in range(x.size):
                line = np.repeat(x[None], LINE_POINTS, axis=0)
                line[:, j] = np.linspace(lo[j], hi[j], LINE_POINTS)
                c = cost(bank, line)
                k = int(np.argmin(c))
                if c[k] < best:
                    best, x, gained = float(c[k]), line[k], True
            if not gained:
                break
        out.append(x)
    return np.array(out)


def swivel_envelope(bank: Bank, samples: int = ENVELOPE_SAMPLES) -> SwivelEnvelope:
    """The swivels' margins and the connected arms' clearance where the ship may be presented and how it may move
    while connected: the manifold anywhere in the flanging area (the first arm's datasheet, about its design
    flange: one manifold, one box) and the ship anywhere within the terminal's roll, pitch and yaw limits (the
    first installation's ``[operability]``, PIANC's for gas tankers: beyond them the terminal disconnects).

    The cases: at rest, each corner of the box at every sign of the limits (81), ``samples`` points inside
    (:data:`ENVELOPE_SAMPLES`, a seeded scrambled Sobol sequence), then the :data:`ENVELOPE_REFINED` least of each
    (the swivels' margin, the clearance) moved to a local least by line searches across the box
    (:func:`_refined`). A search, not a proof: the least found is never less than the true least.

    Parameters
    ----------
    bank : Bank
    samples : int
        Points inside (a power of two; 0: the corners only).

    Returns
    -------
    SwivelEnvelope
    """
    moves = flanging_moves(bank)
    op = bank.installations[0].operability
    lim = np.array([op.roll_limit_deg, op.pitch_limit_deg, op.yaw_limit_deg], dtype=float)
    rots = [(0.0, 0.0, 0.0)] + [(float(r), float(p), float(y)) for r in (-lim[0], lim[0])
                                for p in (-lim[1], lim[1]) for y in (-lim[2], lim[2])]
    cases = [(d, r) for d in moves for r in rots]
    corners = np.array(moves[1:], dtype=float)
    lo, hi = np.r_[corners.min(axis=0), -lim], np.r_[corners.max(axis=0), lim]
    if samples:
        x = qmc.scale(qmc.Sobol(6, scramble=True, seed=0).random(samples), lo, hi)
        cases += [(tuple(map(float, v[:3])), tuple(map(float, v[3:]))) for v in x]
    out, poses = _envelope_cases(bank, cases)
    if samples:
        rows = np.array([np.r_[d, r] for d, r in cases])
        least = np.where(np.isnan(out), np.inf, out).min(axis=(1, 2))
        gaps = np.where(np.isnan(out).any(axis=(1, 2)), np.inf, path_clearance(bank.shapes, poses).minimum)
        first = rows[np.argsort(least, kind="stable")[:ENVELOPE_REFINED]]
        second = rows[np.argsort(gaps, kind="stable")[:ENVELOPE_REFINED]]
        more = _as_cases(np.concatenate([_refined(bank, _least_swivel, first, lo, hi),
                                         _refined(bank, _least_gap, second, lo, hi)]))
        extra, extra_poses = _envelope_cases(bank, more)
        cases += more
        out = np.concatenate([out, extra])
        poses = [np.concatenate([p, e]) for p, e in zip(poses, extra_poses, strict=True)]
    reached = np.flatnonzero(~np.isnan(out).any(axis=(1, 2)))          # the cases every arm reaches
    clearance = None if reached.size == 0 else path_clearance(
        bank.shapes, [p[reached] for p in poses], reached.astype(float), required=bank.file.clearance.min_clearance)
    return SwivelEnvelope(bank.names, tuple(cases), out, clearance)


def bank_approaches(bank: Bank, *, order: tuple[str, ...] | None = None, timing: str = "smooth",
                    samples: int = 201, waves: tuple[tuple[str, ...], ...] | None = None,
                    displacement=None) -> tuple[np.ndarray, list[np.ndarray]]:
    """Every arm's approach on one time base.

    Parameters
    ----------
    bank : Bank
    displacement : array_like, shape (3,), optional
        The manifold presented this far from its design position, m (a corner of the flanging area).
    order : tuple of str, optional
        The arms, in the order they move one after another (default: all at once).
    waves : tuple of tuple of str, optional
        Instead of ``order``: groups of arms that move together, each group once the previous one has arrived.
    timing : str
        The timing law of each plan.
    samples : int
        Samples of each arm's plan.

    Returns
    -------
    t : ndarray, shape (n,)
        s.
    trajectories : list of ndarray, shape (n, 3)
        Each arm's (slew, inboard, elbow) angles, rad, in the bank's order of arms.
    """
    names = bank.names
    if order is not None:
        waves = tuple((name,) for name in order)
    if waves is not None and sorted(n for w in waves for n in w) != sorted(names):
        raise ValueError(f"order {[list(w) for w in waves]} must name every arm of the bank once: {list(names)}")
    plans = []
    shift = np.zeros(3) if displacement is None else np.asarray(displacement, dtype=float)
    for i, model in enumerate(bank.models):
        p = bank.flange_position(i) + shift
        plans.append(plan_approach_3d(model, target=(float(p[0]), float(p[1]), float(p[2])), timing=timing,
                                      samples=samples))
    starts = np.zeros(len(plans))
    if waves is not None:
        clock = 0.0
        for wave in waves:
            idx = [names.index(name) for name in wave]
            starts[idx] = clock
            clock += max(plans[i].duration for i in idx)
    end = max(s + p.duration for s, p in zip(starts, plans, strict=True))
    t = np.linspace(0.0, end, max(samples, int(np.ceil(samples * end / max(p.duration for p in plans)))))
    trajectories = []
    for s, p in zip(starts, plans, strict=True):
        local = np.clip(t - s, 0.0, p.duration)
        trajectories.append(np.column_stack([np.interp(local, p.t, v) for v in (p.phi, p.alpha, p.beta)]))
    return t, trajectories


def check_bank_approaches(bank: Bank, *, order: tuple[str, ...] | None = None, timing: str = "smooth",
                          samples: int = 201) -> ClearanceResult:
    """The smallest clearance between any two arms along the bank's planned approaches, and where.

    Parameters
    ----------
    bank : Bank
    order : tuple of str, optional
        One after another in this order (default: all at once).
    timing : str
    samples : int

    Returns
    -------
    ClearanceResult
    """
    t, qs = bank_approaches(bank, order=order, timing=timing, samples=samples)
    return path_clearance(bank.shapes, qs, t, required=bank.file.clearance.min_clearance)


@dataclass(frozen=True)
class BankOrder(Result):
    """The order of the bank's approaches: which arms move first, which wait and for whom, and the schedule's
    clearance.

    Attributes
    ----------
    names : tuple of str
        The bank's arms.
    waves : tuple of tuple of str
        The arms moving together, wave by wave (the first moves first).
    waits_for : tuple of (str, tuple of str)
        Each arm of a later wave and the arms it would clash with, had it moved in an earlier wave, or
        :data:`POWER_UNIT` when the earlier waves' oil left too little of the duty pumps' flow for it.
    alone, connected, together : ndarray (n, n) of float
        The smallest clearance of arm ``i``'s approach against arm ``j`` stowed, against it connected, and both
        approaching at once, m (diagonal NaN).
    clearance : ClearanceResult
        The whole schedule's.
    start_s, end_s : tuple of float
        When each arm's approach starts and ends in the schedule, s.
    peak_flow : float
        The schedule's largest draw of oil on the power unit, m^3/s (:func:`approach_flows` summed).
    duty_flow : float
        What the duty pumps deliver, m^3/s (``PowerUnit.duty_flow``): a wave takes no more arms than it allows.
    """

    METRICS = (
        Metric("moves_first", "moves first", ""),
        Metric("order", "approach order (waves)", ""),
        Metric("waits", "waits for", "", none="none"),
        Metric("flow", "power unit, largest draw / duty pumps", ""),
    )

    names: tuple[str, ...]
    waves: tuple[tuple[str, ...], ...]
    waits_for: tuple[tuple[str, tuple[str, ...]], ...]
    alone: np.ndarray
    connected: np.ndarray
    together: np.ndarray
    clearance: ClearanceResult
    start_s: tuple[float, ...]
    end_s: tuple[float, ...]
    peak_flow: float = 0.0
    duty_flow: float = float("inf")

    def wave_of(self, name: str) -> int:
        """The wave an arm moves in (0: first).

        Parameters
        ----------
        name : str

        Returns
        -------
        int
        """
        return next(k for k, w in enumerate(self.waves) if name in w)

    def _values(self) -> dict:
        waits = "; ".join(f"{a} waits for {', '.join(b)}" for a, b in self.waits_for) or None
        return {"moves_first": ", ".join(self.waves[0]), "order": " -> ".join(" + ".join(w) for w in self.waves),
                "waits": waits, "flow": f"{self.peak_flow * 6e4:.1f} / {self.duty_flow * 6e4:.1f} L/min",
                "peak_flow_m3s": self.peak_flow, "duty_flow_m3s": self.duty_flow,
                "min_clearance_m": self.clearance.min_clearance, "clear": self.clearance.clear,
                "waves": [list(w) for w in self.waves], "waits_for": {a: list(b) for a, b in self.waits_for}}

    def _figure(self):
        return bank_order_figure(self)


def _pair_clearances(bank: Bank, t: np.ndarray, qs: list[np.ndarray], connected_poses) -> tuple[np.ndarray, ...]:
    """Each ordered pair's smallest clearance: arm i approaching against arm j stowed, connected, approaching."""
    n = len(qs)
    alone, connected, together = (np.full((n, n), np.nan) for _ in range(3))
    hold = np.ones((t.size, 1))
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            pair = (bank.shapes[i], bank.shapes[j])
            alone[i, j] = path_clearance(pair, [qs[i], hold * bank.stowed[j]], t).min_clearance
            connected[i, j] = path_clearance(pair, [qs[i], hold * connected_poses[j]], t).min_clearance
            together[i, j] = path_clearance(pair, [qs[i], qs[j]], t).min_clearance
    return alone, connected, together


def _sequence(n: int, ok) -> list[int] | None:
    """One arm at a time: the first order (depth first, the bank's order preferred) in which each arm's approach
    keeps the clearance to the arms still stowed and to those connected; None if there is none."""
    alone, connected, _ = ok

    def extend(done: list[int]) -> list[int] | None:
        if len(done) == n:
            return done
        rest = [j for j in range(n) if j not in done]
        for i in rest:
            if all(alone[i, j] for j in rest if j != i) and all(connected[i, c] for c in done):
                found = extend(done + [i])
                if found is not None:
                    return found
        return None

    return extend([])


def approach_flows(bank: Bank, t: np.ndarray, qs: list[np.ndarray]) -> np.ndarray:
    """The oil each arm's approach draws from the power unit over its plan, m^3/s: its two cylinders' filling
    chambers (the piston side extending, the annulus retracting; :func:`loadarm.design.check.cylinder_oil`'s rule,
    per unit time).

    Parameters
    ----------
    bank : Bank
    t : ndarray, shape (n,)
        s.
    qs : list of ndarray, shape (n, 3)
        Each arm's joints over ``t``, rad (every arm starting at 0: :func:`bank_approaches` all at once).

    Returns
    -------
    ndarray, shape (arms, n)
    """
    out = np.zeros((len(qs), t.size))
    for i, (model, q) in enumerate(zip(bank.models, qs, strict=True)):
        r = np.array(cylinder_lengths(model.mount, q[:, 1], q[:, 2]), dtype=float)
        v = np.gradient(r, t, axis=1)
        piston, annulus = model.cylinder_area
        out[i] = np.where(v > 0, piston * v, -annulus * v).sum(axis=0)
    return out


def _fits(k: int, w: int, wave: dict[int, int], ok, flows=None, duty: float = np.inf) -> bool:
    """Arm ``k`` may move in wave ``w`` against every arm already placed, and the wave's arms' oil together stays
    within the duty pumps' flow (the arms of a wave start together)."""
    if flows is not None:
        together_flow = flows[k] + sum((flows[m] for m, wm in wave.items() if wm == w), np.zeros_like(flows[k]))
        if together_flow.max() > duty * (1.0 + 1e-9):
            return False
    alone, connected, together = ok
    for m, wm in wave.items():
        if wm < w and not (alone[m, k] and connected[k, m]):
            return False
        if wm == w and not (together[k, m] and together[m, k]):
            return False
        if wm > w and not (alone[k, m] and connected[m, k]):
            return False
    return True


def _waves(names, ok, flows=None, duty: float = np.inf) -> tuple[list[list[int]], dict[int, list[int]]]:
    """The approaches in waves: a one-at-a-time order first (:func:`_sequence`), then each arm, in that order,
    in the earliest wave that keeps every pair's clearance with the arms already placed (the clearance is a
    property of pairs: pairwise clear is clear) and the wave's oil within the duty pumps' flow; an arm of a later
    wave waits for the arms of earlier waves its approach would clash with, stowed or moving with it."""
    alone, _, together = ok
    order = _sequence(len(names), ok)
    if order is None:
        raise PathError(f"no order of the approaches of {', '.join(names)} keeps the bank's clearance: an arm's "
                        f"approach comes too close to another arm both stowed and connected")
    wave: dict[int, int] = {}
    for k in order:
        wave[k] = next(w for w in range(max(wave.values(), default=-1) + 2) if _fits(k, w, wave, ok, flows, duty))
    waves = [[i for i in order if wave[i] == w] for w in range(max(wave.values()) + 1)]
    waits = {k: [m for m in order if wave[m] < wave[k] and not (alone[k, m] and together[k, m])] for k in order}
    if flows is not None:            # an arm the clearance would let move earlier waits for the power unit's oil
        for k in order:
            others = {m: wm for m, wm in wave.items() if m != k}
            if any(_fits(k, w, others, ok) for w in range(wave[k])):
                waits[k] = waits[k] + [-1]
    return waves, waits


def order_bank_approaches(bank: Bank, *, timing: str = "smooth", samples: int = 201,
                          displacement=None) -> BankOrder:
    """Which arm moves first and which must wait: the approaches in waves that keep every pair's clearance.

    Parameters
    ----------
    bank : Bank
    displacement : array_like, shape (3,), optional
        The manifold presented this far from its design position, m (:func:`flanging_moves`).
    timing : str
        The timing law of each arm's plan.
    samples : int
        Samples of each plan.

    Returns
    -------
    BankOrder

    Raises
    ------
    PathError
        One line when no order keeps the clearance (an arm's approach clashes with a neighbour both stowed and
        connected, or two arms block each other).
    """
    names = bank.names
    t, qs = bank_approaches(bank, timing=timing, samples=samples, displacement=displacement)
    need = bank.file.clearance.min_clearance
    pu = bank.file.power_unit
    flows = approach_flows(bank, t, qs)
    peak = flows.max(axis=1)
    if peak.max() > pu.duty_flow * (1.0 + 1e-9):
        i = int(np.argmax(peak))
        raise PathError(f"{bank.source}: power_unit: the duty pumps deliver {pu.duty_flow * 6e4:.1f} L/min "
                        f"({pu.pumps - pu.standby} of pumps = {pu.pumps}, standby_pumps = {pu.standby}, "
                        f"pump_flow = {pu.pump_flow * 6e4:.1f} L/min each); arm {names[i]}'s approach alone draws "
                        f"{peak[i] * 6e4:.1f} L/min at its peak: short by {(peak[i] - pu.duty_flow) * 6e4:.1f} L/min")
    on = bank.connected if displacement is None else [q[-1] for q in qs]      # each plan ends on its flange
    alone, connected, together = _pair_clearances(bank, t, qs, on)
    waves, waits = _waves(names, (alone >= need, connected >= need, together >= need), flows, pu.duty_flow)
    named = tuple(tuple(names[i] for i in w) for w in waves)
    t2, qs2 = bank_approaches(bank, timing=timing, samples=samples, waves=named, displacement=displacement)
    schedule = path_clearance(bank.shapes, qs2, t2, required=need)
    if not schedule.clear:       # pairwise clear implies clear: a failure here is a bug, not an input
        raise AssertionError(f"the ordered approaches come too close: {schedule.where()}")
    waits_for = tuple((names[i], tuple(names[j] if j >= 0 else POWER_UNIT for j in js))
                      for i, js in sorted(waits.items()) if js)
    moving = [np.flatnonzero(np.any(np.diff(q, axis=0) != 0, axis=1)) for q in qs2]
    start = tuple(float(t2[m[0]]) if m.size else 0.0 for m in moving)
    end = tuple(float(t2[m[-1] + 1]) if m.size else 0.0 for m in moving)
    drawn = approach_flows(bank, t2, qs2).sum(axis=0)             # the schedule's draw on the power unit
    return BankOrder(names, named, waits_for, alone, connected, together, schedule, start, end,
                     float(drawn.max()), float(pu.duty_flow))
