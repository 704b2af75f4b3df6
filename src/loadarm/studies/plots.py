"""Figures of the studies: operability over a metocean record, the synthetic weather against published
distributions. matplotlib is imported when a figure is drawn."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from matplotlib.figure import Figure

__all__ = ["operability_figure", "weather_figure", "johannessen_wind_exceedance"]


def operability_figure(result) -> Figure:
    """Operability over a record: downtime per month (bars), over Hs and Tp (heat map), and the worst week in time
    (Hs with the hours down marked).

    Parameters
    ----------
    result : loadarm.studies.operability.OperabilityResult

    Returns
    -------
    Figure
    """
    import pandas as pd

    df = result.table.copy()
    t = pd.DatetimeIndex(df["time"])
    df.index = t
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 7.5))
    gs = fig.add_gridspec(2, 2, height_ratios=[1, 1])
    ax = fig.add_subplot(gs[0, 0])
    monthly = df["down"].groupby(t.to_period("M")).mean()
    ax.bar([str(m) for m in monthly.index], 100 * monthly.values, color="0.55", edgecolor="0.3")
    ax.set_ylabel("downtime [%]")
    ax.set_title(f"Downtime per month (overall {100 * df['down'].mean():.1f} %)")
    ax.tick_params(axis="x", rotation=60, labelsize=7)
    bx = fig.add_subplot(gs[0, 1])
    hs_bins = np.arange(0.0, max(4.5, float(df["hs_m"].max()) + 0.5), 0.5)
    tp_bins = np.arange(2.0, max(16.0, float(df["tp_s"].max()) + 1.0), 1.0)
    hi = np.digitize(df["hs_m"], hs_bins) - 1
    ti = np.digitize(df["tp_s"], tp_bins) - 1
    frac = np.full((hs_bins.size - 1, tp_bins.size - 1), np.nan)
    count = np.zeros_like(frac)
    for i in range(frac.shape[0]):
        for j in range(frac.shape[1]):
            k = (hi == i) & (ti == j)
            if k.any():
                frac[i, j] = df["down"].values[k].mean()
                count[i, j] = k.sum()
    im = bx.pcolormesh(tp_bins, hs_bins, 100 * frac, cmap="Greys", vmin=0, vmax=100, shading="flat")
    for i in range(frac.shape[0]):
        for j in range(frac.shape[1]):
            if count[i, j]:
                bx.text(0.5 * (tp_bins[j] + tp_bins[j + 1]), 0.5 * (hs_bins[i] + hs_bins[i + 1]), f"{int(count[i, j])}",
                        ha="center", va="center", fontsize=6, color="tab:red" if frac[i, j] > 0.5 else "0.1")
    fig.colorbar(im, ax=bx, label="downtime [%]")
    bx.set_xlabel("Tp [s]")
    bx.set_ylabel("Hs [m]")
    bx.set_title("Downtime over Hs and Tp (hours per cell)")
    cx = fig.add_subplot(gs[1, :])
    week = 168
    down = df["down"].values.astype(float)
    if len(df) > week:
        k = int(np.argmax(np.convolve(down, np.ones(week), "valid")))
    else:
        k = 0
    w = df.iloc[k:k + week]
    cx.plot(w.index, w["hs_m"], color="0.2", lw=1.2, label="Hs [m]")
    cx.plot(w.index, w["wind_speed_ms"] / 10, color="0.5", lw=1.0, ls="--", label="wind / 10 [m/s]")
    bad = w["down"].values
    cx.fill_between(w.index, 0, w["hs_m"].max() * 1.1, where=bad, color="tab:red", alpha=0.25, step="mid",
                    label="down (not connectable, or ESD-1 and worse)")
    cx.set_title("The worst week")
    cx.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def johannessen_wind_exceedance(wind) -> np.ndarray:
    """The published long-term distribution of the 1-hour mean wind at 10 m of Johannessen, Haver & Winterstein
    (2002), "Joint distribution for wind and waves in the northern North Sea", Int. J. Offshore Polar Eng.
    12(1): Weibull, shape 1.708, scale 8.426 m/s. Returns the fraction of hours above ``wind``.

    Parameters
    ----------
    wind : array_like
        m/s.

    Returns
    -------
    ndarray
    """
    return np.exp(-(np.asarray(wind, dtype=float) / 8.426) ** 1.708)


def weather_figure(ds) -> Figure:
    """The synthetic generator's marginals (:func:`loadarm.studies.metocean.synthetic_metocean`) against the
    published distribution of the wind (Johannessen et al. 2002, an exposed site); Hs with its wind sea and swell
    apart; Tp by the partition that sets it.

    Parameters
    ----------
    ds : xarray.Dataset
        A record with the partitions (``windsea_hs_m``, ``swell_hs_m``).

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4.2))
    axw, axh, axt = fig.subplots(1, 3)
    wind, hs, tp = ds["wind_speed_ms"].values, ds["hs_m"].values, ds["tp_s"].values
    years = wind.size / 8766
    x = np.linspace(0, 30, 121)
    h = np.linspace(0, 6, 121)
    pw = johannessen_wind_exceedance(x)

    def exceed(v, grid):
        return np.array([np.mean(v > g) for g in grid])

    axw.semilogy(x, exceed(wind, x), color="0.2", label=f"synthetic ({years:.0f} years)")
    axw.semilogy(x, pw, "--", color="0.5", label="Weibull 1.708 / 8.426 m/s\n(Johannessen et al. 2002)")
    axw.set_xlabel("1-hour mean wind at 10 m [m/s]")
    axw.set_ylabel("fraction of hours exceeded")
    axw.set_ylim(1e-5, 1.2)
    axw.set_title(f"Wind: above 15 m/s {100 * np.mean(wind > 15):.1f} % of hours (published {100 * pw[60]:.1f} %)")
    axw.legend(fontsize=8)
    axh.semilogy(h, exceed(hs, h), color="0.2", label="synthetic sea")
    axh.semilogy(h, exceed(ds["windsea_hs_m"].values, h), ":", color="0.2", label="its wind sea")
    axh.semilogy(h, exceed(ds["swell_hs_m"].values, h), "-.", color="0.4", label="its swell")
    axh.set_xlabel("Hs [m]")
    axh.set_ylim(1e-5, 1.2)
    axh.set_title(f"Hs: above 1.5 m {100 * np.mean(hs > 1.5):.1f} % of hours")
    axh.legend(fontsize=8)
    swell = ds["swell_hs_m"].values > ds["windsea_hs_m"].values
    bins = np.arange(1.0, 23.0, 0.5)
    axt.hist([tp[~swell], tp[swell]], bins=bins, stacked=True, color=["0.75", "0.4"],
             label=["wind sea sets Tp", "swell sets Tp"], density=True)
    axt.set_xlabel("Tp [s]")
    axt.set_ylabel("density")
    axt.set_title(f"Tp: above 13 s {100 * np.mean(tp > 13):.0f} % of hours")
    axt.legend(fontsize=8)
    fig.tight_layout()
    return fig
