"""The closed loop of paper Fig. 11 on the real arm: two PID-controlled valve-cylinder drives.

State (13): joint angles and rates ``alpha, beta, alpha', beta'``; per cylinder
the chamber pressures ``pA, pB`` and the spool position and speed; the supply
pressure. The two drives interact through the arm: each cylinder's force acts
through its exact moment arm (Eqs 12-13), the arm's mass matrix couples the
joints, and both valves draw from one pump.

Integration (fixed step, ``controller.substeps`` plant steps per control
step), chosen for speed with stability:

* spool: exact zero-order-hold discretisation (matrix exponential);
* pressures (stiff): linearly implicit Euler on each node's own flow
  derivative, so the orifice and compressibility poles never destabilise;
* arm: semi-implicit (symplectic) Euler with the full 2x2 mass matrix.

The inner loop is compiled with numba; :func:`plant_rhs` is the same model as
a continuous right-hand side for SciPy's ``solve_ivp`` (the benchmark's naive
route and a cross-check in the tests).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .components import (cylinder_friction, end_stop_force, pump_flow, relief_flow, valve_flows)

__all__ = ["SIGNALS", "ENERGIES", "N_PARAMS", "arm_accelerations", "plant_rhs", "control_step", "simulate_loop",
           "advance", "fail_reason"]

# --- parameter vector layout (one float64 array, so the compiled loop takes few arguments) ---
(I_A1, I_B1, I_B2, I_C2, I_RISER, I_BIN, I_COUT, I_AP, I_AA, I_BETA, I_V0, I_BVISC, I_FC, I_VS, I_CLEAK,
 I_LMIN1, I_STROKE1, I_LMIN2, I_STROKE2, I_KSTOP, I_CSTOP, I_PCOMP, I_PBAND, I_QMAX, I_PRELIEF, I_RBAND, I_VSUP,
 I_PT, I_KV, I_OVERLAP, I_PLAM, I_UMAX, I_RES, I_KP, I_KI, I_KD, I_TD, I_ILIM, I_FF, I_KFF_EXT, I_KFF_RET, I_G,
 I_PHI00, I_PHI01, I_PHI10, I_PHI11, I_GAM0, I_GAM1, I_DT, I_H, I_OMEGA2, I_TWOZW,
 I_K11, I_K22, I_KC, I_GA, I_GAB, I_FELIM) = range(58)
N_PARAMS = 58

#: Logged signals, in column order.
SIGNALS = ("t", "alpha", "beta", "alpha_dot", "beta_dot", "r1", "r2", "r1_ref", "r2_ref", "u1", "u2", "xv1", "xv2",
           "pA1", "pB1", "pA2", "pB2", "ps", "q_pump", "q_relief", "F1", "F2")
#: Energy accumulators, in order (J).
ENERGIES = ("pump", "relief", "valve", "tank", "leakage", "compression", "friction", "end_stop", "cylinder_work")

_FAIL_SIGNALS = ("none", "non-finite state", "pressure beyond 10x relief", "joint rate beyond 10 rad/s",
                 "following error beyond controller.following_error_limit",
                 "valve chattering between its limits (more than 2 rail-to-rail reversals per second)")


@njit(cache=True)
def arm_accelerations(P, a, b, ad, bd, ta, tb):
    """Joint accelerations of the arm under applied joint torques (closed-form Lagrangian).

    Uses the constants of :func:`loadarm.dynamics.lagrange_constants` stored in
    ``P``: ``M(beta) qdd = tau - c(q, qd) - dV/dq``.

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    a, b, ad, bd : float
        Joint angles (rad) and rates (rad/s).
    ta, tb : float
        Applied joint torques, N m.

    Returns
    -------
    add, bdd : float
        Joint accelerations, rad/s^2.
    """
    cb = math.cos(b)
    sb = math.sin(b)
    sab = math.sin(a - b)
    m11 = P[I_K11] - 2.0 * P[I_KC] * cb
    m12 = -P[I_K22] + P[I_KC] * cb
    m22 = P[I_K22]
    d11 = 2.0 * P[I_KC] * sb
    d12 = -P[I_KC] * sb
    r1 = ta - (d11 * ad * bd + d12 * bd * bd) + P[I_G] * (P[I_GA] * math.sin(a) + P[I_GAB] * sab)
    r2 = tb + 0.5 * d11 * ad * ad - P[I_G] * P[I_GAB] * sab
    det = m11 * m22 - m12 * m12
    return (m22 * r1 - m12 * r2) / det, (-m12 * r1 + m11 * r2) / det


@njit(cache=True)
def _geometry(P, a, b):
    a1, b1, b2, c2 = P[I_A1], P[I_B1], P[I_B2], P[I_C2]
    ch = math.cos(0.5 * a)
    sh = math.sin(0.5 * b)
    r1 = math.sqrt((a1 - b1) ** 2 + 4.0 * a1 * b1 * ch * ch)
    r2 = math.sqrt((c2 - b2) ** 2 + 4.0 * c2 * b2 * sh * sh)
    h1 = -a1 * b1 * math.sin(a) / r1
    h2 = b2 * c2 * math.sin(b) / r2
    return r1, r2, h1, h2


@njit(cache=True)
def _cylinder(P, i, pA, pB, r, v):
    """Hydraulic force, friction and stop force, chamber volumes of cylinder i (0 or 1)."""
    lmin = P[I_LMIN1] if i == 0 else P[I_LMIN2]
    stroke = P[I_STROKE1] if i == 0 else P[I_STROKE2]
    x = r - lmin
    xc = min(max(x, 0.0), stroke)
    VA = P[I_V0] + P[I_AP] * xc
    VB = P[I_V0] + P[I_AA] * (stroke - xc)
    fric = cylinder_friction(v, P[I_BVISC], P[I_FC], P[I_VS])
    stop = end_stop_force(x, v, stroke, P[I_KSTOP], P[I_CSTOP])
    return pA * P[I_AP] - pB * P[I_AA], fric, stop, VA, VB


@njit(cache=True)
def plant_rhs(y, u1, u2, P):
    """Continuous-time right-hand side of the whole plant (for ``solve_ivp`` and tests).

    Parameters
    ----------
    y : ndarray, shape (13,)
        ``alpha, beta, alpha', beta', pA1, pB1, pA2, pB2, xv1, vv1, xv2, vv2, ps``.
    u1, u2 : float
        Valve voltages, V (held).
    P : ndarray
        Parameter vector (see :func:`loadarm.hydraulics.simulate.pack_parameters`).

    Returns
    -------
    ndarray, shape (13,)
        Time derivative of ``y``.
    """
    dy = np.zeros(13)
    a, b, ad, bd = y[0], y[1], y[2], y[3]
    r1, r2, h1, h2 = _geometry(P, a, b)
    v = (h1 * ad, h2 * bd)
    r = (r1, r2)
    ps = y[12]
    qp_total = 0.0
    forces = np.zeros(2)
    for i in range(2):
        pA = y[4 + 2 * i]
        pB = y[5 + 2 * i]
        xv = y[8 + 2 * i]
        vv = y[9 + 2 * i]
        xs = min(max(xv, -1.0), 1.0)
        qA, qB, qP, _, _, _, _ = valve_flows(xs, ps, P[I_PT], pA, pB, P[I_KV], P[I_OVERLAP], P[I_PLAM])
        fh, fric, stop, VA, VB = _cylinder(P, i, pA, pB, r[i], v[i])
        ql = P[I_CLEAK] * (pA - pB)
        dy[4 + 2 * i] = P[I_BETA] / VA * (qA - P[I_AP] * v[i] - ql)
        dy[5 + 2 * i] = P[I_BETA] / VB * (qB + P[I_AA] * v[i] + ql)
        u = (u1 if i == 0 else u2) / P[I_UMAX]
        dy[8 + 2 * i] = vv
        dy[9 + 2 * i] = P[I_OMEGA2] * (u - xv) - P[I_TWOZW] * vv
        forces[i] = fh - fric + stop
        qp_total += qP
    qpump, _ = pump_flow(ps, P[I_QMAX], P[I_PCOMP], P[I_PBAND])
    qrel, _ = relief_flow(ps, P[I_QMAX], P[I_PRELIEF], P[I_RBAND])
    dy[12] = P[I_BETA] / P[I_VSUP] * (qpump - qrel - qp_total)
    dy[0] = ad
    dy[1] = bd
    dy[2], dy[3] = arm_accelerations(P, a, b, ad, bd, forces[0] * h1, forces[1] * h2)
    return dy


@njit(cache=True)
def control_step(P, k, r1, r2, ref, vref, fref, integ, dfilt, prev, u, status, ps_nom):
    """One controller cycle for both cylinders: sample the encoders, PID + feed-forward, command the valves.

    Updates ``integ``, ``dfilt``, ``prev`` (controller state) and ``u`` (valve
    voltages, V) in place, and adds ``1 / rate`` to ``status[3 + i]`` while
    valve ``i`` is saturated.

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    k : int
        Control step index into the references.
    r1, r2 : float
        True cylinder lengths, m (quantised here by the encoder).
    ref, vref, fref : ndarray, shape (2, n)
        Length (m), speed (m/s) and force (N) references.
    integ, dfilt, prev, u, status : ndarray
        Controller state and outputs (modified in place).
    ps_nom : float
        Supply pressure assumed by the feed-forward, Pa.
    """
    dt = P[I_DT]
    for i in range(2):
        meas = round((r1 if i == 0 else r2) / P[I_RES]) * P[I_RES]
        e = ref[i, k] - meas
        dm = (meas - prev[i]) / dt
        prev[i] = meas
        dfilt[i] += dt / (P[I_TD] + dt) * (dm - dfilt[i])
        ff = 0.0
        vr = vref[i, k]
        if P[I_FF] == 1.0:      # nominal: flow at the valve's rated drop
            ff = vr * (P[I_KFF_EXT] if vr >= 0.0 else P[I_KFF_RET])
        elif P[I_FF] == 2.0 and vr != 0.0:
            # model-based: steady-state inverse of valve + asymmetric cylinder under the planned force,
            # from continuity through both lands and the force balance (docs/hydraulics.md)
            ap3 = P[I_AP] ** 3 + P[I_AA] ** 3
            if vr > 0.0:
                avail = P[I_AP] * ps_nom - P[I_AA] * P[I_PT] - fref[i, k]
            else:
                avail = P[I_AA] * ps_nom - P[I_AP] * P[I_PT] + fref[i, k]
            avail = max(avail, P[I_AP] * P[I_PLAM])
            ff = vr / P[I_KV] * math.sqrt(ap3 / avail) * P[I_UMAX]
            if P[I_OVERLAP] > 0.0:
                ff = math.copysign(abs(ff) * (1.0 - P[I_OVERLAP]) + P[I_OVERLAP] * P[I_UMAX], ff)
        un = ff + P[I_KP] * e + integ[i] - P[I_KD] * dfilt[i]
        sat = abs(un) >= P[I_UMAX]
        # anti-windup: integrate unless saturated and the error pushes further into saturation
        if not (sat and e * un > 0.0):
            integ[i] = min(max(integ[i] + P[I_KI] * e * dt, -P[I_ILIM]), P[I_ILIM])
        u[i] = min(max(un, -P[I_UMAX]), P[I_UMAX])
        if sat:
            status[3 + i] += dt
            sign = 1.0 if un > 0.0 else -1.0
            if status[6 + i] != 0.0 and sign != status[6 + i]:
                status[8 + i] += 1.0        # a full-scale reversal: rail to rail
            status[6 + i] = sign


@njit(cache=True)
def _run(P, y, ref, vref, fref, n_steps, substeps, log_every, integ, dfilt, prev, u, status, energy, log, tail):
    """The closed loop over ``n_steps`` control steps, starting from and updating ``y`` in place."""
    dt = P[I_DT]
    h = P[I_H]
    a, b, ad, bd = y[0], y[1], y[2], y[3]
    pA = np.array([y[4], y[6]])
    pB = np.array([y[5], y[7]])
    xv = np.array([y[8], y[10]])
    vv = np.array([y[9], y[11]])
    ps = y[12]
    F = np.zeros(2)
    qpump = 0.0
    qrel = 0.0
    il = 0
    ps_nom = P[I_PCOMP] - P[I_PBAND]   # supply pressure while the pump delivers (for the feed-forward)
    for k in range(n_steps + 1):
        t = k * dt
        if k == n_steps and not tail:
            break
        # ---- controller (sample, decide, command) ----
        r1, r2, h1, h2 = _geometry(P, a, b)
        control_step(P, k, r1, r2, ref, vref, fref, integ, dfilt, prev, u, status, ps_nom)
        if k % log_every == 0:
            row = log[il]
            row[0] = t
            row[1] = a
            row[2] = b
            row[3] = ad
            row[4] = bd
            row[5] = r1
            row[6] = r2
            row[7] = ref[0, k]
            row[8] = ref[1, k]
            row[9] = u[0]
            row[10] = u[1]
            row[11] = xv[0]
            row[12] = xv[1]
            row[13] = pA[0]
            row[14] = pB[0]
            row[15] = pA[1]
            row[16] = pB[1]
            row[17] = ps
            row[18] = qpump
            row[19] = qrel
            row[20] = F[0]
            row[21] = F[1]
            il += 1
        if k == n_steps:
            break
        # ---- plant ----
        for _ in range(substeps):
            r1, r2, h1, h2 = _geometry(P, a, b)
            v0 = h1 * ad
            v1 = h2 * bd
            qp_total = 0.0
            dqp_total = 0.0
            cav = False
            for i in range(2):
                # spool: exact discretisation, clipped at its mechanical stops
                un = u[i] / P[I_UMAX]
                x_new = P[I_PHI00] * xv[i] + P[I_PHI01] * vv[i] + P[I_GAM0] * un
                v_new = P[I_PHI10] * xv[i] + P[I_PHI11] * vv[i] + P[I_GAM1] * un
                if x_new > 1.0:
                    x_new = 1.0
                    v_new = min(v_new, 0.0)
                elif x_new < -1.0:
                    x_new = -1.0
                    v_new = max(v_new, 0.0)
                xv[i] = x_new
                vv[i] = v_new
                vi = v0 if i == 0 else v1
                qA, qB, qP, dqA, dqB, dqP, loss = valve_flows(xv[i], ps, P[I_PT], pA[i], pB[i], P[I_KV],
                                                               P[I_OVERLAP], P[I_PLAM])
                fh, fric, stop, VA, VB = _cylinder(P, i, pA[i], pB[i], r1 if i == 0 else r2, vi)
                F[i] = fh - fric + stop
                ql = P[I_CLEAK] * (pA[i] - pB[i])
                netA = qA - P[I_AP] * vi - ql
                netB = qB + P[I_AA] * vi + ql
                # energy bookkeeping (J)
                energy[2] += h * loss
                energy[3] += h * P[I_PT] * (-qB if qB < 0.0 else 0.0) + h * P[I_PT] * (-qA if qA < 0.0 else 0.0)
                energy[4] += h * ql * (pA[i] - pB[i])
                energy[5] += h * (pA[i] * netA + pB[i] * netB)
                energy[6] += h * fric * vi
                energy[7] -= h * stop * vi
                energy[8] += h * fh * vi
                # linearly implicit pressure update
                fA = P[I_BETA] / VA * netA
                jA = P[I_BETA] / VA * (dqA - P[I_CLEAK])
                fB = P[I_BETA] / VB * netB
                jB = P[I_BETA] / VB * (dqB - P[I_CLEAK])
                pA[i] += h * fA / (1.0 - h * jA)
                pB[i] += h * fB / (1.0 - h * jB)
                if pA[i] < 0.0:
                    pA[i] = 0.0
                    cav = True
                if pB[i] < 0.0:
                    pB[i] = 0.0
                    cav = True
                qp_total += qP
                dqp_total += dqP
            if cav:
                status[2] += h
            qpump, dqpump = pump_flow(ps, P[I_QMAX], P[I_PCOMP], P[I_PBAND])
            qrel, dqrel = relief_flow(ps, P[I_QMAX], P[I_PRELIEF], P[I_RBAND])
            energy[0] += h * ps * qpump
            energy[1] += h * ps * qrel
            energy[5] += h * ps * (qpump - qrel - qp_total)
            fs = P[I_BETA] / P[I_VSUP] * (qpump - qrel - qp_total)
            js = P[I_BETA] / P[I_VSUP] * (dqpump - dqrel - dqp_total)
            ps += h * fs / (1.0 - h * js)
            # arm: semi-implicit Euler with the full mass matrix
            acc_a, acc_b = arm_accelerations(P, a, b, ad, bd, F[0] * h1, F[1] * h2)
            ad += h * acc_a
            bd += h * acc_b
            a += h * ad
            b += h * bd
        # ---- divergence watch ----
        code = 0
        if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(ad) and math.isfinite(bd)
                and math.isfinite(ps) and math.isfinite(pA[0] + pA[1] + pB[0] + pB[1])):
            code = 1
        elif max(ps, pA[0], pA[1], pB[0], pB[1]) > 10.0 * P[I_PRELIEF]:
            code = 2
        elif abs(ad) > 10.0 or abs(bd) > 10.0:
            code = 3
        else:
            r1, r2, h1, h2 = _geometry(P, a, b)
            if abs(ref[0, k] - r1) > P[I_FELIM] or abs(ref[1, k] - r2) > P[I_FELIM]:
                code = 4
            elif max(status[8], status[9]) > 20.0 + 2.0 * (k + 1) * dt:
                code = 5
        if code:
            status[0] = code
            status[1] = (k + 1) * dt
            break
    y[0], y[1], y[2], y[3] = a, b, ad, bd
    y[4], y[6], y[5], y[7] = pA[0], pA[1], pB[0], pB[1]
    y[8], y[10], y[9], y[11] = xv[0], xv[1], vv[0], vv[1]
    y[12] = ps
    return il


@njit(cache=True)
def simulate_loop(P, ref, vref, fref, y0, n_steps, substeps, log_every):
    """Fixed-step closed-loop simulation (compiled).

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    ref, vref : ndarray, shape (2, n_steps + 1)
        Cylinder length references (m) and their rates (m/s) at each control step.
    fref : ndarray, shape (2, n_steps + 1)
        Planned cylinder forces (N), for the model-based feed-forward.
    y0 : ndarray, shape (13,)
        Initial state.
    n_steps : int
        Control steps.
    substeps : int
        Plant steps per control step.
    log_every : int
        Log every this many control steps.

    Returns
    -------
    log : ndarray, shape (n_log, len(SIGNALS))
    energy : ndarray, shape (len(ENERGIES),)
    status : ndarray of float, shape (10,)
        ``[fail_code, fail_time, cavitation_time, saturated_time_1, saturated_time_2, n_logged,
        last_saturation_sign_1, last_saturation_sign_2, reversals_1, reversals_2]``.
    """
    n_log = n_steps // log_every + 1
    log = np.full((n_log, 22), np.nan)
    energy = np.zeros(9)
    status = np.zeros(10)
    y = y0.copy()
    integ = np.zeros(2)
    dfilt = np.zeros(2)
    prev = np.zeros(2)
    u = np.zeros(2)
    r1, r2, h1, h2 = _geometry(P, y[0], y[1])
    prev[0] = round(r1 / P[I_RES]) * P[I_RES]
    prev[1] = round(r2 / P[I_RES]) * P[I_RES]
    il = _run(P, y, ref, vref, fref, n_steps, substeps, log_every, integ, dfilt, prev, u, status, energy, log, True)
    status[5] = il
    return log, energy, status


@njit(cache=True)
def advance(P, y, ref, vref, fref, n_steps, substeps, integ, dfilt, prev, u, status):
    """Run the closed loop for ``n_steps`` control steps from state ``y``, updating it in place.

    The stateful form used by the live-guidance runs: plant state ``y`` and
    controller state ``integ, dfilt, prev, u, status`` persist between calls.

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    y : ndarray, shape (13,)
        Plant state (updated).
    ref, vref, fref : ndarray, shape (2, n_steps + 1)
        References for this stretch.
    n_steps, substeps : int
        Control steps and plant steps per control step.
    integ, dfilt, prev, u, status : ndarray
        Controller state (updated).

    Returns
    -------
    int
        Failure code (0 = fine, see :func:`fail_reason`).
    """
    energy = np.zeros(9)
    log = np.zeros((1, 22))
    _run(P, y, ref, vref, fref, n_steps, substeps, n_steps + 1, integ, dfilt, prev, u, status, energy, log, False)
    return int(status[0])


def fail_reason(code: int) -> str:
    """Text of a divergence code returned by :func:`simulate_loop`.

    Parameters
    ----------
    code : int
        ``status[0]``.

    Returns
    -------
    str
    """
    return _FAIL_SIGNALS[int(code)]
