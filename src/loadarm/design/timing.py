"""Timing laws: how fast the coupler runs along the path (paper Eq. 14 and better).

A timing law maps time ``t`` (s) to arc length ``s`` (m) and its first two
derivatives. It knows nothing about the arm; :mod:`loadarm.design.trajectory` joins
path, timing and kinematics.

``paper``
    Paper Eq. 14: the horizontal coordinate runs at constant speed,
    ``x = X0 + v_max t``. The speed *along* the path is then
    ``v_max / |cos(phi)|``, larger than ``v_max`` on any sloping path, and the
    speed jumps from 0 to that value at the start (unbounded acceleration).
    Undefined for a vertical path.
``optimal``
    Time-optimal under the coupler's and each cylinder's speed and
    acceleration limits, computed by toppra (:class:`ToppraTiming`, built by
    :func:`loadarm.design.trajectory.plan_approach`).
``smooth``
    Trapezoidal speed profile along the path: accelerate at ``a_max`` to
    ``v_max``, cruise, decelerate at ``a_max`` to rest. On a path too short to
    reach ``v_max`` the profile is a triangle with peak ``sqrt(L a_max)``. The
    path speed never exceeds ``v_max`` and the acceleration never exceeds
    ``a_max``; speed is continuous, acceleration is piecewise constant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from loadarm.design.path import StraightPath
from loadarm.errors import TimingError

__all__ = ["TimingLaw", "PaperTiming", "TrapezoidTiming", "ToppraTiming", "make_timing", "TIMING_LAWS"]

TIMING_LAWS = ("paper", "smooth", "optimal")


class TimingLaw(Protocol):
    """What every timing law offers."""

    @property
    def duration(self) -> float: ...  # pragma: no cover

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...  # pragma: no cover


def _times(t: np.ndarray | float, duration: float) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.size and (not np.all(np.isfinite(t)) or t.min() < 0 or t.max() > duration * (1 + 1e-12)):
        raise TimingError(f"time must lie in [0, {duration:.6g}] s, got values in [{np.nanmin(t):.6g}, "
                          f"{np.nanmax(t):.6g}] s")
    return np.minimum(t, duration)


@dataclass(frozen=True, slots=True)
class PaperTiming:
    """Paper Eq. 14: constant horizontal speed ``v_x``.

    Parameters
    ----------
    length : float
        Path length, m.
    dx : float
        Horizontal extent ``Xf - X0``, m (nonzero).
    v_x : float
        Horizontal speed, m/s.
    """

    length: float
    dx: float
    v_x: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.v_x) and self.v_x > 0):
            raise TimingError(f"max_speed must be > 0 m/s, got {self.v_x!r}")
        if abs(self.dx) < 1e-9 * max(self.length, 1.0):
            raise TimingError("the paper's timing law (Eq. 14, x = X0 + v t) is undefined for a vertical path "
                              "(Xf == X0); use --timing smooth")

    @property
    def duration(self) -> float:
        """``|Xf - X0| / v_max``, s."""
        return abs(self.dx) / self.v_x

    @property
    def path_speed(self) -> float:
        """Constant speed along the path, ``v_x L / |dx|``, m/s."""
        return self.length / self.duration

    def __call__(self, t: np.ndarray | float, order: int = 0) -> np.ndarray:
        """Arc length (order 0), path speed (1) or path acceleration (2) at times ``t`` (s)."""
        t = _times(t, self.duration)
        if order == 0:
            return self.path_speed * t
        if order == 1:
            return np.full(t.shape, self.path_speed)
        if order == 2:
            return np.zeros(t.shape)
        raise TimingError(f"order must be 0, 1 or 2, got {order!r}")


@dataclass(frozen=True, slots=True)
class TrapezoidTiming:
    """Trapezoidal (or triangular) speed profile along the path.

    Parameters
    ----------
    length : float
        Path length ``L``, m.
    v_max : float
        Speed limit, m/s.
    a_max : float
        Acceleration limit, m/s^2.
    """

    length: float
    v_max: float
    a_max: float

    def __post_init__(self) -> None:
        for name, val in (("length", self.length), ("max_speed", self.v_max), ("max_accel", self.a_max)):
            if not (math.isfinite(val) and val > 0):
                raise TimingError(f"{name} must be a finite number > 0, got {val!r}")

    @property
    def v_peak(self) -> float:
        """Highest speed reached, m/s (``v_max`` unless the path is short)."""
        return min(self.v_max, math.sqrt(self.length * self.a_max))

    @property
    def t_ramp(self) -> float:
        """Duration of each acceleration ramp, s."""
        return self.v_peak / self.a_max

    @property
    def duration(self) -> float:
        """Total time ``L / v_peak + v_peak / a_max``, s."""
        return self.length / self.v_peak + self.t_ramp

    def __call__(self, t: np.ndarray | float, order: int = 0) -> np.ndarray:
        """Arc length (order 0), speed (1) or acceleration (2) at times ``t`` (s)."""
        t = _times(t, self.duration)
        T, tr, v, a = self.duration, self.t_ramp, self.v_peak, self.a_max
        ramp_up = t < tr
        ramp_down = t > T - tr
        td = T - t
        if order == 0:
            return np.where(ramp_up, 0.5 * a * t * t,
                            np.where(ramp_down, self.length - 0.5 * a * td * td, 0.5 * a * tr * tr + v * (t - tr)))
        if order == 1:
            return np.where(ramp_up, a * t, np.where(ramp_down, a * td, v))
        if order == 2:
            return np.where(ramp_up, a, np.where(ramp_down, -a, 0.0))
        raise TimingError(f"order must be 0, 1 or 2, got {order!r}")


def make_timing(name: str, path: StraightPath, *, max_speed: float, max_accel: float) -> PaperTiming | TrapezoidTiming:
    """Build a timing law by name.

    Parameters
    ----------
    name : {'paper', 'smooth'}
        Which law (``optimal`` needs the arm: use
        :func:`loadarm.design.trajectory.plan_approach`).
    path : StraightPath
        The path to time.
    max_speed : float
        Speed limit, m/s (horizontal for ``paper``, along the path for ``smooth``).
    max_accel : float
        Acceleration limit along the path, m/s^2 (``smooth`` only).

    Returns
    -------
    PaperTiming or TrapezoidTiming

    Raises
    ------
    TimingError
        For an unknown name, bad limits, or the paper law on a vertical path.
    """
    if name == "paper":
        # Eq. 14 runs the horizontal coordinate at v_max; in 3D the horizontal distance is in the x-y plane
        dx = (path.end[0] - path.start[0] if path.dim == 2
              else math.hypot(path.end[0] - path.start[0], path.end[1] - path.start[1]))
        return PaperTiming(path.length, dx, max_speed)
    if name == "smooth":
        return TrapezoidTiming(path.length, max_speed, max_accel)
    if name == "optimal":
        raise TimingError("the optimal timing law needs the arm and cylinder limits: use "
                          "loadarm.design.trajectory.plan_approach(..., timing='optimal')")
    raise TimingError(f"timing must be one of {', '.join(TIMING_LAWS)}, got {name!r}")


@dataclass(frozen=True)
class ToppraTiming:
    """Time-optimal traversal under speed and acceleration limits (toppra, TOPP-RA).

    The geometric path handed to toppra is ``g(s) = (s, r_ac1(s), r_ac2(s))``:
    arc length plus both cylinder lengths. Box limits on ``g'`` and ``g''`` are
    then the coupler speed/acceleration limits and each cylinder's
    speed/acceleration limits. toppra guarantees them at its grid points only,
    so :meth:`build` re-checks a dense sampling and refines the grid until
    every limit holds between grid points too (within ``rel_tol``).

    Use :meth:`build`; the attributes are the result.

    Attributes
    ----------
    length : float
        Path length, m.
    duration : float
        Traversal time, s.
    limits : dict
        The limits used (m/s, m/s^2).
    gridpoints : int
        Grid size that passed the dense check.
    """

    length: float
    duration: float
    limits: dict
    gridpoints: int
    _traj: object

    @staticmethod
    def build(length: float, cylinder_lengths_of_s, *, v_max: float, a_max: float, v_cyl: tuple[float, float],
              a_cyl: tuple[float, float], extra: tuple = (), rel_tol: float = 2e-3,
              max_refinements: int = 4) -> "ToppraTiming":
        """Compute the time-optimal parameterisation.

        Parameters
        ----------
        length : float
            Path length, m.
        cylinder_lengths_of_s : callable
            ``s (n,) -> (r1 (n,), r2 (n,))`` in metres.
        v_max, a_max : float
            Coupler speed (m/s) and acceleration (m/s^2) limits.
        v_cyl, a_cyl : tuple of float
            Per-cylinder speed (m/s) and acceleration (m/s^2) limits.
        extra : tuple of (callable, float, float)
            More channels ``(f(s), speed limit, acceleration limit)``, e.g. the
            slew angle with the slew drive's limits.
        rel_tol : float
            Allowed relative excess of any limit on the dense check.
        max_refinements : int
            Grid doublings tried before giving up.

        Returns
        -------
        ToppraTiming

        Raises
        ------
        TimingError
            If toppra finds no feasible parameterisation or the dense check
            keeps failing.
        """
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint

        ta.setup_logging("WARNING")
        for name, val in (("max_speed", v_max), ("max_accel", a_max), ("cylinder speed limit", min(v_cyl)),
                          ("cylinder acceleration limit", min(a_cyl))):
            if not (math.isfinite(val) and val > 0):
                raise TimingError(f"{name} must be a finite number > 0, got {val!r}")
        ss = np.linspace(0.0, length, 400)
        r1, r2 = cylinder_lengths_of_s(ss)
        cols = [ss, r1, r2] + [np.asarray(f(ss), dtype=float) for f, _, _ in extra]
        path = ta.SplineInterpolator(ss / length, np.column_stack(cols))
        vmax = [v_max, v_cyl[0], v_cyl[1]] + [float(v) for _, v, _ in extra]
        amax = [a_max, a_cyl[0], a_cyl[1]] + [float(a) for _, _, a in extra]
        vlim = np.array([[-v, v] for v in vmax])
        alim = np.array([[-a, a] for a in amax])
        limits = {"v_max": v_max, "a_max": a_max, "v_cyl": tuple(v_cyl), "a_cyl": tuple(a_cyl)}
        n = 500
        worst = math.inf
        for _ in range(max_refinements + 1):
            inst = algo.TOPPRA([constraint.JointVelocityConstraint(vlim), constraint.JointAccelerationConstraint(alim)],
                               path, parametrizer="ParametrizeConstAccel", gridpoints=np.linspace(0.0, 1.0, n))
            traj = inst.compute_trajectory()
            if traj is None:
                raise TimingError("toppra found no feasible time parameterisation for these limits")
            t = np.linspace(0.0, traj.duration, 20001)
            v = np.abs(traj(t, 1))
            a = np.abs(traj(t, 2))
            worst = max(float(np.max(v / vlim[:, 1])), float(np.max(a / alim[:, 1])))
            if worst <= 1.0 + rel_tol:
                return ToppraTiming(length, float(traj.duration), limits, n, traj)
            n *= 2
        raise TimingError(f"toppra's parameterisation exceeds a limit by {100 * (worst - 1):.2f} % between grid "
                          f"points even with {n // 2} grid points")

    def __call__(self, t: np.ndarray | float, order: int = 0) -> np.ndarray:
        """Arc length (order 0), speed (1) or acceleration (2) at times ``t`` (s)."""
        t = _times(t, self.duration)
        if order not in (0, 1, 2):
            raise TimingError(f"order must be 0, 1 or 2, got {order!r}")
        out = np.asarray(self._traj(t, order))[..., 0]
        if order == 0:
            out = np.clip(out, 0.0, self.length)
        return out
