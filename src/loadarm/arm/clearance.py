"""Arm-to-arm clearance in a bank (issue 31, item 3).

Each arm is a set of capsules (a segment and a radius): its riser, inboard and outboard pipes, the triple
swivel at the coupler and its two counterweights (the primary one on the inboard arm's rear extension, the
secondary one on the pantograph lever at the riser top, parallel to the outboard arm and pointing away from it:
:class:`loadarm.arm.dynamics.MassModel`'s layout). The clearance between two arms is the smallest distance
between the surfaces of any capsule of one and any capsule of the other: the segment-segment distance less the
two radii, computed for many poses at once (:func:`segment_distance`, vectorised NumPy; Ericson, *Real-Time
Collision Detection*, 2005, section 5.1.9).

Frames: the bank's frame (x towards the ship, y along the jetty, z up from the jetty deck); each arm's own frame
(:mod:`loadarm.arm.slew`) is the bank's shifted to the foot of its riser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm._numba import njit
from loadarm.arm.geometry import Arm
from loadarm.arm.plots import clearance_figure
from loadarm.results import Metric, Result
from loadarm.vocab import CLASH_FACE

__all__ = ["PARTS", "ArmShape", "segment_distance", "capsules", "pair_clearance", "pair_clearance_compiled",
           "capsule_gaps", "ClearanceResult", "path_clearance"]

#: The capsules of an arm, in the order of :func:`capsules`' second-to-last axis.
PARTS: tuple[str, ...] = ("riser", "inboard pipe", "outboard pipe", "triple swivel", "inboard counterweight",
                          "outboard counterweight")


@dataclass(frozen=True, slots=True)
class ArmShape:
    """One arm of a bank as capsules: where its riser stands and how thick each part is.

    Attributes
    ----------
    name : str
    arm : Arm
        Lengths, m.
    base : tuple of float
        The riser's foot in the bank's frame, m.
    counterweight_distances : tuple of float
        Primary counterweight behind the inboard hinge, secondary one along the pantograph lever, m.
    radii : tuple of float
        One radius per part of :data:`PARTS`, m.
    """

    name: str
    arm: Arm
    base: tuple[float, float, float]
    counterweight_distances: tuple[float, float]
    radii: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.radii) != len(PARTS) or not all(r >= 0 for r in self.radii):
            raise ValueError(f"arm {self.name!r}: radii must be {len(PARTS)} non-negative lengths ({', '.join(PARTS)})")


def _vdot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dot products over the last axis (3), summed in order: the compiled route's sum, bit for bit (``einsum``
    sums in another order)."""
    return x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1] + x[..., 2] * y[..., 2]


def segment_distance(p0, p1, q0, q1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance between segments ``p0-p1`` and ``q0-q1``, vectorised over any leading axes.

    Parameters
    ----------
    p0, p1, q0, q1 : array_like, shape (..., 3)
        End points, m (broadcast together).

    Returns
    -------
    distance : ndarray
        m.
    s, t : ndarray
        Where the closest points lie along each segment, in [0, 1].
    """
    p0, p1, q0, q1 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (p0, p1, q0, q1)))
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = _vdot(d1, d1)
    e = _vdot(d2, d2)
    f = _vdot(d2, r)
    c = _vdot(d1, r)
    b = _vdot(d1, d2)
    tiny = 1e-12
    p_point, q_point = a <= tiny, e <= tiny
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        # the general case: the closest point of the infinite lines, clamped; parallel lines (denom 0) take s = 0
        s = np.where(denom > tiny * np.maximum(a * e, tiny), np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
        t = np.where(q_point, 0.0, (b * s + f) / np.where(q_point, 1.0, e))
        # t outside [0, 1]: clamp it and recompute s for the clamped t
        s = np.where(t < 0.0, np.clip(-c / np.where(p_point, 1.0, a), 0.0, 1.0), s)
        s = np.where(t > 1.0, np.clip((b - c) / np.where(p_point, 1.0, a), 0.0, 1.0), s)
        t = np.clip(t, 0.0, 1.0)
        # a segment that is a point
        s = np.where(p_point, 0.0, s)
        t = np.where(p_point & ~q_point, np.clip(f / np.where(q_point, 1.0, e), 0.0, 1.0), t)
        s = np.where(q_point & ~p_point, np.clip(-c / np.where(p_point, 1.0, a), 0.0, 1.0), s)
    gap = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.sqrt(_vdot(gap, gap)), s, t


def capsules(shape: ArmShape, phi, alpha, beta) -> np.ndarray:
    """The arm's capsule segments in the bank's frame, for many poses at once.

    Parameters
    ----------
    shape : ArmShape
    phi, alpha, beta : float or ndarray
        Slew, inboard and elbow angles, rad (broadcast together).

    Returns
    -------
    ndarray, shape (..., len(PARTS), 2, 3)
        Each part's two end points, m.
    """
    phi, alpha, beta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (phi, alpha, beta)))
    arm = shape.arm
    cp, sp = np.cos(phi), np.sin(phi)
    gamma = alpha - beta
    d1, d2 = shape.counterweight_distances
    # in the slewed vertical plane: (rho, z) of each point
    top = (np.zeros_like(alpha), np.full_like(alpha, arm.a))
    elbow = (arm.b * np.sin(alpha), arm.a + arm.b * np.cos(alpha))
    tip = (elbow[0] - arm.c * np.sin(gamma), elbow[1] - arm.c * np.cos(gamma))
    cw1 = (-d1 * np.sin(alpha), arm.a - d1 * np.cos(alpha))
    cw2 = (d2 * np.sin(gamma), arm.a + d2 * np.cos(gamma))
    foot = (np.zeros_like(alpha), np.zeros_like(alpha))
    pairs = ((foot, top), (top, elbow), (elbow, tip), (tip, tip), (top, cw1), (top, cw2))
    base = np.asarray(shape.base, dtype=float)
    out = np.empty(alpha.shape + (len(PARTS), 2, 3))
    for k, ends in enumerate(pairs):
        for e, (rho, z) in enumerate(ends):
            out[..., k, e, 0] = base[0] + rho * cp
            out[..., k, e, 1] = base[1] + rho * sp
            out[..., k, e, 2] = base[2] + z
    return out


def pair_clearance(first: ArmShape, second: ArmShape, q_first, q_second) -> tuple[np.ndarray, np.ndarray]:
    """Clearance between two arms at many poses: the smallest surface-to-surface distance of their capsules.

    Parameters
    ----------
    first, second : ArmShape
    q_first, q_second : array_like, shape (..., 3)
        Each arm's (slew, inboard, elbow) angles, rad, pose by pose.

    Returns
    -------
    clearance : ndarray, shape (...)
        m; negative where the capsules overlap.
    parts : ndarray of int, shape (..., 2)
        The two parts (indices of :data:`PARTS`) that come closest.
    """
    qa, qb = np.asarray(q_first, dtype=float), np.asarray(q_second, dtype=float)
    ca = capsules(first, qa[..., 0], qa[..., 1], qa[..., 2])[..., :, None, :, :]
    cb = capsules(second, qb[..., 0], qb[..., 1], qb[..., 2])[..., None, :, :, :]
    dist, _, _ = segment_distance(ca[..., 0, :], ca[..., 1, :], cb[..., 0, :], cb[..., 1, :])
    gap = dist - (np.asarray(first.radii)[:, None] + np.asarray(second.radii)[None, :])
    n = len(PARTS)
    flat = gap.reshape(gap.shape[:-2] + (n * n,))
    k = np.argmin(flat, axis=-1)
    return np.take_along_axis(flat, k[..., None], axis=-1)[..., 0], np.stack((k // n, k % n), axis=-1)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _dot(x0, x1, x2, y0, y1, y2):
    return x0 * y0 + x1 * y1 + x2 * y2


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _clip01(x):
    return min(max(x, 0.0), 1.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _segment_distance(p0, p1, q0, q1):
    """:func:`segment_distance` of one pair of segments (each end a (3,) array), compiled for the guidance cycle:
    the same operations in the same order, branch by branch (a test holds it to the vectorised route)."""
    d10, d11, d12 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d20, d21, d22 = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    r0, r1, r2 = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = _dot(d10, d11, d12, d10, d11, d12)
    e = _dot(d20, d21, d22, d20, d21, d22)
    f = _dot(d20, d21, d22, r0, r1, r2)
    c = _dot(d10, d11, d12, r0, r1, r2)
    b = _dot(d10, d11, d12, d20, d21, d22)
    tiny = 1e-12
    p_point = a <= tiny
    q_point = e <= tiny
    denom = a * e - b * b
    s = _clip01((b * f - c * e) / denom) if denom > tiny * max(a * e, tiny) else 0.0
    t = 0.0 if q_point else (b * s + f) / e
    a_safe = 1.0 if p_point else a
    if t < 0.0:
        s = _clip01(-c / a_safe)
    if t > 1.0:
        s = _clip01((b - c) / a_safe)
    t = _clip01(t)
    if p_point:
        s = 0.0
        if not q_point:
            t = _clip01(f / e)
    if q_point and not p_point:
        s = _clip01(-c / a)
    g0 = (p0[0] + s * d10) - (q0[0] + t * d20)
    g1 = (p0[1] + s * d11) - (q0[1] + t * d21)
    g2 = (p0[2] + s * d12) - (q0[2] + t * d22)
    return math.sqrt(_dot(g0, g1, g2, g0, g1, g2))


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _bound(ca, cb, m, i, j):
    """A lower bound of the distance of capsules ``i`` and ``j``'s segments at pose ``m``: the distance of their
    axis-aligned boxes (each segment lies in its own)."""
    d2 = 0.0
    for k in range(3):
        lo_a, hi_a = min(ca[m, i, 0, k], ca[m, i, 1, k]), max(ca[m, i, 0, k], ca[m, i, 1, k])
        lo_b, hi_b = min(cb[m, j, 0, k], cb[m, j, 1, k]), max(cb[m, j, 0, k], cb[m, j, 1, k])
        e = max(lo_a - hi_b, lo_b - hi_a, 0.0)
        d2 += e * e
    return math.sqrt(d2)


@njit(cache=True, nogil=True, error_model="numpy")
def _pose_gap(ca, cb, ra, rb, m, seed):
    """The smallest gap of two arms' capsules at pose ``m`` and its pair (the first smallest, as NumPy's argmin:
    the seed pair is computed first, then every pair in order, a pair whose lower bound lies more than 1e-9 m
    above the smallest so far skipped: the result is that of the full loop)."""
    n = ra.shape[0]
    si, sj = seed // n, seed % n
    low = _segment_distance(ca[m, si, 0], ca[m, si, 1], cb[m, sj, 0], cb[m, sj, 1]) - (ra[si] + rb[sj])
    k_low = seed
    if math.isnan(low):               # an undefined pose: the first undefined pair, as argmin
        low, k_low = np.inf, 0
    for i in range(n):
        for j in range(n):
            k = i * n + j
            if k == seed:
                continue
            if _bound(ca, cb, m, i, j) - (ra[i] + rb[j]) > low + 1e-9:
                continue
            d = _segment_distance(ca[m, i, 0], ca[m, i, 1], cb[m, j, 0], cb[m, j, 1]) - (ra[i] + rb[j])
            if math.isnan(d):
                return d, k
            if d < low or (d == low and k < k_low):
                low, k_low = d, k
    return low, k_low


@njit(cache=True, nogil=True, error_model="numpy")
def capsule_gaps(ca, cb, ra, rb, gap, best, seed=21):
    """The clearance of two arms at many poses, compiled: for each pose the smallest segment distance of their
    capsules less the two radii, and which pair of parts (``i * len(PARTS) + j``, the first smallest, as
    :func:`pair_clearance`; a pose with an undefined distance, NaN, gives NaN and the first such pair, as NumPy's
    ``argmin``).

    Parameters
    ----------
    ca, cb : ndarray, shape (n, P, 2, 3)
        The two arms' capsules at each pose (:func:`capsules`, flattened over the poses), m.
    ra, rb : ndarray, shape (P,)
        Their radii, m.
    gap : ndarray, shape (n,)
        Written: the clearance, m.
    best : ndarray of int, shape (n,)
        Written: the closest parts.
    seed : int
        The pair computed first (default: triple swivel to triple swivel, the connected neighbours' nearest
        parts), so that the lower bounds (the distance of the segments' axis-aligned boxes) skip the pairs that
        cannot be nearer.
    """
    for m in range(ca.shape[0]):
        gap[m], best[m] = _pose_gap(ca, cb, ra, rb, m, seed)


def pair_clearance_compiled(first: ArmShape, second: ArmShape, q_first, q_second) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pair_clearance` with the capsules' distances compiled (:func:`capsule_gaps`): the guidance cycle's
    route (the bank's monitor), held to the vectorised one by a test.

    Parameters
    ----------
    first, second : ArmShape
    q_first, q_second : array_like, shape (..., 3)
        Each arm's (slew, inboard, elbow) angles, rad, pose by pose (broadcast together).

    Returns
    -------
    clearance : ndarray, shape (...)
        m.
    parts : ndarray of int, shape (..., 2)
    """
    qa, qb = np.broadcast_arrays(np.asarray(q_first, dtype=float), np.asarray(q_second, dtype=float))
    lead = qa.shape[:-1]
    n = len(PARTS)
    ca = capsules(first, qa[..., 0], qa[..., 1], qa[..., 2]).reshape(-1, n, 2, 3)
    cb = capsules(second, qb[..., 0], qb[..., 1], qb[..., 2]).reshape(-1, n, 2, 3)
    gap, best = np.empty(ca.shape[0]), np.empty(ca.shape[0], dtype=np.int64)
    capsule_gaps(ca, cb, np.asarray(first.radii, dtype=float), np.asarray(second.radii, dtype=float), gap, best)
    return gap.reshape(lead), np.stack((best // n, best % n), axis=-1).reshape(lead + (2,))


@dataclass(frozen=True)
class ClearanceResult(Result):
    """The bank's arms against each other along their paths: the smallest clearance and where.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Times, s.
    names : tuple of str
        The arms.
    minimum : ndarray, shape (n,)
        The smallest clearance of any pair at each time, m.
    pair_minimum : ndarray, shape (n_pairs, n)
        Each pair's clearance, m, pairs in the order of :attr:`pairs`.
    pairs : tuple of (int, int)
    index : int
        The time step of the smallest clearance.
    pair : tuple of int
        The two arms there.
    parts : tuple of str
        Their two parts that come closest.
    required : float
        The bank's minimum clearance, m.
    """

    METRICS = (
        Metric("min_clearance_m", "smallest clearance between arms", "m", ".3f", "clearance"),
        Metric("required_clearance_m", "required clearance", "m", ".3f", "required"),
        Metric("at_time_s", "at", "s", ".2f"),
        Metric("arms", "between arms", ""),
        Metric("parts", "between parts", ""),
        Metric("clear", "clear", ""),
        Metric("face", "face reached", "", none="none"),
    )

    t: np.ndarray
    names: tuple[str, ...]
    minimum: np.ndarray
    pair_minimum: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    index: int
    pair: tuple[int, int]
    parts: tuple[str, str]
    required: float

    @property
    def min_clearance(self) -> float:
        """The smallest clearance, m."""
        return float(self.minimum[self.index])

    @property
    def clear(self) -> bool:
        """True if the arms keep the required clearance all along."""
        return self.min_clearance >= self.required

    def where(self) -> str:
        """One line: the smallest clearance, between which parts of which arms, when."""
        a, b = self.pair
        return (f"{self.min_clearance:.3f} m between the {self.parts[0]} of {self.names[a]} and the {self.parts[1]} "
                f"of {self.names[b]} at t = {float(self.t[self.index]):.2f} s")

    def _values(self) -> dict:
        a, b = self.pair
        return {"min_clearance_m": self.min_clearance, "required_clearance_m": float(self.required),
                "at_time_s": float(self.t[self.index]), "arms": f"{self.names[a]} / {self.names[b]}",
                "parts": f"{self.parts[0]} / {self.parts[1]}", "clear": self.clear,
                "face": None if self.clear else CLASH_FACE.name}

    def _figure(self):
        return clearance_figure(self)


def path_clearance(shapes, trajectories, t=None, *, required: float = 0.0) -> ClearanceResult:
    """Check planned motions along their whole path: every pair of arms at every time step.

    Parameters
    ----------
    shapes : sequence of ArmShape
        The bank's arms.
    trajectories : sequence of array_like, shape (n, 3)
        Each arm's (slew, inboard, elbow) angles, rad, on one time base (an arm that waits holds its pose).
    t : array_like, shape (n,), optional
        The time base, s (default: the step index).
    required : float
        The bank's minimum clearance, m.

    Returns
    -------
    ClearanceResult
    """
    qs = [np.atleast_2d(np.asarray(q, dtype=float)) for q in trajectories]
    if len(qs) != len(shapes) or len(shapes) < 2:
        raise ValueError(f"need one trajectory per arm and at least two arms, got {len(qs)} for {len(shapes)}")
    n = qs[0].shape[0]
    if any(q.shape != (n, 3) for q in qs):
        raise ValueError(f"every trajectory must have shape ({n}, 3): {[q.shape for q in qs]}")
    tt = np.arange(n, dtype=float) if t is None else np.asarray(t, dtype=float)
    pairs = tuple((i, j) for i in range(len(shapes)) for j in range(i + 1, len(shapes)))
    first, second = (np.array(v) for v in zip(*pairs, strict=True))
    # every arm's capsules once, every pair of arms and of parts in one call: (pairs, n, parts, parts)
    caps = np.stack([capsules(s, q[:, 0], q[:, 1], q[:, 2]) for s, q in zip(shapes, qs, strict=True)])
    radii = np.array([s.radii for s in shapes])
    ca, cb = caps[first][:, :, :, None], caps[second][:, :, None, :]
    dist, _, _ = segment_distance(ca[..., 0, :], ca[..., 1, :], cb[..., 0, :], cb[..., 1, :])
    gap = dist - (radii[first][:, None, :, None] + radii[second][:, None, None, :])
    k = len(PARTS)
    flat = gap.reshape(len(pairs), n, k * k)
    best = np.argmin(flat, axis=-1)
    per_pair = np.take_along_axis(flat, best[..., None], axis=-1)[..., 0]
    which = np.argmin(per_pair, axis=0)
    minimum = per_pair[which, np.arange(n)]
    index = int(np.argmin(minimum))
    p = int(which[index])
    ka, kb = divmod(int(best[p, index]), k)
    return ClearanceResult(tt, tuple(s.name for s in shapes), minimum, per_pair, pairs, index, pairs[p],
                           (PARTS[ka], PARTS[kb]), float(required))
