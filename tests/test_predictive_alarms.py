"""The live flange predictor (loadarm.guidance.predict.FlangePredictor) and the predictive alarms of the monitor
(loadarm.guidance.rules, loadarm.guidance.monitor.predicted_crossing), against independent routes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.guidance import predict as pr
from loadarm.guidance.monitor import predicted_crossing
from loadarm.arm.faces import face_margins, first_face
from loadarm.params.config import paper_installation
from loadarm.params.compiler import compile_model
from loadarm.vocab import ALARM_RULES, FACES

from .conftest import ROOT
from .hypo import examples

SCEN = ROOT / "examples" / "scenarios"


def _sway(n: int, seed: int, dt: float = 0.2) -> np.ndarray:
    """A moored flange's slow sway (periods 60-100 s) and waves (8-10 s), sampled every ``dt``: (n, 3), m."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    out = np.zeros((n, 3))
    for ax, amp in enumerate((0.6, 0.4, 0.05)):
        for period, a in ((rng.uniform(60, 100), amp), (rng.uniform(8, 10), 0.3 * amp)):
            out[:, ax] += a * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        out[:, ax] += 0.02 * rng.normal(size=n)
    return out + np.array([13.0, 1.0, 0.5])


def _feed(fp: pr.FlangePredictor, p: np.ndarray, t0: float = 0.0, dt: float = 0.2) -> None:
    for i in range(p.shape[0]):
        fp.push(t0 + i * dt, p[i])


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_the_predictor_claims_only_after_its_fit_and_calibration():
    """No forecast before MIN_FIT s of track and MIN_ERRORS realised errors at the first horizon; then the
    whole claim (120 s) once every horizon has its errors; in a stationary sway the departure test stays quiet."""
    fp = pr.FlangePredictor()
    p = _sway(int(2400 / 0.2), seed=1)
    first_claim = None
    for i in range(p.shape[0]):
        if fp.push(i * 0.2, p[i]) and fp.forecast is not None and first_claim is None:
            first_claim = i * 0.2
    assert first_claim is not None
    assert first_claim >= pr.MIN_FIT + pr.MIN_ERRORS * pr.PREDICT_PERIOD
    assert fp.forecast.claimed == pr.CLAIMS["online AR"]
    assert fp.departed_at is None
    assert fp.trusted(35.0) is fp.forecast
    assert fp.trusted(121.0) is None                         # never trusted beyond its claim
    # beyond the claim: no prediction, not a number
    assert np.all(np.isnan(fp.forecast.lo[int(fp.forecast.claimed):]))


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_a_drift_the_model_has_not_seen_is_found_and_stands_the_prediction_down():
    """A drift at 0.02 m/s^2 (a break-out) added to a calibrated sway: the departure test finds it within 25 s
    (2 blocks at 3 half-widths); from then the prediction is not trusted for the rest of the connection."""
    fp = pr.FlangePredictor()
    n0 = int(2400 / 0.2)
    p = _sway(n0 + 500, seed=2)
    _feed(fp, p[:n0])
    assert fp.trusted(35.0) is not None
    t = np.arange(500) * 0.2
    p[n0:, 0] += 0.5 * 0.02 * t ** 2
    _feed(fp, p[n0:], t0=n0 * 0.2)
    assert fp.departed_at is not None
    assert fp.departed_at - n0 * 0.2 <= 25.0
    assert fp.trusted(35.0) is None


@pytest.mark.slow  # 2-3 s: the sway of the test above, twice
def test_before_the_connection_a_departure_starts_the_calibration_again():
    """Not connected (the berth monitoring's track before the arm connects: ``latch`` off), the same drift is
    found at the same block, but it does not latch: the calibration begins again (no forecast until its errors
    are in), the AR keeps learning the track, and once the drift has stopped the prediction is claimed and
    trusted again (found: Hs 1.5-2.0 m seeds 163 and 177 departed 15-20 minutes before the connection, on the sea
    alone, and lost the prediction for the whole run). Connected (``latch`` on, the default), it latches; and when
    the connection ends (``latch`` off) the latched departure starts the calibration again."""
    n0 = int(2400 / 0.2)
    p = _sway(n0 + 500 + 6000, seed=2)
    t = np.arange(500) * 0.2
    p[n0:n0 + 500, 0] += 0.5 * 0.02 * t ** 2
    p[n0 + 500:, 0] += 0.5 * 0.02 * t[-1] ** 2                   # then still: the ship at its new place
    latched, free = pr.FlangePredictor(), pr.FlangePredictor()
    free.latch = False
    _feed(latched, p[:n0 + 500])
    _feed(free, p[:n0 + 500])
    assert latched.departed_at is not None and not latched.recalibrated
    assert free.departed_at is None and free.recalibrated == [latched.departed_at]
    assert free.trusted(35.0) is None and free.cal.count.max() < pr.MIN_ERRORS    # calibrating afresh
    _feed(free, p[n0 + 500:], t0=(n0 + 500) * 0.2)                      # 20 minutes more of the sway
    assert free.departed_at is None and free.trusted(35.0) is not None
    # the connection ends (latch off): the latched departure's calibration starts again, and the same track
    # brings the prediction back (found: it stood down until the track restarted, so a next connection to the
    # same ship found it still standing down)
    departed = latched.departed_at
    latched.latch = False
    assert latched.departed_at is None and latched.cleared == [departed] and not latched.recalibrated
    assert latched.trusted(35.0) is None and latched.cal.count.max() < pr.MIN_ERRORS
    _feed(latched, p[n0 + 500:], t0=(n0 + 500) * 0.2)
    assert latched.departed_at is None and latched.trusted(35.0) is not None
    latched.latch = True                                               # connected again: nothing to restart
    assert latched.cleared == [departed] and latched.trusted(35.0) is not None


def test_a_short_gap_is_bridged_and_a_long_one_starts_again():
    """A gap of 5 s in the positions keeps the track (its blocks filled by a straight line); one of 15 s
    (beyond MAX_GAP) starts it again."""
    p = _sway(3000, seed=3)
    fp = pr.FlangePredictor()
    _feed(fp, p[:1000])
    _feed(fp, p[1025:1500], t0=1025 * 0.2)                  # 5 s without positions
    assert len(fp.track) == 1500 // 5 - 1                   # every block 0..298, the gap's five filled in
    assert fp.index + 1 == len(fp.track)
    fp2 = pr.FlangePredictor()
    _feed(fp2, p[:1000])
    _feed(fp2, p[1075:1500], t0=1075 * 0.2)                 # 15 s
    assert len(fp2.track) < 90


@settings(max_examples=examples(30), deadline=None)
@given(steps=st.integers(1, 12), made=st.lists(st.integers(0, 40), min_size=1, max_size=30, unique=True),
       seed=st.integers(0, 2 ** 31 - 1))
def test_the_calibrator_s_ring_realises_the_same_errors_as_a_list(steps, made, seed):
    """The calibrator keeps its outstanding forecasts in a ring (vectorised); the errors it realises are those of
    a plain list of every forecast, each answered by the blocks 1..steps after it, bit for bit."""
    rng = np.random.default_rng(seed)
    made = sorted(made)
    cal = pr.Calibrator(steps, memory=64, min_errors=1)
    forecasts = {m: (rng.normal(size=(steps, 3)), rng.uniform(0.1, 2.0, size=(steps, 3))) for m in made}
    values = rng.normal(size=(max(made) + steps + 2, 3))
    expected = [[] for _ in range(steps)]
    for index in range(values.shape[0]):
        cal.observe(index, values[index])
        for m, (mean, sd) in forecasts.items():
            j = index - m - 1
            if 0 <= j < steps and m < index:
                expected[j].append((values[index] - mean[j]) / sd[j])
        if index in forecasts:
            cal.remember(index, *forecasts[index])
    for j in range(steps):
        got = cal.z[j, :, : cal.count[j]].T
        assert np.array_equal(got, np.array(expected[j]).reshape(-1, 3))


def _model():
    return compile_model(paper_installation())


def _forecast(centre, half, claimed=120.0, t=100.0):
    n = centre.shape[0]
    h = np.arange(1, n + 1, dtype=float)
    lo, hi = centre - half, centre + half
    lo[int(claimed):] = np.nan
    hi[int(claimed):] = np.nan
    return pr.Forecast(h, centre, lo, hi, claimed, t, "online AR")


@settings(max_examples=examples(30), deadline=None)
@given(speed=st.floats(0.02, 0.3), half=st.floats(0.0, 0.5), age=st.floats(0.0, 0.99),
       direction=st.floats(-0.6, 0.6))
@pytest.mark.slow           # 3 s (make test's budget; CI runs it)
def test_the_predicted_crossing_is_never_later_than_the_box_s_first_crossing(speed, half, age, direction):
    """A predicted track moving off the berth at ``speed``: the crossing found is the start of the first block
    whose box (interval plus the motion within a block) has a corner past a face, checked by an independent scan
    of the box's corners at 0.05 s steps of a piecewise-constant track (never later than it, at most one block
    earlier)."""
    model = _model()
    h = np.arange(1, 121, dtype=float)
    d = np.array([math.cos(direction), math.sin(direction), 0.0])
    centre = np.array([13.0, 1.0, 0.5]) + speed * h[:, None] * d
    f = _forecast(centre, np.full((120, 3), half))
    within = np.array([0.1, 0.1, 0.05])
    now = f.time + age
    t, face = predicted_crossing(model, f, within, now, 120.0)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    first = math.inf
    for tau in np.arange(0.0, 121.0 - age, 0.05):
        k = int(math.floor(tau + age))                       # the block covering now + tau: (t + k, t + k + 1]
        if k >= 120 or k - age > 120.0:
            break
        pts = centre[k] + (half + within) * corners
        out, _ = first_face(face_margins(model, pts[:, 0], pts[:, 1], pts[:, 2]))
        if out.any():
            first = tau
            break
    if math.isinf(first):
        assert math.isinf(t) and face == ""
    else:
        assert face in FACES
        assert t <= first + 1e-9
        assert t >= first - 1.0 - 1e-9


@settings(max_examples=examples(20), deadline=None)
@given(speed=st.floats(0.02, 0.3), a=st.floats(-0.5, 0.5), b=st.floats(0.0, 0.6),
       direction=st.floats(-3.1, 3.1))
def test_the_bound_is_never_later_than_the_mean_track_even_with_an_edge_inside_the_mean(speed, a, b, direction):
    """An interval that need not hold its mean (both edges on one side: a calibration window whose errors nearly
    all share a sign), ``[mean + a, mean + a + b]`` on each axis: the calibrated bound's time to a face is never
    later than the mean track's (found by review: the box of the edges alone could put it later)."""
    from loadarm.guidance.monitor import prediction_times

    model = _model()
    h = np.arange(1, 121, dtype=float)
    d = np.array([math.cos(direction), math.sin(direction), 0.0])
    mean = np.array([13.0, 1.0, 0.5]) + speed * h[:, None] * d
    lo, hi = mean + a, mean + a + b
    f = pr.Forecast(h, mean, lo, hi, 120.0, 100.0, "online AR")
    bound, at_mean, _ = prediction_times(model, f, np.zeros(3), 100.0, 120.0)
    assert bound <= at_mean


def test_no_prediction_beyond_the_claim_and_no_crossing_from_it():
    """A box past a face only beyond the claimed horizon gives no crossing (no prediction there, not a number)."""
    model = _model()
    h = np.arange(1, 121, dtype=float)
    centre = np.array([13.0, 1.0, 0.5]) + 0.2 * h[:, None] * np.array([1.0, 0.0, 0.0])
    f = _forecast(centre, np.full((120, 3), 0.05), claimed=10.0)
    assert predicted_crossing(model, f, np.zeros(3), f.time, 120.0) == (math.inf, "")


def test_a_held_call_is_said_on_the_screen_and_its_absence_is_silent():
    """ISA-18.2's suppressed by design is shown, never hidden: the screen's time-to-limit detail says how long
    the prediction has held a call for ESD-1 and how much longer it may at most; nothing when none is held or
    not connected."""
    from types import SimpleNamespace

    from loadarm.hmi.state import held_state

    got = held_state(SimpleNamespace(connected=True, held=(100.0, 112.0), t=105.0))
    assert got == {"text": "MEASURED DRIFT CALLS ESD-1, held by the prediction for 5 s: ESD-1 in at most 7 s if "
                           "the call stands", "for_s": 5.0, "left_s": 7.0}
    page = " ".join((ROOT / "docs" / "hmi.md").read_text(encoding="utf-8").split())
    assert f'"{got["text"]}"' in page                    # docs/hmi.md quotes the screen's words
    assert held_state(SimpleNamespace(connected=True, held=(), t=105.0))["text"] == ""
    assert held_state(SimpleNamespace(connected=False, held=(100.0, 112.0), t=105.0))["left_s"] is None


def test_why_a_claimed_prediction_is_not_used_is_said_in_the_rules_order():
    """The reason a claimed prediction does not stand in for the measured routes (the screen's and OPC UA's
    PredictionUnused): none while trusted or with no forecast; then not connected, ESD-1 raised, the moorings
    lost, the track departed, and otherwise a claim short of ESD-1's lead, each a declared code."""
    from types import SimpleNamespace

    from loadarm.guidance.rules import SafetyRules
    from loadarm.vocab import PREDICTION_UNUSED

    def why(trusted=None, forecast=True, attached=True, esd=None, lost=None, departed=None):
        ns = SimpleNamespace(state=SimpleNamespace(trusted=trusted, esd_since=esd),
                             predictor=SimpleNamespace(forecast=object() if forecast else None, departed_at=departed),
                             moorings=SimpleNamespace(lost_at=lost), attached=lambda: attached)
        return SafetyRules._unused_why(ns)

    assert why(trusted=object()) == "" and why(forecast=False) == ""
    assert why(attached=False, esd=1.0, departed=2.0) == "detached"
    assert why(esd=1.0, lost=2.0, departed=2.0) == "esd1"
    assert why(lost=2.0, departed=2.0) == "moorings"
    assert why(departed=2.0) == "departed"
    assert why() == "short"
    assert {why(attached=False), why(esd=1.0), why(lost=1.0), why(departed=1.0), why()} == set(PREDICTION_UNUSED)
    # what is said now: the reason decided with the trust, or "detached" once disconnected (found by review: a
    # prediction trusted at a controlled disconnection read as used while detached)
    now = SimpleNamespace(state=SimpleNamespace(unused=""), predictor=SimpleNamespace(forecast=object()),
                          attached=lambda: False)
    assert SafetyRules.prediction_unused(now) == "detached"
    now.attached = lambda: True
    assert SafetyRules.prediction_unused(now) == ""
    now.predictor.forecast = None
    assert SafetyRules.prediction_unused(now) == ""


def test_the_rules_are_declared_once():
    """Every alarm event's rule code is declared in vocab.ALARM_RULES (the words the journal shows)."""
    assert set(ALARM_RULES) == {"position", "floor", "measured", "prediction", "hold_limit", "operator", "fault"}


@pytest.mark.slow                 # 7 s: make test keeps to its 2-minute budget; CI runs it
def test_without_a_track_the_predictive_rule_changes_nothing():
    """With no history the predictor never claims within a 5-minute run: the drift-off runs exactly as with the
    prediction off (the same alarm times, modes and release), each alarm event naming its rule."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "driftoff.toml")
    off = sc.model_copy(update={"guidance": sc.guidance.model_copy(update={"prediction": "off"})})
    a = run_scenario(sc, model, plant="kinematic")
    b = run_scenario(off, model, plant="kinematic")
    alarms_a = [(e[0], e[1], e[4].get("code")) for e in a.events if e[2] in ("alarm", "mode", "command")]
    alarms_b = [(e[0], e[1], e[4].get("code")) for e in b.events if e[2] in ("alarm", "mode", "command")]
    assert alarms_a == alarms_b
    assert np.array_equal(a.signals["beta"], b.signals["beta"])
    stage_rules = {e[4]["rule"] for e in a.events if str(e[4].get("code", "")).startswith("stage.")}
    assert stage_rules and stage_rules <= set(ALARM_RULES)


@pytest.mark.slow
def test_on_a_tracked_ship_the_prediction_holds_the_measured_false_alarm_up_to_the_hold_limit(tmp_path):
    """Hs 1.5 m on the moored ship with 35 minutes of track before the run (seed 0): the measured drift's
    break-out test calls for ESD-1 at 208 s ("face in 22.6 s"), the prediction (trusted: claimed 120 s, the track
    within its intervals) holds it, and no stage is raised; the event log says so (info.measured_esd1, held) and
    when the call ended (info.measured_esd1_end, 2.6 s on). The hold's budget was the call's own: 22.6 s less the
    release's 20 s lead, 2.6 s. The next call, at 214.84 s, is 4.2 s after that end, under the alarms' 5 s
    off-delay: the same call, its budget spent, so ESD-1 at once, by the rule hold_limit, a false ESD-1 (no face in
    the run). (With the 15 s limit alone, before the per-call budget and the off-delay: at 229.84 s.)"""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import ClosedLoop

    sc, model = load_scenario(SCEN / "hs15_tracked.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": 0})})
    loop = ClosedLoop(sc, model, plant="kinematic")
    cmds = [loop.cycle(k) for k in range(loop.n)]
    res = loop.result()
    during, gap, after = (cmds[round(t / loop.dt)].held for t in (209.0, 212.0, 216.0))
    assert cmds[round(209.0 / loop.dt)].unused == "" and cmds[round(216.0 / loop.dt)].unused == "esd1"
    assert during[0] == pytest.approx(208.04) and 208.04 < during[1] <= 208.04 + 15.0
    assert gap == during and after == ()            # told through the off-delay gap; none once ESD-1 is raised
    held = [e for e in res.events if e[4].get("code") == "info.measured_esd1"]
    assert held and held[0][4]["held"] is True
    assert res.first_code("info.measured_esd1_end") == pytest.approx(210.64)
    assert res.held_calls() == [[208.04, 210.64]]
    esd1 = res.first_data("stage.esd1")
    assert res.first_code("stage.esd1") == pytest.approx(214.84) and esd1["rule"] == "hold_limit"
    assert esd1["measured_since"] == pytest.approx(214.84) and res.limit_at is None
    assert loop.ctrl.predictor.departed_at is None
    assert loop.ctrl.predictor.forecast.claimed == 120.0


@pytest.mark.slow
def test_a_break_out_s_call_is_not_held_once_the_track_leaves_the_intervals():
    """Found in the 100-seed break-out campaign (breakout_tracked, seed 111): the break-out test called for ESD-1
    at 412.88 s, the trusted prediction held it until the departure test's second block, and ESD-1 came 0.2 s
    later than without the prediction. Now a change detector's call is not held once the track's latest block is
    outside the intervals (two tests agree): ESD-1 at the call, the call not marked held."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "breakout_tracked.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": 111})})
    res = run_scenario(sc, model, plant="kinematic")
    calls = [e for e in res.events if e[4].get("code") == "info.measured_esd1"]
    esd1 = res.first_data("stage.esd1")
    assert calls and calls[0][4]["held"] is False
    assert res.first_code("stage.esd1") == calls[0][0] == esd1["measured_since"]
    assert esd1["rule"] == "measured"
    departed = [e for e in res.events if e[4].get("code") == "info.prediction_departed"]
    assert len(departed) == 1 and 400.0 < departed[0][4]["departed_at"] <= departed[0][0] < 430.0   # said once
    # the connection ends with the release: the departure is cleared, said once in words of its own (found by
    # review: said as "not connected, the track left ..." with a time from the connection, it misled)
    reset = [e for e in res.events if e[4].get("code") == "info.prediction_reset"]
    assert len(reset) == 1 and reset[0][4]["departed_at"] == departed[0][4]["departed_at"]
    assert reset[0][0] >= res.first_code("command.release_complete")
    assert not [e for e in res.events if e[4].get("code") == "info.prediction_recalibrated"]


@pytest.mark.slow
@pytest.mark.parametrize("seed, held_s", [(726, 12.32), (412, 3.52)])
def test_a_break_out_s_call_while_the_track_is_inside_the_intervals_is_not_held(seed, held_s):
    """Found in the 1000-seed break-out campaign (breakout_tracked, 2026-12-05): the break-out test called for
    ESD-1 (seed 726 at 414.68 s) with the track's latest block still inside the prediction's intervals, so the
    trusted prediction held the call until the departure test saw the track leave them, ``held_s`` later than the
    rule without the prediction (seed 726: 12.3 s; 412: 3.5 s). Now the mooring load monitoring is the second
    witness: every line slack 1.9 s after they part at 400 s, the moorings are lost, the prediction stands down,
    and ESD-1 comes at the break-out test's call, by the measured rule."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "breakout_tracked.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": seed})})
    res = run_scenario(sc, model, plant="kinematic")
    esd1 = res.first_data("stage.esd1")
    lost = res.first_code("info.moorings_lost")
    assert lost is not None and 401.0 <= lost <= 403.0               # 16 lines slack 2 s after they part at 400 s
    assert res.first_code("stage.esd1") == esd1["measured_since"]    # never later: at the call
    assert esd1["rule"] == "measured"
    calls = [e for e in res.events if e[4].get("code") == "info.measured_esd1" and e[0] >= 400.0]
    assert calls and calls[0][4]["held"] is False


@pytest.mark.slow  # 25-60 s: a tracked run of 560 s (make test's budget; CI runs it)
def test_a_squall_s_partial_break_out_is_no_later_than_the_measured_rule():
    """Found by the partial break-out in a squall (100 seeds, 2026-12-06): 8 of 16 lines part at 400 s, and the
    mooring watch, which then needed more than half the lines slack, said the moorings held while the track stayed
    inside the prediction's intervals; the break-out test's call for ESD-1 at 421.6 s (seed 100) was held, and
    ESD-1 came by the floor at 440.0 s, 18.4 s later (85 s before the face). Now the watch needs more than a
    third: the moorings are lost at the 402 s reading, the prediction stands down, and ESD-1 comes at the
    measured rule's call."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "partial_breakout_squall_tracked.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": 100})})
    res = run_scenario(sc, model, plant="kinematic")
    assert res.first_code("info.moorings_lost") == pytest.approx(402.0, abs=0.2 + 1e-9)   # 2 s after the parting
    esd1 = res.first_data("stage.esd1")
    assert esd1 is not None and esd1.get("measured_since") is not None
    assert res.first_code("stage.esd1") == pytest.approx(esd1["measured_since"], abs=0.05)
    assert esd1["rule"] == "measured"


@pytest.mark.slow  # 35-70 s: a tracked run of 850 s (make test's budget; CI runs it)
def test_seed_533_run_past_its_end_on_the_same_sea_releases_before_the_face(monkeypatch):
    """Issue 30, Hs 2.0-2.5 m seed 533 (Hs 2.20 m): in the 600 s run the rule without the prediction called
    ESD-1 six times (413.8-567.1 s: each "face in 18-35 s"), all held, and the face came at 725.2 s on the
    flange's trajectory after the run, so the campaign could not tell whether ESD-1 would come in time. The
    moored ship is simulated for the run plus ``MOORED_LOOKAHEAD``: lengthening the run by 250 s and shortening
    that by as much keeps the same sea (the face within the look-ahead's 0.1 s step of the stored run's). Before
    the hold limit every call before 600 s was held and ESD-1 came at 706.0 s, 19.2 s before the face, short of its
    35 s lead (found; the coupler free 6 s before the face only because the ERS valves closed in their nominal
    time). With the hold limit (15 s for the paper's sequence) the first call (413.82-424.62 s, "face in 34.9 s")
    is held, and the velocity step's call 2 s later (426.62-427.02 s, found when the event log's rate limiter
    counted its end away) joins it; the call at 474.42 s forecasts the face 18.1 s away, less than the release's
    20 s lead, so it is not held at all: ESD-1 and the release at once, by the measured rule, 251 s before the
    face; the coupler free at 487.44 s; no failure. (With the limit alone, before each call's own budget: ESD-1 at
    489.42 s, the release with the break-out, the coupler free 9.3 s before the face.)"""
    import json

    from loadarm.ship import flange
    from loadarm.sim import limits
    from loadarm.sim.loop import run_scenario
    from loadarm.ship.model import moored_ship
    from loadarm.studies.campaign import ScenarioDraws

    rows = (ROOT / "docs" / "campaigns" / "hs15_tracked_hs2.0-2.5_runs.jsonl").read_text().splitlines()[1:]
    stored = next(r["run"] for r in map(json.loads, rows) if r["run"]["seed"] == 533)
    sc, model = ScenarioDraws(str(SCEN / "hs15_tracked.toml")).build(533, stored["draws"])
    more = 250.0
    monkeypatch.setattr(flange, "MOORED_LOOKAHEAD", flange.MOORED_LOOKAHEAD - more)
    monkeypatch.setattr(limits, "LIMIT_LOOKAHEAD", flange.MOORED_LOOKAHEAD - more - 10.0)
    end = sc.scenario.duration
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": end + more})})
    res = run_scenario(sc, model, plant="kinematic", ship=moored_ship(sc))
    assert res.limit_at == pytest.approx(stored["limit_s"], abs=0.1)          # the same sea
    assert stored["alarm1_s"] is None and stored["alarm1_measured_s"] < end < stored["limit_s"] - 35.0
    assert res.held_calls() == [[413.82, 424.62], [426.62, 427.02]]
    t1, esd1 = res.first_code("stage.esd1"), res.first_data("stage.esd1")
    assert t1 == pytest.approx(474.42) and esd1["rule"] == "measured"
    assert esd1["measured_since"] == pytest.approx(474.42)
    assert res.first_code("stage.release") == pytest.approx(474.42)
    done = res.first_code("command.release_complete")
    assert res.failures() == () and done == pytest.approx(487.44) and done < res.limit_at - 200.0
    from loadarm.guidance.monitor import stage_leads
    from loadarm.vocab import Severity

    lead = stage_leads(model.sequence)[Severity.ESD1]
    assert lead == pytest.approx(35.0)                                         # the installation's, as said
    assert res.limit_at - t1 > lead + 200.0                                    # no longer short: its whole lead


@pytest.mark.slow
def test_without_the_mooring_load_monitoring_no_change_detector_s_call_is_held():
    """No second witness (``[ship] line_load_monitoring = false``): the break-out test's call on the tracked
    Hs 1.5 m ship (seed 0, held with the monitoring: the test above) raises ESD-1 at once, as the rule without the
    prediction does."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import run_scenario

    sc, model = load_scenario(SCEN / "hs15_tracked.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": 0}),
                               "ship": sc.ship.model_copy(update={"line_load_monitoring": False})})
    res = run_scenario(sc, model, plant="kinematic")
    calls = [e for e in res.events if e[4].get("code") == "info.measured_esd1"]
    assert calls and calls[0][4]["held"] is False
    assert res.first_code("stage.esd1") == calls[0][0]
    assert res.first_code("info.moorings_lost") is None


@pytest.mark.slow
def test_on_tracked_ships_false_esd1_are_at_least_halved_and_no_esd1_is_later():
    """A fresh sample of the campaigns of docs/guidance.md section 13 (seeds 5000-5011, kinematic plant): Hs 1.5 m
    on the tracked ship, its false ESD-1 at most half of the rule's without the prediction, and a break-out's
    ESD-1 not later than that rule's on these seeds (100 seeds: none later since a change detector's call is not
    held once the track leaves the intervals; 1000 seeds: 5 later, held while the track was still inside them,
    docs/guidance.md section 13 and the strict xfail above); no overstretch and no coupler opened on live product
    in either."""
    from loadarm.studies.campaign import run_campaign

    sea = run_campaign(SCEN / "hs15_tracked.toml", 12, first_seed=5000, workers=2, plant="kinematic")._values()
    assert sea["overstretches"] == 0 and sea["opened_on_live_product"] == 0
    assert sea["false_alarms_measured"] >= 2, sea                  # the sample shows the problem at all
    assert 2 * sea["false_alarms"] <= sea["false_alarms_measured"], sea
    bo = run_campaign(SCEN / "breakout_tracked.toml", 6, first_seed=5000, workers=2, plant="kinematic")._values()
    assert bo["overstretches"] == 0 and bo["opened_on_live_product"] == 0 and bo["missed_alarms"] == 0
    assert bo["releases"] == 6 and (bo["lead_gained_min_s"] is None or bo["lead_gained_min_s"] >= 0.0), bo


def test_a_position_that_is_not_finite_is_a_missing_sample():
    """A NaN or infinite position (a sensor's fault) is dropped like a missing sample: short runs of them are
    bridged as a gap and no block mean, forecast error or track value is ever NaN (found by review: a NaN block
    mean would count against one edge of the calibration only)."""
    fp = pr.FlangePredictor()
    p = _sway(int(200 / 0.2), seed=3)
    p[100:110] = np.nan                                             # 2 s of NaN: bridged
    p[300, 1] = np.inf
    _feed(fp, p)
    track = np.array(fp.track)
    assert track.shape[0] >= 195 and np.all(np.isfinite(track))
    assert fp.push(500.0, [np.nan, 0.0, 0.0]) is False and fp.push(500.2, [1.0, 2.0]) is False
