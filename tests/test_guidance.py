"""Live guidance: scenarios end to end, each safety rule, the estimator and the sea."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.arm.alarms import AlarmThresholds
from loadarm.arm.slew import forward3d, inverse3d
from loadarm.errors import ConfigError
from loadarm.eventlog import EventLog
from loadarm.guidance.controller import GuidanceController
from loadarm.guidance.estimator import Estimate, FlangeEstimator
from loadarm.guidance.modes import MODES, Cycle, GuidanceState, Mode, OperatorInput
from loadarm.params.compiler import compile_model
from loadarm.params.scenario import Scenario, load_scenario, parse_scenario
from loadarm.ship.flange import flange_motion, jonswap
from loadarm.sim.loop import run_scenario
from loadarm.vocab import Severity

from .conftest import ROOT
from .hypo import examples

SCEN = ROOT / "examples" / "scenarios"


class _Runs(dict):
    """The stock scenarios on the hydraulic plant, each run when first asked for (a worker of the parallel
    suite runs only those its tests need)."""

    def __missing__(self, name):
        sc, inst = load_scenario(SCEN / f"{name}.toml")
        self[name] = (sc, inst, run_scenario(sc, inst))
        return self[name]


@pytest.fixture(scope="module")
def runs():
    return _Runs()


@pytest.mark.slow  # 6 s of the hydraulic closed loop: make test keeps to its 2 minutes (CI runs it)
def test_calm_connects_without_alarm(runs):
    s = runs["calm"][2].summary()
    assert s["mode_sequence"] == ["STORED", "APPROACH", "STANDOFF", "CONNECTED"]
    assert s["alarm1_s"] is None and s["overstretched_s"] is None


@pytest.mark.slow  # 8 s: the hydraulic plant under an Hs 1.5 m sea (CI runs it)
def test_hs15_tracks_the_moving_flange_without_false_alarm(runs):
    sc, _, r = runs["hs15"]
    s = r.summary()
    assert s["mode_sequence"] == ["STORED", "APPROACH", "STANDOFF", "CONNECTED"]
    assert s["alarm1_s"] is None
    # while in standoff the coupler stays near the standoff point of the moving flange
    sig = r.signals
    so = sig["mode"] == MODES.index("STANDOFF")
    err = np.abs(sig["distance"][so] - sc.guidance.standoff)
    assert so.sum() > 100 and np.percentile(err, 95) < 0.3


@pytest.mark.slow  # 5 s of the hydraulic closed loop: make test keeps to its 2 minutes (CI runs it)
def test_driftoff_alarms_in_order_and_releases_before_the_limit(model, runs):
    sc, inst, r = runs["driftoff"]
    s = r.summary()
    # the stages in order; the break-out test's forecast may pass the second alarm and the release in one cycle
    assert s["alarm1_s"] < s["alarm2_s"] <= s["release_s"] < s["release_complete_s"]
    assert s["overstretched_s"] is None and s["verdict"] == "pass"
    seq = s["mode_sequence"]
    assert seq[:5] == ["STORED", "APPROACH", "STANDOFF", "CONNECTED", "ALARM1"] and seq[-2:] == ["RELEASE", "RETURN"]
    assert set(seq[5:-2]) <= {"ALARM2"}
    # at release completion the arm is still short of its hard limit (stroke end / full stretch)
    ctrl = GuidanceController(model, sc.guidance.compile())
    k = int(np.searchsorted(r.signals["t"], s["release_complete_s"]))
    assert r.signals["beta"][k] < ctrl.lim.beta[1]
    # the coupler opened only after the ERS valves were confirmed closed, ers_valve_time after ESD-1, and was
    # free before the flange reached the face (found weak: an 'or ... > 0' branch made a claim like this unchecked)
    seq = inst.sequence
    assert s["valves_confirmed_s"] == pytest.approx(s["alarm1_s"] + seq.ers_valve_time, abs=0.021)
    assert s["coupler_opening_s"] >= s["valves_confirmed_s"]
    assert s["release_margin_s"] > 0 and s["limit_face"] == "beta_max"
    # the time connected (the exposure a campaign counts false alarms out of): from the connection to the release
    connected_at = r.first("mode", "-> CONNECTED")
    assert s["connected_s"] == pytest.approx(s["release_complete_s"] - connected_at, abs=1.5 / sc.guidance.rate)


@pytest.mark.slow  # 4 s of the hydraulic closed loop: make test keeps to its 2 minutes (CI runs it)
def test_dropout_stops_the_arm_within_one_cycle(runs):
    sc, _, r = runs["dropout"]
    sig = r.signals
    dt = 1 / sc.guidance.rate
    stale = np.flatnonzero((sig["healthy"] == 0) & (sig["t"] > 10))
    lost = int(stale[0])
    assert MODES[int(sig["mode"][lost])] == "HOLD"          # the very cycle that sees the stale estimate
    idx = np.flatnonzero(sig["mode"] == MODES.index("HOLD"))
    assert sig["t"][idx[-1]] - sig["t"][idx[0]] == pytest.approx(8.0, abs=0.5 + dt)
    # the command is zero from that cycle on (controller test below); the heavy arm, driven by its
    # hydraulic servos, stops within a few centimetres and its residual oscillation (the arm's low,
    # lightly damped hydraulic mode, about 1 Hz) decays
    p = np.stack([sig["x"], sig["y"], sig["z"]], axis=1)[idx[0]:idx[-1] + 1]
    assert np.max(np.linalg.norm(p - p[0], axis=1)) < 0.1
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / dt
    two = int(2.0 / dt)
    assert np.max(speed[-two:]) < 0.7 * np.max(speed[:two])
    assert r.summary()["mode_sequence"] == ["STORED", "APPROACH", "HOLD", "APPROACH", "STANDOFF", "CONNECTED"]


@pytest.mark.slow           # 2-4 s: make test's budget on 2 cores (CI runs it)
def test_kinematic_plant_holds_exactly():
    sc, inst = load_scenario(SCEN / "dropout.toml")
    r = run_scenario(sc, inst, plant="kinematic")
    sig = r.signals
    idx = np.flatnonzero(sig["mode"] == MODES.index("HOLD"))
    for key in ("phi", "alpha", "beta"):
        assert np.ptp(sig[key][idx[0]:idx[-1] + 1]) < 1e-12   # not a micro-radian of motion while holding
    with pytest.raises(ValueError, match="plant must be"):
        run_scenario(sc, inst, plant="magic")


@pytest.mark.slow           # 2-4 s: make test's budget on 2 cores (CI runs it)
def test_runs_are_deterministic():
    sc, inst = load_scenario(SCEN / "hs15.toml")
    d = sc.model_dump()
    d["scenario"]["duration"] = 60.0
    sc = parse_scenario(d)
    a, b = run_scenario(sc, inst), run_scenario(sc, inst)
    for k in a.signals:
        assert np.array_equal(a.signals[k], b.signals[k], equal_nan=True)


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
def test_event_log_of_a_run_replays_its_mode_sequence(tmp_path):
    sc, inst = load_scenario(SCEN / "driftoff.toml")
    with EventLog(tmp_path / "ev.db", run="x") as log:
        r = run_scenario(sc, inst, log=log)
    with EventLog.open_existing(tmp_path / "ev.db") as log:
        modes = [e.data["mode"] for e in log.query(kinds=["mode"])]
        samples = log.query(kinds=["sample"])
    assert ["STORED"] + modes == r.summary()["mode_sequence"]
    assert len(samples) == pytest.approx(sc.scenario.duration, abs=2)


# ---------------------------------------------------------------- controller rules, one by one

def _ctrl(model):
    return GuidanceController(model, Scenario().guidance.compile())


def _est(p, healthy=True, v=(0.0, 0.0, 0.0)):
    return Estimate(0.0, tuple(p), v, 0.01, 0.0 if healthy else 9.0, healthy, "" if healthy else "stale")


def _stored_q(ctrl):
    q = inverse3d(ctrl.arm, *ctrl.stored)
    return (float(q.phi), float(q.alpha), float(q.beta))


def test_no_motion_without_a_healthy_estimate(model):
    c = _ctrl(model)
    q = _stored_q(c)
    cmd = c.step(0.0, q, _est((14.0, 0.0, 1.0)), OperatorInput(("start",)))
    assert cmd.mode == Mode.APPROACH
    cmd = c.step(0.02, q, _est((14.0, 0.0, 1.0)))
    assert any(abs(v) > 0 for v in cmd.rates)
    cmd = c.step(0.04, q, _est((14.0, 0.0, 1.0), healthy=False))
    assert cmd.mode == Mode.HOLD and cmd.rates == (0.0, 0.0, 0.0)
    # and no start at all without an estimate
    c2 = _ctrl(model)
    cmd = c2.step(0.0, q, _est((14.0, 0.0, 1.0), healthy=False), OperatorInput(("start",)))
    assert cmd.mode == Mode.STORED and cmd.rates == (0.0, 0.0, 0.0)
    assert any("approach refused: no fresh flange estimate" in e[1] for e in cmd.events)


@pytest.mark.parametrize("flange,why", [((30.0, 0.0, 0.0), "out of the arm's reach"),
                                        ((17.5, 0.0, -4.5), "beyond the first alarm"),
                                        ((10.0, 9.0, 1.0), "beyond the slew alarm")])
def test_target_outside_the_envelope_is_refused(model, flange, why):
    c = _ctrl(model)
    cmd = c.step(0.0, _stored_q(c), _est(flange), OperatorInput(("start",)))
    assert cmd.mode == Mode.STORED and cmd.rates == (0.0, 0.0, 0.0)
    assert any(why in e[1] for e in cmd.events)


def test_emergency_stop_from_any_mode(model):
    for target_mode in (Mode.STORED, Mode.APPROACH, Mode.STANDOFF, Mode.CONNECTED, Mode.RETURN, Mode.MANUAL,
                        Mode.HOLD, Mode.ALARM1):
        c = GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=target_mode))
        cmd = c.step(1.0, _stored_q(c), _est((14.0, 0.0, 1.0)), OperatorInput(("estop",)))
        assert cmd.mode == Mode.ESTOP and cmd.rates == (0.0, 0.0, 0.0), target_mode
        cmd = c.step(1.02, _stored_q(c), _est((14.0, 0.0, 1.0)))
        assert cmd.mode == Mode.ESTOP and cmd.rates == (0.0, 0.0, 0.0)


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
@settings(max_examples=examples(200))
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1))
def test_commands_never_cross_a_joint_or_stroke_limit(u0, u1, u2, w0, w1, w2):
    from loadarm.params.config import paper_installation
    c = _ctrl(compile_model(paper_installation()))
    lims = (c.lim.phi, c.lim.alpha, c.lim.beta)
    q = tuple(lo + (hi - lo) * (0.5 + 0.5 * u) for (lo, hi), u in zip(lims, (u0, u1, u2)))
    qd = c._limit(q, np.array([w0, w1, w2]) * 10)
    for i, (lo, hi) in enumerate(lims):
        nxt = q[i] + qd[i] * c.dt_nominal
        assert lo - 1e-12 <= nxt <= hi + 1e-12
        assert abs(qd[i]) <= c.lim.rate[i] * (1 + 1e-12)


def _fed_monitor(model, p0, v, a, window=60.0, t_end=None):
    """An EnvelopeMonitor fed a noiseless drift p0 + v t + a t^2 / 2 for one full window."""
    from loadarm.guidance.monitor import EnvelopeMonitor

    mon = EnvelopeMonitor(model, window)
    t_end = window if t_end is None else t_end
    p0, v, a = (np.asarray(x, dtype=float) for x in (p0, v, a))
    for k in range(int(round(t_end / 0.1)) + 1):
        t = k * 0.1
        mon.observe(t, p0 + v * t + 0.5 * a * t * t)
    return mon, p0 + v * t_end + 0.5 * a * t_end ** 2


def _crossing_time(model, p, v, a, horizon):
    """Independent route: bisection on the faces along the quadratic path."""
    from loadarm.arm.faces import face_margins, first_face

    def out(t):
        q = p + v * t + 0.5 * a * t * t
        return bool(first_face(face_margins(model, q[0], q[1], q[2]))[0])

    if not out(horizon):
        return math.inf
    lo, hi = 0.0, horizon
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if out(mid) else (mid, hi)
    return hi


@settings(max_examples=examples(25), deadline=None)
@given(st.floats(0.16, 0.6), st.floats(0.0, 0.02), st.floats(-40, 40))
def test_the_measured_drift_forecast_matches_the_crossing_time(model, speed, accel, direction_deg):
    """A noiseless drift faster than the design drift (so the measured route, not the floor, decides): the
    least-squares fit is exact for constant acceleration, so the forecast is the true crossing time, early by
    at most the forecast's resolution (1/16 s) and never late."""
    ang = math.radians(direction_deg)
    d = np.array([math.cos(ang), math.sin(ang), 0.0])
    p0 = np.array([11.0, 0.0, 1.0])
    mon, p = _fed_monitor(model, p0, speed * d, accel * d)
    v_now = speed * d + accel * d * 60.0
    f = mon.time_to_limit(p, 40.0)
    truth = _crossing_time(model, p, v_now, accel * d, 40.0)
    est = mon.fit.estimate()
    assert np.allclose(est.v, v_now, atol=1e-9) and np.allclose(est.a, accel * d, atol=1e-9)
    if math.isinf(truth):
        assert f.time >= _crossing_time(model, p, np.zeros(3), np.zeros(3), 1.0) or f.route == "design drift"
    else:
        assert f.time <= truth + 1e-9
        assert f.route == "design drift" or truth - f.time <= mon.resolution + 1e-9


@settings(max_examples=examples(25), deadline=None)
@given(st.floats(0.16, 0.6), st.floats(0.0, 0.02), st.floats(-180, 180))
def test_the_time_to_each_face_comes_from_the_same_scan_and_is_never_late(model, speed, accel, direction_deg):
    """The forecast's time to each face (the operator's screen shows them), from the scan that finds the
    nearest: the nearest is the forecast's own time (never later than the true crossing); the others are no
    earlier than it, within the horizon, nearest first."""
    from loadarm.arm.faces import FACES

    ang = math.radians(direction_deg)
    d = np.array([math.cos(ang), math.sin(ang), 0.0])
    mon, p = _fed_monitor(model, np.array([11.0, 0.0, 1.0]), speed * d, accel * d)
    f = mon.time_to_limit(p, 40.0)
    by = dict(f.by_face)
    if not f.face:
        assert by == {}
        return
    assert by[f.face] == f.time and min(by.values()) == f.time and set(by) <= set(FACES)
    assert [t for _, t in f.by_face] == sorted(t for _, t in f.by_face)
    assert all(0.0 <= t <= 40.0 for t in by.values())
    truth = _crossing_time(model, p, speed * d + accel * d * 60.0, accel * d, 40.0)
    assert f.time <= truth + 1e-9


@settings(max_examples=examples(25), deadline=None)
@given(st.floats(0.02, 0.5), st.floats(0.02, 0.5))
def test_faster_drift_alarms_earlier(model, v_slow, v_fast):
    """The faster of two drifts through the same point now is forecast to reach the face no later. (Found by the
    thorough profile: with both drifts started from one point, the faster one is farther out now, and from there
    the design floor's slew face can lie later than from the slower one's position: 56.0 s against 55.6 s for
    0.02 m/s drifts. The property is about speed, so both now end the window at the same point.)"""
    v_slow, v_fast = sorted((v_slow, v_fast))
    d = np.array([1.0, 0.0, 0.0])
    p_now = np.array([10.0, 0.0, 1.0])
    slow, ps = _fed_monitor(model, p_now - 60.0 * v_slow * d, v_slow * d, np.zeros(3))
    fast, pf = _fed_monitor(model, p_now - 60.0 * v_fast * d, v_fast * d, np.zeros(3))
    assert np.allclose(ps, pf)
    assert fast.time_to_limit(pf, 60.0).time <= slow.time_to_limit(ps, 60.0).time + 1e-9


@settings(max_examples=examples(25), deadline=None)
@given(seed=st.integers(0, 2**32 - 1), wave=st.floats(0.0, 0.5), v=st.floats(-0.5, 0.5),
       age=st.floats(0.0, 30.0), period=st.sampled_from([0.2, 0.25, 0.5, 1.0]))
def test_the_step_statistic_sums_match_the_residuals(seed, wave, v, age, period):
    """The velocity-step test forms its residual sums from the normal equations and the hinge's products from two
    cumulative sums. Independent route: for every candidate age, the hinge column built from its definition,
    ``numpy.linalg.lstsq`` on the positions, and the residuals themselves. Tolerance: 1e-6 relative (the sums
    are of the plain fit's residuals, so what cancels is of the residuals' size: found at 3e-5 relative when
    they were of positions 30 m apart)."""
    from loadarm.guidance.drift import DriftFit

    rng = np.random.default_rng(seed)
    f = DriftFit(60.0, period)
    n = f.n
    t = np.arange(n + 5) * period
    p = (np.array([13.0, -1.0, 0.5]) + 0.01 * t[:, None] + v * np.maximum(t[-1] - age - t, 0.0)[:, None]
         * np.array([-1.0, 0.3, 0.0]) + wave * rng.standard_normal((t.size, 3)) + 1e-3 * rng.standard_normal((t.size, 3)))
    for ti, pi in zip(t, p):
        f.push(float(ti), pi)
    z, coef, sdv, rss = f.step_statistic()
    y = f.buf
    tau = (np.arange(n) - (n - 1)) * period
    for i, c in enumerate(f.step_ages):
        X = np.stack([np.ones(n), tau, 0.5 * tau * tau, np.maximum(0.0, tau + c)], axis=1)
        b = np.linalg.lstsq(X, y, rcond=None)[0]
        res = y - X @ b
        s_x = np.sqrt(np.sum(res * res, axis=0) / (n - 4))
        s_v = np.std(np.diff(res, axis=0), axis=0) / period
        formal = 2.0 * s_x * np.sqrt(np.linalg.inv(X.T @ X)[3, 3])
        sd = np.maximum(formal, np.minimum(s_v, np.sqrt(2.0) * s_x / c))
        assert np.allclose(coef[i], b, rtol=1e-6, atol=1e-9)
        assert np.allclose(sdv[i], sd, rtol=1e-6, atol=1e-12)
        assert np.allclose(z[i], np.abs(b[3]) / sd, rtol=1e-6, atol=1e-6)
        assert np.allclose(rss[i], np.sum(res * res, axis=0), rtol=1e-6, atol=1e-9)


def _drift_windows(name, seed, t0, t1, **drift):
    """The true flange path of a shipped scenario (seeded waves), sampled every 0.2 s from t0 to t1."""
    from loadarm.ship.flange import flange_motion

    sc, _ = load_scenario(ROOT / "examples" / "scenarios" / name)
    upd = {"scenario": sc.scenario.model_copy(update={"seed": seed})}
    if drift:
        upd["drift"] = sc.drift.model_copy(update=drift)
    fm = flange_motion(sc.model_copy(update=upd))
    t = np.arange(t0, t1, 0.2)
    return fm, t, fm.position(t)


@pytest.mark.parametrize("seed", range(10))
def test_a_velocity_step_is_seen_within_seconds_and_never_forecast_late(model, seed):
    """Found: a drift to 0.3 m/s reached at 0.5 m/s^2 (a line parting) was seen 1.7 s late by the 60 s fit, and
    2 of 10 closed-loop runs overstretched. On the stock drift-off's sea (Hs 0.5 m) with that step, the hinge test
    finds it within 3.5 s (measured 1.8-3.6 s over 40 seeds), its velocity within 0.15 m/s of the truth, the
    forecast is then inside ESD-1's lead (so ESD-1 fires at once), and once the true flange (waves included) is
    within the release lead of the face, the forecast is late by less than the sequence's margin (measured: at
    most 1.0 s over 40 seeds; the first estimates after a step are from a few seconds of data)."""
    from loadarm.arm.faces import face_margins, first_face
    from loadarm.guidance.monitor import EnvelopeMonitor, stage_leads

    leads = stage_leads(model.sequence)
    fm, t, p = _drift_windows("driftoff.toml", seed, 120.0, 218.0, speed=0.3, acceleration=0.5)
    tt = np.arange(200.0, 260.0, 0.01)
    out = first_face(face_margins(model, *fm.position(tt).T))[0]
    t_face = float(tt[np.flatnonzero(out)[0]])
    mon = EnvelopeMonitor(model, 60.0)
    found = None
    for ti, pi in zip(t, p):
        mon.observe(float(ti), pi)
        if ti < 200.0 or mon.fit.count < mon.fit.n:
            continue
        step = mon.test_step()
        if step is not None and found is None:
            found = ti
            assert abs(step.v[0] - 0.3 * math.cos(math.radians(10.0))) < 0.15, step.v
            assert mon.time_to_limit(pi, 60.0).time <= leads[Severity.ESD1]
        if found is not None and t_face - ti <= leads[Severity.RELEASE]:
            f = mon.time_to_limit(pi, 60.0)
            assert f.time <= t_face - ti + model.sequence.margin, (ti, f, t_face)
    assert found is not None and found - 200.0 <= 3.5


@pytest.mark.slow
def test_waves_alone_make_no_velocity_step():
    """The step threshold against the statistic on waves alone (the shipped seas, 10 seeds each; 600 s at
    Hs 1.5 m, the 200 s before the drift at Hs 0.5 m): the largest value must stay below the threshold with a
    margin of 1.5. The values are quoted in docs/guidance.md."""
    from loadarm.guidance.drift import DriftFit

    top = {}
    for name, t1 in (("hs15.toml", 600.0), ("driftoff.toml", 200.0)):
        z = 0.0
        for seed in range(10):
            _, t, p = _drift_windows(name, seed, 0.0, t1)
            f = DriftFit(60.0)
            for ti, pi in zip(t, p):
                f.push(float(ti), pi)
                if f.count >= f.n:
                    z = max(z, float(f.step_statistic()[0].max()))
        top[name] = z
        assert z < DriftFit.STEP_Z / 1.5, (name, z)
    from .test_doc_numbers import cited

    cited("docs/guidance.md", f"(the largest value without a step is {top['hs15.toml']:.1f} over 10 seeds of the "
                              f"Hs 1.5 m sea, {top['driftoff.toml']:.1f} at Hs 0.5 m)")


@pytest.mark.slow
def test_a_long_swell_is_taken_for_steps_and_break_outs_the_limit_quoted_in_the_docs():
    """The step and break-out tests' stated limit (docs/guidance.md section 5): waves long against the 60 s
    window look like steps and curvature. The statistics without a drift at Hs 2 m, 5 seeds each, for Tp up to
    20 s and at 25 and 30 s, quoted in the docs; the closed loop at Tp 25 s raises no alarm at the Hs 1.5 m
    scenario's flange (3 seeds), and what it does at Tp 30 s is quoted (found in CI: with the break-out test the
    claim "no alarm at Tp 30 s" no longer held; ESD-1 came in 2 of 3 seeds)."""
    from loadarm.guidance.drift import DriftFit
    from loadarm.ship.flange import flange_motion

    sc, model = load_scenario(ROOT / "examples" / "scenarios" / "hs15.toml")

    def with_sea(seed, tp):
        return sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": seed, "plant": "kinematic"}),
                                     "waves": sc.waves.model_copy(update={"hs": 2.0, "tp": tp})})

    step, bo = {}, {}
    for tp in (4.0, 6.0, 12.0, 16.0, 20.0, 25.0, 30.0):
        z = zb = 0.0
        for seed in range(5):
            t = np.arange(0.0, 600.0, 0.2)
            f = DriftFit(60.0)
            for ti, pi in zip(t, flange_motion(with_sea(seed, tp)).position(t)):
                f.push(float(ti), pi)
                if f.count >= f.n:
                    z = max(z, float(f.step_statistic()[0].max()))
                    zz, coef, _, _ = f.breakout_statistic()      # as breakout_estimate counts it
                    zb = max(zb, float(np.max(np.where(np.abs(coef[:, 3, :]) > f.BREAKOUT_MIN, zz, 0.0))))
        step[tp], bo[tp] = z, zb
    short = max(v for k, v in step.items() if k <= 20.0)
    short_bo = max(v for k, v in bo.items() if k <= 25.0)
    assert short < DriftFit.STEP_Z and short_bo < DriftFit.BREAKOUT_Z
    from .test_doc_numbers import cited

    cited("docs/guidance.md", f"At Hs 2 m the statistic without a step stays below {math.ceil(short * 10) / 10:.1f} "
                              f"up to Tp 20 s, but reaches {step[25.0]:.0f} at Tp 25 s and {step[30.0]:.0f} at Tp 30 s")
    for seed in range(3):
        v = run_scenario(with_sea(seed, 25.0), model).to_dict()
        assert v["alarm1_s"] is None and v["connected_s"] > 300.0, v
    alarmed = sum(run_scenario(with_sea(seed, 30.0), model).to_dict()["alarm1_s"] is not None for seed in range(3))
    cited("docs/guidance.md", f"without a drift it stays below {math.ceil(short_bo * 10) / 10:.1f} up to Tp 25 s "
                              f"(no alarm in 3 seeds at the Hs 1.5 m scenario's flange) but reaches "
                              f"{bo[30.0]:.0f} at Tp 30 s, where the closed loop raised ESD-1 in {alarmed} of 3 seeds")


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
@pytest.mark.parametrize("rate", [2.0, 4.0, 7.0])
def test_the_drift_monitor_forecasts_at_any_guidance_rate(rate):
    """Found: at a guidance rate of 5 Hz or less every cycle kept a fit sample, so the forecast (made in a cycle
    without one) was never renewed: at 4 Hz the stock drift-off fired ESD-1 14 s late on the angle alarm and
    released 0.25 s before the face (9.0 s at 50 Hz); the fit also took samples 0.5 s apart for 0.2 s. Now the
    fit samples a whole number of cycles apart and slow guidance does the fit, the step test and the forecast
    in one cycle."""
    sc, model = load_scenario(ROOT / "examples" / "scenarios" / "driftoff.toml")
    s = sc.model_copy(update={"guidance": sc.guidance.model_copy(update={"rate": rate}),
                              "scenario": sc.scenario.model_copy(update={"plant": "kinematic"})})
    v = run_scenario(s, model).to_dict()
    assert v["overstretched_s"] is None and v["release_margin_s"] >= 7.0, v
    assert v["alarm1_s"] <= 220.0, v


def test_the_design_floor_needs_no_history(model):
    """Right after the connection (no fitted drift yet) the design break-out from where the flange is sets the
    time to the limit: checked against the break-out distance along the worst horizontal direction."""
    from loadarm.arm.faces import breakout_distance
    from loadarm.guidance.monitor import EnvelopeMonitor

    mon = EnvelopeMonitor(model, 60.0)
    p = np.array([13.0, 0.0, 1.0])
    f = mon.time_to_limit(p, 60.0)
    assert f.route == "design drift" and f.face == "beta_max"
    dd = model.design_drift
    tt = np.arange(0, 60.0 + 1 / 16, 1 / 16)
    straight = _crossing_time(model, p, np.zeros(3), np.zeros(3), 0.0)   # inside now
    assert straight == math.inf
    # along +x the break-out reaches the face at the first t with p + D(t) e_x outside
    from loadarm.arm.faces import face_margins, first_face
    outside = [bool(first_face(face_margins(model, 13.0 + breakout_distance(t, dd.speed, dd.acceleration), 0.0,
                                            1.0))[0]) for t in tt]
    t_x = tt[outside.index(True) - 1]
    assert f.time <= t_x + 1 / 16                          # the worst of eight directions is no later than +x


def test_stage_leads_follow_the_sequence_times(model):
    from loadarm.guidance.monitor import stage_leads

    q = model.sequence
    full = stage_leads(q)
    # until the limit switches confirm, the valves count at the worst their timeout allows (issue 25)
    assert full[Severity.RELEASE] == q.ers_valve_time + q.ers_valve_timeout + q.erc_release_time + q.margin
    assert full[Severity.SECOND] == full[Severity.RELEASE] + q.margin
    assert full[Severity.ESD1] == (max(q.esd_time, q.ers_valve_time + q.ers_valve_timeout) + q.erc_release_time
                                   + q.margin)
    assert full[Severity.PRE_ALARM] == full[Severity.ESD1] + q.pre_alarm_lead      # on by default (30 s)
    import dataclasses
    assert Severity.PRE_ALARM not in stage_leads(dataclasses.replace(q, pre_alarm_lead=0.0))
    half = stage_leads(q, valves_left=4.0)
    assert half[Severity.RELEASE] == 4.0 + q.erc_release_time + q.margin
    closed = stage_leads(q, valves_left=0.0, release_left=1.0)
    assert closed[Severity.RELEASE] == 1.0 + q.margin
    pre = stage_leads(dataclasses.replace(q, pre_alarm_lead=20.0))
    assert pre[Severity.PRE_ALARM] == full[Severity.ESD1] + 20.0


def test_position_alarms_follow_the_customer_angles(model, inst):
    thr = AlarmThresholds.from_model(model)
    assert thr.level(1.0, 0.0)[0] == Severity.NORMAL
    assert thr.level(inst.alarms.first + 0.01, 0.0)[0] == Severity.ESD1
    assert thr.level(inst.alarms.second + 0.01, 0.0)[0] == Severity.SECOND
    assert thr.level(inst.alarms.release, 0.0)[0] == Severity.RELEASE
    assert thr.level(0.0, -math.radians(inst.slew.release_deg))[0] == Severity.RELEASE
    assert thr.level(0.0, math.radians(inst.slew.first_deg) + 0.01)[0] == Severity.ESD1


def test_manual_jog_moves_the_coupler_as_commanded(model, inst):
    c = _ctrl(model)
    q0 = inverse3d(c.arm, 10.0, 1.0, 4.0)
    q = (float(q0.phi), float(q0.alpha), float(q0.beta))
    c.step(0.0, q, _est((14.0, 0.0, 1.0)), OperatorInput(("manual",)))
    jog = (0.05, -0.02, 0.03)
    cmd = c.step(0.02, q, _est((14.0, 0.0, 1.0)), OperatorInput((), jog))
    assert cmd.mode == Mode.MANUAL
    h = 1e-4
    p0 = np.array([float(v) for v in forward3d(c.arm, *q)])
    p1 = np.array([float(v) for v in forward3d(c.arm, *(np.array(q) + h * np.array(cmd.rates)))])
    assert np.allclose((p1 - p0) / h, jog, atol=1e-5)
    # at the first-alarm radius, a jog outwards is refused and a jog inwards allowed
    r_first = c.arm.radius_at_beta(inst.alarms.first)
    u = np.array([15.0, 0.0, -9.4]) / np.linalg.norm([15.0, 0.0, -9.4])
    p = np.array([0.0, 0.0, c.arm.a]) + (float(r_first) - 1e-3) * u
    far = inverse3d(c.arm, *p)
    qf = (float(far.phi), float(far.alpha), float(far.beta))
    cmd = c.step(0.04, qf, _est((14.0, 0.0, 1.0)), OperatorInput((), tuple(0.15 * u)))
    assert cmd.rates == (0.0, 0.0, 0.0)
    cmd = c.step(0.06, qf, _est((14.0, 0.0, 1.0)), OperatorInput((), tuple(-0.15 * u)))
    assert any(abs(v) > 0 for v in cmd.rates)


# ---------------------------------------------------------------- estimator and sea

def test_estimator_tracks_rejects_outliers_and_reports_health(model):
    rng = np.random.default_rng(0)
    est = FlangeEstimator(noise=0.01, max_age=0.5)
    v = np.array([0.1, -0.05, 0.02])
    errs = []
    for k in range(400):
        t = k * 0.1
        z = np.array([14.0, 0.0, 1.0]) + v * t + rng.normal(0, 0.01, 3)
        if k == 200:
            z = z + np.array([3.0, 0.0, 0.0])               # an outlier
            assert est.update(t, tuple(z)) is False
            continue
        assert est.update(t, tuple(z))
        if k > 50:
            e = est.estimate(t)
            errs.append(np.linalg.norm(np.array(e.position) - (np.array([14.0, 0.0, 1.0]) + v * t)))
    # filtered position std is about 0.9 cm with this noise and process model: 0.045 m is a 5-sigma bound
    assert max(errs) < 0.045
    assert est.estimate(39.9 + 0.4).healthy
    stale = est.estimate(39.9 + 0.6)
    assert not stale.healthy and "no accepted reading" in stale.reason
    # 6 m away at once: farther than the flange can move in 0.1 s (1 m/s), so rejected, never a restart ...
    for k in range(3):
        assert not est.update(40.0 + 0.1 * k, (20.0, 0.0, 1.0))
    # ... but after 7 s of silence it could be there: the filter takes it up again (its uncertainty has grown),
    # and is not trusted until it has converged
    for k in range(8):
        est.update(47.0 + 0.1 * k, (20.0, 0.0, 1.0))
        e = est.estimate(47.0 + 0.1 * k)
        assert e.healthy == (k >= 4), (k, e.reason)
    assert e.position[0] == pytest.approx(20.0, abs=0.05)


def test_jonswap_is_normalised_to_hs():
    for hs, tp in ((1.5, 9.0), (3.0, 12.0)):
        w = np.linspace(0.2 * 2 * math.pi / tp, 8 * 2 * math.pi / tp, 20000)
        m0 = np.trapezoid(jonswap(w, hs, tp), w)
        assert 4 * math.sqrt(m0) == pytest.approx(hs, rel=1e-3)


def test_estimator_velocity_with_a_quiet_process_model():
    # the default process noise (0.1 m^2/s^3) follows waves; a quiet one gives a precise drift velocity
    rng = np.random.default_rng(1)
    est = FlangeEstimator(noise=0.01, accel_psd=1e-4)
    v = np.array([0.1, -0.05, 0.02])
    for k in range(600):
        est.update(k * 0.1, tuple(np.array([14.0, 0.0, 1.0]) + v * k * 0.1 + rng.normal(0, 0.01, 3)))
    assert np.allclose(est.estimate(59.9).velocity, v, atol=0.005)


def test_drift_and_slow_motion():
    sc = parse_scenario({"ship": {"flange": [13.0, 0.0, 1.0], "tide_rate": 1e-4},
                         "drift": {"start": 10.0, "speed": 0.2, "acceleration": 0.02}})
    m = flange_motion(sc)
    p = m.position(np.array([0.0, 10.0, 20.0, 30.0]))
    assert p[1, 0] == pytest.approx(13.0) and p[1, 2] == pytest.approx(1.001)
    assert p[3, 0] - p[2, 0] == pytest.approx(2.0)          # full speed after 10 s of acceleration
    assert m.velocity(np.array([40.0]))[0, 0] == pytest.approx(0.2)


def test_scenario_validation(tmp_path):
    with pytest.raises(ConfigError, match="scenario file not found"):
        load_scenario(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[waves]\nhs = -1\n")
    with pytest.raises(ConfigError, match=r"waves.hs = -1: .*valid range \[0, 8\] m"):
        load_scenario(bad)
    bad.write_text("[guidance]\nstandoff = 0\n")
    with pytest.raises(ConfigError, match=r"guidance.standoff = 0: .*valid range \(0, 10\] m"):
        load_scenario(bad)
    from loadarm.params.config import load_config, parse_config
    d = load_config(SCEN.parent / "paper.toml").model_dump()
    d["slew"]["first_deg"] = 39.0
    with pytest.raises(ConfigError, match="slew angles must increase"):
        parse_config(d)
    bad.write_text("[sensor]\nrate = 10\nbogus = 1\n")
    with pytest.raises(ConfigError, match="unknown key 'sensor.bogus'"):
        load_scenario(bad)


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_same_controller_runs_in_real_time():
    import time as _time

    from loadarm.sim.loop import wall_clock_pacer
    sc, inst = load_scenario(SCEN / "calm.toml")
    d = sc.model_dump()
    d["scenario"]["duration"] = 1.5
    sc = parse_scenario(d)
    t0 = _time.monotonic()
    r = run_scenario(sc, inst, pace=wall_clock_pacer(), plant="kinematic")
    wall = _time.monotonic() - t0
    fast = run_scenario(sc, inst, plant="kinematic")
    assert wall >= 1.4                       # paced by the wall clock
    assert np.array_equal(r.signals["mode"], fast.signals["mode"])   # same decisions either way
    with pytest.raises(ValueError, match="speedup must be > 0"):
        wall_clock_pacer(0)


def test_manual_jog_scenario_moves_the_coupler_as_the_joystick_says():
    sc, inst = load_scenario(SCEN / "manual.toml")
    r = run_scenario(sc, inst, plant="kinematic")
    assert r.summary()["mode_sequence"] == ["STORED", "MANUAL", "ESTOP", "RETURN", "STORED"]
    s = r.signals
    dt = 1 / sc.guidance.rate
    i0, i1 = int(6 / dt), int(19.9 / dt)
    v = np.array([(s[k][i1] - s[k][i0]) / (s["t"][i1] - s["t"][i0]) for k in ("x", "y", "z")])
    assert np.allclose(v, sc.operator.jog[0][2:], atol=1e-3)
    stop = int(np.flatnonzero(s["mode"] == MODES.index("ESTOP"))[0])
    assert np.ptp(s["x"][stop:stop + int(4 / dt)]) < 1e-12       # the E-stop cycle stops it
    with pytest.raises(ConfigError, match="operator.jog segments"):
        d = sc.model_dump()
        d["operator"]["jog"] = [[10.0, 5.0, 0.0, 0.0, 0.0]]
        parse_scenario(d)


@settings(max_examples=examples(200))
@given(st.floats(-0.6, 0.6), st.floats(0.05, 2.5), st.floats(0.05, 3.0))
def test_controller_jacobian_is_the_kinematics_jacobian(phi, alpha, beta):
    """The 3D Jacobian (loadarm.arm.slew.jacobian3d, the guidance cycle's) uses kinematics.jacobian_entries on floats: its planar block, rotated
    back, is kinematics.jacobian to the bit; and the whole matrix matches finite differences of forward3d
    (tolerance 1e-7 m/rad: central differences with h = 1e-6 rad on a 20 m arm carry ~4e-9 m/rad of
    rounding and ~2e-11 of truncation)."""
    from loadarm.arm.kinematics import jacobian
    from loadarm.arm.slew import forward3d, jacobian3d
    from loadarm.params.config import paper_installation

    c = _ctrl(compile_model(paper_installation()))
    J3 = jacobian3d(c.arm, phi, alpha, beta)
    J2 = jacobian(c.arm, np.float64(alpha), np.float64(beta))
    cp, sp = math.cos(phi), math.sin(phi)
    assert J3[0, 1] == J2[0, 0] * cp and J3[0, 2] == J2[0, 1] * cp
    assert J3[1, 1] == J2[0, 0] * sp and J3[1, 2] == J2[0, 1] * sp
    assert J3[2, 1] == J2[1, 0] and J3[2, 2] == J2[1, 1]
    h = 1e-6
    for j in range(3):
        dq = np.zeros(3)
        dq[j] = h
        plus = np.array([float(v) for v in forward3d(c.arm, *(np.array([phi, alpha, beta]) + dq))])
        minus = np.array([float(v) for v in forward3d(c.arm, *(np.array([phi, alpha, beta]) - dq))])
        assert np.allclose((plus - minus) / (2 * h), J3[:, j], atol=1e-7)


# ---- the controller as a table of rules: each rule on its own, then the dispatcher ------------------------

def _cycle(ctrl, now=1.0, q=None, est=None, actions=()):
    q = _stored_q(ctrl) if q is None else q
    return Cycle(now, tuple(q), est or _est((14.0, 0.0, 1.0)), OperatorInput(tuple(actions)), frozenset(actions),
                 ctrl.dt_nominal)


def _attached_ctrl(model, mode=Mode.CONNECTED):
    return GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=mode))


def test_rule_emergency_stop_keeps_the_mode_to_resume(model):
    c = _attached_ctrl(model, Mode.ALARM1)
    c.rule_emergency_stop(_cycle(c))
    assert c.state.mode == Mode.ALARM1                       # no E-stop pressed: nothing happens
    c.rule_emergency_stop(_cycle(c, actions=("estop",)))
    assert c.state.mode == Mode.ESTOP and c.state.resume == Mode.ALARM1
    assert [k for k, _, _ in c.state.events] == ["mode", "command"]      # connected: the E-stop initiates ESD-1
    assert c.state.events[1][1].startswith("ESD-1") and c.state.esd_since == 1.0


def test_rule_alarm_escalation_steps_through_every_stage_and_commands_esd_and_ers(model):
    c = _attached_ctrl(model)
    q_release = (0.0, 1.0, c.thr.beta_release + 0.01)        # beyond the release angle at once
    c.rule_alarm_escalation(_cycle(c, q=q_release))
    kinds = [(k, r.split(":")[0]) for k, r, _ in c.state.events]
    assert [r for k, r in kinds if k == "alarm"] == ["PRE-ALARM", "ALARM1", "ALARM2", "RELEASE"]
    assert any(r.startswith("ESD-1") for k, r in kinds if k == "command")
    assert any(r.startswith("ERS-2") for k, r in kinds if k == "command")
    assert c.state.mode == Mode.RELEASE and c.state.esd_since == 1.0 and c.state.release_since == 1.0
    # not attached: the rule does nothing
    d = _ctrl(model)
    d.rule_alarm_escalation(_cycle(d, q=q_release))
    assert d.state.mode == Mode.STORED and not d.state.events


def test_rule_alarm_escalation_during_an_emergency_stop_updates_the_mode_to_resume(model):
    c = GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=Mode.ESTOP, resume=Mode.CONNECTED))
    c.rule_alarm_escalation(_cycle(c, q=(0.0, 1.0, c.thr.beta_first + 0.01)))
    assert c.state.mode == Mode.ESTOP and c.state.resume == Mode.ALARM1 and c.state.esd_since == 1.0


def test_rule_fresh_estimate_enters_hold_in_the_cycle_it_goes_stale(model):
    c = GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=Mode.APPROACH))
    assert c.rule_fresh_estimate(_cycle(c)) and c.state.mode == Mode.APPROACH
    assert not c.rule_fresh_estimate(_cycle(c, est=_est((14.0, 0.0, 1.0), healthy=False)))
    assert c.state.mode == Mode.HOLD and "flange estimate lost" in c.state.events[-1][1]


def test_rule_target_in_envelope_refuses_and_returns(model):
    c = GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=Mode.APPROACH))
    assert c.rule_target_in_envelope(_cycle(c), np.array([12.0, 0.0, 2.0]))
    assert not c.rule_target_in_envelope(_cycle(c), np.array([40.0, 0.0, 0.0]))
    assert c.state.mode == Mode.RETURN and "out of the arm's reach" in c.state.events[-1][1]


@pytest.mark.parametrize("mode", list(Mode))
def test_rule_no_motion_when_held_or_attached(model, mode):
    c = GuidanceController(model, Scenario().guidance.compile(), GuidanceState(mode=mode))
    out = c.rule_no_motion_when_held_or_attached((0.01, 0.02, 0.03))
    held = mode in (Mode.ESTOP, Mode.HOLD, Mode.CONNECTED, Mode.ALARM1, Mode.ALARM2, Mode.RELEASE, Mode.DISCONNECT)
    assert np.all(out == 0.0) if held else np.array_equal(out, [0.01, 0.02, 0.03])


def test_step_is_a_dispatcher_over_named_rules_and_one_handler_per_mode(model):
    import inspect

    c = _ctrl(model)
    assert c.SAFETY_RULES == ("rule_emergency_stop", "rule_manual_emergency", "rule_sensor_fault",
                              "rule_alarm_escalation", "rule_ers_switches", "rule_emergency_release_sequence",
                              "rule_annunciate")
    assert set(c.HANDLERS) == set(Mode) and all(callable(getattr(c, h)) for h in c.HANDLERS.values())
    src = inspect.getsource(GuidanceController.step)
    assert src.count("if ") == 0 and "for rule in self.SAFETY_RULES" in src


def test_scripted_operator_presses_on_cue():
    """run_scenario's stages are testable alone: the operator script fires each action in one cycle."""
    from types import SimpleNamespace as NS

    from loadarm.sim.world import ScriptedOperator

    op = NS(start=1.0, connect_after=2.0, disconnect_at=None, estop_at=5.0, reset_at=None, ack_at=None, esd_at=None,
            ers_at=None, ers_confirm_after=2.0, jog=((7.0, 8.0, 0.1, 0.0, 0.0),))
    s = ScriptedOperator(op, 0.02)
    assert s.inputs(1.0, Mode.STORED, False).actions == ("start",)
    assert s.inputs(1.02, Mode.APPROACH, False).actions == ()
    assert s.inputs(3.0, Mode.STANDOFF, False).actions == ()           # waits connect_after at the standoff
    assert s.inputs(5.0, Mode.STANDOFF, False).actions == ("connect", "estop")
    assert s.inputs(6.0, Mode.ESTOP, True).actions == ()               # a fault does not re-press in ESTOP
    assert s.inputs(6.0, Mode.CONNECTED, True).actions == ("estop",)
    inp = s.inputs(7.0, Mode.STORED, False)
    assert inp.actions == ("manual",) and inp.jog == (0.1, 0.0, 0.0)
    assert s.inputs(8.0, Mode.MANUAL, False).actions == ("auto",)


def test_arm_plant_follows_the_flange_and_reports_overstretch(model):
    from loadarm.guidance.modes import Command
    from loadarm.sim.world import ArmPlant

    seen = []
    c = _ctrl(model)
    q0 = np.array(_stored_q(c))
    ap = ArmPlant(model, q0, "kinematic", lambda *a: seen.append(a))
    attached = Command(Mode.CONNECTED, (0.0, 0.0, 0.0), True, False, False)
    q = ap.step(1.0, 0.02, attached, np.array([12.0, 0.0, 2.0]))
    assert np.allclose(forward3d(c.arm, *q), (12.0, 0.0, 2.0))
    ap.step(2.0, 0.02, attached, np.array([40.0, 0.0, 0.0]))       # beyond reach: the arm stays, alarm once
    ap.step(2.02, 0.02, attached, np.array([41.0, 0.0, 0.0]))
    assert ap.overstretched == 2.0 and len(seen) == 1 and "OVERSTRETCHED" in seen[0][3]
    free = Command(Mode.RETURN, (0.01, 0.0, 0.0), False, False, False)
    q1 = ap.step(3.0, 0.5, free, np.zeros(3))
    assert q1[0] == pytest.approx(q[0] + 0.005)


# ---- the emergency release sequence (issue "connected-mode safety chain", first part) -------------------

def _with_sequence(model, **times):
    import dataclasses

    return dataclasses.replace(model, sequence=dataclasses.replace(model.sequence, **times))


def _release_run(model, ers_valve_time=10.0, estop_at=None, until=60.0, actions=None, stuck=False, q=None):
    """Attached arm held beyond the release angle from t = 0 (or at ``q``), with the ERS valves of the plant;
    returns the controller and the events (t, kind, reason)."""
    from loadarm.guidance.modes import PlantFeedback
    from loadarm.sim.world import ErsValves

    m = _with_sequence(model, ers_valve_time=ers_valve_time)
    c = GuidanceController(m, Scenario().guidance.compile(), GuidanceState(mode=Mode.CONNECTED))
    q = (0.0, 1.0, c.thr.beta_release + 0.01) if q is None else q      # or a function of time
    valves = ErsValves(ers_valve_time, stuck=stuck)
    fb = PlantFeedback()
    actions = dict(actions or {})
    if estop_at is not None:
        actions[estop_at] = ("estop",)
    out = []
    for k in range(int(until / 0.02)):
        now = round(k * 0.02, 9)
        qq = q(now) if callable(q) else q
        cmd = c.step(now, qq, _est((14.0, 0.0, 1.0)), OperatorInput(actions.get(now, ())), fb)
        out += [(now, kind, reason) for kind, reason, _ in cmd.events]
        fb = PlantFeedback(ers_switches=valves.step(now, cmd.close_ers_valves))
        assert not cmd.coupler_open or c.state.valves_closed_at is not None or not c.attached()
    return c, out


def _first(events, text):
    return next(t for t, _, r in events if text in r)


@pytest.mark.parametrize("ers_valve_time", [5.0, 10.0, 30.0])
def test_the_coupler_never_opens_before_the_ers_valves_are_confirmed_closed(model, ers_valve_time):
    """Found: the release was a 3 s timer started at the release angle; with a 30 s ESD-1 the coupler opened
    before the valves had closed, on live product. Now the plant's limit switches decide."""
    c, ev = _release_run(model, ers_valve_time)
    q = c.seq
    t_esd, t_closed = _first(ev, "ESD-1"), _first(ev, "confirmed closed (limit switches)")
    t_open, t_free = _first(ev, "coupler opening"), _first(ev, "release complete")
    assert t_esd == 0.0 and t_closed == pytest.approx(ers_valve_time, abs=0.021)
    assert t_open >= t_closed and t_free == pytest.approx(t_open + q.erc_release_time, abs=0.021)
    assert [k for t, k, r in ev if "limit switches" in r] == ["interlock"]


def test_a_valve_that_never_confirms_is_a_fault_and_the_coupler_stays_closed(model):
    c, ev = _release_run(model, 10.0, stuck=True, until=40.0)
    t_fault = _first(ev, "ERS VALVE FAULT")
    assert t_fault == pytest.approx(10.0 + c.seq.ers_valve_timeout, abs=0.041)
    assert [k for t, k, r in ev if "ERS VALVE FAULT" in r] == ["alarm"]           # once
    assert not any("coupler opening" in r for _, _, r in ev) and c.attached()
    assert c.state.alarms["ERS_VALVE_FAULT"].value == "unacknowledged"


def test_an_emergency_stop_never_blocks_the_release(model):
    """Found: an E-stop pressed during a drift-off stopped the emergency release; the arm overstretched attached."""
    c, ev = _release_run(model, 10.0, estop_at=2.0)
    assert _first(ev, "emergency stop") == pytest.approx(2.0)
    assert _first(ev, "release complete") == pytest.approx(10.0 + c.seq.erc_release_time, abs=0.021)
    assert c.state.mode == Mode.ESTOP and c.state.resume == Mode.RETURN and not c.attached()
    cmd = c.step(100.0, (0.0, 1.0, 1.0), _est((14.0, 0.0, 1.0)), OperatorInput(("reset",)))
    assert cmd.mode == Mode.RETURN


def test_manual_ers_needs_its_confirmation_and_manual_esd_works_from_estop(model):
    q_ok = tuple(float(v) for v in inverse3d(model.arm, 13.0, 0.0, 1.0))
    # armed and never confirmed: nothing is released
    c, ev = _release_run(model, q=q_ok, actions={1.0: ("ers",)}, until=30.0)
    assert any("manual ERS armed" in r for _, _, r in ev) and not any("ERS-2" in r for _, _, r in ev)
    # confirmed too late: refused
    c, ev = _release_run(model, q=q_ok, actions={1.0: ("ers",), 12.0: ("ers_confirm",)}, until=30.0)
    assert any("ERS confirmation refused" in r for _, _, r in ev) and not any("ERS-2" in r for _, _, r in ev)
    # confirmed in time: ESD-1 at once, the coupler opens after the valves, the arm leaves
    c, ev = _release_run(model, q=q_ok, actions={1.0: ("ers",), 3.0: ("ers_confirm",)}, until=30.0)
    assert _first(ev, "ESD-1") == 3.0 and _first(ev, "coupler opening") >= 3.0 + 10.0 - 0.021
    assert _first(ev, "release complete") < 30.0
    # E-stop first, then a manual ESD-1: the ESD-1 still runs
    c, ev = _release_run(model, q=q_ok, actions={1.0: ("estop",), 2.0: ("esd",)}, until=15.0)
    assert _first(ev, "ESD-1") == 1.0 and _first(ev, "confirmed closed") == pytest.approx(11.0, abs=0.021)


def test_esd_reset_needs_the_condition_cleared_and_the_alarms_acknowledged(model):
    """ISA-18.2: beyond the first alarm, then slowly back inside (a berth with a small design drift, so only the
    customer's angle alarms); the reset is refused while the condition is present and until the alarm is
    acknowledged, then takes the arm from ALARM1 back to CONNECTED."""
    import dataclasses

    calm = dataclasses.replace(model, design_drift=dataclasses.replace(model.design_drift, speed=0.02))
    q_ok = tuple(float(v) for v in inverse3d(model.arm, 13.0, 0.0, 1.0))
    b_far, b_in = model.alarms.first + 0.02, model.alarms.first - 0.05

    def q(t):                                                  # back inside at about 0.1 m/s between 4 and 9 s
        f = min(max((t - 4.0) / 5.0, 0.0), 1.0)
        return (q_ok[0], q_ok[1], b_far + f * (b_in - b_far))

    c, ev = _release_run(calm, q=q, actions={2.0: ("reset",), 80.0: ("reset",), 85.0: ("ack",), 86.0: ("reset",)},
                         until=90.0)
    refused = [(t, r) for t, _, r in ev if "reset refused" in r]
    assert [t for t, _ in refused] == [2.0, 80.0]
    assert "still present" in refused[0][1]
    assert "ESD1 returned to normal, unacknowledged" in refused[1][1]      # cleared, not acknowledged
    assert _first(ev, "ESD-1 reset") == 86.0 and c.state.mode == Mode.CONNECTED
    assert c.state.esd_since is None and c.alarms_clear() and not any("ERS-2" in r for _, _, r in ev)
    states = [(t, r) for t, k, r in ev if k == "alarm_state" and r.startswith("ESD1")]
    assert states[0] == (0.0, "ESD1: unacknowledged") and states[-1] == (85.0, "ESD1: normal")
    assert states[-2][1] == "ESD1: returned to normal, unacknowledged"
    # Known limitation (issue note): the quadratic drift fit extrapolates the knee of the ramp back outwards, so
    # the condition comes and goes until the ramp has left the fit's window (60 s).


def test_controlled_disconnection_closes_drains_unclamps_and_lifts_off(model):
    q_ok = tuple(float(v) for v in inverse3d(model.arm, 13.0, 0.0, 1.0))
    c, ev = _release_run(model, q=q_ok, actions={1.0: ("disconnect",)}, until=60.0)
    seq = c.seq
    t_closed = _first(ev, "confirmed closed")
    assert t_closed == pytest.approx(1.0 + seq.ers_valve_time, abs=0.021)
    assert _first(ev, "draining") == t_closed
    assert _first(ev, "unclamping") == pytest.approx(t_closed + seq.drain_time, abs=0.021)
    assert _first(ev, "lifting off") == pytest.approx(t_closed + seq.drain_time + seq.unclamp_time, abs=0.021)
    assert c.state.mode == Mode.RETURN and c.state.lift_target[2] == pytest.approx(1.0 + seq.lift_off)
    assert not any(k == "alarm" for _, k, _ in ev)


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
def test_estop_during_a_driftoff_releases_before_the_limit():
    """The stock drift-off with the E-stop pressed at 220 s and 236 s (found: 15 of 15 runs overstretched)."""
    sc, model = load_scenario(SCEN / "driftoff.toml")
    for t in (220.0, 236.0):
        s = sc.model_copy(update={"operator": sc.operator.model_copy(update={"estop_at": t})})
        r = run_scenario(s, model, plant="kinematic").summary()
        assert r["release_complete_s"] is not None and r["overstretched_s"] is None, (t, r)


def test_a_refused_start_is_forgotten(model):
    """Found: a start refused at 1 s (flange out of reach) stayed armed and the approach began by itself when
    the flange came into reach, logged as 'operator started the approach'; the refusal, whose reason carries
    changing numbers, was logged every cycle."""
    c = _ctrl(model)
    q = _stored_q(c)
    events = []
    cmd = c.step(1.0, q, _est((40.0, 0.0, 1.0)), OperatorInput(("start",)))
    events += cmd.events
    assert cmd.mode == Mode.STORED and any("approach refused" in e[1] for e in cmd.events)
    for k in range(1, 200):                                   # the ship comes in; nobody presses anything
        cmd = c.step(1.0 + 0.02 * k, q, _est((40.0 - 0.2 * k, 0.0, 1.0)))
        events += cmd.events
        assert cmd.mode == Mode.STORED
    assert sum("approach refused" in e[1] for e in events) == 1
    assert not any("started the approach" in e[1] for e in events)
    cmd = c.step(10.0, q, _est((14.0, 0.0, 1.0)), OperatorInput(("start",)))
    assert cmd.mode == Mode.APPROACH                          # a fresh action starts it


def test_a_blind_drift_filter_and_an_unreachable_release_angle_are_refused(tmp_path):
    """Found: drift_filter = 600 s was accepted (the speed alarm blind; now the drift fit's window); release_deg = 175 beyond cylinder 2's
    stroke end (167 deg) was not cross-checked."""
    from loadarm.errors import ConfigError
    from loadarm.params.compiler import compile_model
    from loadarm.params.config import load_config

    bad = tmp_path / "slow.toml"
    bad.write_text("[guidance]\ndrift_window = 600\n")
    with pytest.raises(ConfigError, match=r"drift_window = 600 s is too slow for the sequence it protects .* "
                                          r"valid range \(5, 70\] s"):
        load_scenario(bad)
    text = (SCEN.parent / "paper.toml").read_text().replace("release_deg = 150.0", "release_deg = 175.0")
    cfg = tmp_path / "rel.toml"
    cfg.write_text(text)
    inst = load_config(cfg)                                   # valid on its own ...
    with pytest.raises(ConfigError, match=r"release_deg = 175 deg lies beyond .* stroke ends at beta = 166.8 deg"):
        compile_model(inst)                                   # ... but not for this arm


def test_the_estimator_restarts_only_on_agreeing_readings_and_says_when_it_converges():
    """Found: after three rejected readings the estimator re-initialised on the third, itself possibly an
    outlier, and called itself healthy (with 10-20 % outliers the arm moved on a healthy estimate 0.5 m off)."""
    est = FlangeEstimator(noise=0.02, max_age=0.5)
    t = 0.0
    for _ in range(20):                                     # a steady track at (14, 0, 1)
        assert est.update(t, (14.0, 0.0, 1.0))
        t += 0.1
    for z in ((16.0, 3.0, 1.0), (11.0, -2.0, 4.0), (17.5, 1.0, -2.0), (12.0, 2.5, 3.0)):   # scattered burst
        assert not est.update(t, z)
        t += 0.1
    e = est.estimate(t + 0.2)
    assert e.position == pytest.approx((14.0, 0.0, 1.0), abs=0.05) and est.restarts == 0
    assert not e.healthy and "no accepted reading" in e.reason     # the old track goes stale: motion stops
    # readings 2 m away, consistently: farther than the flange can move (1 m/s) since the last accepted reading,
    # so a second target, not a restart, until enough time has passed; then a restart, unhealthy until converged
    for k in range(3):
        assert not est.update(t, (16.0, 0.0, 1.0))
        t += 0.1
    assert est.restarts == 0 and not est.estimate(t).healthy
    t = 1.9 + 2.2                                            # the flange could now have moved 2 m
    for k in range(3):
        est.update(t, (16.0, 0.0, 1.0))
        t += 0.1
    e = est.estimate(t)
    assert not e.healthy and "converging" in e.reason and e.position[0] == pytest.approx(16.0, abs=0.3)
    healthy = []
    for k in range(60):
        est.update(t, (16.0, 0.0, 1.0))
        healthy.append(est.estimate(t).healthy)
        t += 0.1
    # trusted only once converged (5 readings), once the rejected readings have left the 20-reading window, and
    # 5 s after agreeing readings were rejected (a second target until then)
    assert not any(healthy[:5]) and healthy[-1] and est.estimate(t).position[0] == pytest.approx(16.0, abs=0.01)


@settings(max_examples=examples(30), deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(0.05, 0.45), st.floats(0.0, 0.2))
def test_a_second_flange_and_outlier_bursts_never_make_a_healthy_wrong_estimate(seed, ghost, outliers):
    """Issue 10, item 5: readings from a second flange 2 m away (a fraction ``ghost`` of them, in runs of up to
    1.2 s: much longer, and the flange could really have moved there at 1 m/s) and scattered outliers; the arm moves
    only on a healthy estimate, so whenever the estimate is healthy it must be on the true flange: never 0.5 m off
    (the issue's failure; an outlier that slips through a gate widened by a gap can pull a healthy estimate about
    0.35 m for a few readings, seen once in 500 examples)."""
    rng = np.random.default_rng(seed)
    est = FlangeEstimator(noise=0.02, max_age=0.5)
    true0, ghost_off = np.array([14.0, 0.0, 1.0]), np.array([2.0, 0.0, 0.0])
    on_ghost, run = False, 0
    for k in range(600):
        t = 0.1 * k
        truth = true0 + 0.3 * np.array([math.sin(0.6 * t), 0.0, math.cos(0.6 * t)])
        if run >= 12 or k < 20:                          # runs: the tracker locks on the ghost for up to 1.2 s,
            on_ghost, run = False, 0                     # after a supervised 2 s acquisition on the true flange
        elif rng.random() < 0.2:
            switch = (rng.random() < ghost) != on_ghost
            on_ghost, run = on_ghost ^ switch, 0 if switch else run
        run += on_ghost
        z = truth + (ghost_off if on_ghost else 0.0) + rng.normal(0.0, 0.02, 3)
        if rng.random() < outliers:
            z = truth + rng.uniform(-3.0, 3.0, 3)
        est.update(t, tuple(float(v) for v in z))
        e = est.estimate(t + 0.05)
        if e.healthy:
            assert math.dist(e.position, truth) < 0.5, (k, e)


def test_the_nis_bound_is_the_chi_square_quantile_and_an_inconsistent_filter_is_unhealthy():
    from scipy.stats import chi2

    from loadarm.guidance.estimator import NIS_MEAN_999, NIS_WINDOW

    assert NIS_MEAN_999 == pytest.approx(chi2.ppf(0.999, 3 * NIS_WINDOW) / NIS_WINDOW, abs=1e-4)
    # readings four times noisier than the filter believes: gated rarely, but the innovations are too big
    rng = np.random.default_rng(3)
    est = FlangeEstimator(noise=0.01, max_age=0.5)
    unhealthy = 0
    for k in range(400):
        est.update(0.1 * k, tuple(float(v) for v in np.array([14.0, 0.0, 1.0]) + rng.normal(0.0, 0.025, 3)))
        e = est.estimate(0.1 * k)
        unhealthy += "innovations inconsistent" in e.reason
    assert est.nis_mean() > NIS_MEAN_999 and unhealthy > 100


# ---- faults on the plant side: HPU trip, stuck ERS valves; the retraction after a release ------------------

def _driftoff_with(**faults):
    sc, model = load_scenario(SCEN / "driftoff.toml")
    sc = sc.model_copy(update={"faults": sc.faults.model_copy(update=faults),
                               "scenario": sc.scenario.model_copy(update={"plant": "kinematic"})})
    return run_scenario(sc, model)


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
def test_an_hpu_trip_during_a_driftoff_does_not_stop_the_release():
    r = _driftoff_with(hpu_trip_at=215.0)
    v = r.to_dict()
    assert r.first("alarm", "HPU trip") == 215.0
    assert v["release_complete_s"] is not None and v["overstretched_s"] is None and v["release_margin_s"] > 0
    assert v["coupler_opening_s"] >= v["valves_confirmed_s"]
    # the drives retract the arm on what the ERS left in the accumulator (issue 25; before, they could not move
    # and only the ship drifting away cleared the manifold), then stop where the oil runs out
    assert v["cleared_s"] is not None and v["retracted_s"] is not None
    spent = r.first("alarm", "ERS accumulator spent")
    assert spent is not None and spent > v["retracted_s"]
    k = int(np.searchsorted(r.signals["t"], spent))
    assert np.ptp(r.signals["beta"][k + 1:]) < 1e-12


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
def test_stuck_ers_valves_keep_the_coupler_closed_and_say_so():
    """The interlock holds even when it costs the arm: no release on live product; the fault alarm gives the
    operator the warning (documented in docs/guidance.md section 6)."""
    r = _driftoff_with(ers_valve_stuck=True)
    v = r.to_dict()
    t_fault = r.first("alarm", "ERS VALVE FAULT")
    assert t_fault is not None and v["coupler_opening_s"] is None and v["release_complete_s"] is None
    assert v["overstretched_s"] is not None and t_fault < v["overstretched_s"] - 10.0


@pytest.mark.slow  # 5 s of the hydraulic closed loop: make test keeps to its 2 minutes (CI runs it)
def test_after_an_emergency_release_the_drives_start_from_the_real_state(model, runs):
    from loadarm.hydraulics.servo import HydraulicArm

    arm = HydraulicArm(model, 1.0, 2.0, fill=1.0)
    arm.reset(1.0, 2.0, 0.01, -0.02)
    assert arm.state.y[2] == 0.01 and arm.state.y[3] == -0.02
    empty = HydraulicArm(model, 1.0, 2.0)
    assert arm.k.k11 > empty.k.k11                           # product in the arm: more inertia
    r = runs["driftoff"][2]                                  # the stock drift-off on the hydraulic plant
    v = r.to_dict()
    assert v["overstretched_s"] is None and v["cleared_s"] - v["release_complete_s"] < 10.0
    assert v["final_mode"] == "RETURN" and r.first("alarm", "servo fault") is None


def test_a_coupler_that_does_not_clear_the_manifold_raises_an_alarm():
    from loadarm.guidance.modes import Command
    from loadarm.sim.limits import CLEARANCE_TIME, ClearanceWatch

    seen = []
    w = ClearanceWatch(lambda *a: seen.append(a))
    w.watch(0.0, Command(Mode.RELEASE, (0, 0, 0), True, True, True), 0.0)
    for k in range(1, 2000):                                  # released at 0.02 s, stays 0.5 m from the flange
        w.watch(0.02 * k, Command(Mode.RETURN, (0, 0, 0), False, False, False), 0.5)
    assert len(seen) == 1 and "not clear of the ship's manifold" in seen[0][3]
    assert seen[0][0] == pytest.approx(0.02 + CLEARANCE_TIME, abs=0.021)
    ok = []
    w = ClearanceWatch(lambda *a: ok.append(a))
    w.watch(0.0, Command(Mode.RELEASE, (0, 0, 0), True, True, True), 0.0)
    for k in range(1, 2000):
        w.watch(0.02 * k, Command(Mode.RETURN, (0, 0, 0), False, False, False), 0.05 * k)
    assert not ok


@pytest.mark.slow           # 2-4 s: make test's budget on 2 cores (CI runs it)
def test_over_a_plant_that_does_not_know_the_true_flange_the_clearance_is_watched_on_the_estimate():
    """Over a PLC the plant returns no true flange (NaN): found, the clearance watch then took NaN for the
    distance and raised "not clear of the ship's manifold (nan m ...)" 30 s after every release. The drift-off
    on the kinematic plant with the true flange hidden from the loop: the release clears the coupler by the
    estimate, and no alarm; with the estimate unhealthy too, the alarm says the flange position is unknown."""
    from loadarm.guidance.modes import Command
    from loadarm.sim.limits import CLEARANCE_TIME, ClearanceWatch
    from loadarm.sim.loop import ClosedLoop

    class NoTruth:                                           # the PLC link's answer: encoders, no true flange
        def __init__(self, io):
            self._io = io

        def __getattr__(self, name):
            return getattr(self._io, name)

        def step(self, k, now, dt, cmd):
            q, _ = self._io.step(k, now, dt, cmd)
            return q, np.full(3, np.nan)

    sc, model = load_scenario(SCEN / "driftoff.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"plant": "kinematic"})})
    loop = ClosedLoop(sc, model)
    loop.io = NoTruth(loop.io)
    for k in range(loop.n):
        loop.cycle(k)
    r = loop.result()
    t_rel = r.first("command", "release complete")
    assert t_rel is not None and sc.scenario.duration - t_rel > CLEARANCE_TIME      # the watch had its 30 s
    assert np.isnan(r.signals["distance"]).all()
    assert r.first("alarm", "not clear of the ship's manifold") is None, r.events
    seen = []
    w = ClearanceWatch(lambda *a: seen.append(a))
    w.watch(0.0, Command(Mode.RELEASE, (0, 0, 0), True, True, True), 0.0)
    for k in range(1, 2000):                                  # released, then nothing known of the flange
        w.watch(0.02 * k, Command(Mode.RETURN, (0, 0, 0), False, False, False), math.nan)
    assert len(seen) == 1 and "flange position unknown" in seen[0][3] and "nan" not in seen[0][3]


@pytest.mark.slow  # make test's 2-minute budget (2-4 s here); CI runs it
def test_a_scripted_manual_ers_releases_the_calm_ship_after_the_valves_close():
    """The operator's manual ERS from the scenario file: armed at 150 s, confirmed 2 s later; ESD-1 at once, the
    coupler opens only after the ERS valves' limit switches, then the arm returns."""
    sc, model = load_scenario(SCEN / "calm.toml")
    sc = sc.model_copy(update={"operator": sc.operator.model_copy(update={"ers_at": 150.0, "ack_at": 200.0}),
                               "scenario": sc.scenario.model_copy(update={"plant": "kinematic",
                                                                          "duration": 210.0})})
    r = run_scenario(sc, model)
    v = r.to_dict()
    assert r.first("info", "manual ERS armed") == 150.0 and r.first("command", "ESD-1") == 152.0
    assert v["valves_confirmed_s"] == pytest.approx(152.0 + model.sequence.ers_valve_time, abs=0.021)
    assert v["coupler_opening_s"] >= v["valves_confirmed_s"] and v["overstretched_s"] is None
    assert v["mode_sequence"][-2:] == ["RELEASE", "RETURN"] and r.first("operator", "ack") == 200.0
    # the stages are logged with their cause; an operator's action is not an alarm condition: nothing annunciated
    assert all("manual ERS" in e[3] for e in r.events if e[2] == "alarm") and r.first("alarm_state") is None


def test_the_controller_takes_the_compiled_guidance_record_not_the_file_section():
    """Issue 26: the scenario's sections are compiled once at the edge; the controller takes the frozen
    GuidanceSettings and refuses the pydantic section, naming what it wants."""
    import dataclasses

    from loadarm.params.config import paper_installation
    from loadarm.params.scenario import GuidanceSettings

    model = compile_model(paper_installation())
    g = Scenario().guidance
    with pytest.raises(TypeError, match=r"GuidanceSettings.*Guidance.compile\(\)"):
        GuidanceController(model, g)
    rec = g.compile()
    assert isinstance(rec, GuidanceSettings) and dataclasses.asdict(rec) == g.model_dump()
    with pytest.raises(dataclasses.FrozenInstanceError):
        rec.rate = 1.0
    assert GuidanceController(model, rec).dt_nominal == 1.0 / g.rate


def test_warming_up_the_plant_changes_nothing_of_the_run():
    """Found (issue 26, CI on a fresh clone): `loadarm serve`'s first cycle compiled the hydraulic plant for
    seconds, late on the clock and deaf to a Ctrl-C. The loop now compiles it before its clock starts, on a copy
    of the servo's state that is put back: the run is the same, bit for bit."""
    from loadarm.sim.loop import ClosedLoop

    sc, model = load_scenario("examples/scenarios/driftoff.toml")
    d = sc.model_dump()
    d["scenario"]["duration"] = 20.0
    sc = sc.model_validate(d)
    runs = []
    for warm in (True, False):
        loop = ClosedLoop(sc, model)
        if warm:
            loop.warm_up()
        for k in range(loop.n):
            loop.cycle(k)
        runs.append(loop.result().signals)
    assert runs[0].keys() == runs[1].keys()
    assert all(np.array_equal(runs[0][s], runs[1][s], equal_nan=True) for s in runs[0])


def test_an_esd1_reset_forgets_the_call_and_its_hold(model):
    """Found by review: the rule without the prediction's call and its hold outlived an ESD-1 reset, so the next
    cycle ended a "call" holding the whole ESD-1 episode, and a call just after the reset joined that group with
    its hold spent (ESD-1 again at once, by hold_limit). The reset forgets them, as a new connection does."""
    import math

    c = _attached_ctrl(model, Mode.ALARM1)
    s = c.state
    s.esd_since, s.raised, s.shadow_esd1_at, s.hold_since, s.hold_until = 10.0, Severity.ESD1, 5.0, 5.0, 20.0
    c._reset_esd(30.0)
    assert s.mode == Mode.CONNECTED and s.esd_since is None
    assert (s.shadow_esd1_at, s.hold_since, s.hold_until, s.shadow_end_at) == (None, None, math.inf, -math.inf)
