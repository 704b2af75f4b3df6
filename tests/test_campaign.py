"""Campaigns (`loadarm campaign`) and the closed-loop safety properties they rest on."""

import dataclasses
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.cli import main
from loadarm.design.check import design_check
from loadarm.errors import ConfigError
from loadarm.params.scenario import load_scenario
from loadarm.sim.loop import run_scenario
from loadarm.studies.campaign import _judge, parse_vary, run_campaign

from .conftest import ROOT
from .hypo import examples

SCEN = ROOT / "examples" / "scenarios"


def test_parse_vary_refuses_malformed_ranges():
    v = parse_vary("drift.speed=0.1:0.3")
    assert (v.key, v.lo, v.hi) == ("drift.speed", 0.1, 0.3)
    for bad in ("drift.speed", "drift.speed=0.1", "=1:2", "drift.speed=a:b", "drift.speed=0.3:0.1",
                "drift.speed=nan:1"):
        with pytest.raises(ConfigError):
            parse_vary(bad)


def test_judge_counts_each_failure_on_its_own():
    base = dict(coupler_opening_s=100.0, valves_confirmed_s=99.0, limit_s=110.0, release_complete_s=103.0,
                alarm1_s=89.0, overstretched_s=None, release_margin_s=7.0, limit_face="beta_max", duration_s=120.0,
                connected_s=80.0, failures=[])
    ok = _judge(1, {}, base)
    assert ok.connected_s == 80.0
    assert not (ok.overstretched or ok.overstretched_before_isolation or ok.opened_on_live_product
                or ok.false_alarm or ok.missed_alarm)
    assert _judge(1, {}, {**base, "failures": ["opened_on_live_product"]}).opened_on_live_product
    assert _judge(1, {}, {**base, "failures": ["missed_alarm"]}).missed_alarm
    assert _judge(1, {}, {**base, "limit_s": None}).false_alarm
    late = _judge(1, {}, {**base, "limit_s": 130.0, "release_complete_s": None, "coupler_opening_s": None})
    assert not (late.false_alarm or late.missed_alarm)
    after = _judge(1, {}, {**base, "failures": ["overstretch"]})
    assert after.overstretched and not after.overstretched_before_isolation
    live = _judge(1, {}, {**base, "failures": ["overstretch_before_isolation", "missed_alarm"]})
    assert live.overstretched and live.overstretched_before_isolation and live.missed_alarm


def test_a_departure_is_counted_only_in_runs_that_kept_it():
    """A run's departure (the prediction standing down: info.prediction_departed) is kept with its verdict; a run
    stored before departures were kept says so (departure_kept false) rather than counting as none."""
    from loadarm.studies.campaign import CampaignResult

    base = dict(limit_s=None, release_complete_s=None, alarm1_s=None, release_margin_s=None, limit_face="",
                connected_s=80.0, failures=[])
    gone = _judge(1, {}, {**base, "departed_s": 412.0})
    stayed = _judge(2, {}, {**base, "departed_s": None})
    old = _judge(3, {}, base)
    assert (gone.departed_s, gone.departure_kept) == (412.0, True)
    assert (stayed.departed_s, stayed.departure_kept) == (None, True)
    assert (old.departed_s, old.departure_kept) == (None, False)
    v = CampaignResult("x.toml", (), (gone, stayed, old)).summary()
    assert (v["departures"], v["departures_kept"], v["departed_seeds"]) == (1, 2, [1])


def test_esd1_short_of_its_lead_and_undecided_where_the_face_is_past_the_run():
    """Issue 30 (Hs 2.0-2.5 m seed 533): the rule without the prediction called ESD-1 at 413.8 s, the rule with it
    did not within the 600 s run, and the face was at 725.2 s on the flange's trajectory after it. That run is
    later (certainly: by at least the end less that call), and whether its ESD-1 came in time, at least ESD-1's
    35 s lead before the face, the run cannot say (no ESD-1 was due by its end): undecided. A face within the lead
    of the end with no ESD-1 is short; an ESD-1 less than the lead before the face is short; a run whose bounds
    are not known is neither short nor undecided."""
    from loadarm.studies.campaign import CampaignResult

    base = dict(coupler_opening_s=None, valves_confirmed_s=None, limit_s=725.2, release_complete_s=None,
                alarm1_s=None, overstretched_s=None, release_margin_s=None, limit_face="beta_max", duration_s=600.0,
                connected_s=450.0, failures=[], alarm1_measured_s=413.8, alarm1_measured_first_s=413.8)
    past = _judge(533, {}, base, (600.0, 35.0))
    assert past.alarm1_undecided and past.short_of_lead(None) is None and past.short_of_lead(413.8) is False
    assert past.lead_gained_s == pytest.approx(413.8 - 725.2)                  # later, as if at the face
    near = _judge(534, {}, {**base, "limit_s": 634.0}, (600.0, 35.0))       # due by the end: none is short
    assert not near.alarm1_undecided and near.short_of_lead(None) is True
    unknown = _judge(535, {}, base)
    assert not unknown.alarm1_undecided and unknown.short_of_lead(None) is None
    late = _judge(536, {}, {**base, "alarm1_s": 706.0}, (600.0, 35.0))        # 19.2 s before the face: short
    assert late.short_of_lead(late.alarm1_s) is True and late.short_of_lead(690.2) is False
    v = CampaignResult("s.toml", (), (past, near, unknown, late))._values()
    assert v["alarm1_undecided"] == 1 and v["undecided_seeds"] == [533]
    assert v["alarm1_short"] == 2 and v["short_seeds"] == [534, 536] and v["alarm1_short_measured"] == 0
    assert v["alarm1_later"] == 4 and v["later_seeds"] == [533, 534, 535, 536]


def test_later_and_short_against_today_s_rule_latching_on_its_first_call():
    """The partial break-out in a squall, seed 128 (2026-12-07, found by review): the rule without the prediction
    first called ESD-1 at 187.96 s (a wave's call, held), and again at 422.56 s once the lines had parted; with
    the prediction ESD-1 came at 422.56 s, 30.0 s before the face at 452.54 s. Against that rule's call in
    progress it is neither later nor short; against today's rule, which latches ESD-1 on its first call, it is
    234.6 s later and short of its 35 s lead where today's was not."""
    from loadarm.studies.campaign import CampaignResult

    base = dict(coupler_opening_s=None, valves_confirmed_s=None, limit_s=452.54, release_complete_s=435.58,
                alarm1_s=422.56, overstretched_s=None, release_margin_s=16.96, limit_face="beta_max",
                duration_s=560.0, connected_s=380.0, failures=[], alarm1_measured_s=422.56,
                alarm1_measured_first_s=187.96)
    held = _judge(128, {}, base, (560.0, 35.0))
    assert held.lead_gained_s == 0.0 and held.lead_gained_first_s == pytest.approx(187.96 - 422.56)
    plain = _judge(129, {}, {**base, "alarm1_s": 187.96, "alarm1_measured_s": 187.96}, (560.0, 35.0))
    assert plain.lead_gained_first_s == 0.0
    none = _judge(130, {}, {**base, "limit_s": None, "release_complete_s": None}, (560.0, 35.0))
    assert none.lead_gained_first_s is None                                  # no face: nothing to be later for
    # no call of the measured routes: ESD-1 by the floor, which today's rule has too, at the same instant (found
    # by review: counted as no ESD-1 at all, the run was short by today's rule)
    floor = _judge(131, {}, {**base, "alarm1_rule": "floor", "alarm1_measured_s": None,
                             "alarm1_measured_first_s": None}, (560.0, 35.0))
    assert floor.alarm1_today_s == 422.56 and floor.lead_gained_first_s == 0.0
    early = _judge(132, {}, {**base, "alarm1_s": 150.0, "alarm1_rule": "floor"}, (560.0, 35.0))
    assert early.alarm1_today_s == 150.0 and early.lead_gained_first_s == 0.0     # the floor before the first call
    alone = _judge(133, {}, {**base, "alarm1_rule": "prediction", "alarm1_measured_s": None,
                             "alarm1_measured_first_s": None}, (560.0, 35.0))
    assert alone.alarm1_today_s is None and alone.lead_gained_first_s is None     # today's ESD-1 unknown
    v = CampaignResult("s.toml", (), (held, plain, none, floor))._values()
    assert (v["alarm1_later"], v["alarm1_later_first"], v["later_first_seeds"]) == (0, 1, [128])
    assert v["lead_gained_first_min_s"] == pytest.approx(187.96 - 422.56)
    assert v["lead_gained_first_median_s"] == 0.0                       # over 128, 129 and 131
    assert (v["alarm1_short_measured"], v["alarm1_short_first"], v["alarm1_short"]) == (2, 1, 2)


def test_stored_runs_without_their_end_get_it_from_the_scenario():
    """Runs kept before the runs file held their end and ESD-1's lead get them from the scenario (its duration and
    the installation's sequence), the same as a run made now."""
    from loadarm.guidance.monitor import stage_leads
    from loadarm.studies.campaign import with_bounds
    from loadarm.vocab import Severity

    scen = str(ROOT / "examples" / "scenarios" / "hs15_tracked.toml")
    sc, model = load_scenario(scen)
    old = _judge(7, {"environment.hs": 2.2}, dict(coupler_opening_s=None, valves_confirmed_s=None, limit_s=None,
                                                  release_complete_s=None, alarm1_s=None, overstretched_s=None,
                                                  release_margin_s=None, limit_face="", duration_s=600.0,
                                                  connected_s=0.0, failures=[]))
    assert old.end_s is None
    (new,) = with_bounds(scen, [old])
    assert new.end_s == sc.scenario.duration and new.esd1_lead_s == stage_leads(model.sequence)[Severity.ESD1] > 0
    assert dataclasses.replace(new, end_s=None, esd1_lead_s=None) == old


def _result(events, overstretched_at=None, limit_at=None, t_end=120.0):
    """A run's result with just the events and times its verdict reads."""
    from loadarm.sim.result import RunResult

    t = np.arange(0.0, t_end + 0.05, 0.1)
    sig = {k: np.zeros_like(t) for k in ("mode", "x", "y", "z", "connected", "distance", "beta", "phi")}
    sig["t"] = t
    from loadarm.vocab import event_label

    return RunResult("r", sig, [(tt, "X", kind, event_label(code), {"code": code}) for tt, kind, code in events],
                     overstretched_at,
                     np.zeros(0), limit_at=limit_at, limit_face="beta_max")


def test_a_run_names_each_failure_and_its_time():
    """One rule for the verdict (RunResult.failures), read by the run, its exit status and the campaign."""
    good = [(99.0, "interlock", "interlock.valves_confirmed"), (100.0, "command", "command.coupler_opening"),
            (103.0, "command", "command.release_complete")]
    assert _result(good, limit_at=110.0).failures() == () and _result(good, limit_at=110.0).verdict() == "pass"
    # found (issue 25): at a 0.7 m/s step the arm overstretched 2.5 s before the valves confirmed, and the run
    # reported "release complete" as if nothing had happened
    live = _result(good, overstretched_at=96.5, limit_at=96.5)
    assert live.failures() == ("overstretch_before_isolation", "missed_alarm")
    assert live.verdict().startswith("FAILED: the arm overstretched before the ERS valves were confirmed closed "
                                     "(live product) at 96.50 s, 2.50 s before the confirmation")
    after = _result(good, overstretched_at=101.0, limit_at=101.0)
    assert after.failures() == ("overstretch", "missed_alarm")
    never = _result([], overstretched_at=50.0, limit_at=50.0)
    assert never.failures()[0] == "overstretch_before_isolation"
    opened = [(98.0, "command", "command.coupler_opening")] + [good[0], good[2]]
    assert "opened_on_live_product" in _result(opened, limit_at=110.0).failures()
    # found (review): the flange passing a face after a controlled disconnection is no missed alarm; attached, it is
    away = _result([], limit_at=60.0)                          # the coupler was never on the flange at 60 s
    assert away.failures() == ()
    on = _result([], limit_at=60.0)
    on.signals["connected"][:] = 1.0
    assert on.failures() == ("missed_alarm",)


def _short_driftoff(tmp_path, **drift):
    """The stock drift-off, shortened (kinematic plant, drift from 160 s) for tests."""
    text = (SCEN / "driftoff.toml").read_text().replace('installation = "../paper.toml"',
                                                         f'installation = "{(ROOT / "examples" / "paper.toml").as_posix()}"')
    text = text.replace("duration = 320.0", "duration = 260.0\nplant = \"kinematic\"").replace("start = 200.0",
                                                                                              "start = 160.0")
    p = tmp_path / "short.toml"
    p.write_text(text)
    return p


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
def test_a_campaign_is_repeatable_and_draws_within_the_ranges(tmp_path):
    sc = _short_driftoff(tmp_path)
    vary = [parse_vary("drift.speed=0.1:0.25"), parse_vary("installation.sequence.margin=1:3")]
    seen = []
    a = run_campaign(sc, 1, vary=vary, workers=1, first_seed=3, progress=lambda d, n: seen.append((d, n)))
    b = run_campaign(sc, 1, vary=vary, workers=1, first_seed=3)
    assert a.to_dict() == b.to_dict() and seen[-1] == (1, 1)
    for r in a.runs:
        assert 0.1 <= r.draws["drift.speed"] <= 0.25 and 1 <= r.draws["installation.sequence.margin"] <= 3
        assert not (r.overstretched or r.opened_on_live_product or r.missed_alarm)
    s = a.summary()
    assert s["runs"] == 1 and s["overstretches"] == 0 and s["margin_min_s"] > 0
    # exposure: connected from the connection to the release (independent route: the event times of one run)
    r = a.runs[0]
    assert s["connected_runs"] == 1 and s["connected_h"] == pytest.approx(r.connected_s / 3600.0)
    assert r.alarm1_s < r.release_complete_s and 60.0 < r.connected_s < r.release_complete_s
    assert "release margin, min" in str(s)


@pytest.mark.slow                      # 3.5-5 s: to keep make test under two minutes with the HMI's browser tests
def test_campaign_cli_refuses_typos_and_reports_json(capsys, tmp_path):
    sc = _short_driftoff(tmp_path)
    assert main(["campaign", "-s", str(sc), "-n", "1", "--vary", "drift.sped=0.1:0.2"]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'speed'" in err and len(err.strip().splitlines()[-1:]) == 1
    assert main(["campaign", "-s", str(sc), "-n", "1", "--vary", "installation.sequence.margn=1:2"]) == 2
    assert "did you mean 'margin'" in capsys.readouterr().err
    assert main(["campaign", "-s", str(sc), "-n", "1", "--vary", "scenario.name=1:2"]) == 2
    assert "not a numeric parameter" in capsys.readouterr().err
    assert main(["campaign", "-s", str(sc), "-n", "2", "--workers", "2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["runs"] == 2 and data["overstretches"] == 0 and data["opened_on_live_product"] == 0


@pytest.mark.slow
@pytest.mark.parametrize("seed", [16, 24, 32, 52, 84])
def test_the_stock_driftoff_seeds_that_overstretched_now_release_in_time(seed):
    """Found: the stock drift-off overstretched before the release completed on seeds 16, 24, 32, 52 and 84 of
    100 (hydraulic plant; seed 16: 'release complete at 247.90 s, overstretched at 247.82 s', exit 0)."""
    res = run_campaign(SCEN / "driftoff.toml", 1, first_seed=seed, workers=1)
    r = res.runs[0]
    assert not (r.overstretched or r.opened_on_live_product or r.missed_alarm or r.false_alarm), r
    assert r.release_margin_s > 1.0


@pytest.mark.slow
@pytest.mark.parametrize("accel", [0.01, 0.5])
def test_a_drift_of_0_3_m_s_no_longer_overstretches(accel):
    """Found: 0.3 m/s (the top of the range the scenario's drift documents) overstretched 1 run in 10 at
    0.01 m/s^2 and 3 in 10 at 0.5 m/s^2. 0.3 m/s is beyond this berth's design drift (0.15 m/s; `loadarm check`
    says 0.275 m/s is absorbed off the berth). At 0.5 m/s^2 (a velocity step, 0.6 s to full speed) 2 of 10 still
    overstretched by 0.14-0.16 s once the 0.01 m/s^2 case passed: the 60 s drift fit saw the step 1.7 s late. The
    velocity-step test (DriftFit.step_estimate) sees it within seconds; the margins are quoted in docs/guidance.md."""
    sc, model = load_scenario(SCEN / "driftoff.toml")
    margins = []
    for seed in range(10):
        s = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"seed": seed, "plant": "kinematic"}),
                                  "drift": sc.drift.model_copy(update={"speed": 0.3, "acceleration": accel})})
        v = run_scenario(s, model).to_dict()
        assert v["overstretched_s"] is None and v["release_margin_s"] > 0, (seed, v)
        assert v["coupler_opening_s"] >= v["valves_confirmed_s"]
        margins.append(v["release_margin_s"])
    if accel == 0.5:                             # the step is seen within seconds: the sequence's own margin holds
        assert min(margins) >= model.sequence.margin, margins
        from .test_doc_numbers import cited

        cited("docs/guidance.md", f"released on 10 of 10 seeds with {min(margins):.1f}-{max(margins):.1f} s to spare")


@pytest.mark.slow
def test_an_estop_at_205_s_during_the_driftoff_still_releases():
    """Found: an E-stop at 205, 220 or 236 s stopped the emergency release (15 of 15 runs overstretched);
    220 and 236 s are in tests/test_guidance.py."""
    sc, model = load_scenario(SCEN / "driftoff.toml")
    s = sc.model_copy(update={"operator": sc.operator.model_copy(update={"estop_at": 205.0})})
    v = run_scenario(s, model).to_dict()
    assert v["release_complete_s"] is not None and v["overstretched_s"] is None and v["release_margin_s"] > 0


@pytest.mark.slow          # the fast suite's budget on a 2-core machine; CI runs it
@settings(max_examples=examples(4), deadline=None)
@given(speed=st.floats(0.05, 0.27), accel=st.floats(0.005, 0.05), direction=st.floats(-60.0, 60.0),
       start=st.floats(140.0, 170.0), ers_valve_time=st.floats(3.0, 15.0), erc=st.floats(1.0, 5.0),
       hs=st.floats(0.0, 1.0), seed=st.integers(0, 10_000),
       estop=st.one_of(st.none(), st.floats(0.0, 40.0)))
def test_within_the_design_envelope_the_release_completes_after_the_valves_and_before_any_face(
        speed, accel, direction, start, ers_valve_time, erc, hs, seed, estop):
    """Issue 10, item 8, on the closed loop: drift speed, acceleration, direction, start time, sequence times, sea
    state, an E-stop at any time after the drift starts, and seeds. Within what `loadarm check` guarantees
    (horizontal drift up to the speed it says is absorbed), the coupler opens only after the ERS valves are
    confirmed closed, and the release completes before the flange reaches any face (a slow drift whose face lies
    beyond the end of the run is judged on what happened in it: found by the thorough profile once the run's
    face could lie beyond its end)."""
    sc, model = load_scenario(SCEN / "driftoff.toml")
    model = dataclasses.replace(model, sequence=dataclasses.replace(model.sequence, ers_valve_time=ers_valve_time,
                                                                    erc_release_time=erc))
    check = design_check(model)
    absorbed = min(r.max_speed for r in check.rows[:4])             # horizontal directions
    if not check.ok or speed > absorbed:
        assert not check.ok or speed > absorbed                     # beyond it: the check said so beforehand
        return
    sc = sc.model_copy(update={
        "scenario": sc.scenario.model_copy(update={"seed": seed, "duration": start + 120.0, "plant": "kinematic"}),
        "drift": sc.drift.model_copy(update={"start": start, "speed": speed, "acceleration": accel,
                                             "direction_deg": direction}),
        "waves": sc.waves.model_copy(update={"hs": hs}),
        "operator": sc.operator.model_copy(update={"estop_at": None if estop is None else start + estop})})
    r = run_scenario(sc, model)
    v = r.to_dict()
    assert v["overstretched_s"] is None, v
    if v["coupler_opening_s"] is not None:
        assert v["valves_confirmed_s"] is not None and v["coupler_opening_s"] >= v["valves_confirmed_s"]
    if v["limit_s"] is not None and v["limit_s"] <= v["duration_s"]:     # the face inside the run
        assert v["release_complete_s"] is not None and v["release_complete_s"] < v["limit_s"], v
        assert v["release_margin_s"] > 0 and math.isfinite(v["release_margin_s"])


@pytest.mark.slow
def test_hs15_on_the_moored_ship_stays_safe():
    """Issue 12's done-when, in small, on the real lines of issue 28: Hs 1.5 m on the moored example ship
    (design wind and current, spread sea, slow drift) over 10 seeds: every run connects, no overstretch, no
    missed alarm, nothing opened on live product. On the 60 MN lines it also raised no alarm and never
    released; on HMPE lines with nylon tails the ship moves more (moored periods 47-95 s instead of 19-26 s)
    and the paper's arm, connected 5 deg from its stretched face, raises ESD-1 without a face reached in most
    runs and releases in some (100 seeds: 55 and 5, docs/ship-motion.md section 9), on the safe side. This
    scenario starts with no track of the ship, so the predictive alarms (docs/guidance.md section 13), which
    need one, cannot act: tests/test_predictive_alarms.py measures them on the tracked ship
    (hs15_tracked.toml). Here the false alarms stay an expected failure; the test passes outright when both are
    0."""
    res = run_campaign(SCEN / "hs15_moored.toml", 10, workers=2)
    d = res.to_dict()
    assert d["connected_runs"] == 10 and d["overstretches"] == 0 and d["missed_alarms"] == 0
    assert d["opened_on_live_product"] == 0 and not d["failed_seeds"]
    if d["false_alarms"] or d["releases"]:
        pytest.xfail(f"{d['false_alarms']} of 10 runs raised ESD-1 and {d['releases']} released without reaching "
                     "a face (no track of the ship: the predictive alarms cannot act; see hs15_tracked.toml)")


@pytest.mark.slow
def test_a_campaign_on_a_dask_scheduler_gives_the_same_runs(tmp_path):
    """Issue 13, item 5: `loadarm campaign --scheduler`: the same runs as local processes, on a Dask cluster
    (a LocalCluster on loopback standing in for a user's; its address is all the campaign gets)."""
    from distributed import LocalCluster

    text = (SCEN / "driftoff.toml").read_text()
    text = text.replace('installation = "../paper.toml"', f'installation = "{(SCEN.parent / "paper.toml").as_posix()}"')
    text = text.replace("duration = 320.0", 'duration = 240.0\nplant = "kinematic"').replace("start = 200.0",
                                                                                           "start = 150.0")
    sc = tmp_path / "short.toml"
    sc.write_text(text)
    local = run_campaign(sc, 3, workers=1)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1", scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster:
        remote = run_campaign(sc, 3, scheduler=cluster.scheduler_address)
    assert remote.to_dict() == local.to_dict()
