"""Reference routes for validating the fast simulator.

* :func:`reference_simulation`: the same closed loop (same controller code,
  same plant equations via :func:`~loadarm.hydraulics.circuit.plant_rhs`) with
  the plant integrated by SciPy's ``solve_ivp`` (adaptive, stiff-capable)
  between control samples. Slow, accurate: the naive route of the benchmark
  and the reference traces of the tests.
* :func:`cylinder_rig`: one valve-cylinder drive moving a lumped mass, with
  the simulator's own integration scheme, for component-level physics checks
  (pressure build-up, hydraulic natural frequency).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.integrate import solve_ivp

from loadarm._numba import njit
from loadarm.design.trajectory import Plan
from loadarm.hydraulics import circuit as plant
from loadarm.hydraulics.components import cylinder_friction, end_stop_force, valve_flows
from loadarm.hydraulics.simulate import initial_state, pack_parameters, reference_signals

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["reference_simulation", "cylinder_rig"]


def reference_simulation(model: ArmModel, plan: Plan, t_end: float, *, fill: float | None = None,
                         method: str = "LSODA", rtol: float = 1e-8) -> dict:
    """Closed loop with the plant integrated by ``solve_ivp`` between control samples.

    Parameters
    ----------
    model : ArmModel
        The installation.
    plan : Plan
        The approach.
    t_end : float
        Simulated time, s (> 0).
    fill : float, optional
        Product fill.
    method : str
        ``solve_ivp`` method.
    rtol : float
        Relative tolerance (absolute tolerances are scaled per state).

    Returns
    -------
    dict of str to ndarray
        ``t`` and the state signals ``alpha, beta, alpha_dot, beta_dot, pA1, pB1, pA2, pB2, ps, u1, u2`` at
        every control sample.
    """

    if not t_end > 0:
        raise ValueError(f"t_end must be > 0 s, got {t_end!r}")
    P = pack_parameters(model, fill=fill)
    dt = P[plant.I_DT]
    n = int(round(t_end / dt))
    ref, vref, fref = reference_signals(model, plan, n, fill)
    y = initial_state(model, float(plan.alpha[0]), float(plan.beta[0]), fill=fill)
    c = plant.controller_at_rest(P, y)
    ps_nom = P[plant.I_PCOMP] - P[plant.I_PBAND]
    atol = np.array([1e-9, 1e-9, 1e-9, 1e-9] + [1.0] * 4 + [1e-7, 1e-5, 1e-7, 1e-5, 1.0])
    out = {k: np.empty(n + 1) for k in ("t", "alpha", "beta", "alpha_dot", "beta_dot", "pA1", "pB1", "pA2", "pB2",
                                          "ps", "u1", "u2")}
    for k in range(n + 1):
        r1, r2, _, _ = plant._geometry(P, y[0], y[1])
        plant.control_step(P, k, r1, r2, ref, vref, fref, c, ps_nom)
        for name, val in zip(("t", "alpha", "beta", "alpha_dot", "beta_dot", "pA1", "pB1", "pA2", "pB2", "ps",
                              "u1", "u2"), (k * dt, *y[:8], y[12], c[plant.C_U1], c[plant.C_U2])):
            out[name][k] = val
        if k == n:
            break
        u1, u2 = float(c[plant.C_U1]), float(c[plant.C_U2])
        sol = solve_ivp(lambda _t, yy, u1=u1, u2=u2: plant.plant_rhs(yy, u1, u2, P), (k * dt, (k + 1) * dt), y, method=method,
                        rtol=rtol, atol=atol)
        if not sol.success:  # pragma: no cover
            raise RuntimeError(f"solve_ivp failed at t = {k * dt:.3f} s: {sol.message}")
        y = sol.y[:, -1].copy()
    return out


@njit(cache=True)
def _rig_loop(P, mass, x0, pA0, pB0, spool, f_ext, ps, n, h):
    out = np.empty((n + 1, 5))
    x, v, pA, pB = x0, 0.0, pA0, pB0
    stroke = P[plant.I_STROKE1]
    for k in range(n + 1):
        out[k, 0] = k * h
        out[k, 1] = x
        out[k, 2] = v
        out[k, 3] = pA
        out[k, 4] = pB
        qA, qB, _, dqA, dqB, _, _ = valve_flows(spool, ps, P[plant.I_PT], pA, pB, P[plant.I_KV], P[plant.I_OVERLAP],
                                                 P[plant.I_PLAM])
        VA = P[plant.I_V0] + P[plant.I_AP] * x
        VB = P[plant.I_V0] + P[plant.I_AA] * (stroke - x)
        ql = P[plant.I_CLEAK] * (pA - pB)
        fA = P[plant.I_BETA] / VA * (qA - P[plant.I_AP] * v - ql)
        jA = P[plant.I_BETA] / VA * (dqA - P[plant.I_CLEAK])
        fB = P[plant.I_BETA] / VB * (qB + P[plant.I_AA] * v + ql)
        jB = P[plant.I_BETA] / VB * (dqB - P[plant.I_CLEAK])
        pA += h * fA / (1.0 - h * jA)
        pB += h * fB / (1.0 - h * jB)
        F = (pA * P[plant.I_AP] - pB * P[plant.I_AA] - cylinder_friction(v, P[plant.I_BVISC], P[plant.I_FC], P[plant.I_VS])
             + end_stop_force(x, v, stroke, P[plant.I_KSTOP], P[plant.I_CSTOP]) + f_ext)
        v += h * F / mass
        x += h * v
    return out


def cylinder_rig(model: ArmModel, *, mass: float, duration: float, x0: float, spool: float = 0.0,
                 force: float = 0.0, pA0: float | None = None, pB0: float | None = None, supply: float | None = None,
                 step: float | None = None, overrides: dict | None = None) -> dict:
    """One drive (valve + cylinder 1's geometry) moving a free mass, integrated like the simulator.

    Parameters
    ----------
    model : ArmModel
        Valve and cylinder parameters.
    mass : float
        Moving mass, kg.
    duration : float
        Simulated time, s.
    x0 : float
        Initial piston position from fully retracted, m.
    spool : float
        Fixed spool position, normalised (-1..1).
    force : float
        Constant external force on the piston, N (positive = extending).
    pA0, pB0 : float, optional
        Initial chamber pressures, Pa (default: both at half supply).
    supply : float, optional
        Ideal supply pressure, Pa (default the compensator setting).
    step : float, optional
        Integration step, s (default the simulator's plant step).
    overrides : dict, optional
        Parameter-vector entries to replace, by index name, e.g.
        ``{"I_FC": 0.0, "I_CLEAK": 0.0}``.

    Returns
    -------
    dict of str to ndarray
        ``t, x, v, pA, pB``.
    """

    P = pack_parameters(model)
    for key, val in (overrides or {}).items():
        P[getattr(plant, key)] = val
    h = P[plant.I_H] if step is None else float(step)
    ps = model.pump.compensator_pressure if supply is None else float(supply)
    pA0 = ps / 2 if pA0 is None else pA0
    pB0 = ps / 2 if pB0 is None else pB0
    n = int(math.ceil(duration / h))
    out = _rig_loop(P, float(mass), float(x0), float(pA0), float(pB0), float(spool), float(force), ps, n, h)
    return {"t": out[:, 0], "x": out[:, 1], "v": out[:, 2], "pA": out[:, 3], "pB": out[:, 4]}
