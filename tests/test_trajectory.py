"""The whole approach plan: paper numbers and consistency checks between columns."""

import math

import numpy as np
import pytest

from loadarm.arm.kinematics import forward
from loadarm.design.trajectory import plan_approach
from loadarm.errors import PathError, UnreachableError, ValveRangeError
from loadarm.params.compiler import compile_model
from loadarm.params.config import parse_config

from .conftest import ROOT


def test_paper_timing_reproduces_the_paper(model):
    p = plan_approach(model, timing="paper", samples=1001)
    assert round(p.duration, 2) == 67.87
    assert p.x[0] == 3.82 and p.y[0] == 10.40 and p.x[-1] == pytest.approx(14.0) and p.y[-1] == pytest.approx(1.0)
    assert np.allclose(p.vx, 0.15)                                     # Eq. 14: constant horizontal speed
    assert math.degrees(p.alpha[0]) == pytest.approx(15.3108, abs=1e-4)
    assert math.degrees(p.beta[-1]) == pytest.approx(96.0553, abs=1e-4)
    assert p.u1[0] == 0 and p.u2[0] == 0                              # voltages relative to the stored pose
    assert p.u1[-1] == pytest.approx(-0.459446, abs=1e-6)              # cylinder 1 contracts
    assert p.u2[-1] == pytest.approx(0.586727, abs=1e-6)               # cylinder 2 extends
    assert set(p.zone.tolist()) == {0}                 # Severity.NORMAL everywhere


@pytest.mark.parametrize("law", ["paper", "smooth"])
def test_columns_are_mutually_consistent(model, arm, law):
    p = plan_approach(model, timing=law, samples=4001)
    xf, yf = forward(arm, p.alpha, p.beta)
    assert np.max(np.hypot(xf - p.x, yf - p.y)) < 1e-9
    dt = p.t[1] - p.t[0]
    # finite-difference checks of every velocity column (central differences, interior points;
    # tolerance = truncation ~ dt^2 * max|third derivative| plus a margin for the trapezoid's corners)
    for pos, vel, tol in ((p.x, p.vx, 2e-4), (p.y, p.vy, 2e-4), (p.alpha, p.alpha_dot, 2e-4),
                          (p.beta, p.beta_dot, 2e-4), (p.r_ac1, p.v_ac1, 2e-5), (p.r_ac2, p.v_ac2, 2e-5)):
        fd = np.gradient(pos, dt)
        assert np.allclose(fd[2:-2], vel[2:-2], atol=tol)
    # Eq. 4: every sample on the straight line
    slope = (p.target[1] - p.start[1]) / (p.target[0] - p.start[0])
    assert np.allclose(p.y, slope * (p.x - p.start[0]) + p.start[1], atol=1e-12)


def test_smooth_law_limits_hold_on_samples(model, inst):
    p = plan_approach(model, timing="smooth", samples=20001)
    speed = np.hypot(p.vx, p.vy)
    assert speed.max() <= inst.approach.max_speed * (1 + 1e-12)
    acc = np.abs(np.diff(speed)) / np.diff(p.t)
    assert acc.max() <= inst.approach.max_accel * (1 + 1e-9)
    assert speed[0] == 0 and speed[-1] == pytest.approx(0, abs=1e-12)
    assert p.duration == pytest.approx(p.path_length / 0.15 + 0.15 / 0.05)


def test_custom_start_and_target(model):
    p = plan_approach(model, start=(6.0, 9.0), target=(12.0, -2.0), samples=11)
    assert p.x[0] == 6.0 and p.y[-1] == pytest.approx(-2.0)
    assert p.u1[0] != 0            # voltages stay relative to the configured stored pose


def test_unreachable_target_is_refused_before_motion(model):
    with pytest.raises(UnreachableError, match="leaves the reachable workspace"):
        plan_approach(model, target=(25.0, 0.0))


def test_stored_position_unreachable(inst):
    d = inst.model_dump()
    d["approach"]["stored"] = (0.5, 7.5)
    bad = compile_model(parse_config(d))
    with pytest.raises(UnreachableError):
        plan_approach(bad, start=(6.0, 9.0))


@pytest.mark.parametrize("samples", [1, 0, -5, 2.5, True, 10**7])
def test_bad_sample_counts(model, samples):
    with pytest.raises(PathError, match=r"samples must be an integer in \[2, 1000000\]"):
        plan_approach(model, samples=samples)


def test_valve_range_exceeded_is_an_error_not_a_clip(inst):
    d = inst.model_dump()
    d["actuators"]["volts_per_metre"] = 30.0     # 0.46 m retraction * 30 V/m = -13.8 V beyond -10 V
    with pytest.raises(ValveRangeError, match=r"u1 \(cylinder 1\) would reach -13.783 V at t = 95.37 s"):
        plan_approach(compile_model(parse_config(d)))


def test_records_and_csv(model, tmp_path):
    p = plan_approach(model, timing="paper", samples=5)
    rec = p.records()
    assert len(rec) == 5
    assert list(rec[0]) == ["t_s", "x_m", "y_m", "alpha_deg", "beta_deg", "r_ac1_m", "r_ac2_m", "u1_V", "u2_V", "zone"]
    f = p.write_csv(tmp_path / "sub" / "plan.csv")
    lines = f.read_text().splitlines()
    assert lines[0].startswith("t_s,x_m,y_m") and len(lines) == 6


def test_joint_accelerations_match_finite_differences(model):
    p = plan_approach(model, timing="smooth", samples=8001)
    dt = p.t[1] - p.t[0]
    for vel, acc in ((p.alpha_dot, p.alpha_ddot), (p.beta_dot, p.beta_ddot)):
        fd = np.gradient(vel, dt)
        # exclude the samples next to the trapezoid's acceleration steps (t_r = 3 s and T - 3 s)
        smooth = (np.abs(p.t - 3.0) > 2 * dt) & (np.abs(p.t - (p.duration - 3.0)) > 2 * dt)
        smooth[[0, -1]] = False
        assert np.allclose(fd[smooth], acc[smooth], atol=1e-6)


@pytest.mark.parametrize("law", ["paper", "smooth", "optimal"])
def test_3d_plan_in_the_vertical_plane_is_the_2d_plan(model, law):
    from loadarm.design.trajectory import plan_approach_3d
    p2 = plan_approach(model, timing=law, samples=301)
    p3 = plan_approach_3d(model, timing=law, samples=301)
    assert p3.duration == p2.duration
    for a, b in ((p2.x, p3.x), (p2.y, p3.z), (p2.alpha, p3.alpha), (p2.beta, p3.beta), (p2.u1, p3.u1),
                 (p2.u2, p3.u2), (p2.zone, p3.zone)):
        assert np.array_equal(a, b)
    assert np.all(p3.y == 0) and np.all(p3.phi == 0)


def test_3d_plan_slews_and_its_rates_are_consistent(model):
    from loadarm.arm.slew import forward3d
    from loadarm.design.trajectory import plan_approach_3d
    p = plan_approach_3d(model, target=(12.0, 6.0, 1.0), samples=8001)
    x, y, z = forward3d(model.arm, p.phi, p.alpha, p.beta)
    assert np.max(np.abs(x - p.x)) < 1e-9 and np.max(np.abs(y - p.y)) < 1e-9 and np.max(np.abs(z - p.z)) < 1e-9
    dt = p.t[1] - p.t[0]
    for pos, vel in ((p.phi, p.phi_dot), (p.alpha, p.alpha_dot), (p.beta, p.beta_dot), (p.r_ac1, p.v_ac1)):
        assert np.allclose(np.gradient(pos, dt)[2:-2], vel[2:-2], atol=2e-4)
    assert math.degrees(p.phi[-1]) == pytest.approx(math.degrees(math.atan2(6.0, 12.0)))


def test_3d_plan_refusals(model):
    from loadarm.design.trajectory import plan_approach_3d
    from loadarm.errors import PathError
    with pytest.raises(PathError, match="beyond the slew limit"):
        plan_approach_3d(model, target=(5.0, 12.0, 1.0))
    with pytest.raises(UnreachableError, match="leaves the reachable workspace"):
        plan_approach_3d(model, target=(18.0, 10.0, 0.0))
    with pytest.raises(PathError, match="needs \\(x, y, z\\)"):
        plan_approach_3d(model, start=(3.82, 10.4), target=(14.0, 1.0))


@pytest.mark.slow  # make test's 2-minute budget (2-4 s here); CI runs it
def test_results_are_data_with_summary_to_dict_and_plot(model):
    """Every result type offers summary() (a dict that knows its metrics), to_dict() (plain JSON) and plot()."""
    import json

    from matplotlib.figure import Figure

    from loadarm.design.balancing import balance_counterweights
    from loadarm.design.loads import actuator_loads
    from loadarm.design.multibody import verify_kinematics
    from loadarm.hydraulics.simulate import SIMULATION_METRICS, simulate_approach
    from loadarm.results import Summary

    plan = plan_approach(model, timing="smooth", samples=101)
    sim = simulate_approach(model, plan_approach(model, timing="smooth", samples=2001))
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, smodel = load_scenario(ROOT / "examples" / "scenarios" / "calm.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": 20.0, "plant": "kinematic"})})
    from loadarm.design.sizing import size_arm
    from loadarm.design.trajectory import plan_approach_3d

    results = [plan, actuator_loads(model, plan), balance_counterweights(model, spacing=1.0),
               verify_kinematics(model, plan_approach(model, timing="paper", samples=21)), sim,
               run_scenario(sc, smodel), size_arm(7.0, 13.5, 4.7, math.radians(123.0), (8.0, 14.0), (4.0, 12.0)),
               plan_approach_3d(model, target=(14.0, 2.0, 1.0), samples=51)]
    for r in results:
        s = r.summary()
        assert isinstance(s, Summary) and isinstance(s, dict)
        d = r.to_dict()
        assert type(d) is dict and json.loads(json.dumps(d)) == json.loads(json.dumps(dict(s)))
        assert isinstance(r.plot(), Figure)
    # metric names are declared once and every declared one is produced
    assert {m.key for m in SIMULATION_METRICS} <= set(sim.summary())
    rows = dict(sim.summary().rows())
    assert rows["max deviation from the line"].endswith(" mm") and rows["first time within the arrival tolerance"] != "n/a"
    assert "max deviation from the line" in str(sim.summary())
