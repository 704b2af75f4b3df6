"""Arm geometry: the immutable description of one loading arm in its vertical plane.

Coordinates (paper Fig. 3/5): origin at the riser base on the jetty deck, ``x``
horizontal towards the ship, ``y`` up. The inboard hinge (riser top) is at
``(0, a)``. All lengths are metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Arm", "Mounting"]


def _positive(name: str, value: float, hi: float = 100.0) -> float:
    v = float(value)
    if not np.isfinite(v) or not (0.0 < v <= hi):
        raise ValueError(f"{name} must be in (0, {hi:g}] m, got {value!r}")
    return v


@dataclass(frozen=True, slots=True)
class Arm:
    """Riser, inboard and outboard lengths (paper's a, b, c), metres.

    Parameters
    ----------
    a : float
        Riser length: jetty deck to the inboard hinge, m.
    b : float
        Inboard arm length, m.
    c : float
        Outboard arm length (elbow to coupler), m.
    """

    a: float
    b: float
    c: float

    def __post_init__(self) -> None:
        for name in ("a", "b", "c"):
            object.__setattr__(self, name, _positive(f"arm length {name}", getattr(self, name)))

    @property
    def r_min(self) -> float:
        """Smallest reachable distance from the riser top, ``|b - c|``, m."""
        return abs(self.b - self.c)

    @property
    def r_max(self) -> float:
        """Largest reachable distance from the riser top, ``b + c``, m."""
        return self.b + self.c

    @property
    def top(self) -> tuple[float, float]:
        """Riser top (inboard hinge) position ``(0, a)``, m."""
        return (0.0, self.a)

    def radius_at_beta(self, beta: float | np.ndarray) -> np.ndarray:
        """Coupler distance from the riser top for an elbow angle (paper Eq. 6).

        Parameters
        ----------
        beta : float or ndarray
            Inboard-outboard angle, rad.

        Returns
        -------
        ndarray
            ``sqrt(b^2 + c^2 - 2 b c cos(beta))``, m, same shape as ``beta``.
        """
        beta = np.asarray(beta, dtype=float)
        return np.sqrt(self.b**2 + self.c**2 - 2.0 * self.b * self.c * np.cos(beta))


@dataclass(frozen=True, slots=True)
class Mounting:
    """Cylinder mounting distances of paper Fig. 5, metres.

    Cylinder 1 joins a pin on the riser, ``a1`` below the inboard hinge, to a
    pin on the inboard arm, ``b1`` from that hinge. Cylinder 2 joins a pin on
    the inboard arm, ``b2`` from the elbow, to a pin on the outboard arm, ``c2``
    from the elbow.
    """

    a1: float
    b1: float
    b2: float
    c2: float

    def __post_init__(self) -> None:
        for name in ("a1", "b1", "b2", "c2"):
            object.__setattr__(self, name, _positive(f"mounting distance {name}", getattr(self, name), 20.0))
