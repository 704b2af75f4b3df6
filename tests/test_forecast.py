"""``loadarm forecast``: connect windows from a forecast or an ensemble (loadarm.studies.forecast)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.errors import ConfigError
from loadarm.studies.forecast import _completes, run_forecast
from loadarm.studies.metocean import perturbed_ensemble, read_metocean, write_metocean_csv

from .conftest import ROOT
from .hypo import examples

EX = ROOT / "examples"
MEMBERS = sorted((EX / "metocean" / "forecast").glob("member-*.csv"))


@settings(max_examples=examples(60), deadline=None)
@given(up=st.lists(st.lists(st.booleans(), min_size=6, max_size=6), min_size=1, max_size=5),
       length=st.integers(1, 8))
def test_a_loading_completes_when_every_one_of_its_hours_is_up_in_the_same_run(up, length):
    """The windowed probability against a plain loop over the runs and the starts; nan past the forecast."""
    a = np.array(up, dtype=bool)
    got = _completes(a, length)
    for start in range(a.shape[1]):
        if start + length > a.shape[1]:
            assert np.isnan(got[start])
        else:
            want = np.mean([all(run[start: start + length]) for run in a])
            assert got[start] == pytest.approx(want, abs=1e-12)


@pytest.mark.parametrize("kw, match", [({"members": []}, "0 members"), ({"hours": 0}, "--hours = 0"),
                                       ({"hours": 241}, "--hours = 241"), ({"seeds": 0}, "--seeds = 0"),
                                       ({"seeds": 21}, "--seeds = 21")])
def test_bad_arguments_are_refused_in_one_line_before_any_work(kw, match):
    args = {"members": [EX / "metocean" / "sample.csv"], **kw}
    with pytest.raises(ConfigError, match=match) as e:
        run_forecast(EX / "paper.toml", EX / "berths" / "lng150k.toml", args.pop("members"), **args)
    assert "\n" not in str(e.value)


def test_members_of_other_hours_are_refused_naming_the_member(tmp_path):
    ds, _ = read_metocean(EX / "metocean" / "sample.csv")
    late = write_metocean_csv(ds.isel(time=slice(10, 40)), tmp_path / "late.csv")
    with pytest.raises(ConfigError, match="late.csv: its hours are not those of"):
        run_forecast(EX / "paper.toml", EX / "berths" / "lng150k.toml", [EX / "metocean" / "sample.csv", late],
                     hours=24)


def test_a_forecast_with_a_gap_is_refused_naming_the_file_and_the_hour(tmp_path):
    """Review of issue 30: a missing hour joined two hours that are not neighbours (a loading window ran across
    it). A forecast with an hour dropped is refused in one line naming the file and the hour before the gap."""
    import numpy as np

    ds, _ = read_metocean(EX / "metocean" / "sample.csv")
    keep = np.r_[0:10, 11:30]
    gap = write_metocean_csv(ds.isel(time=keep), tmp_path / "gap.csv")
    when = f"{np.datetime_as_string(ds['time'].values[9], unit='m').replace('T', ' ')}"
    with pytest.raises(ConfigError, match=f"gap.csv: time: the forecast has a gap after {when}") as e:
        run_forecast(EX / "paper.toml", EX / "berths" / "lng150k.toml", [gap], hours=24, seeds=1, workers=1)
    assert "\n" not in str(e.value)


def test_the_shipped_ensemble_is_the_generator_s():
    """examples/metocean/forecast/: five members about the sample's first 72 hours (perturbed_ensemble, seed 3),
    to the CSV's rounding; their spread grows with the lead time (Hs's over the members, the last day against
    the first six hours)."""
    ds, _ = read_metocean(EX / "metocean" / "sample.csv")
    want = perturbed_ensemble(ds.isel(time=slice(0, 72)), 5, seed=3)
    assert len(MEMBERS) == 5
    hs = []
    for path, w in zip(MEMBERS, want, strict=True):
        got, _ = read_metocean(path)
        for k in ("hs_m", "tp_s", "wind_speed_ms", "wave_from_deg"):
            assert np.allclose(got[k].values, w[k].values, atol=6e-4, rtol=0), k
        hs.append(got["hs_m"].values)
    spread = np.std(np.log(hs), axis=0)
    assert spread[48:].mean() > 2 * spread[:6].mean()


@pytest.mark.slow
def test_an_ensemble_in_processes_is_the_ensemble_in_this_one_and_the_cli_prints_it(tmp_path, capsys):
    """Two members, six hours, two seeds: the spawned workers (a member cut in parts) give exactly the states of
    this process; probabilities are shares of the 4 runs; `loadarm forecast --json` and the figure."""
    from loadarm.cli import main

    cfg, berth = EX / "paper.toml", EX / "berths" / "lng150k.toml"
    from loadarm.studies.operability import OperabilitySettings

    s = OperabilitySettings(duration_per_state=600.0)
    one = run_forecast(cfg, berth, MEMBERS[:2], hours=6, seeds=2, settings=s, workers=1)
    many = run_forecast(cfg, berth, MEMBERS[:2], hours=6, seeds=2, settings=s, workers=2)
    for k in ("connected", "esd1", "completes"):
        assert np.array_equal(getattr(one, k), getattr(many, k), equal_nan=True), k
    assert set(np.round(one.connected * 4, 9)) <= {0, 1, 2, 3, 4}
    png = tmp_path / "f.png"
    code = main(["forecast", "--config", str(cfg), "--berth", str(berth), "--metocean", str(MEMBERS[0]),
                 "--metocean", str(MEMBERS[1]), "--hours", "6", "--seeds", "2", "--duration-per-state", "600",
                 "--json", "--png", str(png)])
    assert code == 0 and png.stat().st_size > 10_000
    d = json.loads(capsys.readouterr().out)
    assert d["members"] == 2 and d["seeds"] == 2 and len(d["hourly"]) == 6
    assert [h["connected_probability"] for h in d["hourly"]] == pytest.approx(list(one.connected), abs=1e-12)


@pytest.mark.slow
def test_the_shipped_ensemble_s_windows_are_the_docs(tmp_path):
    """The five shipped members over 72 hours: the numbers docs/operability.md quotes and its figure."""
    from loadarm.present.docsgen import compare_figures, shipped_forecast, study_figures

    r = shipped_forecast()
    d = r.to_dict()
    page = " ".join((ROOT / "docs" / "operability.md").read_text().split())
    runs = d["members"] * d["seeds"]
    quote = (f"the first hour below 50 % is {d['first_down']}, {d['expected_esd1']:.1f} ESD-1 are expected over the "
             f"three days while connected, and a loading is best started at {d['best_start']} "
             f"({round(d['best_start_probability'] * runs)} of {runs} members complete it")
    assert quote in page, quote
    bad = compare_figures(ROOT / "docs" / "img", study_figures(tmp_path, ("forecast.png",), forecast=r))
    assert not bad, "stale figure (run `make docs`): " + "; ".join(bad)


def test_no_loading_start_is_offered_when_none_completes():
    """A forecast whose loadings all fail names no best start (not the first hour at 0 %)."""
    from loadarm.studies.forecast import ForecastResult

    t = np.arange("2025-01-01T00", "2025-01-01T04", dtype="datetime64[h]")
    r = ForecastResult(t, np.zeros(4), np.ones(4), np.array([0.0, 0.0, np.nan, np.nan]), np.ones(4), np.ones(4),
                       np.ones(4), ("arm",) * 4, ("a.csv",), 1, 2.0)
    s = r.summary()
    assert s["best_start"] is None and s["first_down"] == "2025-01-01 00:00"
    assert "none within the forecast" in str(s)
