"""Cylinder lengths (Eqs 12-13) against pin coordinates, inverse map, valve commands."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from loadarm.arm.actuators import (
    cylinder_lengths,
    cylinder_rates,
    joint_angles_from_cylinders,
    length_limits,
    valve_voltages,
)
from loadarm.arm.geometry import Arm, Mounting
from loadarm.arm.kinematics import forward, inverse
from loadarm.errors import ActuatorError, ValveRangeError


def _pins(arm, m, alpha, beta):
    """Independent route: place the four pins in the plane and measure."""
    top = np.array([0.0, arm.a])
    u_in = np.array([math.sin(alpha), math.cos(alpha)])            # riser top -> elbow
    elbow = top + arm.b * u_in
    u_out = np.array([-math.sin(alpha - beta), -math.cos(alpha - beta)])  # elbow -> coupler
    p1 = top + np.array([0.0, -m.a1])     # on the riser, a1 below the hinge
    q1 = top + m.b1 * u_in                # on the inboard arm
    p2 = elbow - m.b2 * u_in              # on the inboard arm, b2 from the elbow
    q2 = elbow + m.c2 * u_out             # on the outboard arm
    return float(np.linalg.norm(q1 - p1)), float(np.linalg.norm(q2 - p2))


@given(st.floats(0.1, 5), st.floats(0.1, 5), st.floats(0.1, 5), st.floats(0.1, 5),
       st.floats(0.0, math.pi), st.floats(0.0, math.pi))
def test_eqs_12_13_equal_pin_distances(a1, b1, b2, c2, alpha, beta):
    arm = Arm(7, 12, 8.2)
    m = Mounting(a1, b1, b2, c2)
    r1, r2 = cylinder_lengths(m, alpha, beta)
    d1, d2 = _pins(arm, m, alpha, beta)
    assert float(r1) == pytest.approx(d1, abs=1e-12)
    assert float(r2) == pytest.approx(d2, abs=1e-12)


@given(st.floats(0.1, 5), st.floats(0.1, 5), st.floats(0.1, 5), st.floats(0.1, 5),
       st.floats(1e-3, math.pi - 1e-3), st.floats(1e-3, math.pi - 1e-3))
def test_encoder_reading_back_to_position(a1, b1, b2, c2, alpha, beta):
    arm = Arm(7, 12, 8.2)
    m = Mounting(a1, b1, b2, c2)
    r1, r2 = cylinder_lengths(m, alpha, beta)
    a_back, b_back = joint_angles_from_cylinders(m, r1, r2)
    x, y = forward(arm, alpha, beta)
    xb, yb = forward(arm, a_back, b_back)
    # arccos near 0/pi amplifies round-off: error ~ eps / sin(angle)
    tol = 1e-13 / min(math.sin(alpha), math.sin(beta)) * (arm.b + arm.c) + 1e-9
    assert math.hypot(float(xb) - float(x), float(yb) - float(y)) < tol


def test_inverse_map_refuses_impossible_lengths(mount):
    lim = length_limits(mount)
    assert lim["r_ac1"] == (0.0, 2.0) and lim["r_ac2"] == (1.0, 2.0)
    with pytest.raises(ActuatorError, match=r"r_ac1 = 2.5 m is impossible for this mounting: valid range \[0, 2\] m"):
        joint_angles_from_cylinders(mount, 2.5, 1.5)
    with pytest.raises(ActuatorError, match="r_ac2 = 0.5 m"):
        joint_angles_from_cylinders(mount, 1.5, 0.5)
    with pytest.raises(ActuatorError, match="r_ac2 = nan"):
        joint_angles_from_cylinders(mount, 1.5, float("nan"))


def test_cylinder_rates_match_finite_differences(arm, mount):
    t = np.linspace(0, 10, 2001)
    alpha = 0.3 + 0.05 * t + 0.01 * np.sin(t)
    beta = 0.4 + 0.08 * t
    ad = 0.05 + 0.01 * np.cos(t)
    bd = np.full_like(t, 0.08)
    v1, v2 = cylinder_rates(mount, alpha, beta, ad, bd)
    r1, r2 = cylinder_lengths(mount, alpha, beta)
    dt = t[1] - t[0]
    # central differences: truncation error ~ dt^2 |r'''| / 6 < 1e-6 m/s here
    assert np.allclose(np.gradient(r1, dt)[1:-1], v1[1:-1], atol=1e-6)
    assert np.allclose(np.gradient(r2, dt)[1:-1], v2[1:-1], atol=1e-6)


def test_valve_voltages_scale_sign_and_range():
    r1 = np.array([2.0, 1.5, 2.5])
    r2 = np.array([1.0, 1.2, 0.9])
    u = valve_voltages(r1, r2, (2.0, 1.0), volts_per_metre=2.0, valve_range=10.0)
    assert np.allclose(u.u1, [0.0, -1.0, 1.0]) and np.allclose(u.u2, [0.0, 0.4, -0.2])
    u1, u2 = u
    assert u1 is u.u1
    with pytest.raises(ValveRangeError, match=r"u1 \(cylinder 1\) would reach -1.000 V at t = 1.50 s, beyond the valve "
                                              r"range \+/-0.5 V"):
        valve_voltages(r1, r2, (2.0, 1.0), volts_per_metre=2.0, valve_range=0.5, times=np.array([0.0, 1.5, 3.0]))
    with pytest.raises(ValveRangeError, match="volts_per_metre must be > 0"):
        valve_voltages(r1, r2, (2.0, 1.0), volts_per_metre=0.0, valve_range=10.0)
    with pytest.raises(ValveRangeError, match="valve_range_V must be > 0"):
        valve_voltages(r1, r2, (2.0, 1.0), volts_per_metre=1.0, valve_range=-1.0)


def test_mounting_validation():
    with pytest.raises(ValueError, match=r"mounting distance c2 must be in \(0, 20\] m"):
        Mounting(1, 1, 1, 0)


def test_paper_strokes(arm, mount):
    """Paper Fig. 9 case: stroke of each cylinder between stored and flange poses."""
    q = inverse(arm, [3.82, 14.0], [10.40, 1.0])
    r1, r2 = cylinder_lengths(mount, q.alpha, q.beta)
    # a1 = b1 = 1: r_ac1 = 2 cos(alpha/2) exactly
    assert np.allclose(r1, 2 * np.cos(q.alpha / 2), atol=1e-15)
    assert r1[0] - r1[1] == pytest.approx(0.459446, abs=1e-6)   # cylinder 1 retracts
    assert r2[1] - r2[0] == pytest.approx(0.586727, abs=1e-6)   # cylinder 2 extends


@given(st.floats(0.5, 40), st.floats(0.5, 40), st.floats(0.5, 40), st.integers(1, 40000))
def test_fused_solver_equals_separate_routes(a, b, c, n):
    from loadarm.arm.actuators import solve_ik_cylinders
    arm = Arm(a, b, c)
    m = Mounting(1.0, 1.2, 1.5, 0.5)
    rng = np.random.default_rng(n)
    r = rng.uniform(max(arm.r_min, 1e-3), arm.r_max, n)
    ang = rng.uniform(-math.pi, math.pi, n)
    x, y = r * np.sin(ang), a - r * np.cos(ang)
    alpha, beta, r1, r2 = solve_ik_cylinders(arm, m, x, y, chunk=4096)
    q = inverse(arm, x, y)
    c1, c2 = cylinder_lengths(m, q.alpha, q.beta)
    assert np.allclose(beta, q.beta, atol=1e-9)
    assert np.allclose(np.remainder(alpha - q.alpha + math.pi, 2 * math.pi) - math.pi, 0, atol=1e-9)
    # 1 + cos(alpha) from products loses ~sqrt(eps) relative near alpha = pi (cylinder 1 fully closed)
    assert np.allclose(r1, c1, atol=1e-7) and np.allclose(r2, c2, atol=1e-9)
    xf, yf = forward(arm, alpha, beta)
    assert np.max(np.hypot(xf - x, yf - y)) < 1e-9


def test_fused_solver_refuses_unreachable_and_bad_shapes(arm, mount):
    from loadarm.arm.actuators import solve_ik_cylinders
    from loadarm.errors import UnreachableError
    with pytest.raises(UnreachableError, match="beyond the arm's reach"):
        solve_ik_cylinders(arm, mount, np.array([5.0, 40.0]), np.array([5.0, 0.0]))
    with pytest.raises(UnreachableError, match="not a finite number"):
        solve_ik_cylinders(arm, mount, np.array([5.0, np.nan]), np.array([5.0, 0.0]))
    with pytest.raises(ValueError, match="same length"):
        solve_ik_cylinders(arm, mount, np.array([5.0]), np.array([5.0, 0.0]))


def test_coupler_from_encoder_readings_along_the_paper_plan(model, arm, mount):
    from loadarm.arm.actuators import coupler_from_cylinders
    from loadarm.design.trajectory import plan_approach
    p = plan_approach(model, samples=101)
    x, y = coupler_from_cylinders(arm, mount, p.r_ac1, p.r_ac2)
    assert np.max(np.hypot(x - p.x, y - p.y)) < 1e-9
