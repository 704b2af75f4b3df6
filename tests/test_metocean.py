"""Metocean records: read, validate, report gaps (never fill them), generate, turn into the berth frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.studies.metocean import (
    VARIABLES,
    MetoceanError,
    berth_directions,
    read_metocean,
    synthetic_metocean,
    write_metocean_csv,
)

from .conftest import ROOT
from .hypo import examples

SAMPLE = ROOT / "examples" / "metocean" / "sample.csv"
HEADER = "time," + ",".join(VARIABLES)


def _csv(tmp_path, rows, header=HEADER):
    p = tmp_path / "m.csv"
    p.write_text(header + "\n" + "\n".join(rows) + "\n")
    return p


def _row(t, hs=1.0, tp=8.0, wave=250.0, s=4.0, wind=10.0, wfrom=250.0, cur=0.3, cto=0.0, tide=0.5):
    return f"{t},{hs},{tp},{wave},{s},{wind},{wfrom},{cur},{cto},{tide}"


def test_the_shipped_sample_is_the_generator_s_and_reads_back():
    """examples/metocean/sample.csv: two months of synthetic_metocean(1416, seed=7) from 2025-01-01, exactly
    (regenerate it with write_metocean_csv if the generator changes)."""
    ds, gaps = read_metocean(SAMPLE)
    assert gaps.hours == gaps.usable == 24 * 59 and gaps.summary() == "1416 hourly states, no gap"
    again = synthetic_metocean(24 * 59, seed=7, start="2025-01-01T00:00")
    assert set(ds.data_vars) == set(again.data_vars)                # the partitions too
    for v in [v for v in VARIABLES if v in again]:
        assert np.allclose(ds[v].values, np.round(again[v].values, 3), atol=5e-4), v
    from loadarm.files import written_by_loadarm

    assert written_by_loadarm(SAMPLE)


def test_gaps_are_reported_not_filled(tmp_path):
    rows = [_row("2025-03-01T00:00Z"), _row("2025-03-01T01:00Z"), _row("2025-03-01T04:00Z"),
            _row("2025-03-01T05:00Z", hs="")]
    ds, gaps = read_metocean(_csv(tmp_path, rows))
    assert gaps.hours == 6 and gaps.usable == 3 and gaps.missing_times == 2
    assert gaps.missing_values == {"hs_m": 1} and gaps.longest_gap_h == 2
    assert gaps.first_gaps == ["2025-03-01 02:00 .. 2025-03-01 03:00", "2025-03-01 05:00 .. 2025-03-01 05:00"]
    assert np.isnan(ds["hs_m"].values[2]) and list(ds["usable"].values) == [True, True, False, False, True, False]
    assert "3 usable hourly states of 6" in gaps.summary()


@pytest.mark.parametrize("rows, match", [
    ([_row("2025-03-01T00:00Z", hs=25.0)], r"m\.csv: hs_m: 25\.0 m at 2025-03-01 00:00:00 is outside \[0, 20\] m"),
    ([_row("2025-03-01T00:00Z", wfrom=-10.0)], r"wind_from_deg: -10\.0 deg .* outside \[0, 360\]"),
    ([_row("2025-03-01T01:00Z"), _row("2025-03-01T00:00Z")], r"time: times must increase"),
    ([_row("2025-03-01T00:30Z")], r"time: hourly states on whole hours"),
    ([_row("2025-03-01T00:00Z", tp="abc")], r"tp_s: 'abc' at .* is not a number"),
    ([_row("2025-03-01T00:00Z", hs="")], r"time: no hour has every required value"),
])
def test_bad_values_are_refused_in_one_line(tmp_path, rows, match):
    with pytest.raises(MetoceanError, match=match) as info:
        read_metocean(_csv(tmp_path, rows))
    assert "\n" not in str(info.value)


def test_bad_files_are_refused(tmp_path):
    with pytest.raises(MetoceanError, match="metocean file not found"):
        read_metocean(tmp_path / "none.csv")
    with pytest.raises(MetoceanError, match=r"unknown column \(known"):
        read_metocean(_csv(tmp_path, ["2025-01-01T00:00Z,1"], header="time,swh"))
    with pytest.raises(MetoceanError, match="tp_s: missing"):
        read_metocean(_csv(tmp_path, ["2025-01-01T00:00Z,1"], header="time,hs_m"))
    p = tmp_path / "m.txt"
    p.write_text("x")
    with pytest.raises(MetoceanError, match="unknown format"):
        read_metocean(p)


def test_era5_names_in_netcdf(tmp_path):
    """An ERA5 point extract (swh, pp1d, mwd, the partitions shww, shts, mdts, u10, v10 on (valid_time,
    latitude, longitude)) plus current and tide columns reads as the record (docs/operability.md's mapping);
    u10 = v10 = -5 is a wind from the north-east (45 deg); the swell's height in cm is converted by pint."""
    import pandas as pd
    import xarray as xr

    t = pd.date_range("2025-01-01", periods=3, freq="h")
    one = lambda v, u: (("valid_time", "latitude", "longitude"), np.full((3, 1, 1), v), {"units": u})  # noqa: E731
    ds = xr.Dataset({"swh": one(1.2, "m"), "pp1d": one(9.0, "s"), "mwd": one(270.0, "Degree true"),
                     "shww": one(0.5, "m"), "shts": one(120.0, "cm"), "mdts": one(250.0, "Degree true"),
                     "u10": one(-5.0, "m s**-1"), "v10": one(-5.0, "m s**-1"), "current_speed_ms": one(0.2, "m s**-1"),
                     "current_to_deg": one(10.0, "degrees"), "tide_m": one(0.1, "m")},
                    coords={"valid_time": t, "latitude": [51.0], "longitude": [3.0]})
    p = tmp_path / "era5.nc"
    ds.to_netcdf(p)
    rec, gaps = read_metocean(p)
    assert gaps.usable == 3
    assert rec["hs_m"].values[0] == pytest.approx(1.2)
    assert rec["wind_speed_ms"].values[0] == pytest.approx(math.sqrt(50))
    assert rec["wind_from_deg"].values[0] == pytest.approx(45.0)
    assert rec["wave_spreading"].values[0] == 4.0
    assert rec["windsea_hs_m"].values[0] == pytest.approx(0.5) and rec["swell_hs_m"].values[0] == pytest.approx(1.2)
    assert rec["swell_from_deg"].values[0] == pytest.approx(250.0) and "swell_tp_s" not in rec


def test_an_era5_file_in_the_cds_layout_reads_with_the_partitions(tmp_path):
    """A small NetCDF file written in ERA5's layout (the new CDS, 2024+): a ``valid_time`` coordinate with CF units
    (seconds since 1970), scalar ``latitude``/``longitude``/``number`` and a string ``expver`` along time, float32
    variables with a ``_FillValue`` and ERA5's units ("m", "s", "degree true", "m s**-1"), the wind-wave and swell
    partitions. Read by read_metocean: each variable mapped by docs/operability.md's table (the mean periods mpww,
    mpts kept as mean periods), the fill value a reported gap."""
    import pandas as pd
    import xarray as xr

    t = pd.date_range("2024-12-31T22:00", periods=4, freq="h")
    f32 = lambda v, u: ("valid_time", np.asarray(v, dtype=np.float32), {"units": u})  # noqa: E731
    ds = xr.Dataset(
        {"swh": f32([1.5, np.nan, 1.7, 1.8], "m"), "pp1d": f32([9.5, 9.6, 9.7, 9.8], "s"),
         "mwd": f32([260, 261, 262, 263], "degree true"),
         "shww": f32([0.9, 1.0, 1.1, 1.2], "m"), "mpww": f32([4.1, 4.2, 4.3, 4.4], "s"),
         "mdww": f32([230, 231, 232, 233], "degree true"),
         "shts": f32([1.2, 1.2, 1.3, 1.3], "m"), "mpts": f32([11.0, 11.5, 12.0, 12.5], "s"),
         "mdts": f32([280, 281, 282, 283], "degree true"),
         "u10": f32([0, 0, 3, 0], "m s**-1"), "v10": f32([10, 10, 0, -4], "m s**-1"),
         "current_speed_ms": f32([0.2] * 4, "m s**-1"), "current_to_deg": f32([10] * 4, "degrees"),
         "tide_m": f32([0.1] * 4, "m")},
        coords={"valid_time": t, "latitude": 57.5, "longitude": 1.75, "number": 0,
                "expver": ("valid_time", np.array(["0001"] * 4))})
    enc = {v: {"dtype": "float32", "_FillValue": np.float32(-32767.0)} for v in ds.data_vars}
    enc["valid_time"] = {"units": "seconds since 1970-01-01", "dtype": "int64"}
    p = tmp_path / "era5.nc"
    ds.to_netcdf(p, encoding=enc)
    with xr.open_dataset(p, decode_times=False, mask_and_scale=False) as raw:   # the file is as ERA5's
        assert raw["swh"].dtype == np.float32 and raw["swh"].values[1] == np.float32(-32767.0)
        assert raw["valid_time"].attrs["units"] == "seconds since 1970-01-01" and "time" not in raw.variables
    rec, gaps = read_metocean(p)
    assert list(pd.DatetimeIndex(rec["time"].values)) == list(t)
    assert gaps.hours == 4 and gaps.usable == 3 and gaps.missing_values == {"hs_m": 1}
    want = {"hs_m": 1.5, "tp_s": 9.5, "wave_from_deg": 260, "windsea_hs_m": 0.9, "windsea_tm_s": 4.1,
            "windsea_from_deg": 230, "swell_hs_m": 1.2, "swell_tm_s": 11.0, "swell_from_deg": 280}
    for v, x in want.items():
        assert rec[v].values[0] == pytest.approx(x, rel=1e-6), v      # float32's precision
    assert "windsea_tp_s" not in rec and "swell_tp_s" not in rec        # a mean period is not a peak period
    # u10, v10 are the wind's components towards east and north: (0, 10) blows north, so it comes from the south
    assert rec["wind_speed_ms"].values.tolist() == pytest.approx([10, 10, 3, 4])
    assert rec["wind_from_deg"].values.tolist() == pytest.approx([180, 180, 270, 0])


def test_an_era5_expver_dimension_is_merged(tmp_path):
    """The old CDS's ERA5 with final (expver 1) and preliminary (expver 5) data along an ``expver`` dimension,
    each hour in one of them: read as one record, the first version with a value hour by hour."""
    import pandas as pd
    import xarray as xr

    t = pd.date_range("2025-01-01", periods=3, freq="h")
    two = lambda a, b, u: (("time", "expver"), np.array([a, b]).T, {"units": u})  # noqa: E731
    nan3 = [np.nan] * 3
    ds = xr.Dataset({"swh": two([1.0, 1.1, np.nan], [np.nan, np.nan, 1.3], "m"),
                     "pp1d": two([8, 8, np.nan], [np.nan, np.nan, 9], "s"),
                     "mwd": two([200, 200, np.nan], [np.nan, np.nan, 210], "degree true"),
                     "u10": two([1, 1, np.nan], [np.nan, np.nan, 2], "m s**-1"),
                     "v10": two([0, 0, np.nan], [np.nan, np.nan, 0], "m s**-1"),
                     "current_speed_ms": two([0.2] * 3, nan3, "m s**-1"),
                     "current_to_deg": two([10] * 3, nan3, "degrees"), "tide_m": two([0.1] * 3, nan3, "m")},
                    coords={"time": t, "expver": [1, 5]})
    p = tmp_path / "era5x.nc"
    ds.to_netcdf(p)
    rec, gaps = read_metocean(p)
    assert gaps.usable == 3
    assert rec["hs_m"].values.tolist() == pytest.approx([1.0, 1.1, 1.3])
    assert rec["tp_s"].values.tolist() == pytest.approx([8, 8, 9])
    assert rec["wind_speed_ms"].values.tolist() == pytest.approx([1, 1, 2])


@pytest.fixture(scope="module")
def decade():
    return synthetic_metocean(10 * 8760, seed=1)


def test_the_wind_follows_the_published_weibull(decade):
    """Ten synthetic years: the 1-hour mean wind exceeds 10, 15 and 20 m/s in the fractions of hours of
    Johannessen et al.'s (2001) Weibull (shape 1.708, scale 8.426 m/s: 23.6, 6.9 and 1.2 %) within 30 % (the
    seasons, the extra storms and ten years' sampling: measured 7.3 % above 15 m/s and 1.23 times the published
    fraction above 20 m/s; the old generator, wind
    tied to Hs through a fully developed sea, gave 0.18 %)."""
    from loadarm.studies.plots import johannessen_wind_exceedance

    w = decade["wind_speed_ms"].values
    for u in (10.0, 15.0, 20.0):
        assert abs(np.mean(w > u) / johannessen_wind_exceedance(u) - 1) < 0.3, u


@pytest.mark.parametrize("site", ["Ekofisk", "northern North Sea"])
def test_the_published_sea_models_are_transcribed_whole(site):
    """The figure's open-sea references (Haver & Nyhus's model with Sagli's parameters, as WAFO tabulates them):
    the log-normal body and the Weibull tail were fitted to meet at hc, so a mistyped parameter shows as a step
    there (they meet within 0.005 in exceedance: measured 0.0005 and 0.0017); the Tp marginal integrates the
    conditional model over Hs to a distribution (1 at 1 s, 0 at 40 s, within the trapezoids' 0.005)."""
    from loadarm.studies.plots import SEASTATE_MODELS, seastate_hs_exceedance, seastate_tp_exceedance

    hc = SEASTATE_MODELS[site][0][3]
    below, above = seastate_hs_exceedance([hc, hc + 1e-9], site)
    assert abs(below - above) < 0.005 and 0.2 < below < 0.3
    assert seastate_tp_exceedance(1.0, site)[0] == pytest.approx(1.0, abs=0.005)
    assert seastate_tp_exceedance(40.0, site)[0] == pytest.approx(0.0, abs=0.005)


def test_swell_brings_long_periods_and_the_partitions_make_the_sea(decade):
    """Swell apart from the local sea: Tp above 13 s in 5-30 % of hours (15 % measured; never with the old
    generator); the record's Hs is the partitions' root sum of squares (to 1e-12), its Tp the more energetic
    one's; the swell is not the wind's (correlation below 0.3)."""
    hs, ws, sw = decade["hs_m"].values, decade["windsea_hs_m"].values, decade["swell_hs_m"].values
    assert 0.05 < np.mean(decade["tp_s"].values > 13.0) < 0.30
    inside = (hs > 0.05) & (hs < 19.0)
    assert np.allclose(hs[inside], np.hypot(ws, sw)[inside], rtol=1e-12, atol=0)
    swell_sets = sw > ws
    assert np.array_equal(decade["tp_s"].values[swell_sets], decade["swell_tp_s"].values[swell_sets])
    assert np.array_equal(decade["tp_s"].values[~swell_sets], decade["windsea_tp_s"].values[~swell_sets])
    assert np.array_equal(decade["wave_spreading"].values, np.where(swell_sets, 15.0, 4.0))
    assert decade["swell_tp_s"].values.min() >= 8.0 and decade["windsea_tp_s"].values.max() < 13.0
    assert abs(np.corrcoef(sw, decade["wind_speed_ms"].values)[0, 1]) < 0.3


def test_in_a_storm_the_wind_comes_before_the_waves(decade):
    """The wind sea answers the wind hours later: the cross-correlation of wind speed and wind-sea height
    peaks at a positive lag (1-2 h measured; the sea's response time is 3 h), higher than at lag 0."""
    w, ws = decade["wind_speed_ms"].values, decade["windsea_hs_m"].values
    r = [np.corrcoef(w[:w.size - lag], ws[lag:])[0, 1] for lag in range(0, 8)]
    assert 1 <= int(np.argmax(r)) <= 6 and r[int(np.argmax(r))] > r[0]


@pytest.mark.parametrize("column, value, bounds", [("swell_tp_s", 45, "[1, 30]"), ("windsea_hs_m", -0.5, "[0, 20]"),
                                                   ("windsea_tp_s", 0.2, "[1, 30]"),
                                                   ("swell_from_deg", 400, "[0, 360]")])
def test_a_bad_partition_is_refused_in_one_line(tmp_path, column, value, bounds):
    p = tmp_path / "m.csv"
    p.write_text("time,hs_m,tp_s,wave_from_deg,wind_speed_ms,wind_from_deg,current_speed_ms,current_to_deg,tide_m,"
                 f"{column}\n2025-01-01T00:00Z,1,9,270,5,270,0.1,0,0,{value}\n")
    with pytest.raises(MetoceanError) as exc:
        read_metocean(p)
    msg = str(exc.value)
    assert "\n" not in msg and f"{column}: {float(value)!r}" in msg and bounds in msg and str(p) in msg


def test_a_record_without_partitions_still_reads(tmp_path):
    """The partitions are optional: a record of the required columns only reads, and has none of them."""
    p = tmp_path / "m.csv"
    p.write_text("time,hs_m,tp_s,wave_from_deg,wind_speed_ms,wind_from_deg,current_speed_ms,current_to_deg,tide_m\n"
                 "2025-01-01T00:00Z,1,9,270,5,270,0.1,0,0\n")
    rec, gaps = read_metocean(p)
    assert gaps.usable == 1 and not [v for v in rec.data_vars if v.startswith(("windsea_", "swell_"))]


def test_synthetic_year_has_seasons_and_storms():
    ds = synthetic_metocean(8760, seed=1)
    import pandas as pd

    hs = pd.Series(ds["hs_m"].values, index=pd.DatetimeIndex(ds["time"].values))
    monthly = hs.resample("MS").mean()
    winter, summer = monthly.iloc[[0, 1, 11]].mean(), monthly.iloc[5:8].mean()
    assert winter > 1.3 * summer
    assert 0.4 < np.median(hs) < 1.0 and hs.max() > 2.5


def test_same_seed_same_weather_other_seed_other_weather():
    """A seed is a record: the same seed twice gives identical values (every variable, partitions included); two
    seeds differ in every stochastic variable (not one hour equal in wind, wind sea or swell over a week) while the
    tide, which is not drawn, stays the same."""
    a, b, c = (synthetic_metocean(168, seed=s) for s in (3, 3, 4))
    assert a.equals(b) and "swell_hs_m" in a
    for v in ("wind_speed_ms", "windsea_hs_m", "swell_hs_m", "swell_tp_s", "hs_m"):
        assert not np.any(a[v].values == c[v].values), v
    assert np.array_equal(a["tide_m"].values, c["tide_m"].values)


@settings(max_examples=examples(60), deadline=None)
@given(bearing=st.floats(0, 360), wind_from=st.floats(0, 360))
def test_berth_directions_turn_compass_into_the_berth_frame(bearing, wind_from):
    """Second route: unit vectors. A wind from compass bearing f goes towards f + 180; berth +x points to
    `bearing`, berth +y 90 deg anticlockwise of it (bearing - 90)."""
    import xarray as xr

    ds = xr.Dataset({"wind_from_deg": ("time", [wind_from]), "wave_from_deg": ("time", [wind_from]),
                     "current_to_deg": ("time", [wind_from])}, coords={"time": [0]})
    ang = math.radians(float(berth_directions(ds, bearing)["wind_direction_deg"][0]))
    to = math.radians(wind_from + 180.0)
    east_north = np.array([math.sin(to), math.cos(to)])                 # the wind's heading, (east, north)
    x = np.array([math.sin(math.radians(bearing)), math.cos(math.radians(bearing))])
    y = np.array([math.sin(math.radians(bearing - 90)), math.cos(math.radians(bearing - 90))])
    assert math.cos(ang) == pytest.approx(east_north @ x, abs=1e-9)
    assert math.sin(ang) == pytest.approx(east_north @ y, abs=1e-9)


def test_written_record_reads_back(tmp_path):
    ds = synthetic_metocean(48, seed=2)
    p = write_metocean_csv(ds, tmp_path / "r.csv")
    back, gaps = read_metocean(p)
    assert gaps.usable == 48
    written = [v for v in VARIABLES if v in ds]
    assert "windsea_tp_s" in written and "swell_from_deg" in written and "windsea_tm_s" not in back
    for v in written:
        assert np.allclose(back[v].values, ds[v].values, atol=5e-4), v


@pytest.mark.slow
def test_the_weather_page_quotes_the_generator_s_own_marginals():
    """docs/operability.md's numbers of the synthetic weather (ten years, seed 1: the figure's record) are the
    generator's, to the digits printed, and the published curves' at the same points: the page cannot drift from
    the program (two significant digits; the offshore models' ranges in whole per cent)."""
    from loadarm.studies.plots import (SEASTATE_MODELS, johannessen_wind_exceedance, seastate_hs_exceedance,
                                       seastate_tp_exceedance)

    text = " ".join((ROOT / "docs" / "operability.md").read_text().split())
    ds = synthetic_metocean(10 * 8760, seed=1)
    wind, hs, tp = ds["wind_speed_ms"].values, ds["hs_m"].values, ds["tp_s"].values
    pct = lambda x: f"{100 * x:.2g}"  # noqa: E731
    wind_pub = float(johannessen_wind_exceedance(np.array([15.0]))[0])
    assert f"exceeds 15 m/s in {pct(np.mean(wind > 15))} % of hours (published: {pct(wind_pub)} %" in text
    levels = (1.0, 1.5, 2.0, 3.0)
    ours = ", ".join(pct(np.mean(hs > h)) for h in levels[:-1]) + f" and {pct(np.mean(hs > levels[-1]))}"
    assert f"exceeds 1, 1.5, 2 and 3 m in {ours} % of hours (median {np.median(hs):.2f} m)" in text
    ranges = []
    for h in levels:
        lo, hi = sorted(100 * float(seastate_hs_exceedance(np.array([h]), s)[0]) for s in SEASTATE_MODELS)
        ranges.append(f"{lo:.0f}-{hi:.0f} %")
    assert "the offshore models: " + ", ".join(ranges[:-1]) + f" and {ranges[-1]}" in text
    eko, nns = (float(seastate_tp_exceedance(np.array([13.0]), s)[0]) for s in ("Ekofisk", "northern North Sea"))
    assert (f"Tp exceeds 13 s in {pct(np.mean(tp > 13))} % of hours (the swell; never with the old generator), the "
            f"offshore models {pct(eko)} % (Ekofisk) and {pct(nns)} % (northern North Sea)") in text
    swell_wind = np.corrcoef(wind, ds["swell_hs_m"].values)[0, 1]
    assert f"apart from the local wind (correlation {swell_wind:.1g})" in text
