"""The bank's figures drawn from the arm's mathematics (issue 31): the clearance between arms along their paths
and the swivel angles against their travel. Drawn without pyplot (:func:`loadarm.figures.subplots`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from loadarm.figures import subplots

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["clearance_figure", "swivel_figure"]


def clearance_figure(result) -> Figure:
    """Each pair of arms' clearance against time, the smallest marked, the required clearance dashed.

    Parameters
    ----------
    result : loadarm.arm.clearance.ClearanceResult

    Returns
    -------
    Figure
    """
    r = result
    fig, ax = subplots(figsize=(8, 4.2))
    for (i, j), c in zip(r.pairs, r.pair_minimum, strict=True):
        ax.plot(r.t, c, label=f"{r.names[i]} / {r.names[j]}")
    ax.axhline(r.required, color="k", ls="--", lw=1, label="required clearance")
    ax.plot([r.t[r.index]], [r.min_clearance], "o", mfc="none", color="r", ms=9, label="smallest")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("clearance [m]")
    ax.set_title(f"Clearance between arms: {r.where()}", fontsize=9)
    ax.legend(fontsize=8, loc="center right")
    ax.grid(alpha=0.3)
    return fig


def swivel_figure(t, angles, limits) -> Figure:
    """The three swivel angles against time, with their travel limits.

    Parameters
    ----------
    t : array_like
        Times, s.
    angles : loadarm.arm.swivel.SwivelAngles
        rad.
    limits : sequence of (float, float)
        Each swivel's travel, rad.

    Returns
    -------
    Figure
    """
    fig, axes = subplots(3, 1, figsize=(8, 6), sharex=True)
    for k, (ax, s, (lo, hi)) in enumerate(zip(axes, angles, limits, strict=True)):
        ax.plot(t, np.degrees(s))
        for v in (lo, hi):
            ax.axhline(np.degrees(v), color="r", ls="--", lw=1)
        ax.set_ylabel(f"swivel {k + 1} [deg]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    return fig
