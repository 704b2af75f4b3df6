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
from numba.np.unsafe.ndarray import to_fixed_tuple

from loadarm._numba import njit
from loadarm.arm.actuators import pin_lengths as _pin_lengths
from loadarm.arm.actuators import pin_moment_arms as _pin_moment_arms
from loadarm.arm.dynamics import lagrange_terms as _lagrange_terms
from loadarm.hydraulics.components import cylinder_friction, end_stop_force, pump_flow, relief_flow, valve_flows

__all__ = ["SIGNALS", "ENERGIES", "N_PARAMS", "N_CTRL", "N_STATE", "ServoState", "arm_accelerations", "plant_rhs",
           "control_step", "controller_at_rest", "encoder", "first_readings", "simulate_loop", "advance",
           "fail_reason"]

# --- parameter vector layout (one float64 array, so the compiled loop takes few arguments) ---
(I_A1, I_B1, I_B2, I_C2, I_RISER, I_BIN, I_COUT, I_AP, I_AA, I_BETA, I_V0, I_BVISC, I_FC, I_VS, I_CLEAK,
 I_LMIN1, I_STROKE1, I_LMIN2, I_STROKE2, I_KSTOP, I_CSTOP, I_PCOMP, I_PBAND, I_QMAX, I_PRELIEF, I_RBAND, I_VSUP,
 I_PT, I_KV, I_OVERLAP, I_PLAM, I_UMAX, I_RES, I_KP, I_KI, I_KD, I_TD, I_ILIM, I_FF, I_KFF_EXT, I_KFF_RET, I_G,
 I_PHI00, I_PHI01, I_PHI10, I_PHI11, I_GAM0, I_GAM1, I_DT, I_H, I_OMEGA2, I_TWOZW,
 I_K11, I_K22, I_KC, I_GA, I_GAB, I_FELIM) = range(58)
N_PARAMS = 58

# --- controller state vector: PID states, valve commands and the run's status, one float64 array ---
(C_INTEG1, C_INTEG2, C_DFILT1, C_DFILT2, C_PREV1, C_PREV2, C_U1, C_U2,
 C_FAIL, C_FAIL_T, C_CAV, C_SAT1, C_SAT2, C_NLOG, C_SIGN1, C_SIGN2, C_REV1, C_REV2) = range(18)
N_CTRL = 18
#: Plant state length: ``alpha, beta, alpha', beta', pA1, pB1, pA2, pB2, xv1, vv1, xv2, vv2, ps``.
N_STATE = 13

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

    Uses the constants of :func:`loadarm.arm.dynamics.lagrange_constants` stored in
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
    return _accelerations(P, math.sin(a), math.cos(a), math.sin(b), math.cos(b), ad, bd, ta, tb)


#: :func:`loadarm.arm.dynamics.lagrange_terms` compiled: the NumPy route's formula of the arm's dynamics.
lagrange_terms = njit(cache=True)(_lagrange_terms)


@njit(cache=True)
def _accelerations(P, sa, ca, sb, cb, ad, bd, ta, tb):
    """:func:`arm_accelerations` from the sines and cosines of the joint angles (shared with the geometry)."""
    sab = sa * cb - ca * sb                      # sin(alpha - beta)
    m11, m12, m22, c1, c2, g1, g2 = lagrange_terms(P[I_K11], P[I_K22], P[I_KC], P[I_GA], P[I_GAB], P[I_G], sa, sab,
                                                   sb, cb, ad, bd)
    r1 = ta - c1 - g1
    r2 = tb - c2 - g2
    det = m11 * m22 - m12 * m12
    return (m22 * r1 - m12 * r2) / det, (-m12 * r1 + m11 * r2) / det


#: :func:`loadarm.arm.actuators.pin_lengths` and :func:`~loadarm.arm.actuators.pin_moment_arms` (Eqs 12-13 and their
#: derivatives) compiled for scalars: the very functions the NumPy routes use, so the plant cannot drift.
pin_lengths = njit(cache=True)(_pin_lengths)
pin_moment_arms = njit(cache=True)(_pin_moment_arms)


@njit(cache=True)
def pin_geometry(P, ch, sh, sa, sb):
    """Cylinder lengths and moment arms from the joint angles' (half-angle) sines and cosines."""
    r1, r2 = pin_lengths(P[I_A1], P[I_B1], P[I_B2], P[I_C2], ch, sh)
    h1, h2 = pin_moment_arms(P[I_A1], P[I_B1], P[I_B2], P[I_C2], sa, sb, r1, r2)
    return r1, r2, h1, h2


@njit(cache=True)
def _geometry(P, a, b):
    """Cylinder lengths and moment arms (paper Eqs 12-13) at ``(alpha, beta)``."""
    return pin_geometry(P, math.cos(0.5 * a), math.sin(0.5 * b), math.sin(a), math.sin(b))


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
def encoder(P, r):
    """Encoder reading of a cylinder length: quantised to ``encoder.resolution``.

    Parameters
    ----------
    P : ndarray or tuple
        Parameter vector.
    r : float
        True length, m.

    Returns
    -------
    float
        Reading, m.
    """
    return round(r / P[I_RES]) * P[I_RES]


@njit(cache=True)
def first_readings(P, a, b):
    """Both encoders' readings with the arm at ``(alpha, beta)``: the controller's first "previous" sample.

    Parameters
    ----------
    P : ndarray or tuple
        Parameter vector.
    a, b : float
        Joint angles, rad.

    Returns
    -------
    tuple of float
        Readings of cylinders 1 and 2, m.
    """
    r1, r2, _, _ = _geometry(P, a, b)
    return encoder(P, r1), encoder(P, r2)


@njit(cache=True)
def _pid(P, meas, r_ref, v_ref, f_ref, integ, dfilt, prev, ps_nom):
    """One cylinder's controller cycle on scalars: PID on the encoder reading plus the valve feed-forward.

    Returns
    -------
    u, un, integ, dfilt, prev : float
        Valve command (clipped to the valve range) and unclipped, V; the new integrator, derivative filter and
        previous reading.
    """
    dt = P[I_DT]
    e = r_ref - meas
    dm = (meas - prev) / dt
    dfilt += dt / (P[I_TD] + dt) * (dm - dfilt)
    ff = 0.0
    if P[I_FF] == 1.0:      # nominal: flow at the valve's rated drop
        ff = v_ref * (P[I_KFF_EXT] if v_ref >= 0.0 else P[I_KFF_RET])
    elif P[I_FF] == 2.0 and v_ref != 0.0:
        # model-based: steady-state inverse of valve + asymmetric cylinder under the planned force,
        # from continuity through both lands and the force balance (docs/hydraulics.md)
        ap3 = P[I_AP] * P[I_AP] * P[I_AP] + P[I_AA] * P[I_AA] * P[I_AA]
        if v_ref > 0.0:
            avail = P[I_AP] * ps_nom - P[I_AA] * P[I_PT] - f_ref
        else:
            avail = P[I_AA] * ps_nom - P[I_AP] * P[I_PT] + f_ref
        avail = max(avail, P[I_AP] * P[I_PLAM])
        ff = v_ref / P[I_KV] * math.sqrt(ap3 / avail) * P[I_UMAX]
        if P[I_OVERLAP] > 0.0:
            ff = math.copysign(abs(ff) * (1.0 - P[I_OVERLAP]) + P[I_OVERLAP] * P[I_UMAX], ff)
    un = ff + P[I_KP] * e + integ - P[I_KD] * dfilt
    sat = abs(un) >= P[I_UMAX]
    # anti-windup: integrate unless saturated and the error pushes further into saturation
    if not (sat and e * un > 0.0):
        integ = min(max(integ + P[I_KI] * e * dt, -P[I_ILIM]), P[I_ILIM])
    return min(max(un, -P[I_UMAX]), P[I_UMAX]), un, integ, dfilt, meas


@njit(cache=True)
def _saturation(P, un, sat_time, last_sign, reversals):
    """Saturation bookkeeping of one valve: time at the rail and rail-to-rail reversals."""
    if abs(un) >= P[I_UMAX]:
        sat_time += P[I_DT]
        sign = 1.0 if un > 0.0 else -1.0
        if last_sign != 0.0 and sign != last_sign:
            reversals += 1.0        # a full-scale reversal: rail to rail
        last_sign = sign
    return sat_time, last_sign, reversals


@njit(cache=True)
def control_step(P, k, r1, r2, ref, vref, fref, c, ps_nom):
    """One controller cycle for both cylinders: sample the encoders, PID + feed-forward, command the valves.

    Updates the controller state vector ``c`` in place (PID states, valve
    voltages, saturation time and reversals; layout ``C_*``). (The compiled loop calls the same scalar functions
    with its state in registers; this array form serves the ``solve_ivp`` route.)

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
    c : ndarray, shape (N_CTRL,)
        Controller state and outputs (modified in place).
    ps_nom : float
        Supply pressure assumed by the feed-forward, Pa.
    """
    for i in range(2):
        meas = encoder(P, r1 if i == 0 else r2)
        c[C_U1 + i], un, c[C_INTEG1 + i], c[C_DFILT1 + i], c[C_PREV1 + i] = _pid(
            P, meas, ref[i, k], vref[i, k], fref[i, k], c[C_INTEG1 + i], c[C_DFILT1 + i], c[C_PREV1 + i], ps_nom)
        c[C_SAT1 + i], c[C_SIGN1 + i], c[C_REV1 + i] = _saturation(P, un, c[C_SAT1 + i], c[C_SIGN1 + i],
                                                                   c[C_REV1 + i])


@njit(cache=True)
def _cylinder_step(P, i, u, xv, vv, pA, pB, r, v, ps, h):
    """One plant step of drive ``i`` (0 or 1): spool, valve flows, force, chamber pressures, energy terms.

    Everything is passed and returned as scalars, so the compiled loop keeps the state in registers.

    Returns
    -------
    tuple
        ``xv, vv, pA, pB, F, qP, dqP, cav, e_valve, e_tank, e_leak, e_comp, e_fric, e_stop, e_work``: new
        spool position and speed, new chamber pressures, net force on the piston (N), flow drawn from the
        supply and its slope, whether a chamber was clamped at 0 bar, and this step's energy terms (J).
    """
    # spool: exact discretisation, clipped at its mechanical stops
    un = u / P[I_UMAX]
    x_new = P[I_PHI00] * xv + P[I_PHI01] * vv + P[I_GAM0] * un
    v_new = P[I_PHI10] * xv + P[I_PHI11] * vv + P[I_GAM1] * un
    if x_new > 1.0:
        x_new = 1.0
        v_new = min(v_new, 0.0)
    elif x_new < -1.0:
        x_new = -1.0
        v_new = max(v_new, 0.0)
    qA, qB, qP, dqA, dqB, dqP, loss = valve_flows(x_new, ps, P[I_PT], pA, pB, P[I_KV], P[I_OVERLAP], P[I_PLAM])
    fh, fric, stop, VA, VB = _cylinder(P, i, pA, pB, r, v)
    ql = P[I_CLEAK] * (pA - pB)
    netA = qA - P[I_AP] * v - ql
    netB = qB + P[I_AA] * v + ql
    e_tank = h * P[I_PT] * (-qB if qB < 0.0 else 0.0) + h * P[I_PT] * (-qA if qA < 0.0 else 0.0)
    e_comp = h * (pA * netA + pB * netB)
    # linearly implicit pressure update
    fA = P[I_BETA] / VA * netA
    jA = P[I_BETA] / VA * (dqA - P[I_CLEAK])
    fB = P[I_BETA] / VB * netB
    jB = P[I_BETA] / VB * (dqB - P[I_CLEAK])
    pA_new = pA + h * fA / (1.0 - h * jA)
    pB_new = pB + h * fB / (1.0 - h * jB)
    cav = False
    if pA_new < 0.0:
        pA_new = 0.0
        cav = True
    if pB_new < 0.0:
        pB_new = 0.0
        cav = True
    return (x_new, v_new, pA_new, pB_new, fh - fric + stop, qP, dqP, cav, h * loss, e_tank, h * ql * (pA - pB),
            e_comp, h * fric * v, -h * stop * v, h * fh * v)


@njit(cache=True)
def _run(P, y, c, ref, vref, fref, n_steps, substeps, log_every, energy, log, tail):
    """The closed loop over ``n_steps`` control steps, starting from and updating ``y`` in place.

    The plant state lives in scalars for the whole loop; the geometry computed for the divergence watch at
    the end of a control step is the controller's sample at the start of the next.
    """
    dt = P[I_DT]
    h = P[I_H]
    a, b, ad, bd = y[0], y[1], y[2], y[3]
    pA0, pB0, pA1, pB1 = y[4], y[5], y[6], y[7]
    xv0, vv0, xv1, vv1 = y[8], y[9], y[10], y[11]
    ps = y[12]
    F0 = 0.0
    F1 = 0.0
    qpump = 0.0
    qrel = 0.0
    e_pump, e_rel, e_valve, e_tank, e_leak = energy[0], energy[1], energy[2], energy[3], energy[4]
    e_comp, e_fric, e_stop, e_work = energy[5], energy[6], energy[7], energy[8]
    cav_time = c[C_CAV]
    sat0, sat1, sign0, sign1, rev0, rev1 = c[C_SAT1], c[C_SAT2], c[C_SIGN1], c[C_SIGN2], c[C_REV1], c[C_REV2]
    integ0, integ1, dfilt0, dfilt1, prev0, prev1 = c[C_INTEG1], c[C_INTEG2], c[C_DFILT1], c[C_DFILT2], c[C_PREV1], \
        c[C_PREV2]
    u0, u1 = c[C_U1], c[C_U2]
    il = 0
    ps_nom = P[I_PCOMP] - P[I_PBAND]   # supply pressure while the pump delivers (for the feed-forward)
    r1, r2, h1, h2 = _geometry(P, a, b)
    for k in range(n_steps + 1):
        t = k * dt
        if k == n_steps and not tail:
            break
        # ---- controller (sample, decide, command): the scalar form of control_step ----
        u0, un0, integ0, dfilt0, prev0 = _pid(P, encoder(P, r1), ref[0, k], vref[0, k], fref[0, k], integ0, dfilt0,
                                              prev0, ps_nom)
        u1, un1, integ1, dfilt1, prev1 = _pid(P, encoder(P, r2), ref[1, k], vref[1, k], fref[1, k], integ1, dfilt1,
                                              prev1, ps_nom)
        sat0, sign0, rev0 = _saturation(P, un0, sat0, sign0, rev0)
        sat1, sign1, rev1 = _saturation(P, un1, sat1, sign1, rev1)
        if k % log_every == 0:
            log[il, 0] = t
            log[il, 1] = a
            log[il, 2] = b
            log[il, 3] = ad
            log[il, 4] = bd
            log[il, 5] = r1
            log[il, 6] = r2
            log[il, 7] = ref[0, k]
            log[il, 8] = ref[1, k]
            log[il, 9] = u0
            log[il, 10] = u1
            log[il, 11] = xv0
            log[il, 12] = xv1
            log[il, 13] = pA0
            log[il, 14] = pB0
            log[il, 15] = pA1
            log[il, 16] = pB1
            log[il, 17] = ps
            log[il, 18] = qpump
            log[il, 19] = qrel
            log[il, 20] = F0
            log[il, 21] = F1
            il += 1
        if k == n_steps:
            break
        # ---- plant ----
        for _ in range(substeps):
            sa = math.sin(a)
            ca = math.cos(a)
            sb = math.sin(b)
            cb = math.cos(b)
            r1, r2, h1, h2 = pin_geometry(P, math.cos(0.5 * a), math.sin(0.5 * b), sa, sb)
            v0 = h1 * ad
            v1 = h2 * bd
            (xv0, vv0, pA0, pB0, F0, qP0, dqP0, cav0, dv0, dt0, dl0, dc0, df0, ds0, dw0) = _cylinder_step(
                P, 0, u0, xv0, vv0, pA0, pB0, r1, v0, ps, h)
            (xv1, vv1, pA1, pB1, F1, qP1, dqP1, cav1, dv1, dt1, dl1, dc1, df1, ds1, dw1) = _cylinder_step(
                P, 1, u1, xv1, vv1, pA1, pB1, r2, v1, ps, h)
            e_valve += dv0 + dv1
            e_tank += dt0 + dt1
            e_leak += dl0 + dl1
            e_comp += dc0 + dc1
            e_fric += df0 + df1
            e_stop += ds0 + ds1
            e_work += dw0 + dw1
            if cav0 or cav1:
                cav_time += h
            qp_total = qP0 + qP1
            qpump, dqpump = pump_flow(ps, P[I_QMAX], P[I_PCOMP], P[I_PBAND])
            qrel, dqrel = relief_flow(ps, P[I_QMAX], P[I_PRELIEF], P[I_RBAND])
            e_pump += h * ps * qpump
            e_rel += h * ps * qrel
            e_comp += h * ps * (qpump - qrel - qp_total)
            fs = P[I_BETA] / P[I_VSUP] * (qpump - qrel - qp_total)
            js = P[I_BETA] / P[I_VSUP] * (dqpump - dqrel - dqP0 - dqP1)
            ps += h * fs / (1.0 - h * js)
            # arm: semi-implicit Euler with the full mass matrix
            acc_a, acc_b = _accelerations(P, sa, ca, sb, cb, ad, bd, F0 * h1, F1 * h2)
            ad += h * acc_a
            bd += h * acc_b
            a += h * ad
            b += h * bd
        # ---- divergence watch (its geometry is the next control step's sample) ----
        r1, r2, h1, h2 = _geometry(P, a, b)
        code = 0
        if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(ad) and math.isfinite(bd)
                and math.isfinite(ps) and math.isfinite(pA0 + pA1 + pB0 + pB1)):
            code = 1
        elif max(ps, pA0, pA1, pB0, pB1) > 10.0 * P[I_PRELIEF]:
            code = 2
        elif abs(ad) > 10.0 or abs(bd) > 10.0:
            code = 3
        elif abs(ref[0, k] - r1) > P[I_FELIM] or abs(ref[1, k] - r2) > P[I_FELIM]:
            code = 4
        elif max(rev0, rev1) > 20.0 + 2.0 * (k + 1) * dt:
            code = 5
        if code:
            c[C_FAIL] = code
            c[C_FAIL_T] = (k + 1) * dt
            break
    c[C_CAV] = cav_time
    c[C_SAT1], c[C_SAT2], c[C_SIGN1], c[C_SIGN2], c[C_REV1], c[C_REV2] = sat0, sat1, sign0, sign1, rev0, rev1
    c[C_INTEG1], c[C_INTEG2], c[C_DFILT1], c[C_DFILT2], c[C_PREV1], c[C_PREV2] = integ0, integ1, dfilt0, dfilt1, \
        prev0, prev1
    c[C_U1], c[C_U2] = u0, u1
    energy[0], energy[1], energy[2], energy[3], energy[4] = e_pump, e_rel, e_valve, e_tank, e_leak
    energy[5], energy[6], energy[7], energy[8] = e_comp, e_fric, e_stop, e_work
    y[0], y[1], y[2], y[3] = a, b, ad, bd
    y[4], y[6], y[5], y[7] = pA0, pA1, pB0, pB1
    y[8], y[10], y[9], y[11] = xv0, xv1, vv0, vv1
    y[12] = ps
    return il


@njit(cache=True)
def controller_at_rest(P, y):
    """A fresh controller state vector for a plant at rest in state ``y``: PID cleared, valves centred, the
    encoders' first readings as the previous sample.

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    y : ndarray, shape (N_STATE,)
        Plant state.

    Returns
    -------
    ndarray, shape (N_CTRL,)
    """
    c = np.zeros(N_CTRL)
    c[C_PREV1], c[C_PREV2] = first_readings(P, y[0], y[1])
    return c


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
    y0 : ndarray, shape (N_STATE,)
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
    c : ndarray, shape (N_CTRL,)
        The controller state at the end: ``c[C_FAIL]`` failure code, ``c[C_FAIL_T]`` its time,
        ``c[C_CAV]`` cavitation time, ``c[C_SAT1]``, ``c[C_SAT2]`` saturated times, ``c[C_NLOG]`` rows
        logged, ``c[C_REV1]``, ``c[C_REV2]`` rail-to-rail reversals.
    """
    n_log = n_steps // log_every + 1
    log = np.full((n_log, 22), np.nan)
    energy = np.zeros(9)
    y = y0.copy()
    c = controller_at_rest(P, y)
    # the parameters as a fixed-size tuple: passed by value to every helper, no reference counting per call
    il = _run(to_fixed_tuple(P, N_PARAMS), y, c, ref, vref, fref, n_steps, substeps, log_every, energy, log, True)
    c[C_NLOG] = il
    return log, energy, c


@njit(cache=True)
def advance(P, y, c, ref, vref, fref, n_steps, substeps):
    """Run the closed loop for ``n_steps`` control steps from plant state ``y`` and controller state ``c``,
    updating both in place (the stateful form of the live-guidance runs: see :class:`ServoState`).

    Parameters
    ----------
    P : ndarray
        Parameter vector.
    y : ndarray, shape (N_STATE,)
        Plant state (updated).
    c : ndarray, shape (N_CTRL,)
        Controller state (updated).
    ref, vref, fref : ndarray, shape (2, n_steps + 1)
        References for this stretch.
    n_steps, substeps : int
        Control steps and plant steps per control step.

    Returns
    -------
    int
        Failure code (0 = fine, see :func:`fail_reason`).
    """
    energy = np.zeros(9)
    log = np.zeros((1, 22))
    _run(to_fixed_tuple(P, N_PARAMS), y, c, ref, vref, fref, n_steps, substeps, n_steps + 1, energy, log, False)
    return int(c[C_FAIL])


class ServoState:
    """The mutable state of the two servo drives between calls (like MuJoCo's ``MjData``).

    Parameters
    ----------
    y : ndarray, shape (N_STATE,)
        Plant state: ``alpha, beta, alpha', beta', pA1, pB1, pA2, pB2, xv1, vv1, xv2, vv2, ps``.
    c : ndarray, shape (N_CTRL,)
        Controller state (layout ``C_*``).
    """

    __slots__ = ("y", "c")

    def __init__(self, y: np.ndarray, c: np.ndarray):
        self.y = np.asarray(y, dtype=float)
        self.c = np.asarray(c, dtype=float)
        if self.y.shape != (N_STATE,) or self.c.shape != (N_CTRL,):
            raise ValueError(f"ServoState needs y of shape ({N_STATE},) and c of shape ({N_CTRL},), "
                             f"got {self.y.shape} and {self.c.shape}")

    @classmethod
    def at_rest(cls, P, y0: np.ndarray) -> "ServoState":
        """A plant at rest in ``y0`` with a fresh controller.

        Parameters
        ----------
        P : ndarray
            Parameter vector.
        y0 : ndarray, shape (N_STATE,)
            Plant state.

        Returns
        -------
        ServoState
        """
        y = np.array(y0, dtype=float)
        return cls(y, controller_at_rest(P, y))

    @property
    def joints(self) -> tuple[float, float]:
        """Alpha and beta, rad."""
        return float(self.y[0]), float(self.y[1])

    @property
    def valve_commands(self) -> tuple[float, float]:
        """Last valve voltages, V."""
        return float(self.c[C_U1]), float(self.c[C_U2])

    @property
    def failure(self) -> int:
        """Failure code of the last run (0 = none)."""
        return int(self.c[C_FAIL])


def fail_reason(code: int) -> str:
    """Text of a divergence code returned by :func:`simulate_loop`.

    Parameters
    ----------
    code : int
        The controller state's ``c[C_FAIL]``.

    Returns
    -------
    str
    """
    return _FAIL_SIGNALS[int(code)]
