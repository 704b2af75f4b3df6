"""Sizing (paper Eqs 1-3) and envelope zones."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.envelope import (AlarmAngles, Zone, alarms_from_installation, berth_box, classify_beta,
                              classify_point, zone_radii)
from loadarm.errors import SizingError
from loadarm.geometry import Arm
from loadarm.kinematics import forward
from loadarm.sizing import alarm_radius, check_corners, first_alarm_corner, size_arm, size_installation

B123 = math.radians(123.0)


def test_paper_first_alarm_corner_and_radius(inst):
    X, Y = first_alarm_corner(inst)
    assert X == pytest.approx(2.5 + 1.7 + 1 + 4.6 - 1 + 4.7) and X == pytest.approx(13.5)
    assert Y == pytest.approx(3.8 + 2.4 - 1.5) and Y == pytest.approx(4.7)
    assert alarm_radius(7.0, X, Y) == pytest.approx(math.sqrt(11.7**2 + 13.5**2), rel=1e-15)


def test_paper_sizing_reproduces_b12_c82(inst):
    res = size_installation(inst)
    assert res.inboard == pytest.approx(12.0, abs=1e-9)
    # the paper quotes c to one decimal: 8.2 m; the exact optimum is 8.2242 m
    assert round(res.outboard, 1) == 8.2
    assert res.outboard == pytest.approx(8.224242, abs=1e-6)
    assert "inboard upper bound" in res.active_bound
    # Eq. 2 holds at the optimum: the cosine law gives back r_al
    assert Arm(7, res.inboard, res.outboard).radius_at_beta(B123) == pytest.approx(res.r_alarm, rel=1e-12)


def test_optimum_sits_on_a_bound_and_is_global():
    # wider bounds: two local minima (one on each arm's upper bound); the global one is returned
    res = size_arm(7.0, 13.5, 4.7, B123, (8.0, 14.0), (4.0, 12.0))
    assert len(res.local_minima) == 2
    totals = [b + c for b, c in res.local_minima]
    assert res.total == pytest.approx(min(totals))
    assert res.inboard == pytest.approx(14.0)


@settings(max_examples=40)
@given(st.floats(8.0, 14.0), st.floats(4.0, 12.0))
def test_result_independent_of_starting_point(b0, c0):
    ref = size_arm(7.0, 13.5, 4.7, B123, (8.0, 14.0), (4.0, 12.0))
    res = size_arm(7.0, 13.5, 4.7, B123, (8.0, 14.0), (4.0, 12.0), x0=(b0, c0))
    assert res.inboard == pytest.approx(ref.inboard, abs=1e-7)
    assert res.outboard == pytest.approx(ref.outboard, abs=1e-7)


@settings(max_examples=60)
@given(st.floats(5.0, 15.0), st.floats(5.0, 25.0), st.floats(0.0, 10.0), st.floats(60.0, 160.0))
def test_sizing_beats_brute_force(a, X, Y, beta_deg):
    """Independent route: brute-force the constraint curve on a fine grid of b."""
    beta = math.radians(beta_deg)
    bounds_b, bounds_c = (3.0, 20.0), (3.0, 20.0)
    try:
        res = size_arm(a, X, Y, beta, bounds_b, bounds_c)
    except SizingError:
        return
    r = alarm_radius(a, X, Y)
    b = np.linspace(*bounds_b, 200001)
    cb = math.cos(beta)
    disc = r * r - b * b * (1 - cb * cb)
    best = math.inf
    for sign in (1, -1):
        c = b * cb + sign * np.sqrt(np.where(disc >= 0, disc, np.nan))
        ok = (disc >= 0) & (c >= bounds_c[0]) & (c <= bounds_c[1])
        if ok.any():
            best = min(best, float(np.min((b + c)[ok])))
    assert res.total <= best + 1e-6
    assert res.constraint_residual < 1e-7


def test_infeasible_bounds_say_which_reach_is_missing():
    with pytest.raises(SizingError, match=r"longest arm allowed \(b <= 6 m, c <= 5 m\) reaches only"):
        size_arm(7.0, 13.5, 4.7, B123, (4.0, 6.0), (3.0, 5.0))
    with pytest.raises(SizingError, match="every arm inside the bounds is too long"):
        size_arm(7.0, 13.5, 4.7, B123, (15.0, 20.0), (15.0, 20.0))
    with pytest.raises(SizingError, match=r"bounds must satisfy 0 < low <= high"):
        size_arm(7.0, 13.5, 4.7, B123, (12.0, 8.0), (4.0, 10.0))
    with pytest.raises(SizingError, match="first-alarm angle"):
        size_arm(7.0, 13.5, 4.7, 0.0, (8.0, 12.0), (4.0, 10.0))


def test_corner_table_for_sized_and_configured_arm(inst, arm):
    alarms = alarms_from_installation(inst)
    res = size_installation(inst)
    rows = check_corners(Arm(7.0, res.inboard, res.outboard), alarms, inst)
    assert len(rows) == 4
    assert all(r.zone == Zone.NORMAL for r in rows)           # sized arm serves the whole berth
    far_low = rows[3]
    assert math.degrees(far_low.beta) == pytest.approx(123.0, abs=1e-9)
    conf = check_corners(arm, alarms, inst)
    assert conf[3].zone == Zone.FIRST_ALARM                   # c = 8.2 < 8.2242: corner just past 123 deg
    tiny = check_corners(Arm(7.0, 5.0, 4.0), alarms, inst)
    assert any(r.zone == Zone.UNREACHABLE and math.isnan(r.beta) for r in tiny)


def test_berth_box(inst):
    box = berth_box(inst.datasheet)
    assert (box.x_near, box.x_far) == pytest.approx((5.2, 13.5))
    assert (box.y_low, box.y_high) == pytest.approx((-4.7, 11.2))
    assert (box.htl, box.ltl) == pytest.approx((-3.8, -6.2))


def test_classify_beta_boundaries():
    al = AlarmAngles(*np.radians([123.0, 143.0, 150.0]))
    deg = np.array([0.0, 122.9, 123.0, 123.1, 143.0, 143.1, 149.9, 150.0, 170.0, np.nan])
    z = classify_beta(np.radians(deg), al)
    assert z.tolist() == [1, 1, 1, 2, 2, 3, 3, 4, 4, 0]


def test_alarm_angles_validated():
    with pytest.raises(ValueError, match="alarm angles must satisfy"):
        AlarmAngles(2.0, 1.0, 2.5)


@given(st.floats(-25, 25), st.floats(-20, 30))
def test_classify_point_matches_radius_bands(x, y):
    arm = Arm(7.0, 12.0, 8.2)
    al = AlarmAngles(*np.radians([123.0, 143.0, 150.0]))
    radii = zone_radii(arm, al)
    r = math.hypot(x, y - 7.0)
    z = int(classify_point(arm, al, x, y))
    if r > radii["r_max"] + 1e-9 or r < radii["r_min"] - 1e-9:
        assert z == Zone.UNREACHABLE
    elif abs(r - radii["first"]) > 1e-6 and abs(r - radii["second"]) > 1e-6 and abs(r - radii["release"]) > 1e-6:
        expect = 1 + (r > radii["first"]) + (r > radii["second"]) + (r > radii["release"])
        assert z == expect


def test_zone_radii_increase_and_match_forward_kinematics(arm, inst):
    al = alarms_from_installation(inst)
    radii = zone_radii(arm, al)
    vals = [radii[k] for k in ("r_min", "first", "second", "release", "r_max")]
    assert vals == sorted(vals)
    x, y = forward(arm, 0.7, al.first)
    assert math.hypot(x, y - arm.a) == pytest.approx(radii["first"], rel=1e-12)
