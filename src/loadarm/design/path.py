"""The coupler's straight-line approach path (paper Eq. 4, Fig. 5).

A path is a geometric object only, parameterised by arc length ``s`` in
metres: ``path(s, order)`` gives the position (order 0), the unit tangent
(order 1) or the curvature vector (order 2, zero for a line). Time enters
through a timing law (:mod:`loadarm.design.timing`), kept apart as in toppra.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import ROUNDOFF_M
from loadarm.errors import PathError, UnreachableError

__all__ = ["StraightPath"]

#: Shortest path accepted, m: below this the direction is meaningless.
MIN_LENGTH_M = 1e-6


@dataclass(frozen=True, slots=True)
class StraightPath:
    """Straight line from ``start`` to ``end`` (paper Eq. 4), in the arm plane or in 3D.

    Parameters
    ----------
    start, end : tuple of float
        End points, m, in the riser-base frame: ``(x, y)`` in the arm's
        vertical plane (the paper's case), or ``(x, y, z)`` in 3D with ``y``
        along the berth and ``z`` up (see :mod:`loadarm.arm.slew`).

    Raises
    ------
    PathError
        If an end point is not finite or the two coincide.
    """

    start: tuple[float, ...]
    end: tuple[float, ...]

    def __post_init__(self) -> None:
        for name in ("start", "end"):
            p = getattr(self, name)
            if len(p) not in (2, 3) or not all(math.isfinite(float(v)) for v in p):
                raise PathError(f"path {name} must be two (x, y) or three (x, y, z) finite numbers in metres, "
                                f"got {p!r}")
            object.__setattr__(self, name, tuple(float(v) for v in p))
        if len(self.start) != len(self.end):
            raise PathError(f"path start {self.start} and end {self.end} must have the same number of coordinates")
        if self.length < MIN_LENGTH_M:
            raise PathError(f"path start {self.start} and end {self.end} coincide (length {self.length:.3g} m "
                            f"< {MIN_LENGTH_M:g} m): nothing to plan")

    @property
    def dim(self) -> int:
        """2 (arm plane) or 3."""
        return len(self.start)

    @property
    def length(self) -> float:
        """Path length ``L``, m."""
        return math.dist(self.start, self.end)

    @property
    def direction(self) -> tuple[float, ...]:
        """Unit tangent (``(cos(phi), sin(phi))`` in the plane)."""
        L = self.length
        return tuple((e - s) / L for s, e in zip(self.start, self.end))

    @property
    def slope(self) -> float:
        """Paper Eq. 4 slope ``(Yf - Y0) / (Xf - X0)``; ``inf`` for a vertical path."""
        dx = self.end[0] - self.start[0]
        return math.inf if dx == 0 else (self.end[1] - self.start[1]) / dx

    def __call__(self, s: np.ndarray | float, order: int = 0) -> np.ndarray:
        """Evaluate the path or its derivatives by arc length.

        Parameters
        ----------
        s : float or ndarray, shape (n,)
            Arc length from the start, m, in ``[0, length]``.
        order : {0, 1, 2}
            0: position; 1: ``dp/ds`` (unit tangent); 2: ``d2p/ds2`` (zero).

        Returns
        -------
        ndarray, shape (n, dim) (or (dim,) for scalar ``s``)
            Position in m, or the derivative.

        Raises
        ------
        PathError
            If ``s`` leaves ``[0, length]`` or ``order`` is not 0, 1 or 2.
        """
        s_arr = np.asarray(s, dtype=float)
        L = self.length
        if s_arr.size and (not np.all(np.isfinite(s_arr)) or s_arr.min() < -1e-9 * L or s_arr.max() > L * (1 + 1e-9)):
            raise PathError(f"arc length s must lie in [0, {L:.6g}] m, got values in "
                            f"[{np.nanmin(s_arr):.6g}, {np.nanmax(s_arr):.6g}]")
        d = np.array(self.direction)
        if order == 0:
            return np.asarray(self.start) + s_arr[..., None] * d
        if order == 1:
            return np.broadcast_to(d, s_arr.shape + (self.dim,)).copy()
        if order == 2:
            return np.zeros(s_arr.shape + (self.dim,))
        raise PathError(f"order must be 0, 1 or 2, got {order!r}")

    def distance_range(self, point: tuple[float, float]) -> tuple[float, float, float]:
        """Closest and farthest distance from ``point`` to the segment.

        Returns
        -------
        d_min, s_min, d_max : float
            Smallest distance, the arc length where it occurs, and the largest
            distance (always at an end point), m.
        """
        p0 = np.asarray(self.start)
        d = np.asarray(self.direction)
        q = np.asarray(point, dtype=float)
        s_star = float(np.clip(np.dot(q - p0, d), 0.0, self.length))
        d_min = float(np.linalg.norm(p0 + s_star * d - q))
        d_max = max(float(np.linalg.norm(p0 - q)), float(np.linalg.norm(np.asarray(self.end) - q)))
        return d_min, s_star, d_max

    def _first_crossing(self, centre: np.ndarray, radius: float, *, inward: bool) -> float:
        """Smallest s at which the path enters (``inward``) or leaves the circle; 0 if it starts there."""
        p0 = np.asarray(self.start) - centre
        d = np.asarray(self.direction)
        bq = float(np.dot(p0, d))
        cq = float(np.dot(p0, p0)) - radius * radius
        if (inward and cq <= 0) or (not inward and cq >= 0):
            return 0.0
        root = math.sqrt(max(bq * bq - cq, 0.0))
        s = -bq - root if inward else -bq + root
        return min(max(s, 0.0), self.length)

    def check_reachable(self, arm: Arm) -> None:
        """Refuse a path that leaves the annulus ``|b-c| <= r <= b+c`` anywhere.

        The test is exact (closest and farthest point of the segment from the
        riser top), not sampled. In 3D the reachable set is the spherical shell
        ``|b-c| <= |p - (0, 0, a)| <= b+c`` (the planar annulus swept by the
        slew), so the same test applies.

        Parameters
        ----------
        arm : Arm
            Arm lengths.

        Raises
        ------
        UnreachableError
            Naming the arc length and point where the path first leaves the
            workspace, and the reachable radii.
        """
        top = np.array(arm.top) if self.dim == 2 else np.array([0.0, 0.0, arm.a])
        d_min, s_min, d_max = self.distance_range(tuple(top))
        if d_max > arm.r_max + ROUNDOFF_M:
            # first s where the distance exceeds r_max
            s = self._first_crossing(top, arm.r_max, inward=False)
            pt = tuple(float(v) for v in self(s))
            raise UnreachableError(
                f"straight path {self.start} -> {self.end} leaves the reachable workspace at s = {s:.3f} m "
                f"of {self.length:.3f} m, point ({', '.join(f'{v:.3f}' for v in pt)}) m: farthest point is {d_max:.3f} m from "
                f"the riser top, reachable range [{arm.r_min:.3f}, {arm.r_max:.3f}] m",
                point=pt, r=d_max, r_min=arm.r_min, r_max=arm.r_max)
        if d_min < arm.r_min - ROUNDOFF_M or d_min <= 0.0:
            s = self._first_crossing(top, arm.r_min, inward=True) if arm.r_min > 0 else s_min
            pt = tuple(float(v) for v in self(s))
            raise UnreachableError(
                f"straight path {self.start} -> {self.end} passes too close to the riser top at s = {s:.3f} m "
                f"of {self.length:.3f} m, point ({', '.join(f'{v:.3f}' for v in pt)}) m: closest approach {d_min:.3f} m at "
                f"s = {s_min:.3f} m, reachable range [{arm.r_min:.3f}, {arm.r_max:.3f}] m",
                point=pt, r=d_min, r_min=arm.r_min, r_max=arm.r_max)
