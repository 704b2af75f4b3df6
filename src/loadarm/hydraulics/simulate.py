"""Run the closed loop on a planned approach and report what an engineer needs.

:func:`simulate_approach` packs the installation into the compiled
simulator's parameter vector, starts the arm at rest in the stored pose with
the chamber pressures that hold it, feeds the plan's cylinder lengths and
speeds as references at the control rate, and turns the logged signals into a
:class:`SimulationResult`: the coupler's deviation from the straight line,
arrival time and final error, tracking errors, pressures, valve saturation,
pump flow and power, and the energy balance.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.dynamics import G, chamber_pressures, lagrange_constants, mass_model, moment_arms, static_torques
from loadarm.arm.kinematics import forward
from loadarm.design.loads import actuator_loads
from loadarm.design.trajectory import Plan
from loadarm.errors import LoadarmError
from loadarm.hydraulics import circuit as plant
from loadarm.hydraulics.components import spool_discretisation, valve_coefficient
from loadarm.hydraulics.plots import simulation_figure
from loadarm.results import Metric, Result

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["SIMULATION_METRICS", "arrival_note", "SimulationError", "SimulationResult", "pack_parameters", "initial_state", "simulate_approach",
           "simulate_hold", "stable_substeps"]

#: Largest ``h * omega`` allowed for the explicit (semi-implicit Euler) part of the plant step. Symplectic
#: Euler is stable up to 2; 0.5 keeps the phase error of the fastest mode below 1 % per period.
STEP_FACTOR = 0.5


class SimulationError(LoadarmError, RuntimeError):
    """The simulation diverged or its parameters make it meaningless."""


@functools.lru_cache(maxsize=64)
def stable_substeps(model: ArmModel) -> int:
    """Plant steps per control step from a stability bound, not a constant.

    The plant step treats the chamber and supply pressures linearly implicitly and the spool exactly, so
    what limits the step is the explicit part: the arm's joints on the cylinders' springs, oil columns
    ``beta (Ap^2 + Aa^2) / V0`` (both chambers at their dead volume: stiffer than any real pose) in
    parallel with the end-stop spring. For the joint stiffness ``K = diag(k1 h1^2, k2 h2^2)`` and the
    arm's mass matrix ``M(beta)``, the fastest mode is the largest eigenvalue of ``M^-1 K``, taken over a
    grid of the whole joint range. The explicit dampers on each piston (end stop, viscous friction and the
    slope ``fc / v_s`` of the smoothed Coulomb friction) add ``h <= 1 / (c h_i^2 (M^-1)_ii)`` (no overshoot of
    the damped velocity). The chamber pressures are integrated linearly implicitly (stable for any step) but
    are accurate only while ``h lambda_p`` is small, ``lambda_p = beta / V0 * kv / sqrt(p_lam)`` being the
    fastest pressure build-up (a fully open land, laminar region). The step is ``h <= STEP_FACTOR / omega_max``,
    ``h <= STEP_FACTOR / lambda_p`` and within the damper bound.

    Parameters
    ----------
    model : ArmModel
        The installation (the bound is taken for the drained arm, the lightest and so the fastest, whatever
        the fill; the result is cached per installation).

    Returns
    -------
    int
        Substeps, at least 1.
    """
    cy, c = model.cylinders, model.controller
    mount = model.mount
    Ap, Aa = model.cylinder_area
    k_oil = cy.bulk_modulus * (Ap * Ap + Aa * Aa) / cy.dead_volume
    kk = k_oil + cy.end_stop_stiffness
    lc = lagrange_constants(mass_model(model, fill=0.0))       # drained: the lightest arm has the fastest modes
    a, b = np.meshgrid(np.linspace(0.0, math.pi, 181), np.linspace(0.02, math.pi - 0.02, 181))
    h1, h2 = moment_arms(mount, a, b)
    cb = np.cos(b)
    m11, m12, m22 = lc.k11 - 2.0 * lc.k_c * cb, -lc.k22 + lc.k_c * cb, lc.k22
    det = m11 * m22 - m12 * m12
    i11, i12, i22 = m22 / det, -m12 / det, m11 / det            # M^-1
    k1, k2 = kk * h1 * h1, kk * h2 * h2
    # eigenvalues of M^-1 K = [[i11 k1, i12 k2], [i12 k1, i22 k2]]
    tr = i11 * k1 + i22 * k2
    dt_ = (i11 * i22 - i12 * i12) * k1 * k2
    lam = 0.5 * (tr + np.sqrt(np.maximum(tr * tr - 4.0 * dt_, 0.0)))
    omega = float(np.sqrt(lam.max()))
    # explicit dampers on the piston: the end-stop damper, viscous friction, and the Coulomb friction's
    # tanh(v / v_s) whose slope at rest is fc / v_s (the stiffest of the three for the defaults)
    c_piston = cy.end_stop_damping + cy.viscous_friction + cy.coulomb_friction / cy.stribeck_velocity
    damp = float(c_piston * max((h1 * h1 * i11).max(), (h2 * h2 * i22).max()))
    # pressure build-up through a fully open land at rest (the laminar slope kv / sqrt(p_lam) is the orifice
    # law's steepest): integrated linearly implicitly, so always stable, but accurate only for h lambda_p small
    v = model.valve
    lam_p = cy.bulk_modulus / cy.dead_volume * valve_coefficient(v.nominal_flow, v.nominal_pressure_drop) \
        / math.sqrt(v.laminar_pressure)
    h_max = min(STEP_FACTOR / omega, STEP_FACTOR / lam_p, 1.0 / damp if damp > 0 else math.inf)
    return max(1, math.ceil((1.0 / c.rate) / h_max - 1e-9))


def pack_parameters(model: ArmModel, *, substeps: int | None = None, gains: dict | None = None,
                    fill: float | None = None) -> np.ndarray:
    """The compiled simulator's parameter vector, in SI units.

    Parameters
    ----------
    model : ArmModel
        The installation.
    substeps : int, optional
        Plant steps per control step (default ``controller.substeps``).
    gains : dict, optional
        Override controller gains: keys ``kp``, ``ki``, ``kd``.
    fill : float, optional
        Product fill of the mass model (default ``masses.fill``).

    Returns
    -------
    ndarray, shape (plant.N_PARAMS,)
    """
    c, p, v, cy, enc, act = model.controller, model.pump, model.valve, model.cylinders, model.encoder, model.actuators
    gains = dict(gains or {})
    unknown = set(gains) - {"kp", "ki", "kd"}
    if unknown:
        raise ValueError(f"unknown gain(s) {sorted(unknown)}; allowed: kp, ki, kd")
    if substeps is None:
        n_sub = stable_substeps(model) if c.substeps == "auto" else c.substeps
    else:
        n_sub = int(substeps)
    if not (1 <= n_sub <= 1000):
        raise ValueError(f"substeps must be in [1, 1000], got {substeps!r}")
    dt = 1.0 / c.rate
    h = dt / n_sub
    arm = model.arm
    mount = model.mount
    Ap, Aa = model.cylinder_area
    omega = 2 * math.pi * v.natural_frequency
    Phi, Gam = spool_discretisation(omega, v.damping, h)
    kv = valve_coefficient(v.nominal_flow, v.nominal_pressure_drop)
    P = np.full(plant.N_PARAMS, np.nan)   # a slot nobody fills stays NaN and is refused below
    vals = {
        plant.I_A1: mount.a1, plant.I_B1: mount.b1, plant.I_B2: mount.b2, plant.I_C2: mount.c2,
        plant.I_RISER: arm.a, plant.I_BIN: arm.b, plant.I_COUT: arm.c, plant.I_AP: Ap, plant.I_AA: Aa,
        plant.I_BETA: cy.bulk_modulus, plant.I_V0: cy.dead_volume, plant.I_BVISC: cy.viscous_friction,
        plant.I_FC: cy.coulomb_friction, plant.I_VS: cy.stribeck_velocity, plant.I_CLEAK: cy.leakage,
        plant.I_LMIN1: cy.length_range_1[0], plant.I_STROKE1: cy.length_range_1[1] - cy.length_range_1[0],
        plant.I_LMIN2: cy.length_range_2[0], plant.I_STROKE2: cy.length_range_2[1] - cy.length_range_2[0],
        plant.I_KSTOP: cy.end_stop_stiffness, plant.I_CSTOP: cy.end_stop_damping,
        plant.I_PCOMP: p.compensator_pressure, plant.I_PBAND: p.regulation_band, plant.I_QMAX: p.max_flow,
        plant.I_PRELIEF: p.relief_pressure, plant.I_RBAND: p.relief_band, plant.I_VSUP: p.supply_volume,
        plant.I_PT: cy.return_pressure, plant.I_KV: kv, plant.I_OVERLAP: v.overlap, plant.I_PLAM: v.laminar_pressure,
        plant.I_UMAX: act.valve_range_V, plant.I_RES: enc.resolution,
        plant.I_KP: gains.get("kp", c.kp), plant.I_KI: gains.get("ki", c.ki), plant.I_KD: gains.get("kd", c.kd),
        plant.I_TD: c.derivative_filter, plant.I_ILIM: c.integral_limit, plant.I_FF: {"none": 0.0, "nominal": 1.0, "model": 2.0}[c.feedforward],
        # feed-forward: volts per m/s at the rated drop, piston side extending, annulus side retracting
        plant.I_KFF_EXT: act.valve_range_V * Ap / v.nominal_flow,
        plant.I_KFF_RET: act.valve_range_V * Aa / v.nominal_flow,
        plant.I_G: G, plant.I_PHI00: Phi[0, 0], plant.I_PHI01: Phi[0, 1], plant.I_PHI10: Phi[1, 0],
        plant.I_PHI11: Phi[1, 1], plant.I_GAM0: Gam[0], plant.I_GAM1: Gam[1], plant.I_DT: dt, plant.I_H: h,
        plant.I_OMEGA2: omega ** 2, plant.I_TWOZW: 2 * v.damping * omega,
    }
    k = lagrange_constants(mass_model(model, fill=fill))
    vals[plant.I_FELIM] = c.following_error_limit
    vals.update({plant.I_K11: k.k11, plant.I_K22: k.k22, plant.I_KC: k.k_c, plant.I_GA: k.g_a, plant.I_GAB: k.g_ab})
    for k, val in vals.items():
        P[k] = val
    if not np.all(np.isfinite(P)):  # pragma: no cover - config validation and the index test prevent this
        missing = [int(i) for i in np.flatnonzero(~np.isfinite(P))]
        raise SimulationError(f"simulation parameter slot(s) {missing} not filled or not finite")
    return P


def initial_state(model: ArmModel, alpha: float, beta: float, *, fill: float | None = None) -> np.ndarray:
    """Arm at rest at ``(alpha, beta)``, held by its cylinders, spools centred, supply at the compensator.

    Each cylinder's chamber pressures are those that produce the static
    holding force (the other chamber at return pressure).

    Parameters
    ----------
    model : ArmModel
        The installation.
    alpha, beta : float
        Joint angles, rad.
    fill : float, optional
        Product fill.

    Returns
    -------
    ndarray, shape (13,)
    """
    mm = mass_model(model, fill=fill)
    ta, tb = static_torques(mm, alpha, beta)
    h1, h2 = (float(v) for v in moment_arms(model.mount, alpha, beta))
    cy = model.cylinders
    y = np.zeros(13)
    y[0], y[1] = alpha, beta
    for i, (tau, h) in enumerate(((ta, h1), (tb, h2))):
        if abs(h) < 1e-6:
            raise SimulationError(f"cylinder {i + 1} has no moment arm in the start pose (it cannot hold the arm)")
        pA, pB = chamber_pressures(float(tau) / h, cy.bore, cy.rod, cy.return_pressure)
        y[4 + 2 * i], y[5 + 2 * i] = float(pA), float(pB)
    y[12] = model.pump.compensator_pressure
    return y


#: The headline numbers of a closed-loop run, declared once: the CLI, the report and the JSON use these.
SIMULATION_METRICS = (
    Metric("timing", "timing law", short="timing"),
    Metric("plan_duration_s", "plan duration", "s", ".2f", short="T"),
    Metric("arrival_time_s", "first time within the arrival tolerance", "s", ".2f", short="arrive", none="never"),
    Metric("arrival_tolerance_mm", "arrival tolerance", "mm", "g"),
    Metric("final_position_error_mm", "position error at the end of the run", "mm", ".2f", short="final"),
    Metric("max_deviation_mm", "max deviation from the line", "mm", ".1f", short="dev max"),
    Metric("rms_deviation_mm", "RMS deviation from the line", "mm", ".1f", short="dev RMS"),
    Metric("max_tracking_error_mm", "cylinder tracking error (max, 1 / 2)", "mm", ".2f"),
    Metric("max_chamber_pressure_bar", "max chamber pressure", "bar", ".1f", short="p max"),
    Metric("min_supply_pressure_bar", "min supply pressure", "bar", ".1f"),
    Metric("valve_saturation_s", "valve saturation (1 / 2)", "s", ".2f"),
    Metric("peak_pump_flow_L_min", "peak pump flow", "L/min", ".1f", short="pump peak"),
    Metric("mean_pump_flow_L_min", "mean pump flow", "L/min", ".1f"),
    Metric("peak_pump_power_kW", "peak pump power", "kW", ".2f"),
    Metric("pump_energy_kJ", "pump energy", "kJ", ".0f", short="energy"),
    Metric("energy_balance_error_pct", "energy balance error", "%", ".3f"),
)




def arrival_note(tolerance_mm: float) -> str:
    """What "arrive" and "final" mean, printed under every table that shows the pair (found: "arrive 67.85 s"
    beside "final 44.57 mm" read as a contradiction).

    Parameters
    ----------
    tolerance_mm : float
        The arrival tolerance (``controller.arrival_tolerance``), mm.

    Returns
    -------
    str
        Two lines.
    """
    return (f"arrive: the first time within {tolerance_mm:g} mm of the flange (the arrival tolerance);\n"
            "final: the distance from the flange when the run ends (the plan, then settling)")


@dataclass(frozen=True)
class SimulationResult(Result):
    """Logged signals and the headline numbers of one closed-loop run.

    Attributes
    ----------
    timing : str
        Timing law of the plan.
    signals : dict of str to ndarray
        Every logged signal (see ``plant.SIGNALS``), SI units.
    x, y : ndarray
        Coupler position, m.
    deviation : ndarray
        Signed distance of the coupler from the planned straight line, m.
    energy : dict of str to float
        Energy accumulators, J (see ``plant.ENERGIES``), plus ``mechanical``
        (change of the arm's kinetic plus potential energy) and ``balance_error``.
    metrics : dict
        Headline numbers (see :meth:`summary`).
    """

    timing: str
    signals: dict
    x: np.ndarray
    y: np.ndarray
    deviation: np.ndarray
    energy: dict
    metrics: dict

    METRICS = SIMULATION_METRICS

    def _values(self) -> dict:
        return dict(self.metrics)

    def _figure(self):

        return simulation_figure(self)


def _mech_energy(model, fill, a, b, ad, bd):
    """Kinetic plus potential energy of the arm, J (from the mass model, independent of the loop)."""
    mm = mass_model(model, fill=fill)
    arm = mm.arm
    ey = arm.a + arm.b * math.cos(a)
    exd, eyd = arm.b * math.cos(a) * ad, -arm.b * math.sin(a) * ad
    e = 0.0
    for l in mm.lumps:
        # link angle and rate, and the height and velocity of the link's hinge
        if l.link == "inboard":
            psi, w, by, bxd, byd = a, ad, arm.a, 0.0, 0.0
        elif l.link == "outboard":
            psi, w, by, bxd, byd = a - b + math.pi, ad - bd, ey, exd, eyd
        else:
            psi, w, by, bxd, byd = a - b, ad - bd, arm.a, 0.0, 0.0
        y = by + l.offset * math.cos(psi)
        vx = bxd + l.offset * math.cos(psi) * w
        vy = byd - l.offset * math.sin(psi) * w
        e += 0.5 * l.mass * (vx * vx + vy * vy) + 0.5 * l.inertia * w * w + G * l.mass * y
    return e


def reference_signals(model: ArmModel, plan: Plan, n_steps: int, fill: float | None):
    """Cylinder length, speed and force references at every control step (held after the plan ends)."""

    dt = 1.0 / model.controller.rate
    tk = np.arange(n_steps + 1) * dt
    tp = np.minimum(tk, plan.duration)
    ref = np.vstack([np.interp(tp, plan.t, plan.r_ac1), np.interp(tp, plan.t, plan.r_ac2)])
    vref = np.vstack([np.interp(tp, plan.t, plan.v_ac1), np.interp(tp, plan.t, plan.v_ac2)])
    vref[:, tk > plan.duration] = 0.0
    ld = actuator_loads(model, plan, fill=fill)
    fref = np.vstack([np.interp(tp, plan.t, ld.force1), np.interp(tp, plan.t, ld.force2)])
    return ref, vref, fref


def simulate_approach(model: ArmModel, plan: Plan, *, fill: float | None = None, substeps: int | None = None,
                      gains: dict | None = None, log_rate: float = 100.0) -> SimulationResult:
    """Simulate the electro-hydraulic closed loop driving the arm along a plan.

    Parameters
    ----------
    model : ArmModel
        Arm, masses, cylinders, pump, valve, encoder and controller.
    plan : Plan
        The approach (its cylinder lengths and speeds are the references).
    fill : float, optional
        Product fill (default ``masses.fill``).
    substeps : int, optional
        Plant steps per control step (default ``controller.substeps``).
    gains : dict, optional
        Override ``kp``, ``ki``, ``kd``.
    log_rate : float
        Logging rate, Hz (a divisor of the control rate is used).

    Returns
    -------
    SimulationResult

    Raises
    ------
    SimulationError
        If the simulation diverges (bad gains, impossible parameters): the
        message names the time and the signal, and no NaN-filled result is
        returned.
    """
    c = model.controller
    P = pack_parameters(model, substeps=substeps, gains=gains, fill=fill)
    dt = P[plant.I_DT]
    n_plan = int(math.ceil(plan.duration / dt))
    n_steps = n_plan + int(round(c.settle_time / dt))
    ref, vref, fref = reference_signals(model, plan, n_steps, fill)
    y0 = initial_state(model, float(plan.alpha[0]), float(plan.beta[0]), fill=fill)
    log_every = max(1, int(round(c.rate / log_rate)))
    log, energy, c_end = plant.simulate_loop(P, ref, vref, fref, y0, n_steps,
                                              int(P[plant.I_DT] / P[plant.I_H] + 0.5), log_every)
    if c_end[plant.C_FAIL] != 0:
        raise SimulationError(
            f"simulation stopped at t = {c_end[plant.C_FAIL_T]:.3f} s: {plant.fail_reason(int(c_end[plant.C_FAIL]))}; the loop is unstable "
            "or cannot follow the plan: check the controller gains (kp, ki, kd), the valve, pump and cylinder "
            "sizes, or raise controller.substeps")
    n = int(c_end[plant.C_NLOG])
    sig = {name: log[:n, j].copy() for j, name in enumerate(plant.SIGNALS)}
    arm = model.arm
    x, y = forward(arm, sig["alpha"], sig["beta"])
    # deviation from the planned straight line (signed, left of the direction of travel positive)
    (x0, y0p), (x1, y1) = plan.start, plan.target
    L = math.hypot(x1 - x0, y1 - y0p)
    ux, uy = (x1 - x0) / L, (y1 - y0p) / L
    dev = (x - x0) * (-uy) + (y - y0p) * ux
    dist = np.hypot(x - x1, y - y1)
    arrived = np.flatnonzero(dist <= c.arrival_tolerance)
    arrival = float(sig["t"][arrived[0]]) if arrived.size else None
    e1 = sig["r1"] - sig["r1_ref"]
    e2 = sig["r2"] - sig["r2_ref"]
    ps = sig["ps"]
    p_pump = ps * sig["q_pump"]
    e_mech = (_mech_energy(model, fill, sig["alpha"][-1], sig["beta"][-1], sig["alpha_dot"][-1], sig["beta_dot"][-1])
              - _mech_energy(model, fill, *y0[:4]))
    en = dict(zip(plant.ENERGIES, (float(v) for v in energy)))
    en["mechanical"] = e_mech
    spent = (en["relief"] + en["valve"] + en["tank"] + en["leakage"] + en["compression"] + en["friction"]
             + en["end_stop"] + en["mechanical"])
    en["balance_error"] = en["pump"] - spent
    pmax = max(float(np.max(sig[k])) for k in ("pA1", "pB1", "pA2", "pB2"))
    metrics = {
        "timing": plan.timing,
        "plan_duration_s": plan.duration,
        "simulated_s": float(sig["t"][-1]),
        "arrival_time_s": arrival,
        "arrival_tolerance_mm": c.arrival_tolerance * 1e3,
        "final_position_error_mm": float(dist[-1] * 1e3),
        "max_deviation_mm": float(np.max(np.abs(dev)) * 1e3),
        "rms_deviation_mm": float(np.sqrt(np.mean(dev ** 2)) * 1e3),
        "max_tracking_error_mm": [float(np.max(np.abs(e1)) * 1e3), float(np.max(np.abs(e2)) * 1e3)],
        "rms_tracking_error_mm": [float(np.sqrt(np.mean(e1 ** 2)) * 1e3), float(np.sqrt(np.mean(e2 ** 2)) * 1e3)],
        "max_chamber_pressure_bar": pmax / 1e5,
        "min_supply_pressure_bar": float(np.min(ps)) / 1e5,
        "valve_saturation_s": [float(c_end[plant.C_SAT1]), float(c_end[plant.C_SAT2])],
        "cavitation_s": float(c_end[plant.C_CAV]),
        "peak_pump_flow_L_min": float(np.max(sig["q_pump"])) * 60e3,
        "mean_pump_flow_L_min": float(np.mean(sig["q_pump"])) * 60e3,
        "peak_pump_power_kW": float(np.max(p_pump)) / 1e3,
        "pump_energy_kJ": en["pump"] / 1e3,
        "energy_balance_error_pct": 100.0 * abs(en["balance_error"]) / max(en["pump"], 1e-9),
        "max_relief_flow_L_min": float(np.max(sig["q_relief"])) * 60e3,
    }
    warnings = []
    for i in (0, 1):
        if c_end[plant.C_SAT1 + i] > 0:
            warnings.append(f"valve {i + 1} saturated for {c_end[plant.C_SAT1 + i]:.2f} s")
    if c_end[plant.C_CAV] > 0:
        warnings.append(f"a chamber reached 0 bar (cavitation risk) for {c_end[plant.C_CAV]:.2f} s")
    if pmax > model.cylinders.max_pressure:
        warnings.append(f"chamber pressure {pmax / 1e5:.1f} bar above the {model.cylinders.max_pressure / 1e5:g} bar rating")
    if metrics["max_relief_flow_L_min"] > 0:
        warnings.append("the relief valve opened")
    if arrival is None:
        warnings.append(f"the coupler never came within {c.arrival_tolerance * 1e3:g} mm of the flange")
    metrics["warnings"] = warnings
    return SimulationResult(plan.timing, sig, x, y, dev, en, metrics)


def simulate_hold(model: ArmModel, alpha: float, beta: float, duration: float, *, pressures: tuple | None = None,
                  fill: float | None = None, log_rate: float = 100.0) -> dict:
    """Closed loop told to hold the arm still at ``(alpha, beta)``.

    Parameters
    ----------
    model : ArmModel
        The installation.
    alpha, beta : float
        Pose, rad.
    duration : float
        Simulated time, s.
    pressures : tuple of float, optional
        Initial ``(pA1, pB1, pA2, pB2)``, Pa; default the static holding
        pressures (then nothing should happen).
    fill : float, optional
        Product fill.
    log_rate : float
        Logging rate, Hz.

    Returns
    -------
    dict of str to ndarray
        The logged signals (``plant.SIGNALS``).

    Raises
    ------
    SimulationError
        On divergence.
    """
    P = pack_parameters(model, fill=fill)
    dt = P[plant.I_DT]
    n = int(round(duration / dt))
    y0 = initial_state(model, alpha, beta, fill=fill)
    if pressures is not None:
        y0[4:8] = pressures
    r1, r2, _, _ = plant._geometry(P, alpha, beta)
    ref = np.vstack([np.full(n + 1, r1), np.full(n + 1, r2)])
    mm = mass_model(model, fill=fill)
    ta, tb = static_torques(mm, alpha, beta)
    _, _, h1, h2 = plant._geometry(P, alpha, beta)
    fref = np.vstack([np.full(n + 1, float(ta) / h1), np.full(n + 1, float(tb) / h2)])
    log_every = max(1, int(round(model.controller.rate / log_rate)))
    log, _, c_end = plant.simulate_loop(P, ref, np.zeros_like(ref), fref, y0, n,
                                         int(P[plant.I_DT] / P[plant.I_H] + 0.5), log_every)
    if c_end[plant.C_FAIL] != 0:
        raise SimulationError(f"hold simulation diverged at t = {c_end[plant.C_FAIL_T]:.3f} s "
                              f"({plant.fail_reason(int(c_end[plant.C_FAIL]))})")
    m = int(c_end[plant.C_NLOG])
    return {name: log[:m, j].copy() for j, name in enumerate(plant.SIGNALS)}
