"""Figures of the studies: operability over a metocean record, the synthetic weather against published
distributions, the flange predictors' error and calibration. matplotlib is imported when a figure is drawn."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.special import ndtr

from loadarm.guidance.moorings import LOST_SHARE
from loadarm.studies.metocean import WEATHER

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from matplotlib.figure import Figure

__all__ = ["hold_limit_figure", "rule_change_figure", "manifold_study_figure", "operability_figure", "weather_figure", "prediction_figure", "forecast_figure", "johannessen_wind_exceedance", "SEASTATE_MODELS",
           "seastate_hs_exceedance", "seastate_tp_exceedance"]


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


#: Published long-term models of the open sea's Hs and Tp (Haver & Nyhus 1986, "A wave climate description for
#: long term response calculation", Proc. OMAE'86: log-normal Hs up to ``hc``, Weibull above; Tp given Hs
#: log-normal), with the parameters of Sagli (2000), "Model uncertainty and simplified estimates of long term
#: extremes of hull girder loads in ships", PhD thesis NTNU, pp. 45-47, as tabulated in the WAFO toolbox
#: (``pdfseastate.m``). Per site: (Weibull scale, shape, location, hc, mean and variance of ln Hs),
#: (a1, a2, a3, b1, b2, b3, b4) of mean ln Tp = a1 + a2 ln(Hs + a3) (form 0) or a1 + a2 Hs^a3 (form 1) and
#: variance b1 + b2 exp(-b3 Hs^b4), and the form. Offshore sites (Ekofisk: central North Sea, 70 m of water;
#: northern North Sea), exposed to the whole sea: an upper bound for a berth's sea, not a berth's record.
SEASTATE_MODELS = {
    "Ekofisk": ((2.08, 1.37, 0.00, 2.65, 0.52, 0.67 ** 2), (1.00, 0.90, 0.25, 0.005, 0.10, 0.44, 1.00), 1),
    "northern North Sea": ((2.82, 1.55, 0.00, 3.27, 0.84, 0.61 ** 2), (1.59, 0.42, 2.00, 0.005, 0.09, 0.13, 1.34),
                           0),
}


def seastate_hs_exceedance(hs, site: str) -> np.ndarray:
    """The fraction of hours above ``hs`` of a published open-sea model (:data:`SEASTATE_MODELS`).

    Parameters
    ----------
    hs : array_like
        m.
    site : str
        A key of :data:`SEASTATE_MODELS`.

    Returns
    -------
    ndarray
    """
    (c1, c2, c3, hc, m1, s1), _, _ = SEASTATE_MODELS[site]
    h = np.asarray(hs, dtype=float)
    body = 1 - ndtr((np.log(np.maximum(h, 1e-9)) - m1) / np.sqrt(s1))
    return np.where(h <= hc, body, np.exp(-(np.maximum(h - c3, 0.0) / c1) ** c2))


def seastate_tp_exceedance(tp, site: str) -> np.ndarray:
    """The fraction of hours with a peak period above ``tp`` of a published open-sea model
    (:data:`SEASTATE_MODELS`): Tp given Hs integrated over Hs (trapezoids on 1-20 000 mm, 8000 points).

    Parameters
    ----------
    tp : array_like
        s.
    site : str

    Returns
    -------
    ndarray
    """
    _, (a1, a2, a3, b1, b2, b3, b4), form = SEASTATE_MODELS[site]
    h = np.linspace(0.001, 20.0, 8000)
    f = np.gradient(1 - seastate_hs_exceedance(h, site), h)
    mu = a1 + a2 * np.log(h + a3) if form == 0 else a1 + a2 * h ** a3
    sd = np.sqrt(b1 + b2 * np.exp(-b3 * h ** b4))
    t = np.atleast_1d(np.asarray(tp, dtype=float))
    return np.array([np.trapezoid(f * (1 - ndtr((np.log(x) - mu) / sd)), h) for x in t])


def johannessen_wind_exceedance(wind) -> np.ndarray:
    """The published long-term distribution of the 1-hour mean wind at 10 m of Johannessen, Meling & Haver
    (2001), "Joint distribution for wind and waves in the northern North Sea", Proc. ISOPE-2001 (journal version
    Int. J. Offshore Polar Eng. 12(1), 2002): Weibull, shape and scale as in
    :data:`loadarm.studies.metocean.WEATHER` (1.708, 8.426 m/s). Returns the fraction of hours above ``wind``.

    Parameters
    ----------
    wind : array_like
        m/s.

    Returns
    -------
    ndarray
    """
    return np.exp(-(np.asarray(wind, dtype=float) / WEATHER["wind_scale_ms"]) ** WEATHER["wind_shape"])


def weather_figure(ds) -> Figure:
    """The synthetic generator's marginals (:func:`loadarm.studies.metocean.synthetic_metocean`) against published
    distributions: the wind against Johannessen et al.'s (2001) Weibull (an exposed site); Hs (and its wind sea
    and swell apart) and Tp against the open sea's published models (:data:`SEASTATE_MODELS`, Ekofisk and the
    northern North Sea: offshore, an upper bound for a berth behind a coast).

    Parameters
    ----------
    ds : xarray.Dataset
        A record with the partitions (``windsea_hs_m``, ``swell_hs_m``).

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4.4))
    axw, axh, axt = fig.subplots(1, 3)
    wind, hs, tp = ds["wind_speed_ms"].values, ds["hs_m"].values, ds["tp_s"].values
    years = wind.size / 8766
    x = np.linspace(0, 30, 121)
    h = np.linspace(0, 8, 161)
    period = np.linspace(2, 24, 111)
    pw = johannessen_wind_exceedance(x)
    styles = {"Ekofisk": (0, (5, 2)), "northern North Sea": (0, (1, 1.5))}

    def exceed(v, grid):
        return np.array([np.mean(v > g) for g in grid])

    axw.semilogy(x, exceed(wind, x), color="0.2", label=f"synthetic ({years:.0f} years)")
    axw.semilogy(x, pw, "--", color="0.5", label="Weibull 1.708 / 8.426 m/s, northern\nNorth Sea "
                                                 "(Johannessen et al. 2001)")
    axw.set_xlabel("1-hour mean wind at 10 m [m/s]")
    axw.set_ylabel("fraction of hours exceeded")
    axw.set_ylim(1e-5, 1.2)
    axw.set_title(f"Wind: above 15 m/s {100 * np.mean(wind > 15):.1f} % of hours (published {100 * pw[60]:.1f} %)",
                  fontsize=10)
    axw.legend(fontsize=7)
    axh.semilogy(h, exceed(hs, h), color="0.2", label="synthetic sea")
    axh.semilogy(h, exceed(ds["windsea_hs_m"].values, h), ":", color="0.2", label="its wind sea")
    axh.semilogy(h, exceed(ds["swell_hs_m"].values, h), "-.", color="0.4", label="its swell")
    for site, ls in styles.items():
        axh.semilogy(h, seastate_hs_exceedance(h, site), ls=ls, color="tab:blue",
                     label=f"open sea, {site}\n(Haver & Nyhus model, Sagli 2000)")
    axh.set_xlabel("Hs [m]")
    axh.set_ylim(1e-5, 1.2)
    axh.set_title(f"Hs: above 1.5 m {100 * np.mean(hs > 1.5):.1f} % of hours (offshore: "
                  f"{100 * seastate_hs_exceedance(1.5, 'Ekofisk'):.0f}-"
                  f"{100 * seastate_hs_exceedance(1.5, 'northern North Sea'):.0f} %)", fontsize=10)
    axh.legend(fontsize=7, loc="upper right")
    swell = ds["swell_hs_m"].values > ds["windsea_hs_m"].values
    axt.semilogy(period, exceed(tp, period), color="0.2", label="synthetic sea")
    axt.semilogy(period, exceed(np.where(swell, tp, 0.0), period), "-.", color="0.4", label="  of which swell sets Tp")
    for site, ls in styles.items():
        axt.semilogy(period, seastate_tp_exceedance(period, site), ls=ls, color="tab:blue", label=f"open sea, {site}")
    axt.set_xlabel("Tp [s]")
    axt.set_ylim(1e-5, 1.2)
    axt.set_title(f"Tp: above 13 s {100 * np.mean(tp > 13):.0f} % of hours (offshore: "
                  f"{100 * seastate_tp_exceedance(13.0, 'Ekofisk')[0]:.0f}-"
                  f"{100 * seastate_tp_exceedance(13.0, 'northern North Sea')[0]:.0f} %)", fontsize=10)
    axt.legend(fontsize=7)
    fig.tight_layout()
    return fig


def prediction_figure(result) -> Figure:
    """The predictors on the hold-out records: the error of the mean against the horizon (with the climatology, the
    record's recent mean as the forecast) and the 95 % intervals' coverage against the horizon, with the band
    every claimed horizon must stay in.

    Parameters
    ----------
    result : loadarm.studies.prediction.PredictionCalibration

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    band = result.band
    fig = Figure(figsize=(12, 4.4))
    axe, axc = fig.subplots(1, 2)
    styles = {"online AR": "-", "model AR": "--"}
    axis_names = ("x, off the berth", "y, along it")
    for name, r in result.routes.items():
        h = np.arange(1, r.rmse.shape[0] + 1)
        for ax_i, (label, grey) in enumerate(zip(axis_names, ("0.1", "0.55"), strict=True)):
            axe.plot(h, r.rmse[:, ax_i], styles[name], color=grey, label=f"{name}, {label}")
            axc.plot(h, 100 * r.coverage[:, ax_i], styles[name], color=grey, label=f"{name}, {label}")
    clim = next(iter(result.routes.values())).climatology
    h = np.arange(1, clim.shape[0] + 1)
    axe.plot(h, clim[:, 0], ":", color="0.3", label="climatology (recent mean), x")
    axe.set_xlabel("horizon [s]")
    axe.set_ylabel("RMS error of the predicted 1-s mean [m]")
    axe.set_ylim(bottom=0)
    axe.legend(fontsize=7)
    axe.set_title(f"error, {result.to_dict()['records']} hold-out records", fontsize=9)
    axc.axhspan(100 * band[0], 100 * band[1], color="0.9", label=f"{100 * band[0]:.0f}-{100 * band[1]:.0f} %")
    axc.axhline(95, color="0.6", lw=0.8)
    axc.set_ylim(85, 100)
    axc.set_xlabel("horizon [s]")
    axc.set_ylabel("coverage of the 95 % interval [%]")
    axc.legend(fontsize=7, loc="lower left")
    axc.set_title("calibration (intervals claimed only)", fontsize=9)
    for a in (axe, axc):
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def forecast_figure(result) -> Figure:
    """Connect windows of a forecast: per hour the probability of staying connected without ESD-1 and that a
    loading starting then completes, the expected ESD-1 (bars), and below the members' median Hs and wind.

    Parameters
    ----------
    result : loadarm.studies.forecast.ForecastResult

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 6))
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    t = np.arange(result.times.size)
    top.bar(t, result.esd1 * 100, width=0.8, color="0.85", label="expected ESD-1 in the hour [x 100]")
    top.step(t, 100 * result.connected, where="mid", color="0.1", label="connected through the hour, no ESD-1")
    top.plot(t, 100 * result.completes, "--", color="0.45",
             label=f"a {result.loading_hours:g}-h loading starting then completes")
    top.set_ylim(0, 105)
    top.set_ylabel("probability [%]")
    top.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=3, frameon=False)
    n = len(result.members)
    top.set_title(f"{n} member{'s' if n > 1 else ''} x {result.seeds} wave realisation"
                  f"{'s' if result.seeds > 1 else ''}", fontsize=9)
    bottom.plot(t, result.hs, color="0.1", label="Hs (members' median) [m]")
    bottom.set_ylabel("Hs [m]")
    wind = bottom.twinx()
    wind.plot(t, result.wind, ":", color="0.4", label="wind [m/s]")
    wind.set_ylabel("wind [m/s]")
    ticks = t[:: max(1, t.size // 12)]
    bottom.set_xticks(ticks)
    bottom.set_xticklabels([str(np.datetime_as_string(result.times[i], unit="h")).replace("T", "\n") for i in ticks],
                           fontsize=7)
    lines = bottom.get_legend_handles_labels()[0] + wind.get_legend_handles_labels()[0]
    bottom.legend(lines, [h.get_label() for h in lines], fontsize=8, loc="upper left")
    for a in (top, bottom):
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def manifold_study_figure(times, names, utilisation: np.ndarray) -> Figure:
    """Each arm's largest load on its flange (as a share of its allowable) per sea state of a record.

    Parameters
    ----------
    times : sequence of str
        Each state's hour (ISO 8601).
    names : sequence of str
        The arms.
    utilisation : ndarray, shape (states, arms)
        The largest load / allowable of each arm in each state.

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 3.6))
    ax = fig.add_subplot()
    t = np.array(times, dtype="datetime64[s]")
    for i, name in enumerate(names):
        ax.plot(t, utilisation[:, i], lw=0.9, marker="." if len(t) < 200 else None, label=name)
    ax.axhline(1.0, color="r", ls="--", lw=1.0, label="allowable")
    ax.set_ylim(0.0, max(1.1, float(np.max(utilisation)) * 1.1))
    ax.set_ylabel("largest load / allowable")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=len(names) + 1)
    ax.set_title("Loads on the ship's flanges over the metocean record: each arm's worst per sea state", fontsize=9)
    fig.autofmt_xdate()
    fig.tight_layout()
    return fig


def watch_basis_figure(result) -> Figure:
    """The most lines slack at once per run (how many runs), against the watch's share
    (:class:`loadarm.studies.watch_basis.WatchBasis`)."""
    from matplotlib.figure import Figure

    most = np.array([r.most_slack for r in result.runs], dtype=int)
    n = max(result.lines, int(most.max(initial=0)))
    counts = np.bincount(most, minlength=n + 1)
    fig = Figure(figsize=(7.0, 3.6))
    ax = fig.add_subplot()
    ax.bar(np.arange(n + 1), counts, color="0.45")
    ax.axvline(LOST_SHARE * result.lines, color="tab:red", lw=1.2,
               label=f"lost: more than {LOST_SHARE:.3g} of {result.lines} lines")
    ax.set(xlabel="most lines slack at once in the run", ylabel="runs", title=f"{result.scenario}: {len(most)} runs")
    ax.legend(loc="upper right", fontsize=8)
    return fig


def hold_limit_figure(result) -> Figure:
    """The held calls' lengths (the share of calls held at least that long) and, per limit, the false ESD-1 it
    adds and how much later ESD-1 can still come.

    Parameters
    ----------
    result : loadarm.studies.hold_limit.HoldLimitBasis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    d = np.sort(result.durations())
    fig = Figure(figsize=(9.0, 3.6))
    ax, bx = fig.subplots(1, 2)
    if d.size:
        ax.step(d, 1.0 - np.arange(d.size) / d.size, where="post", color="0.3")
        ax.set_xscale("log")
    ax.axvline(result.limit_s, color="tab:red", lw=1.2, label=f"hold limit {result.limit_s:g} s")
    ax.set(xlabel="held call [s]", ylabel="share of calls held at least that long",
           title=f"{result.stored_file.rsplit('/', 1)[-1].removesuffix('_runs.jsonl')}: {d.size} calls in "
                 f"{len(result.reruns)} runs")
    ax.legend(loc="upper right", fontsize=8)
    lim = [e["limit_s"] for e in result.effects]
    bx.plot(lim, [len(e["added_false"]) for e in result.effects], "o-", color="0.3", label="false ESD-1 added")
    bx.plot(lim, [max(e["later"].values(), default=0.0) for e in result.effects], "s--", color="0.6",
            label="ESD-1 later by at most [s]")
    bx.axvline(result.limit_s, color="tab:red", lw=1.2)
    bx.set(xlabel="hold limit [s]", title="what a limit changes (the runs run again)")
    bx.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def rule_change_figure(result) -> Figure:
    """Each run whose ESD-1 a rule change moved: ESD-1 before against after (the diagonal: unchanged), the runs that
    reach a face apart from those that do not; a run without ESD-1 on one side is drawn at that axis's end.

    Parameters
    ----------
    result : loadarm.studies.hold_limit.RuleChange

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.4, 4.6))
    ax = fig.subplots()
    rows = np.array([[math.nan if a is None else a, math.nan if b is None else b, 0.0 if f is None else 1.0]
                     for _, a, b, f in result.shifts], dtype=float).reshape(-1, 3)
    top = float(np.nanmax(rows[:, :2])) * 1.05 if rows.size and np.isfinite(rows[:, :2]).any() else 1.0
    shown = np.where(np.isnan(rows[:, :2]), top, rows[:, :2]) if rows.size else rows[:, :2]
    for face, marker, colour, label in ((1.0, "s", "tab:red", "reaches a face"), (0.0, "o", "0.45", "reaches none")):
        sel = rows[:, 2] == face if rows.size else np.zeros(0, bool)
        if sel.any():
            ax.scatter(shown[sel, 0], shown[sel, 1], marker=marker, s=18, color=colour, label=label)
    ax.plot([0.0, top], [0.0, top], color="0.7", lw=1.0)
    ax.set(xlim=(0.0, top * 1.02), ylim=(0.0, top * 1.02), xlabel="ESD-1 before [s] (none: at the end)",
           ylabel="ESD-1 after [s] (none: at the end)")
    v = result._values()
    ax.set_title(f"{v['scenario']}: {v['changed']} of {v['runs']} runs changed\n{v['earlier']} earlier, "
                 f"{v['added']} added, {v['later']} later, {v['removed']} removed", fontsize=9)
    if rows.size:
        ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return fig
