"""Figures of a closed-loop run: the guidance timeline (modes, angles, distance to the nearest face, alarms).
matplotlib is imported when a figure is drawn.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from loadarm.figures import subplots
from loadarm.guidance.modes import MODES
from loadarm.vocab import alarm_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from matplotlib.figure import Figure

__all__ = ["timeline_figure", "run_timeline_figure"]


def timeline_figure(t, mode, beta, phi, distance, modes, *, alarms=None, title: str = "Guidance timeline",
                    beta_thresholds_deg=None, ttl=None) -> Figure:
    """Timeline of a guidance run: mode, elbow and slew angles, distance to the flange, alarms.

    Works from a run's signals or from the samples replayed out of the event log.

    Parameters
    ----------
    t : ndarray
        Time, s.
    mode : ndarray of int
        Mode index per sample (into ``modes``).
    beta, phi : ndarray
        Elbow and slew angles, rad.
    distance : ndarray
        Coupler-to-flange distance, m.
    modes : sequence of str
        Mode names.
    alarms : list of (float, str), optional
        Alarm events (time, label) drawn as vertical lines.
    title : str
        Figure title.
    beta_thresholds_deg : sequence of float, optional
        First, second and release angles to draw.
    ttl : ndarray, optional
        Forecast time to the nearest face of the envelope while connected, s (NaN: none in sight); adds a
        panel.

    Returns
    -------
    Figure
    """
    n = 4 if ttl is None else 5
    fig, ax = subplots(n, 1, figsize=(11, 9 + 2 * (n - 4)), sharex=True,
                           gridspec_kw={"height_ratios": [1.3] + [1] * (n - 1)})
    ax[0].step(t, mode, where="post")
    ax[0].set_yticks(range(len(modes)))
    ax[0].set_yticklabels(modes, fontsize=7)
    ax[0].set_ylabel("mode")
    ax[1].plot(t, np.degrees(beta), color="C0", label="beta")
    for v, name, ls in zip(beta_thresholds_deg or (), ("first", "second", "release"), ("--", "-.", ":")):
        ax[1].axhline(v, color="r", ls=ls, lw=0.9, label=f"{name} {v:g} deg")
    ax[1].set_ylabel("beta [deg]")
    ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0), borderaxespad=0)
    ax[2].plot(t, np.degrees(phi))
    ax[2].set_ylabel("slew [deg]")
    ax[3].plot(t, distance)
    ax[3].set_ylabel("coupler to flange [m]")
    if ttl is not None:
        ax[4].plot(t, ttl, color="0.2")
        ax[4].set_ylabel("time to a face [s]\n(within the forecast horizon)", fontsize=8)
        ax[4].set_ylim(bottom=0)
    ax[-1].set_xlabel("t [s]")
    # Alarm times as vertical lines, each named in the legend (labels written on the plot overlapped when
    # two alarms came seconds apart).
    styles = ("-", "--", "-.", ":")
    for a in ax:
        a.grid(alpha=0.3)
    for i, (ta, label) in enumerate(alarms or ()):
        for j, a in enumerate(ax):
            a.axvline(ta, color=f"C{(i % 8) + 1}", lw=0.9, ls=styles[i % 4],
                      label=f"{label} {ta:.1f} s" if j == 0 else None)
    if alarms:
        ax[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0), borderaxespad=0)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def run_timeline_figure(result) -> Figure:
    """:func:`timeline_figure` of a guidance run, with its alarms and beta thresholds.

    Parameters
    ----------
    result : loadarm.sim.result.RunResult
        The run (it carries its own thresholds).

    Returns
    -------
    Figure
    """

    s = result.signals
    alarms = [(t, alarm_label(data)) for t, _, kind, _, data in result.events if kind == "alarm"]
    thr = result.beta_thresholds_deg
    ttl = s.get("ttl")
    return timeline_figure(s["t"], s["mode"], s["beta"], s["phi"], s["distance"], MODES, alarms=alarms,
                           title=f"Guidance timeline: {result.name}", beta_thresholds_deg=thr or None,
                           ttl=ttl if ttl is not None and np.any(np.isfinite(ttl)) else None)
