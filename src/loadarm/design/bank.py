"""The bank's planned approaches checked for clearance along their whole path (issue 31, item 3).

Each arm's approach is its own straight-line plan (:func:`loadarm.design.trajectory.plan_approach_3d`) from its
stowed position to its flange at the manifold's design position; the bank's arms run them on one time base, all
at once or one after another in a given order (an arm waiting holds its stowed pose, an arm connected holds its
flange), and :func:`loadarm.arm.clearance.path_clearance` checks every pair of arms at every sample.
"""

from __future__ import annotations

import numpy as np

from loadarm.arm.clearance import ClearanceResult, path_clearance
from loadarm.design.trajectory import plan_approach_3d
from loadarm.params.bank import Bank

__all__ = ["bank_approaches", "check_bank_approaches"]


def bank_approaches(bank: Bank, *, order: tuple[str, ...] | None = None, timing: str = "smooth",
                    samples: int = 201) -> tuple[np.ndarray, list[np.ndarray]]:
    """Every arm's approach on one time base.

    Parameters
    ----------
    bank : Bank
    order : tuple of str, optional
        The arms, in the order they move one after another (default: all at once).
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
    if order is not None and sorted(order) != sorted(names):
        raise ValueError(f"order {list(order)} must name every arm of the bank once: {list(names)}")
    plans = []
    for i, model in enumerate(bank.models):
        p = bank.flange_position(i)
        plans.append(plan_approach_3d(model, target=(float(p[0]), float(p[1]), float(p[2])), timing=timing,
                                      samples=samples))
    starts = np.zeros(len(plans))
    if order is not None:
        clock = 0.0
        for name in order:
            i = names.index(name)
            starts[i] = clock
            clock += plans[i].duration
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
