"""Straight path (Eq. 4) and timing laws (Eq. 14, trapezoid), checked on dense
samples, not only at grid points."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import reach_mask
from loadarm.design.path import StraightPath
from loadarm.design.timing import PaperTiming, TrapezoidTiming, make_timing
from loadarm.errors import PathError, TimingError, UnreachableError


def test_path_evaluation_matches_eq4():
    p = StraightPath((3.82, 10.40), (14.0, 1.0))
    s = np.linspace(0, p.length, 11)
    xy = p(s)
    # Eq. 4: y = (Yf - Y0)/(Xf - X0) (x - X0) + Y0
    assert np.allclose(xy[:, 1], p.slope * (xy[:, 0] - 3.82) + 10.40, atol=1e-12)
    assert np.allclose(xy[-1], (14.0, 1.0))
    assert np.allclose(np.linalg.norm(p(s, 1), axis=1), 1.0)
    assert np.all(p(s, 2) == 0)
    with pytest.raises(PathError, match="order must be"):
        p(s, 3)
    with pytest.raises(PathError, match="arc length s must lie in"):
        p(np.array([-1.0]))


def test_degenerate_and_non_finite_paths():
    with pytest.raises(PathError, match="coincide"):
        StraightPath((1.0, 2.0), (1.0, 2.0))
    with pytest.raises(PathError, match="finite"):
        StraightPath((1.0, float("nan")), (1.0, 2.0))


def test_path_through_the_hole_between_reachable_ends_is_refused():
    arm = Arm(7.0, 12.0, 8.2)           # r_min = 3.8 m around (0, 7)
    p = StraightPath((-5.0, 7.5), (5.0, 7.5))
    assert reach_mask(arm, *p.start) and reach_mask(arm, *p.end)
    with pytest.raises(UnreachableError) as e:
        p.check_reachable(arm)
    msg = str(e.value)
    assert "too close to the riser top" in msg
    x, y = e.value.point
    assert math.hypot(x, y - 7.0) == pytest.approx(3.8, abs=1e-9)  # named where it enters the hole
    assert x < 0


def test_path_leaving_the_outer_circle_names_the_exit_point():
    arm = Arm(7.0, 12.0, 8.2)
    p = StraightPath((5.0, 7.0), (30.0, 7.0))
    with pytest.raises(UnreachableError, match="leaves the reachable workspace at s = 15.200") as e:
        p.check_reachable(arm)
    assert e.value.point == pytest.approx((20.2, 7.0))


@given(st.floats(-25, 25), st.floats(-20, 30), st.floats(-25, 25), st.floats(-20, 30))
def test_exact_reachability_test_agrees_with_dense_sampling(x0, y0, x1, y1):
    arm = Arm(7.0, 12.0, 8.2)
    if math.hypot(x1 - x0, y1 - y0) < 1e-3:
        return
    p = StraightPath((x0, y0), (x1, y1))
    s = np.linspace(0, p.length, 20001)
    xy = p(s)
    r = np.hypot(xy[:, 0], xy[:, 1] - 7.0)
    try:
        p.check_reachable(arm)
        assert r.min() >= arm.r_min - 1e-9 and r.max() <= arm.r_max + 1e-9
    except UnreachableError:
        # refused: sampling must show an excursion (up to the sampling resolution)
        step = p.length / 20000
        assert r.min() < arm.r_min + step or r.max() > arm.r_max - step


def test_paper_timing_duration_is_67_87_s():
    p = StraightPath((3.82, 10.40), (14.0, 1.0))
    law = make_timing("paper", p, max_speed=0.15, max_accel=0.05)
    assert law.duration == pytest.approx((14 - 3.82) / 0.15) and round(law.duration, 2) == 67.87
    t = np.linspace(0, law.duration, 101)
    x = p(law(t))[:, 0]
    assert np.allclose(x, 3.82 + 0.15 * t, atol=1e-12)   # Eq. 14 exactly


def test_paper_timing_runs_backwards_too():
    p = StraightPath((14.0, 1.0), (3.82, 10.40))
    law = make_timing("paper", p, max_speed=0.15, max_accel=0.05)
    t = np.linspace(0, law.duration, 11)
    assert np.allclose(p(law(t))[:, 0], 14.0 - 0.15 * t)


def test_paper_timing_refuses_vertical_path_smooth_handles_it():
    p = StraightPath((5.0, 10.0), (5.0, 2.0))
    with pytest.raises(TimingError, match="undefined for a vertical path"):
        make_timing("paper", p, max_speed=0.15, max_accel=0.05)
    law = make_timing("smooth", p, max_speed=0.15, max_accel=0.05)
    assert law(law.duration) == pytest.approx(8.0)


def test_unknown_timing_and_bad_limits():
    p = StraightPath((5.0, 10.0), (6.0, 2.0))
    with pytest.raises(TimingError, match="timing must be one of paper, smooth, optimal, got 'fast'"):
        make_timing("fast", p, max_speed=0.15, max_accel=0.05)
    with pytest.raises(TimingError, match="max_accel must be a finite number > 0"):
        TrapezoidTiming(1.0, 0.1, -1.0)
    with pytest.raises(TimingError, match="max_speed must be > 0"):
        PaperTiming(1.0, 1.0, 0.0)
    law = TrapezoidTiming(1.0, 0.1, 0.1)
    with pytest.raises(TimingError, match="time must lie in"):
        law(np.array([law.duration + 1.0]))
    with pytest.raises(TimingError, match="order must be"):
        law(0.0, 5)


@given(st.floats(1e-3, 50.0), st.floats(0.01, 1.0), st.floats(0.005, 2.0))
def test_trapezoid_respects_limits_between_grid_points(L, v, a):
    law = TrapezoidTiming(L, v, a)
    t = np.linspace(0, law.duration, 20001)
    s, sd, sdd = law(t, 0), law(t, 1), law(t, 2)
    assert s[0] == 0 and s[-1] == pytest.approx(L, rel=1e-12)
    assert sd[0] == pytest.approx(0, abs=1e-12) and sd[-1] == pytest.approx(0, abs=1e-12)
    assert np.all(sd <= v * (1 + 1e-12)) and np.all(sd >= -1e-12)
    assert np.all(np.abs(sdd) <= a * (1 + 1e-12))
    assert np.all(np.diff(s) >= -1e-12)
    # derivatives are consistent: finite differences of s and sd
    dt = t[1] - t[0]
    assert np.allclose(np.diff(s) / dt, 0.5 * (sd[1:] + sd[:-1]), atol=a * dt + 1e-12)
    # and the speed itself never needs more than a_max between samples
    assert np.all(np.abs(np.diff(sd)) / dt <= a * (1 + 1e-9))
    if L >= v * v / a:
        assert law.v_peak == pytest.approx(v) and law.duration == pytest.approx(L / v + v / a)
    else:
        assert law.duration == pytest.approx(2 * math.sqrt(L / a))
