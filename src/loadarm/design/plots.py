"""Figures of the design: the envelope and the approach (the paper's Figs 4, 6, 8, 9 and 10), actuator loads, the
multibody check, sizing, the design check, alarm design and the surge. Degrees appear only here, on axis labels.
matplotlib is imported when a figure is drawn.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.envelope import zone_radii
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import elbow_position, forward, inverse_paper
from loadarm.figures import subplots
from loadarm.vocab import Severity

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from matplotlib.figure import Figure

    from loadarm.arm.model import ArmModel

__all__ = ["envelope_figure", "alpha_beta_figure", "angles_time_figure", "cylinders_figure", "voltages_figure",
           "timing_figure", "verification_figure", "residual_torque_figure", "loads_figure",
           "timing_comparison_figure", "sizing_figure", "plan3d_figure", "check_figure", "alarm_design_figure",
           "surge_figure", "manifold_check_figure", "manifold_record_figure", "swivel_envelope_figure"]


_SEVERITY_COLOURS = {Severity.NORMAL: "#cfe8cf", Severity.ESD1: "#ffe08a", Severity.SECOND: "#ffb366",
                     Severity.RELEASE: "#ff7f7f"}


def _draw_arm(ax, arm: Arm, alpha: float, beta: float, **kw) -> None:
    ex, ey = elbow_position(arm, alpha)
    px, py = forward(arm, alpha, beta)
    ax.plot([0, 0, float(ex), float(px)], [0, arm.a, float(ey), float(py)], "-o", ms=3, **kw)


def envelope_figure(model: ArmModel, plan=None, arm: Arm | None = None) -> Figure:
    """Operating envelope with alarm zones (paper Fig. 4).

    Draws the zones as annular bands around the riser top, the datasheet's
    flange box, the stored position and flange, riser, jetty and tide levels,
    and (if given) the approach path with arm snapshots.

    Parameters
    ----------
    model : ArmModel
        The installation.
    plan : Plan, optional
        An approach to overlay.
    arm : Arm, optional
        Arm to draw (default: the configured one).

    Returns
    -------
    Figure
    """
    from matplotlib.patches import Rectangle, Wedge

    arm = arm or model.arm
    alarms = model.alarms
    radii = zone_radii(arm, alarms)
    box = model.berth
    fig, ax = subplots(figsize=(11.5, 7.5))
    top = (0.0, arm.a)
    bands = [
        (radii["r_min"], radii["first"], Severity.NORMAL, f"< {math.degrees(model.alarms.first):g} deg"),
        (radii["first"], radii["second"], Severity.ESD1, f">= {math.degrees(model.alarms.first):g} deg"),
        (radii["second"], radii["release"], Severity.SECOND, f">= {math.degrees(model.alarms.second):g} deg"),
        (radii["release"], radii["r_max"], Severity.RELEASE, f">= {math.degrees(model.alarms.release):g} deg"),
    ]
    for r0, r1, sev, cond in bands:
        ax.add_patch(Wedge(top, r1, -120, 90, width=r1 - r0, facecolor=_SEVERITY_COLOURS[sev], edgecolor="grey",
                           lw=0.5, label=f"{sev.label} (beta {cond})", alpha=0.9))
    # jetty deck, face, berthing line, tides
    xmax = max(radii["r_max"] + 1.0, box.x_far + 2.0)
    ymin = min(box.y_low, box.ltl) - 3.0
    ax.fill_between([-2.0, box.jetty_face], [0, 0], [ymin, ymin], color="#b0a89a", zorder=1, label="jetty")
    ax.axvline(box.berthing_line, color="k", ls=":", lw=1)
    ax.text(box.berthing_line, ymin + 0.3, " berthing line", fontsize=8)
    for yv, name in ((box.htl, "HTL"), (box.ltl, "LTL")):
        ax.plot([box.jetty_face, xmax], [yv, yv], color="tab:blue", ls="--", lw=1)
        ax.text(xmax, yv, f" {name}", va="center", fontsize=8, color="tab:blue")
    ax.add_patch(Rectangle((box.x_near, box.y_low), box.x_far - box.x_near, box.y_high - box.y_low, fill=False,
                           ec="tab:blue", lw=1.5, ls="-", label="datasheet flange box", zorder=5))
    ax.plot([0, 0], [0, arm.a], color="k", lw=4, zorder=6, label="riser")
    sx, sy = model.approach.stored
    fx, fy = model.approach.flange
    ax.plot(sx, sy, "s", color="tab:green", ms=8, zorder=7, label=f"stored ({sx:g}, {sy:g})")
    ax.plot(fx, fy, "*", color="tab:red", ms=12, zorder=7, label=f"flange ({fx:g}, {fy:g})")
    if plan is not None:
        ax.plot(plan.x, plan.y, color="tab:red", lw=1.5, zorder=7, label="straight approach (Eq. 4)")
        for i in np.linspace(0, plan.t.size - 1, 5).astype(int):
            _draw_arm(ax, arm, float(plan.alpha[i]), float(plan.beta[i]), color="0.25", lw=1.2, zorder=8)
    ax.set_aspect("equal")
    ax.set_xlim(-3, xmax + 2)
    ax.set_ylim(ymin, arm.a + arm.b + 1.0)
    ax.set_xlabel("x from riser centre line [m]")
    ax.set_ylabel("y above jetty deck [m]")
    ax.set_title(f"Operating envelope (paper Fig. 4): a = {arm.a:g} m, b = {arm.b:.3g} m, c = {arm.c:.3g} m")
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, framealpha=0.9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def alpha_beta_figure(plans: dict) -> Figure:
    """Alpha against beta along the straight line (paper Fig. 6).

    Parameters
    ----------
    plans : dict of str to Plan
        Labelled plans (the curve is the same for every timing law).

    Returns
    -------
    Figure
    """
    fig, ax = subplots(figsize=(6, 4.5))
    for label, plan in plans.items():
        ax.plot(np.degrees(plan.beta), np.degrees(plan.alpha), label=label)
    ax.set_xlabel("beta [deg]")
    ax.set_ylabel("alpha [deg]")
    ax.set_title("alpha versus beta on the straight path (paper Fig. 6)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


def angles_time_figure(model: ArmModel, plan) -> Figure:
    """Alpha and beta against time, closed form (atan2) and paper Eqs 7-11 literally (paper Fig. 8).

    The paper's Fig. 8 overlays ADAMS on its equations; here the literal
    piecewise equations are the second route (multibody verification is a
    separate capability).

    Parameters
    ----------
    model : ArmModel
        The installation (for the arm lengths).
    plan : Plan
        The approach.

    Returns
    -------
    Figure
    """
    arm = model.arm
    qp = inverse_paper(arm, plan.x, plan.y)
    fig, ax = subplots(figsize=(7, 4.5))
    ax.plot(plan.t, np.degrees(plan.alpha), label="alpha, closed form")
    ax.plot(plan.t, np.degrees(plan.beta), label="beta, closed form")
    step = max(1, plan.t.size // 25)
    ax.plot(plan.t[::step], np.degrees(qp.alpha[::step]), "o", mfc="none", label="alpha, paper Eqs 7-11")
    ax.plot(plan.t[::step], np.degrees(qp.beta[::step]), "s", mfc="none", label="beta, paper Eqs 7-11")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle [deg]")
    ax.set_title(f"Joint angles, {plan.timing} timing (paper Fig. 8)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _same_curve(t1, y1, t2, y2) -> bool:
    """Whether two sampled curves would draw on top of each other (within 2 % of their extent)."""
    t1, y1, t2, y2 = (np.asarray(v, dtype=float) for v in (t1, y1, t2, y2))
    dur = max(float(np.ptp(t1)), float(np.ptp(t2)), 1e-12)
    if abs(t1[0] - t2[0]) > 5e-3 * dur or abs(t1[-1] - t2[-1]) > 5e-3 * dur:
        return False
    span = max(float(np.ptp(y1)), float(np.ptp(y2)), 1e-12)
    return bool(np.max(np.abs(np.interp(t1, t2, y2) - y1)) <= 2e-2 * span)


def _law_lines(ax, series: dict[str, tuple], quantity: str = "", style: str = "-") -> None:
    """Plot one curve per timing law so that every law stays visible.

    Each law gets its own colour, a line narrower than the one before it and, after the first, its own
    hollow marker every twelfth of the curve, so a curve lying on another still shows; a law whose curve
    coincides with an earlier one says so in the legend.

    Parameters
    ----------
    ax : Axes
        Where to draw.
    series : dict of str to (t, y)
        Curves by law name, in drawing order.
    quantity : str
        Prefix of the legend labels.
    style : str
        Line style shared by these curves.
    """
    drawn: list[tuple[str, tuple]] = []
    markers = ("", "s", "o", "^", "D")
    for i, (law, (t, y)) in enumerate(series.items()):
        same = [name for name, (t0, y0) in drawn if _same_curve(t0, y0, t, y)]
        label = f"{quantity}, {law}" if quantity else law
        if same:
            label += f" (on top of {same[0].split(':')[0]})"
        ax.plot(t, y, style, color=f"C{i}", lw=max(3.2 - 1.1 * i, 0.9), label=label, marker=markers[i % 5],
                markevery=max(1, len(t) // 12), markersize=6, fillstyle="none", markeredgewidth=1.2)
        drawn.append((law, (t, y)))


def _pair_figure(plans: dict, first: str, second: str, ylabel: str, title: str) -> Figure:
    """Two time series of every plan on one axis (solid: ``first``, dashed: ``second``)."""
    fig, ax = subplots(figsize=(7, 4.5))
    _law_lines(ax, {law: (p.t, getattr(p, first)) for law, p in plans.items()}, first, "-")
    _law_lines(ax, {law: (p.t, getattr(p, second)) for law, p in plans.items()}, second, "--")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def cylinders_figure(plans: dict) -> Figure:
    """Cylinder pin-to-pin lengths against time (paper Fig. 9).

    Parameters
    ----------
    plans : dict of str to Plan
        Labelled plans.

    Returns
    -------
    Figure
    """
    return _pair_figure(plans, "r_ac1", "r_ac2", "cylinder length [m]", "Cylinder lengths (paper Fig. 9, Eqs 12-13)")


def voltages_figure(plans: dict) -> Figure:
    """Proportional-valve voltages against time (paper Fig. 10).

    Parameters
    ----------
    plans : dict of str to Plan
        Labelled plans.

    Returns
    -------
    Figure
    """
    fig = _pair_figure(plans, "u1", "u2", "valve command [V] (+ = extension)",
                       "Valve voltages relative to the stored pose (paper Fig. 10)")
    fig.axes[0].axhline(0, color="k", lw=0.8)
    return fig


def timing_figure(plans: dict, max_speed: float) -> Figure:
    """Coupler speed along the path for each timing law, against the limit.

    Parameters
    ----------
    plans : dict of str to Plan
        Labelled plans.
    max_speed : float
        Speed limit drawn as a line, m/s.

    Returns
    -------
    Figure
    """
    fig, ax = subplots(figsize=(7, 4))
    _law_lines(ax, {law: (p.t, np.hypot(p.vx, p.vy)) for law, p in plans.items()}, "path speed", "-")
    _law_lines(ax, {law: (p.t, np.abs(p.vx)) for law, p in plans.items()}, "horizontal speed", ":")
    ax.axhline(max_speed, color="k", lw=1, ls="-.", label=f"max_speed {max_speed:g} m/s")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("speed [m/s]")
    ax.set_title(f"Coupler speed, {len(plans)} timing law{'s' if len(plans) > 1 else ''}: {', '.join(plans)}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def verification_figure(result) -> Figure:
    """Closed form against MuJoCo along the approach (paper Fig. 8 with a real multibody engine).

    Parameters
    ----------
    result : loadarm.design.multibody.VerificationResult
        Output of :func:`loadarm.design.multibody.verify_kinematics`.

    Returns
    -------
    Figure
    """
    r = result
    fig, (ax1, ax2, ax3) = subplots(1, 3, figsize=(14, 4.3))
    step = max(1, r.t.size // 30)
    for name, cf, mj in (("alpha", r.alpha_cf, r.alpha_mj), ("beta", r.beta_cf, r.beta_mj)):
        ax1.plot(r.t, np.degrees(cf), label=f"{name}, closed form")
        ax1.plot(r.t[::step], np.degrees(mj[::step]), "o", mfc="none", ms=5, label=f"{name}, MuJoCo")
    ax1.set_xlabel("t [s]")
    ax1.set_ylabel("angle [deg]")
    ax1.set_title("Joint angles")
    for name, cf, mj in (("r_ac1", r.r1_cf, r.r1_mj), ("r_ac2", r.r2_cf, r.r2_mj)):
        ax2.plot(r.t, cf, label=f"{name}, Eqs 12-13")
        ax2.plot(r.t[::step], mj[::step], "s", mfc="none", ms=5, label=f"{name}, MuJoCo tendon")
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("cylinder length [m]")
    ax2.set_title("Cylinder lengths")
    tiny = 1e-16
    ax3.semilogy(r.t, np.degrees(np.abs(r.alpha_mj - r.alpha_cf)) + tiny, label="|d alpha| [deg]")
    ax3.semilogy(r.t, np.degrees(np.abs(r.beta_mj - r.beta_cf)) + tiny, label="|d beta| [deg]")
    ax3.semilogy(r.t, 1e3 * np.abs(r.r1_mj - r.r1_cf) + tiny, label="|d r_ac1| [mm]")
    ax3.semilogy(r.t, 1e3 * np.abs(r.r2_mj - r.r2_cf) + tiny, label="|d r_ac2| [mm]")
    ax3.axhline(0.01, color="r", ls="--", lw=1, label="0.01 deg tolerance")
    ax3.axhline(0.1, color="m", ls=":", lw=1, label="0.1 mm tolerance")
    ax3.set_xlabel("t [s]")
    ax3.set_title("Differences")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Kinematic verification in MuJoCo (paper Fig. 8, ADAMS replaced by MuJoCo)")
    fig.tight_layout()
    return fig


def residual_torque_figure(result) -> Figure:
    """Residual static torque over the envelope with the balancing counterweights.

    Parameters
    ----------
    result : loadarm.design.balancing.BalanceResult
        Output of :func:`loadarm.design.balancing.balance_counterweights`.

    Returns
    -------
    Figure
    """
    g = result.grid
    fig, axes = subplots(1, 2, figsize=(12, 4.8))
    for ax, name, res in ((axes[0], "inboard joint (alpha)", result.residual_alpha),
                          (axes[1], "elbow joint (beta)", result.residual_beta)):
        worst = np.max(np.abs(res), axis=0) / 1e3
        sc = ax.scatter(g.x, g.y, c=worst, s=6, cmap="viridis", marker="s")
        fig.colorbar(sc, ax=ax, label="max |tau| over fill cases [kN m]")
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(f"{name}: max {worst.max():.1f} kN m")
        ax.grid(alpha=0.3)
    fig.suptitle(f"Residual static torque, counterweights {result.counterweight_inboard_kg:.0f} kg / "
                 f"{result.counterweight_outboard_kg:.0f} kg, fills {list(result.fills)}")
    fig.tight_layout()
    return fig


def loads_figure(loads: dict) -> Figure:
    """Cylinder forces and working pressures along the approach for each timing law.

    Parameters
    ----------
    loads : dict of str to loadarm.design.loads.ActuatorLoads
        Labelled loads.

    Returns
    -------
    Figure
    """
    fig, (ax1, ax2) = subplots(1, 2, figsize=(13, 4.3))
    for label, ld in loads.items():
        ax1.plot(ld.t, ld.force1 / 1e3, label=f"F1, {label}")
        ax1.plot(ld.t, ld.force2 / 1e3, "--", label=f"F2, {label}")
        ax2.plot(ld.t, ld.pressure1 / 1e5, label=f"p1, {label}")
        ax2.plot(ld.t, ld.pressure2 / 1e5, "--", label=f"p2, {label}")
    ax1.set_ylabel("cylinder force [kN] (+ = push)")
    ax2.set_ylabel("working-chamber pressure [bar]")
    for ax in (ax1, ax2):
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Actuator loads along the approach (gravity, counterweights, inertia)")
    fig.tight_layout()
    return fig


def timing_comparison_figure(results: dict) -> Figure:
    """Deviation from the straight line for each timing law.

    Parameters
    ----------
    results : dict of str to SimulationResult
        Runs by timing law.

    Returns
    -------
    Figure
    """
    fig, ax = subplots(figsize=(8, 4.2))
    _law_lines(ax, {f"{law}: max {r.metrics['max_deviation_mm']:.1f} mm": (r.signals["t"], r.deviation * 1e3)
                    for law, r in results.items()})
    ax.set_xlabel("t [s]")
    ax.set_ylabel("deviation from the line [mm]")
    ax.set_title("Coupler deviation from the straight line, by timing law")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def sizing_figure(result) -> Figure:
    """Paper Eq. 3 in the ``(b, c)`` plane: the first-alarm ellipse, the bounds, the local minima, the optimum.

    Shows why the optimum sits on a bound: ``b + c`` (dotted lines) is largest at ``b = c`` along the ellipse.

    Parameters
    ----------
    result : loadarm.design.sizing.SizingResult
        A sizing.

    Returns
    -------
    Figure
    """
    from matplotlib.patches import Rectangle

    fig, ax = subplots(figsize=(6.5, 6))
    psi = np.linspace(0.0, math.pi / 2, 721)
    rho = result.r_alarm / np.sqrt(1.0 - np.sin(2 * psi) * math.cos(result.beta_alarm))
    ax.plot(rho * np.cos(psi), rho * np.sin(psi), color="C0", label="Eq. 2 at the first-alarm angle")
    if result.bounds:
        (blo, bhi), (clo, chi) = result.bounds
        ax.add_patch(Rectangle((blo, clo), bhi - blo, chi - clo, fill=False, ec="k", lw=1.2, label="bounds"))
    top = float(np.max(rho)) * 1.05
    for total in sorted({round(b + c, 6) for b, c in result.local_minima} | {round(2 * top, 6)})[:4]:
        ax.plot([0, total], [total, 0], ":", color="grey", lw=0.8)
    for b, c in result.local_minima:
        ax.plot(b, c, "o", mfc="none", color="C1", ms=8)
    ax.plot([], [], "o", mfc="none", color="C1", label="local minima (b + c dotted)")
    ax.plot(result.inboard, result.outboard, "*", color="C3", ms=14,
            label=f"optimum b = {result.inboard:.4f}, c = {result.outboard:.4f} m")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_aspect("equal")
    ax.set_xlabel("inboard b [m]")
    ax.set_ylabel("outboard c [m]")
    ax.set_title(f"Arm sizing (Eq. 3): r_al = {result.r_alarm:.3f} m at {math.degrees(result.beta_alarm):g} deg")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plan3d_figure(plan) -> Figure:
    """A 3D approach against time: slew and joint angles, and both cylinder lengths.

    Parameters
    ----------
    plan : loadarm.design.trajectory.Plan3D
        The plan.

    Returns
    -------
    Figure
    """
    fig, (ax1, ax2) = subplots(1, 2, figsize=(12, 4.2))
    for name, v in (("slew", plan.phi), ("alpha", plan.alpha), ("beta", plan.beta)):
        ax1.plot(plan.t, np.degrees(v), label=name)
    ax1.set_ylabel("angle [deg]")
    ax2.plot(plan.t, plan.r_ac1, label="r_ac1")
    ax2.plot(plan.t, plan.r_ac2, "--", label="r_ac2")
    ax2.set_ylabel("cylinder length [m]")
    for ax in (ax1, ax2):
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"3D approach {plan.start} -> {plan.target}, {plan.timing} timing")
    fig.tight_layout()
    return fig


def check_figure(result) -> Figure:
    """The design check: per drift direction, the distance to the first face against the distance the design
    drift needs during the first alarm's lead, and where the first alarm fires.

    Parameters
    ----------
    result : loadarm.design.check.CheckResult
        The check.

    Returns
    -------
    Figure
    """
    rows = result.rows
    fig, ax = subplots(figsize=(9, 0.6 * len(rows) + 1.8))
    y = np.arange(len(rows))[::-1]
    for yi, r in zip(y, rows):
        bad = not r.ok
        ax.barh(yi, r.available, color="#ff7f7f" if bad else "0.82", edgecolor="0.3", height=0.6)
        start = max(r.available - r.needed, 0.0)
        ax.barh(yi, r.available - start, left=start, color="none", edgecolor="0.15", hatch="///", height=0.6)
        ax.plot([r.alarm_at] * 2, [yi - 0.35, yi + 0.35], color="0.1", lw=2)
        if r.angle_alarm is not None:          # past the bar: too late on its own (red, and the title says so)
            ax.plot(r.angle_alarm, yi, marker="v", color="#d62728" if r.angle_late else "0.1", ms=7)
        ax.text(r.available + 0.1, yi, f"{r.face or 'none'}  ({r.max_speed:.2f} m/s absorbed)", va="center",
                fontsize=8)
    ax.set_yticks(y)
    ax.set_yticklabels([r.direction for r in rows], fontsize=8)
    ax.set_xlabel("distance from the nominal flange [m]")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(facecolor="0.82", edgecolor="0.3", label="available: to the first face"),
                       Patch(facecolor="none", edgecolor="0.15", hatch="///",
                             label=f"needed: design drift during the {result.esd_lead:g} s first-alarm lead"),
                       Line2D([], [], color="0.1", lw=2, label="first alarm fires at the latest"),
                       Line2D([], [], color="0.1", marker="v", ls="none", label="customer's first-alarm angle"),
                       Line2D([], [], color="#d62728", marker="v", ls="none",
                              label="... past the bar: late on its own, the floor fires first")],
              fontsize=7, loc="lower right")
    ax.set_xlim(0, max(r.available for r in rows) * 1.45)
    ax.set_title(f"Design check: {'REFUSED' if result.verdict == 'refused' else result.verdict} "
                 f"(design drift {result.design_speed:g} m/s, {result.design_accel:g} m/s^2)")
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def alarm_design_figure(design) -> Figure:
    """The alarm design of an arm at a berth: side view of the flanging area, the intact drift allowance and
    each stage's zone (beta loci about the inboard hinge), and the break-out drift against time with the
    sequence's stages.

    Parameters
    ----------
    design : loadarm.design.alarm_design.AlarmDesign

    Returns
    -------
    Figure
    """
    from matplotlib.patches import Rectangle as _Rect

    arm = design.arm
    fig, (ax, bx) = subplots(1, 2, figsize=(12, 5.2), gridspec_kw={"width_ratios": [1.3, 1]})
    x0, x1, z0, z1 = design.flanging_area
    off = design.rows[0]
    ups = [r for r in design.rows if r.vector[2] > 0]
    downs = [r for r in design.rows if r.vector[2] < 0]
    au = ups[0].allowance_m if ups else 0.0
    ad = downs[0].allowance_m if downs else 0.0
    ax.add_patch(_Rect((x0, z0 - ad), x1 - x0 + off.allowance_m, z1 - z0 + au + ad, facecolor="none",
                       edgecolor="0.2", hatch="///", lw=0.8, label=f"drift allowance (intact, +{off.allowance_m:.2f} m "
                                                                    "off the berth)"))
    ax.add_patch(_Rect((x0, z0), x1 - x0, z1 - z0, facecolor="0.8", edgecolor="0.3", label="flanging area"))
    th = np.linspace(-math.pi / 2, math.pi / 3, 300)
    rec = design.recommended
    stages = (("first_beta_deg", "ESD-1", Severity.ESD1), ("second_beta_deg", "second alarm", Severity.SECOND),
              ("release_beta_deg", "ERS-2 release", Severity.RELEASE))
    for key, label, sev in stages:
        if rec.get(key) is None:
            continue
        r = float(arm.radius_at_beta(math.radians(rec[key])))
        ax.plot(r * np.cos(th), arm.a + r * np.sin(th), color=_SEVERITY_COLOURS[sev], lw=2,
                label=f"{label}: beta {rec[key]:.1f} deg")
    r = float(arm.radius_at_beta(design.joint_limits.beta[1]))
    ax.plot(r * np.cos(th), arm.a + r * np.sin(th), color="0.1", lw=1.2, ls="--",
            label=f"face: beta {math.degrees(design.joint_limits.beta[1]):.1f} deg (stroke end)")
    ax.plot([0, 0], [0, arm.a], color="k", lw=4)
    fx, fz = design.nominal_flange
    ax.plot(fx, fz, "*", color="0.1", ms=11, label=f"nominal flange ({fx:g}, {fz:g})")
    ax.set_aspect("equal")
    ax.set_xlim(-1, arm.r_max + 2)
    ax.set_ylim(min(z0 - ad, 0) - 3, arm.a + 0.7 * arm.r_max)
    ax.set_xlabel("x, off the berth from the riser [m]")
    ax.set_ylabel("z, above the jetty deck [m]")
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Alarm zones (side view, slew 0)")
    seq = design.sequence
    t, s = design.breakout_t, design.breakout_s
    bx.plot(t, off.allowance_m + s, color="0.2", lw=1.5, label="break-out drift from the allowance's edge")
    t_rel = seq["valves_worst_s"]          # the valves confirmed at the latest their timeout allows
    t_free = t_rel + seq["erc_release_time_s"] + seq["margin_s"]
    for tt, label, sev in ((0.0, "ESD-1", Severity.ESD1), (0.5 * t_rel, "second alarm", Severity.SECOND),
                           (t_rel, "ERS-2 (valves closed, at the latest)", Severity.RELEASE)):
        bx.axvline(tt, color=_SEVERITY_COLOURS[sev], lw=1.5, label=f"{label} at {tt:g} s")
    bx.axvline(t_free, color="0.4", ls=":", label=f"coupler free + margin at {t_free:g} s")
    bx.axvline(seq["esd_lead_s"], color="0.4", ls="-.", label=f"ESD-1 lead {seq['esd_lead_s']:g} s")
    bx.axhline(off.available_m, color="0.1", ls="--", label=f"face, {off.available_m:.2f} m from the worst corner")
    bx.set_xlim(-1.0, max(seq["esd_lead_s"] * 1.5, t_free * 1.5))
    bx.set_ylim(0, max(off.available_m, float(off.allowance_m + np.interp(bx.get_xlim()[1], t, s))) * 1.15)
    bx.set_xlabel("time since every line parted [s]")
    bx.set_ylabel("distance off the berth from the worst corner [m]")
    bx.legend(fontsize=7, loc="upper left")
    bx.set_title("Break-out (Choi et al. 2018 stages)" + ("" if design.ok else ": REFUSED"))
    fig.tight_layout()
    return fig


def surge_figure(result) -> Figure:
    """Pressure at the ERS valve against time, with the design pressure and Joukowsky's bound.

    Parameters
    ----------
    result : loadarm.design.surge.SurgeResult

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure as _Figure

    bar = 1e-5
    fig = _Figure(figsize=(10, 5.5), layout="constrained")
    ax = top = fig.add_subplot(1, 1, 1)
    t_end = result.delay + result.closure_time + 4.0 * result.round_trip
    if result.t.size:
        t_end = float(result.t[-1])
        ax.plot(result.t, result.valve_pressure * bar, color="0.1", lw=1.4, label="pressure at the valve (MOC)")
        ax.plot(result.peak_time, result.peak_pressure * bar, "o", color="tab:red", ms=5,
                label=f"peak {result.peak_pressure * bar:.2f} bar g at {result.peak_time:.2f} s")
        bx = top = ax.twinx()
        bx.plot(result.t, result.opening, color="0.55", lw=1.0, ls=":", label=f"valve opening ({result.law})")
        bx.set_ylim(0.0, 1.05)
        bx.set_ylabel("effective opening tau [-]")
        extra = bx.get_legend_handles_labels()
    else:
        ax.text(0.35, 0.65, "passed on Joukowsky's bound alone: no transient computed", transform=ax.transAxes,
                ha="center", va="center", fontsize=9, color="0.3")
        extra = ([], [])
    if np.isfinite(result.design_pressure):
        ax.axhline(result.design_pressure * bar, color="tab:red", ls="--",
                   label=f"design pressure {result.design_pressure * bar:.2f} bar g")
    ax.axhline(result.bound * bar, color="0.4", ls="-.",
               label=f"Joukowsky's bound {result.bound * bar:.2f} bar g (pump + rho a v)")
    ax.axhline(result.operating_pressure * bar, color="0.6", lw=0.8,
               label=f"steady flow {result.operating_pressure * bar:.2f} bar g")
    ax.axvspan(result.delay, result.delay + result.closure_time, color="0.92", zorder=0, label="valve closing")
    ax.set_xlim(0.0, t_end)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("pressure [bar g]")
    handles, labels = ax.get_legend_handles_labels()
    top.legend(handles + extra[0], labels + extra[1], fontsize=8, loc="center right")
    verdict = "passes" if result.ok else "REFUSED"
    ax.set_title(f"ERS valve closure in {result.closure_time:g} s ({result.route}): {verdict}")
    return fig


def manifold_check_figure(names, labels, utilisation: np.ndarray, static: np.ndarray) -> Figure:
    """Each arm's worst load on its flange as a share of the allowable, per load, with the static share.

    Parameters
    ----------
    names : sequence of str
        The arms.
    labels : sequence of str
        The loads.
    utilisation : ndarray, shape (arms, loads)
        Worst load over the check's cases / allowable.
    static : ndarray, shape (arms, loads)
        The design case, calm, no friction / allowable (signed).

    Returns
    -------
    Figure
    """
    fig, ax = subplots(figsize=(10, 4.2))
    n = len(names)
    width = 0.8 / n
    x = np.arange(len(labels))
    for i, name in enumerate(names):
        bars = ax.bar(x + (i - (n - 1) / 2) * width, utilisation[i], width, label=f"{name}: worst")
        ax.bar(x + (i - (n - 1) / 2) * width, np.abs(static[i]), width * 0.5, color="k", alpha=0.45,
               label="design case, calm, no friction" if i == 0 else None)
        ax.bar_label(bars, fmt="%.2f", fontsize=6)
    ax.axhline(1.0, color="r", lw=1.2, ls="--", label="allowable")
    ax.set_xticks(x, labels)
    ax.set_ylabel("load / allowable")
    ax.set_ylim(0, max(1.15, float(np.max(utilisation)) * 1.15))
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    ax.set_title("Loads on the ship's flanges: worst over the design case, the flange box's corners, the wind "
                 "and the friction", fontsize=9)
    fig.tight_layout()
    return fig


def manifold_record_figure(t: np.ndarray, names, labels, utilisation: np.ndarray) -> Figure:
    """Each arm's loads on its flange through a record of the ship's motion, as shares of the allowable.

    Parameters
    ----------
    t : ndarray, shape (n,)
        s.
    names, labels : sequence of str
        The arms and the loads.
    utilisation : ndarray, shape (arms, n, loads)
        Signed load / allowable.

    Returns
    -------
    Figure
    """
    fig, axes = subplots(len(labels), 1, figsize=(10, 1.6 * len(labels) + 0.8), sharex=True)
    for j, (ax, label) in enumerate(zip(axes, labels, strict=True)):
        for i, name in enumerate(names):
            ax.plot(t, utilisation[i, :, j], lw=0.8, label=name)
        for level in ((1.0,) if j == 3 else (-1.0, 1.0)):
            ax.axhline(level, color="r", lw=1.0, ls="--")
        if j == 3:
            ax.set_ylim(0.0, 1.1)
        ax.set_ylabel(label.replace(" ", "\n", 1), fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=len(names), loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("Loads on the ship's flanges through the moored ship's motion (load / allowable; allowable dashed)",
                 fontsize=9)
    fig.tight_layout()
    return fig


def bank_order_figure(order) -> Figure:
    """The bank's approach order: each arm's approach in time (coloured by its wave), and each pair's clearance
    along the schedule with the required clearance dashed.

    Parameters
    ----------
    order : loadarm.design.bank.BankOrder

    Returns
    -------
    Figure
    """
    r = order.clearance
    fig, (top, bottom) = subplots(2, 1, figsize=(8, 5.5), sharex=True, height_ratios=(1, 2))
    fig.set_layout_engine("constrained")
    for k, name in enumerate(order.names):
        wave = order.wave_of(name)
        top.barh(k, order.end_s[k] - order.start_s[k], left=order.start_s[k], color=f"C{wave}", height=0.6)
        top.text(order.end_s[k], k, f"  wave {wave + 1}", va="center", fontsize=8)
    top.set_yticks(range(len(order.names)), order.names)
    top.invert_yaxis()
    top.set_xlim(0.0, float(r.t[-1]) * 1.1)           # room for the last wave's label
    top.set_title(f"Approach order: {' -> '.join(' + '.join(w) for w in order.waves)}", fontsize=9)
    for (i, j), c in zip(r.pairs, r.pair_minimum, strict=True):
        bottom.plot(r.t, c, label=f"{r.names[i]} / {r.names[j]}")
    bottom.axhline(r.required, color="k", ls="--", lw=1, label="required clearance")
    bottom.plot([r.t[r.index]], [r.min_clearance], "o", mfc="none", color="r", ms=9, label="smallest")
    bottom.set_xlabel("t [s]")
    bottom.set_ylabel("clearance [m]")
    bottom.legend(fontsize=8, loc="center right")
    bottom.grid(alpha=0.3)
    return fig


def swivel_envelope_figure(env) -> Figure:
    """The swivels over the flanging area and the ship's motions: each arm's least swivel margin in each case (the
    manifold's corner, the ship's roll, pitch and yaw), the stop at zero dashed.

    Parameters
    ----------
    env : loadarm.design.bank.SwivelEnvelope

    Returns
    -------
    Figure
    """
    fig, ax = subplots(figsize=(8, 3.5))
    fig.set_layout_engine("constrained")
    least = np.degrees(np.nanmin(env.margins, axis=2))                 # (cases, arms)
    for i, name in enumerate(env.names):
        ax.plot(np.arange(least.shape[0]), least[:, i], ".", ms=5, label=name)
    ax.axhline(0.0, color="k", ls="--", lw=1, label="stop")
    ax.set_xlabel("case (the corners of the flanging area and of the ship's roll, pitch and yaw limits, then "
                  "points inside and the searched leasts)")
    ax.set_ylabel("least swivel margin [deg]")
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(least))) - 2.0)
    ax.legend(fontsize=8, ncols=len(env.names) + 1, loc="lower right")
    ax.grid(alpha=0.3)
    return fig
