"""Figures of the electro-hydraulic closed loop. matplotlib is imported when a figure is drawn."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from loadarm.figures import subplots

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from matplotlib.figure import Figure

__all__ = ["simulation_figure", "release_figure"]


def simulation_figure(result) -> Figure:
    """Closed-loop simulation of one approach: deviation, tracking, pressures, valves, pump.

    Parameters
    ----------
    result : loadarm.hydraulics.simulate.SimulationResult
        One run.

    Returns
    -------
    Figure
    """
    s = result.signals
    t = s["t"]
    fig, ax = subplots(3, 2, figsize=(13, 10), sharex=True)
    ax[0, 0].plot(t, result.deviation * 1e3)
    ax[0, 0].set_ylabel("deviation from the line [mm]")
    ax[0, 0].set_title(f"coupler off the straight line: max {result.metrics['max_deviation_mm']:.1f} mm, "
                       f"RMS {result.metrics['rms_deviation_mm']:.1f} mm")
    ax[0, 1].plot(t, (s["r1"] - s["r1_ref"]) * 1e3, label="cylinder 1")
    ax[0, 1].plot(t, (s["r2"] - s["r2_ref"]) * 1e3, label="cylinder 2")
    ax[0, 1].set_ylabel("tracking error [mm]")
    ax[0, 1].set_title("cylinder length error (actual - plan)")
    for key, style in (("pA1", "-"), ("pB1", "--"), ("pA2", "-"), ("pB2", "--")):
        ax[1, 0].plot(t, s[key] / 1e5, style, label=key)
    ax[1, 0].plot(t, s["ps"] / 1e5, "k", lw=1, label="supply")
    ax[1, 0].set_ylabel("pressure [bar]")
    ax[1, 0].set_title("chamber and supply pressures")
    ax[1, 1].plot(t, s["u1"], label="u1 [V]")
    ax[1, 1].plot(t, s["u2"], label="u2 [V]")
    ax[1, 1].plot(t, 10 * s["xv1"], ":", label="spool 1 [x10]")
    ax[1, 1].plot(t, 10 * s["xv2"], ":", label="spool 2 [x10]")
    ax[1, 1].set_ylabel("valve command [V]")
    ax[1, 1].set_title("valve commands and spool positions")
    ax[2, 0].plot(t, s["q_pump"] * 60e3, label="pump")
    ax[2, 0].plot(t, s["q_relief"] * 60e3, label="relief")
    ax[2, 0].set_ylabel("flow [L/min]")
    ax[2, 0].set_xlabel("t [s]")
    ax[2, 0].set_title("pump and relief flow")
    ax[2, 1].plot(t, s["ps"] * s["q_pump"] / 1e3)
    ax[2, 1].set_ylabel("pump power [kW]")
    ax[2, 1].set_xlabel("t [s]")
    ax[2, 1].set_title(f"hydraulic power, {result.metrics['pump_energy_kJ']:.0f} kJ in all")
    for a in ax.ravel():
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=7)
    fig.suptitle(f"Electro-hydraulic closed loop (paper Fig. 11), {result.timing} timing")
    fig.tight_layout()
    return fig


def release_figure(result) -> Figure:
    """The bank's release on its accumulators: their pressure and the oil delivered, and each arm's steps.

    Parameters
    ----------
    result : loadarm.hydraulics.bank_release.BankRelease

    Returns
    -------
    Figure
    """
    fig, ax = subplots(2, 1, figsize=(10, 7), sharex=True)
    ax[0].plot(result.t, result.pressure / 1e5, "C0", label="pressure")
    ax[0].axhline(result.min_pressure / 1e5, color="C3", ls="--", lw=1, label="minimum working pressure")
    ax[0].set_ylabel("accumulators [bar]")
    twin = ax[0].twinx()
    twin.plot(result.t, result.oil * 1e3, "C1", label="oil delivered")
    twin.set_ylabel("oil delivered [L]")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[0].set_title(f"the power unit's accumulators, pumps lost: {result.summary()['verdict']}")
    colours = ("C2", "C4", "C7")
    for i, name in enumerate(result.names):
        for j in range(3):
            a, b = result.start[i, j], result.end[i, j]
            if math.isfinite(a):
                b = b if math.isfinite(b) else float(result.t[-1])
                ax[1].barh(i, b - a, left=a, color=colours[j], edgecolor="k", lw=0.5,
                           label=("ERS valves", "coupler", "retraction")[j] if i == 0 else None)
    ax[1].set_yticks(range(len(result.names)), result.names)
    ax[1].set_xlabel("t [s]")
    ax[1].set_title("each arm's steps")
    ax[1].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig
