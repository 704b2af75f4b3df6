"""Physics of the electro-hydraulic loop, each against a textbook law or a reference route.

Stated tolerances and why:
* orifice law: 5e-4 relative: the only difference is the laminar regularisation,
  (1 + (p_lam/dp)^2)^(-1/4) = 1 - 2e-4 at dp = 35 bar, p_lam = 1 bar;
* pressure build-up: 2e-3 relative: analytic solution of the same ODE; error from the
  linearly implicit step (h = 0.25 ms) and regularisation;
* natural frequency: 1 %: small-amplitude linear theory against the nonlinear model;
* static hold: hydraulic force within the Coulomb friction (it can hold part of the load
  at rest) plus 0.5 %;
* energy: 0.5 % of the pump energy;
* fixed step against solve_ivp: per signal (Hopsan style), see REFERENCE_TOL.
"""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from loadarm.arm.dynamics import cylinder_areas, mass_model, moment_arms, static_torques
from loadarm.design.trajectory import plan_approach
from loadarm.hydraulics import circuit as plant
from loadarm.hydraulics.components import (
    effective_opening,
    orifice_flow,
    orifice_slope,
    pump_flow,
    relief_flow,
    spool_discretisation,
    valve_coefficient,
    valve_flows,
)
from loadarm.hydraulics.reference import cylinder_rig, reference_simulation
from loadarm.hydraulics.simulate import SimulationError, simulate_approach, simulate_hold
from loadarm.params.compiler import compile_model
from loadarm.params.config import parse_config


def test_valve_flow_matches_the_orifice_equation(inst):
    v = inst.valve
    kv = valve_coefficient(v.nominal_flow, v.nominal_pressure_drop)
    half = v.nominal_pressure_drop / 2
    # full opening at the rated drop per land gives the rated flow
    qA, qB, qP, *_ = valve_flows(1.0, 100e5 + half, 0.0, 100e5, half, kv, 0.0, v.laminar_pressure)
    assert qA == pytest.approx(v.nominal_flow, rel=5e-4)
    assert qB == pytest.approx(-v.nominal_flow, rel=5e-4) and qP == qA
    # Q = kv x sqrt(dp) for other openings and drops, both directions
    for x, dp in ((0.3, 80e5), (0.7, 20e5), (-0.5, 50e5)):
        qA, qB, *_ = valve_flows(x, 200e5, 0.0, 200e5 - dp if x > 0 else dp, 200e5 - dp if x < 0 else dp, kv, 0.0,
                                 v.laminar_pressure)
        expect = kv * abs(x) * math.sqrt(dp)
        # the laminar regularisation lowers the flow by at most (p_lam / dp)^2 / 4
        assert abs(qA if x > 0 else qB) == pytest.approx(expect, rel=(v.laminar_pressure / dp) ** 2 / 4 + 1e-9)


@given(st.floats(-1, 1), st.floats(0, 0.4))
def test_overlap_is_a_deadband(x, ov):
    xe = effective_opening(x, ov)
    if abs(x) <= ov:
        assert xe == 0.0
    else:
        assert math.copysign(1, xe) == math.copysign(1, x) and abs(xe) <= 1.0 + 1e-12


@given(st.floats(-300e5, 300e5), st.floats(1e3, 5e5))
def test_orifice_slope_is_the_derivative(dp, plam):
    k = 3e-7
    h = max(abs(dp) * 1e-6, 1.0)
    fd = (orifice_flow(k, dp + h, plam) - orifice_flow(k, dp - h, plam)) / (2 * h)
    assert orifice_slope(k, dp, plam) == pytest.approx(fd, rel=1e-4, abs=1e-16)


def test_pump_and_relief_laws(inst):
    p = inst.pump
    assert pump_flow(p.compensator_pressure - 2 * p.regulation_band, p.max_flow, p.compensator_pressure,
                     p.regulation_band)[0] == p.max_flow
    assert pump_flow(p.compensator_pressure - 0.5 * p.regulation_band, p.max_flow, p.compensator_pressure,
                     p.regulation_band)[0] == pytest.approx(0.5 * p.max_flow)
    assert pump_flow(p.compensator_pressure, p.max_flow, p.compensator_pressure, p.regulation_band)[0] == 0.0
    assert relief_flow(p.relief_pressure - 1, p.max_flow, p.relief_pressure, p.relief_band)[0] == 0.0
    assert relief_flow(p.relief_pressure + p.relief_band, p.max_flow, p.relief_pressure,
                       p.relief_band)[0] == pytest.approx(p.max_flow)


def test_spool_discretisation_is_exact():
    omega, zeta, dt = 2 * math.pi * 30, 0.7, 0.01
    Phi, Gam = spool_discretisation(omega, zeta, dt)
    # step response of a second-order system, closed form
    wd = omega * math.sqrt(1 - zeta ** 2)
    x = np.zeros(2)
    for n in range(1, 20):
        x = Phi @ x + Gam * 1.0
        t = n * dt
        exact = 1 - math.exp(-zeta * omega * t) * (math.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2) * math.sin(wd * t))
        assert x[0] == pytest.approx(exact, abs=1e-12)


def test_chamber_pressure_build_up_follows_the_bulk_modulus_law(model, inst):
    """Piston held, valve open 20 %: dp/dt = beta/V kv x sqrt(ps - p), solved exactly."""
    ps, p0, x0, spool = 210e5, 50e5, 0.3, 0.2
    r = cylinder_rig(model, mass=1e15, duration=0.2, x0=x0, spool=spool, pA0=p0, pB0=0.0, supply=ps,
                     overrides={"I_CLEAK": 0.0, "I_FC": 0.0, "I_BVISC": 0.0})
    cy = inst.cylinders
    Ap, _ = cylinder_areas(cy.bore, cy.rod)
    V = cy.dead_volume + Ap * x0
    kv = valve_coefficient(inst.valve.nominal_flow, inst.valve.nominal_pressure_drop)
    c = cy.bulk_modulus / V * kv * spool
    t = r["t"]
    exact = ps - (math.sqrt(ps - p0) - c * t / 2) ** 2
    ok = ps - exact > 20e5            # stay out of the laminar region near the end
    ok &= t < 2 * math.sqrt(ps - p0) / c
    assert ok.sum() > 100
    assert np.allclose(r["pA"][ok], exact[ok], rtol=2e-3)
    assert np.max(np.abs(r["x"] - x0)) < 1e-9          # the piston really was held


def test_hydraulic_natural_frequency_matches_the_textbook(model, inst):
    """Closed valve, no friction, no leakage: omega = sqrt(beta (Ap^2/VA + Aa^2/VB) / m)."""
    cy = inst.cylinders
    Ap, Aa = cylinder_areas(cy.bore, cy.rod)
    m, x0 = 5e4, 0.4
    stroke = cy.length_range_1[1] - cy.length_range_1[0]
    VA, VB = cy.dead_volume + Ap * x0, cy.dead_volume + Aa * (stroke - x0)
    pB0 = 50e5
    pA0 = pB0 * Aa / Ap                        # force balance at rest
    r = cylinder_rig(model, mass=m, duration=3.0, x0=x0, spool=0.0, force=2e3, pA0=pA0, pB0=pB0,
                     overrides={"I_CLEAK": 0.0, "I_FC": 0.0, "I_BVISC": 0.0})
    x = r["x"] - np.mean(r["x"])
    crossings = np.flatnonzero(np.diff(np.sign(x)) != 0)
    period = 2 * np.mean(np.diff(r["t"][crossings]))
    omega_sim = 2 * math.pi / period
    omega_text = math.sqrt(cy.bulk_modulus * (Ap ** 2 / VA + Aa ** 2 / VB) / m)
    assert omega_sim == pytest.approx(omega_text, rel=0.01)
    # single-chamber form of the issue, sqrt(beta A^2 / (V m)), is the lower bound of the two-chamber value
    assert omega_text > math.sqrt(cy.bulk_modulus * Ap ** 2 / (VA * m))


def test_static_hold_balances_the_gravity_torques(model, inst):
    """Start both drives at 50 bar in both chambers; the loop must end holding the static torques."""
    alpha, beta = 0.6, 0.9
    h = simulate_hold(model, alpha, beta, 60.0, pressures=(50e5, 50e5, 50e5, 50e5))
    cy = inst.cylinders
    Ap, Aa = cylinder_areas(cy.bore, cy.rod)
    ta, tb = static_torques(mass_model(model), alpha, beta)
    h1, h2 = moment_arms(model.mount, alpha, beta)
    for i, (tau, arm) in enumerate(((ta, h1), (tb, h2)), start=1):
        f_need = float(tau / arm)
        f_hyd = h[f"pA{i}"][-1] * Ap - h[f"pB{i}"][-1] * Aa
        assert abs(f_hyd - f_need) <= cy.coulomb_friction * 1.05 + 0.005 * abs(f_need)
        assert abs(h[f"r{i}"][-1] - h[f"r{i}_ref"][-1]) < 5 * inst.encoder.resolution
    assert abs(h["alpha"][-1] - alpha) < 1e-4 and abs(h["beta"][-1] - beta) < 1e-4


def test_hold_from_static_pressures_does_not_move(model):
    # started with the static holding pressures (the other chamber at return pressure), the arm settles
    # into the loop's stiffness: both cylinders stay within half a millimetre of their reference
    h = simulate_hold(model, 0.6, 0.9, 5.0)
    for i in (1, 2):
        assert np.max(np.abs(h[f"r{i}"] - h[f"r{i}_ref"])) < 5e-4


@pytest.fixture(scope="module")
def smooth_run(request):
    from loadarm.params.config import paper_installation
    inst = paper_installation()
    model = compile_model(inst)
    plan = plan_approach(model, timing="smooth", samples=2001)
    return inst, plan, simulate_approach(model, plan)


def test_energy_bookkeeping_closes(smooth_run):
    _, _, r = smooth_run
    e = r.energy
    assert e["pump"] > 0 and e["valve"] > 0 and e["friction"] > 0 and e["leakage"] >= 0
    # the cylinders' work on the arm equals the change of its mechanical energy (an independent computation)
    assert e["cylinder_work"] - e["friction"] == pytest.approx(e["mechanical"] + e["end_stop"],
                                                                                 rel=5e-3)
    assert abs(e["balance_error"]) < 5e-3 * e["pump"]


def test_default_approach_is_accurate(smooth_run):
    inst, plan, r = smooth_run
    m = r.summary()
    assert m["max_deviation_mm"] < 25 and m["rms_deviation_mm"] < 6
    assert m["arrival_time_s"] is not None and abs(m["arrival_time_s"] - plan.duration) < 2.0
    assert m["final_position_error_mm"] < 3
    assert m["max_chamber_pressure_bar"] < inst.cylinders.max_pressure / 1e5
    assert m["warnings"] == []
    assert np.all(np.isfinite(r.deviation))


REFERENCE_TOL = {"alpha": 5e-5, "beta": 5e-5, "pA1": 0.5e5, "pB1": 0.5e5, "pA2": 0.5e5, "pB2": 0.5e5, "ps": 0.1e5,
                 "u1": 0.01, "u2": 0.01}


def test_fixed_step_simulator_matches_solve_ivp_reference(model, smooth_run):
    inst, plan, _ = smooth_run
    fast = simulate_approach(model, plan, log_rate=inst.controller.rate)
    ref = reference_simulation(model, plan, 3.0)
    n = ref["t"].size
    assert np.allclose(fast.signals["t"][:n], ref["t"])
    for name, tol in REFERENCE_TOL.items():
        assert np.max(np.abs(fast.signals[name][:n] - ref[name])) < tol, name


def test_substeps_converge(model, smooth_run):
    inst, plan, r = smooth_run
    fine = simulate_approach(model, plan, substeps=16).summary()
    assert fine["max_deviation_mm"] == pytest.approx(r.summary()["max_deviation_mm"], rel=0.02)


def test_paper_timing_deviates_more_than_smooth(model, smooth_run):
    inst, _, r = smooth_run
    paper = simulate_approach(model, plan_approach(model, timing="paper", samples=2001)).summary()
    assert paper["max_deviation_mm"] > 2 * r.summary()["max_deviation_mm"]


@pytest.mark.parametrize("gains", [{"kp": 1e4}, {"kp": 1e6, "ki": 1e5}])
def test_unstable_gains_stop_with_a_clear_message(model, smooth_run, gains):
    inst, plan, _ = smooth_run
    with pytest.raises(SimulationError, match=r"simulation stopped at t = .* s: .*check the controller gains"):
        simulate_approach(model, plan, gains=gains)


def test_bad_simulation_arguments(model, smooth_run):
    inst, plan, _ = smooth_run
    with pytest.raises(ValueError, match="unknown gain"):
        simulate_approach(model, plan, gains={"kq": 1.0})
    with pytest.raises(ValueError, match=r"substeps must be in \[1, 1000\]"):
        simulate_approach(model, plan, substeps=0)
    d = inst.model_dump()
    d["pump"]["relief_pressure"] = 100e5
    with pytest.raises(ValueError, match="relief_pressure"):
        parse_config(d)


def test_optimal_timing_respects_every_limit_between_grid_points(inst):
    d = inst.model_dump()
    d["approach"]["max_cylinder_accel"] = 0.001      # make the cylinder limits bind
    tight = compile_model(parse_config(d))
    p = plan_approach(tight, timing="optimal", samples=20001)
    smooth = plan_approach(tight, timing="smooth", samples=20001)
    dt = p.t[1] - p.t[0]
    tol = 1 + 3e-3                                    # the dense check in ToppraTiming allows 2e-3
    assert np.hypot(p.vx, p.vy).max() <= tight.approach.max_speed * tol
    for v in (p.v_ac1, p.v_ac2):
        assert np.max(np.abs(np.diff(v)) / dt) <= 0.001 * tol
    # the smooth trapezoid ignores the cylinder limit; optimal is slower but legal
    assert max(np.max(np.abs(np.diff(v)) / dt) for v in (smooth.v_ac1, smooth.v_ac2)) > 0.001 * tol
    assert p.duration > smooth.duration


def test_optimal_equals_trapezoid_when_only_the_path_limits_bind(model):
    p = plan_approach(model, timing="optimal", samples=2001)
    s = plan_approach(model, timing="smooth", samples=2001)
    assert p.duration == pytest.approx(s.duration, rel=2e-3)
    assert p.duration >= s.duration * (1 - 1e-4)      # nothing beats the trapezoid under path limits alone


def test_plant_parameters_vector_is_complete(model, inst):
    """Every slot of the parameter vector has exactly one named index and is filled.

    Found weak: `isfinite` on a zero-initialised vector could not fail. The vector now starts as NaN, and the
    named indices must cover 0..N_PARAMS-1 once each.
    """
    from loadarm.hydraulics.simulate import pack_parameters
    idx = sorted(v for k, v in vars(plant).items() if k.startswith("I_") and isinstance(v, int))
    assert idx == list(range(plant.N_PARAMS)), "gaps or duplicates among plant.I_* indices"
    P = pack_parameters(model)
    assert P.shape == (plant.N_PARAMS,) and np.all(np.isfinite(P))
    assert P[plant.I_FELIM] == inst.controller.following_error_limit


def test_plant_geometry_is_the_vectorised_formula_bit_for_bit(model):
    """The 1 kHz plant compiles actuators.pin_geometry itself: given the same sines and cosines it returns the
    same bits as the NumPy route, over the whole joint range including nearly closed pin triangles
    (alpha -> pi, beta -> 0). Only the trigonometric inputs may differ between NumPy and libm (<= 1 ulp), so
    the plant's full _geometry is held to 1e-14 m of actuators.cylinder_lengths / moment_arms."""
    from loadarm.arm.actuators import cylinder_lengths, moment_arms, pin_lengths, pin_moment_arms
    from loadarm.hydraulics.simulate import pack_parameters

    P = pack_parameters(model)
    mount = model.mount
    a = np.concatenate([np.linspace(0.0, np.pi, 400), np.pi - np.logspace(-8, -1, 50)])
    b = np.concatenate([np.linspace(0.0, np.pi, 400), np.logspace(-8, -1, 50)])
    trig = (np.cos(0.5 * a), np.sin(0.5 * b), np.sin(a), np.sin(b))
    m4 = (mount.a1, mount.b1, mount.b2, mount.c2)
    rr = pin_lengths(*m4, trig[0], trig[1])
    vec = (*rr, *pin_moment_arms(*m4, trig[2], trig[3], *rr))
    for k in range(a.size):
        one = plant.pin_geometry(P, *(float(t[k]) for t in trig))
        assert one == tuple(float(v[k]) for v in vec), k
    r1, r2 = cylinder_lengths(mount, a, b)
    h1, h2 = moment_arms(mount, a, b)
    got = np.array([plant._geometry(P, ai, bi) for ai, bi in zip(a, b)])
    assert np.max(np.abs(got[:, 0] - r1)) < 1e-14 and np.max(np.abs(got[:, 1] - r2)) < 1e-14
    assert np.max(np.abs(got[:, 2] - h1)) < 1e-14 and np.max(np.abs(got[:, 3] - h2)) < 1e-14


def test_the_plant_dynamics_is_the_vectorised_formula_bit_for_bit(model):
    """Issue 26: the 1 kHz plant compiles dynamics.lagrange_terms itself (the mass matrix was written twice).
    Given the same sines and cosines, the compiled terms are the NumPy route's bits; and the plant's joint
    accelerations, put back through joint_torques (the vectorised inverse dynamics), return the torques to
    1e-9 relative (two 2x2 solves' rounding, against torques of order 1e5 N m)."""
    from loadarm.arm.dynamics import G, joint_torques, lagrange_constants, lagrange_terms
    from loadarm.hydraulics.simulate import pack_parameters

    mm = model.mass
    k = lagrange_constants(mm)
    P = pack_parameters(model)
    rng = np.random.default_rng(26)
    a, b = rng.uniform(0.1, 3.0, 300), rng.uniform(0.05, 3.0, 300)
    ad, bd = rng.uniform(-0.3, 0.3, 300), rng.uniform(-0.3, 0.3, 300)
    sa, sb, cb = np.sin(a), np.sin(b), np.cos(b)
    sab = np.sin(a - b)
    vec = lagrange_terms(k.k11, k.k22, k.k_c, k.g_a, k.g_ab, G, sa, sab, sb, cb, ad, bd)
    for i in range(a.size):
        one = plant.lagrange_terms(k.k11, k.k22, k.k_c, k.g_a, k.g_ab, G, float(sa[i]), float(sab[i]), float(sb[i]),
                                   float(cb[i]), float(ad[i]), float(bd[i]))
        assert one == tuple(float(np.broadcast_to(v, a.shape)[i]) for v in vec), i
    ta, tb = rng.uniform(-2e5, 2e5, 300), rng.uniform(-2e5, 2e5, 300)
    for i in range(0, a.size, 10):
        add, bdd = plant.arm_accelerations(P, float(a[i]), float(b[i]), float(ad[i]), float(bd[i]), float(ta[i]),
                                           float(tb[i]))
        t1, t2 = joint_torques(mm, a[i], b[i], ad[i], bd[i], add, bdd)
        assert abs(float(t1) - ta[i]) < 1e-9 * 2e5 and abs(float(t2) - tb[i]) < 1e-9 * 2e5
