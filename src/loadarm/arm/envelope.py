"""Operating envelope and alarm zones (paper Section 2, Fig. 4).

The zones are bands of the elbow angle ``beta``, valued in the one severity
type :class:`loadarm.vocab.Severity`: normal up to the first-alarm angle, the
first alarm (ESD-1: stop transfer pumps, close the ERS valves) up to the
second-alarm angle, the second alarm up to the release angle, and release
(ERS-2: the coupler lets go) at or beyond it. Because ``r = sqrt(b^2 + c^2 - 2bc cos(beta))`` (Eq. 6) grows with
``beta``, each band is an annulus around the riser top.

The datasheet (paper Table 1) fixes where the ship's flange can be: between
the nearest reach ``A + B + C`` and the farthest ``A + B + D + E`` (with
drift), and between the lowest flange ``-(F + G) + H`` (smallest ship loaded
at low tide) and the highest ``-F + I`` (largest ship unloaded at high tide),
heights measured up from the jetty deck.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from loadarm.arm.alarms import AlarmAngles, beta_severity
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import solve_ik

__all__ = [
    "classify_point",
    "zone_radii",
    "BerthBox",
    "berth_box",
    "flanging_x_far",
]


def classify_point(arm: Arm, alarms: AlarmAngles, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
    """Severity of each coupler position (:data:`loadarm.vocab.UNREACHABLE` outside the annulus).

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alarms : AlarmAngles
        Thresholds.
    x, y : float or ndarray
        Coupler positions, m.

    Returns
    -------
    ndarray of int
        :class:`loadarm.vocab.Severity` values, broadcast shape of ``x`` and ``y``.
    """
    return beta_severity(solve_ik(arm, x, y).beta, alarms)     # NaN beta (unreachable) -> UNREACHABLE


def zone_radii(arm: Arm, alarms: AlarmAngles) -> dict[str, float]:
    """Distances from the riser top at which each zone begins (Eq. 6), m.

    Parameters
    ----------
    arm : Arm
        Arm lengths.
    alarms : AlarmAngles
        Thresholds.

    Returns
    -------
    dict
        ``r_min`` (folded, ``|b-c|``), ``first``, ``second``, ``release`` and
        ``r_max`` (stretched, ``b+c``).
    """
    return {
        "r_min": arm.r_min,
        "first": float(arm.radius_at_beta(alarms.first)),
        "second": float(arm.radius_at_beta(alarms.second)),
        "release": float(arm.radius_at_beta(alarms.release)),
        "r_max": arm.r_max,
    }


@dataclass(frozen=True, slots=True)
class BerthBox:
    """Where the ship's flange can be, from the datasheet (riser-base frame, m).

    Attributes
    ----------
    x_near, x_far : float
        Nearest (``A+B+C``) and farthest (``A+B+D+E``, with drift) horizontal
        flange distance from the riser centre line, m.
    y_low, y_high : float
        Lowest (``-(F+G)+H``) and highest (``-F+I``) flange height above the
        jetty deck, m.
    jetty_face, berthing_line : float
        ``A`` and ``A+B``, m.
    htl, ltl : float
        High and low tide levels ``-F`` and ``-(F+G)``, m.
    """

    x_near: float
    x_far: float
    y_low: float
    y_high: float
    jetty_face: float
    berthing_line: float
    htl: float
    ltl: float

    def corners(self) -> list[tuple[str, float, float]]:
        """The four corners of the flange box as ``(name, x, y)``."""
        return [
            ("nearest reach, highest flange", self.x_near, self.y_high),
            ("nearest reach, lowest flange", self.x_near, self.y_low),
            ("farthest reach, highest flange", self.x_far, self.y_high),
            ("farthest reach, lowest flange (first-alarm corner)", self.x_far, self.y_low),
        ]


def flanging_x_far(ds) -> float:
    """The flanging area's far edge, where the arm must still connect: the datasheet's ``A + B + D``, m (the box's
    ``x_far`` adds the drift allowance ``E`` beyond it).

    Parameters
    ----------
    ds : datasheet

    Returns
    -------
    float
    """
    return ds.A + ds.B + ds.D


def berth_box(ds) -> BerthBox:
    """Flange box implied by a datasheet (paper Table 1).

    Parameters
    ----------
    ds : datasheet
        The customer datasheet's distances A to I (the configuration section or the model's record).

    Returns
    -------
    BerthBox
        Its extreme flange positions.
    """
    return BerthBox(
        x_near=ds.A + ds.B + ds.C,
        x_far=ds.A + ds.B + ds.C + ds.D - ds.C + ds.E,   # the paper's Eq. 1 term, = A+B+D+E
        y_low=-(ds.F + ds.G - ds.H),                     # the paper's |Y| = F+G-H, below the deck
        y_high=-ds.F + ds.I,
        jetty_face=ds.A,
        berthing_line=ds.A + ds.B,
        htl=-ds.F,
        ltl=-(ds.F + ds.G),
    )
