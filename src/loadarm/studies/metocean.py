"""Metocean records for operability studies (issue 13, item 1): read, validate, generate.

A record is an hourly time series of the sea states a berth sees, as an :class:`xarray.Dataset` on a ``time``
coordinate (UTC) with self-describing variables (:data:`VARIABLES`): significant wave height, peak period, the
direction the waves come from and their spreading, the 1-hour mean wind at 10 m and the direction it comes from,
the current and the direction it goes to, the tide. Directions follow the data's own conventions (meteorological
"from" for wind and waves, oceanographic "to" for current), clockwise from true north; the berth's
``[berth] x_bearing_deg`` turns them into the berth frame (:func:`berth_directions`).

* :func:`read_metocean` reads CSV (a ``time`` column in ISO 8601) or NetCDF (also ERA5's short names, :data:`ERA5`:
  ``swh``, ``pp1d``, ``mwd``, ``u10``/``v10`` and the partitions ``shww``/``mpww``/``mdww`` (wind waves) and
  ``shts``/``mpts``/``mdts`` (total swell), ERA5's mean periods kept as mean periods; a ``time`` or the new CDS's
  ``valid_time`` axis; an ``expver`` dimension merged), checks every value against its range, and reports the
  gaps (missing hours, missing values) in a :class:`GapReport` without filling them: the study skips those hours
  and says so.
  Units: a CSV column's name carries its unit (``hs_m`` in metres, ``tp_s`` in seconds, ``wind_speed_ms`` in m/s:
  :data:`VARIABLES`); a NetCDF variable says its unit in its ``units`` attribute, converted with pint
  (``cm``, ``ms``, ``knot``, ``Degree true``, ``m s**-1`` ...), and its time is a CF time. A missing or unknown
  unit is refused, naming the variable.
* :func:`synthetic_metocean` generates a seeded multi-year record whose wind (a published Weibull), wind sea
  (grown from the wind over a fetch, hours behind it) and swell (its own process, long periods) are drawn apart,
  for demos and tests (no data set can be downloaded here; ``examples/metocean/sample.csv`` is two months of
  it).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.signal import lfilter
from scipy.special import ndtr

from loadarm import __version__
from loadarm.errors import ConfigError
from loadarm.files import SIGNATURE, atomic_write, check_input

__all__ = ["VARIABLES", "GapReport", "read_metocean", "validate_metocean", "synthetic_metocean",
           "write_metocean_csv", "berth_directions", "compass_to_berth", "MetoceanError", "perturbed_ensemble",
           "ENSEMBLE_SPREAD"]


class MetoceanError(ConfigError):
    """A metocean record that cannot be used (one line: the file, the variable, the value, the range)."""


#: The record's variables: name -> (unit, lowest, highest, required, description). Ranges are physical bounds for
#: a berth (a value outside is a unit or sign error, not weather).
VARIABLES = {
    "hs_m": ("m", 0.0, 20.0, True, "significant wave height"),
    "tp_s": ("s", 1.0, 30.0, True, "spectral peak period"),
    "wave_from_deg": ("deg", 0.0, 360.0, True, "mean direction the waves come from, clockwise from north"),
    "wave_spreading": ("1", 1.0, 100.0, False, "cos-2s spreading exponent (default 4, wind sea)"),
    "wind_speed_ms": ("m/s", 0.0, 60.0, True, "1-hour mean wind speed at 10 m"),
    "wind_from_deg": ("deg", 0.0, 360.0, True, "direction the wind comes from, clockwise from north"),
    "current_speed_ms": ("m/s", 0.0, 5.0, True, "depth-averaged current speed"),
    "current_to_deg": ("deg", 0.0, 360.0, True, "direction the current goes to, clockwise from north"),
    "tide_m": ("m", -10.0, 10.0, True, "water level above mean sea level"),
    "windsea_hs_m": ("m", 0.0, 20.0, False, "significant wave height of the wind sea (partition)"),
    "windsea_tp_s": ("s", 1.0, 30.0, False, "peak period of the wind sea (partition)"),
    "windsea_tm_s": ("s", 1.0, 30.0, False, "mean period of the wind sea (partition; ERA5's mpww, not peak)"),
    "windsea_from_deg": ("deg", 0.0, 360.0, False, "direction the wind sea comes from, clockwise from north"),
    "swell_hs_m": ("m", 0.0, 20.0, False, "significant wave height of the swell (partition)"),
    "swell_tp_s": ("s", 1.0, 30.0, False, "peak period of the swell (partition)"),
    "swell_tm_s": ("s", 1.0, 30.0, False, "mean period of the swell (partition; ERA5's mpts, not peak)"),
    "swell_from_deg": ("deg", 0.0, 360.0, False, "direction the swell comes from, clockwise from north"),
}
#: Default spreading when a record has none.
DEFAULT_SPREADING = 4.0
#: ERA5 single-level short names and how they map (u10/v10 are combined into speed and direction;
#: docs/operability.md section 2 has the table). ERA5's partition periods ``mpww`` and ``mpts`` are MEAN periods
#: of the partition's spectrum, not peak periods: they are kept as such (``windsea_tm_s``, ``swell_tm_s``) and
#: never turned into ``windsea_tp_s`` / ``swell_tp_s`` by an assumed ratio (for a JONSWAP spectrum a peak period is
#: 1.1-1.2 times a mean period, depending on which moments define the mean).
ERA5 = {"swh": "hs_m", "pp1d": "tp_s", "mwd": "wave_from_deg",
        "shww": "windsea_hs_m", "mpww": "windsea_tm_s", "mdww": "windsea_from_deg",
        "shts": "swell_hs_m", "mpts": "swell_tm_s", "mdts": "swell_from_deg"}
#: Largest file read, bytes (a 30-year hourly CSV is about 25 MB).
MAX_BYTES = 200 * 1024 ** 2


@dataclass(frozen=True)
class GapReport:
    """What the record lacks, reported and never filled.

    Attributes
    ----------
    hours : int
        Hours from the first to the last time stamp, inclusive.
    usable : int
        Hours with every required value.
    missing_times : int
        Hours absent from the time axis.
    missing_values : dict
        Variable -> hours present but without that value.
    longest_gap_h : int
        Longest run of unusable hours.
    first_gaps : list of str
        Up to five gaps as ``start .. end`` (UTC).
    """

    hours: int
    usable: int
    missing_times: int
    missing_values: dict = field(default_factory=dict)
    longest_gap_h: int = 0
    first_gaps: list = field(default_factory=list)

    def summary(self) -> str:
        """One or two lines for the console.

        Returns
        -------
        str
        """
        if self.usable == self.hours:
            return f"{self.hours} hourly states, no gap"
        text = (f"{self.usable} usable hourly states of {self.hours} ({self.hours - self.usable} skipped: "
                f"{self.missing_times} hours absent")
        if self.missing_values:
            text += ", values missing: " + ", ".join(f"{k} {v} h" for k, v in self.missing_values.items())
        return text + f"; longest gap {self.longest_gap_h} h: " + "; ".join(self.first_gaps) + ")"

    def to_dict(self) -> dict:
        """JSON form.

        Returns
        -------
        dict
        """
        return {"hours": self.hours, "usable_hours": self.usable, "missing_times": self.missing_times,
                "missing_values": dict(self.missing_values), "longest_gap_h": self.longest_gap_h,
                "first_gaps": list(self.first_gaps)}


def _err(source, var, what) -> MetoceanError:
    return MetoceanError(f"{source}: {var}: {what}")


def validate_metocean(ds, source: str = "<metocean>"):
    """Check a record and put it on a complete hourly axis (absent hours become NaN, reported as gaps).

    Parameters
    ----------
    ds : xarray.Dataset
        With a ``time`` coordinate and the variables of :data:`VARIABLES`.
    source : str
        Name for messages.

    Returns
    -------
    ds : xarray.Dataset
        Hourly, with ``wave_spreading`` (the default where absent), units in each variable's attributes and a
        boolean ``usable``.
    gaps : GapReport

    Raises
    ------
    MetoceanError
        A required variable missing, a value out of its range, times not increasing or not on whole hours, fewer
        than one usable hour.
    """
    import pandas as pd

    if "time" not in ds.coords:
        raise _err(source, "time", "no time axis (a 'time' column or coordinate in UTC is needed)")
    t = pd.DatetimeIndex(ds["time"].values)
    if t.size == 0:
        raise _err(source, "time", "the record is empty")
    if t.tz is not None:
        t = t.tz_convert("UTC").tz_localize(None)
    if not t.is_monotonic_increasing or t.has_duplicates:
        i = int(np.flatnonzero(np.diff(t.asi8) <= 0)[0]) + 1
        raise _err(source, "time", f"times must increase, {t[i]} follows {t[i - 1]}")
    off = t[(t.minute != 0) | (t.second != 0)]
    if off.size:
        raise _err(source, "time", f"hourly states on whole hours are needed, got {off[0]}")
    missing = [v for v, spec in VARIABLES.items() if spec[3] and v not in ds]
    if missing:
        raise _err(source, missing[0], f"missing (required: {', '.join(v for v, s in VARIABLES.items() if s[3])})")
    ds = ds.assign_coords(time=t)
    if "wave_spreading" not in ds:
        ds["wave_spreading"] = ("time", np.full(t.size, DEFAULT_SPREADING))
    for var, (unit, lo, hi, _req, desc) in VARIABLES.items():
        if var not in ds:                               # an optional one the record does not carry
            continue
        v = np.asarray(ds[var].values, dtype=float)
        bad = np.flatnonzero(np.isfinite(v) & ((v < lo) | (v > hi)) | np.isinf(v))
        if bad.size:
            k = int(bad[0])
            raise _err(source, var, f"{float(v[k])!r} {unit} at {t[k]} is outside [{lo:g}, {hi:g}] {unit} ({desc}; "
                                    f"{bad.size} value(s) out of range)")
        ds[var] = ("time", v, {"units": unit, "long_name": desc})
    full = pd.date_range(t[0], t[-1], freq="h")
    ds = ds[[v for v in VARIABLES if v in ds]].reindex(time=full)
    present = np.isin(full.asi8, t.asi8)
    required = [v for v, s in VARIABLES.items() if s[3]]
    values = np.stack([np.isfinite(ds[v].values) for v in required])
    usable = present & values.all(axis=0)
    if not usable.any():
        raise _err(source, "time", "no hour has every required value")
    missing_values = {v: int(np.sum(present & ~values[i])) for i, v in enumerate(required)
                      if np.any(present & ~values[i])}
    runs, start = [], None
    for i, ok in enumerate(np.append(usable, True)):
        if not ok and start is None:
            start = i
        elif ok and start is not None:
            runs.append((start, i - 1))
            start = None
    gaps = GapReport(hours=int(full.size), usable=int(usable.sum()), missing_times=int((~present).sum()),
                     missing_values=missing_values,
                     longest_gap_h=max((b - a + 1 for a, b in runs), default=0),
                     first_gaps=[f"{full[a]:%Y-%m-%d %H:%M} .. {full[b]:%Y-%m-%d %H:%M}" for a, b in runs[:5]])
    ds["usable"] = ("time", usable)
    ds.attrs["source"] = source
    return ds, gaps


def _merge_expver(ds):
    """ERA5 from the old CDS, with its final (expver 1) and preliminary (expver 5) data along an ``expver``
    dimension, each hour in one of them and NaN in the other: the first version with a value, hour by hour."""
    out = ds.isel(expver=0, drop=True)
    for k in range(1, ds.sizes["expver"]):
        out = out.fillna(ds.isel(expver=k, drop=True))
    return out


def _from_era5(ds):
    import xarray as xr

    ren = {k: v for k, v in ERA5.items() if k in ds and v not in ds}
    ds = ds.rename(ren)
    if "u10" in ds and "v10" in ds and "wind_speed_ms" not in ds:
        u, v = ds["u10"], ds["v10"]
        ds["wind_speed_ms"] = np.hypot(u, v)
        # u, v: the wind's components towards east and north; "from" is the opposite bearing
        ds["wind_from_deg"] = (np.degrees(np.arctan2(-u, -v)) % 360.0)
    if "valid_time" in ds.coords and "time" not in ds.coords:
        ds = ds.rename({"valid_time": "time"})              # the new CDS (2024+) names ERA5's time valid_time
    if "expver" in ds.dims:
        ds = _merge_expver(ds)
    ds = ds.drop_vars([c for c in ("expver", "number") if c in ds.coords and c not in ds.dims])
    # ERA5 extracts are often (time, latitude, longitude) of one point
    extra = [d for d in ds.dims if d != "time" and ds.sizes[d] == 1]
    ds = ds.squeeze(extra, drop=True) if extra else ds
    keep = [v for v in list(VARIABLES) if v in ds]
    return xr.Dataset({v: ("time", np.asarray(ds[v].values, dtype=float).reshape(-1)) for v in keep},
                      coords={"time": ds["time"].values})


#: The unit each NetCDF variable is read in (the record's, and ERA5's short names').
NETCDF_UNITS = {**{k: v[0] for k, v in VARIABLES.items()}, **{k: VARIABLES[v][0] for k, v in ERA5.items()},
                "u10": "m/s", "v10": "m/s"}
#: Unit spellings of NetCDF files (CF, ERA5's GRIB-derived ones) that pint does not read as they are.
UNIT_SPELLINGS = {"Degree true": "degree", "degree true": "degree", "degrees true": "degree",
                  "degree_true": "degree", "degrees_true": "degree", "degrees": "degree", "deg": "degree",
                  "1": "dimensionless", "~": "dimensionless", "m s**-1": "m / s", "m s-1": "m / s"}


def _cf_time(ds, source: str):
    """The time axis must be a CF time (decoded to datetime64: a ``units`` attribute such as ``hours since
    2025-01-01``); found: plain numbers 0..11 without units became one state at 1970-01-01."""
    name = "time" if "time" in ds.coords else "valid_time" if "valid_time" in ds.coords else None
    if name is None:
        raise _err(source, "time", "no time axis (a 'time' or 'valid_time' coordinate is needed)")
    if not np.issubdtype(ds[name].dtype, np.datetime64):
        raise _err(source, name, f"not a CF time: it needs a units attribute such as 'hours since 2025-01-01 "
                                 f"00:00' (got values of type {ds[name].dtype} without one)")
    return ds


def _in_our_units(ds, source: str):
    """Every variable loadarm reads, converted from its ``units`` attribute to the record's unit with pint
    (found: ``tp_s`` in ms was taken as seconds, ``hs_m`` in cm as metres). A missing or unknown unit is refused,
    naming the variable: a unit is never guessed."""
    import pint

    ureg = _units()
    for var in [v for v in ds.data_vars if v in NETCDF_UNITS]:
        unit = ds[var].attrs.get("units")
        want = NETCDF_UNITS[var]
        if not isinstance(unit, str):
            raise _err(source, var, f"no 'units' attribute (loadarm reads it in {want}; a NetCDF variable says its "
                                    "unit)")
        try:
            q = ureg.Quantity(np.asarray(ds[var].values, dtype=float), UNIT_SPELLINGS.get(unit.strip(), unit.strip()))
            values = q.to(UNIT_SPELLINGS.get(want, want)).magnitude
        except (pint.errors.PintError, ValueError, AttributeError, TypeError, AssertionError) as exc:
            raise _err(source, var, f"units {unit!r} cannot be read as {want} ({' '.join(str(exc).split())})") \
                from None
        ds[var] = (ds[var].dims, values, {**ds[var].attrs, "units": want})
    return ds


@functools.lru_cache(maxsize=1)
def _units():
    """pint's unit registry (built once: it parses its definitions file)."""
    import pint

    return pint.UnitRegistry()


def read_metocean(path: str | Path):
    """Read and validate a metocean record (CSV or NetCDF).

    Parameters
    ----------
    path : str or Path
        ``.csv`` (columns ``time`` and :data:`VARIABLES`; ``#`` lines are comments) or ``.nc`` (variables of
        :data:`VARIABLES` or ERA5's short names of :data:`ERA5` and ``u10``, ``v10``; current and tide as named
        here).

    Returns
    -------
    ds : xarray.Dataset
    gaps : GapReport

    Raises
    ------
    MetoceanError
        Unreadable file, unknown format, missing variable, value out of range (one line naming the file).
    """
    import pandas as pd
    import xarray as xr

    p = Path(path)
    source = str(p)
    try:
        check_input(p, "metocean", limit=MAX_BYTES)     # a directory, FIFO or device: named, never opened
    except ConfigError as exc:
        raise MetoceanError(str(exc)) from None
    suffix = p.suffix.lower()
    try:
        if suffix == ".csv":
            df = pd.read_csv(p, comment="#", skipinitialspace=True)
            if "time" not in df:
                raise MetoceanError(f"{source}: time: no 'time' column (columns: {', '.join(map(str, df.columns))})")
            t = pd.to_datetime(df.pop("time"), utc=True, format="ISO8601")
            unknown = [c for c in df.columns if c not in VARIABLES]
            if unknown:
                raise MetoceanError(f"{source}: {unknown[0]}: unknown column (known: time, {', '.join(VARIABLES)})")
            ds = xr.Dataset({c: ("time", pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float))
                             for c in df.columns}, coords={"time": t.dt.tz_localize(None).to_numpy()})
            bad = [c for c in df.columns if df[c].notna().sum() != np.isfinite(ds[c].values).sum()]
            if bad:
                col = df[bad[0]]
                k = int(np.flatnonzero(col.notna() & ~np.isfinite(ds[bad[0]].values))[0])
                raise MetoceanError(f"{source}: {bad[0]}: {col.iloc[k]!r} at {t.iloc[k]} is not a number")
        elif suffix in (".nc", ".nc4", ".netcdf"):
            with xr.open_dataset(p) as raw:
                ds = _from_era5(_in_our_units(_cf_time(raw.load(), source), source))
        else:
            raise MetoceanError(f"{source}: unknown format {suffix!r} (.csv or .nc)")
    except MetoceanError:
        raise
    except (ValueError, OSError, KeyError, TypeError) as exc:
        raise MetoceanError(f"{source}: cannot read: {' '.join(str(exc).split())}") from None
    return validate_metocean(ds, source)


def write_metocean_csv(ds, path: str | Path) -> Path:
    """Write a record as CSV (atomically), with a comment header naming the generator and the units.

    Parameters
    ----------
    ds : xarray.Dataset
    path : str or Path

    Returns
    -------
    Path
    """
    import pandas as pd

    cols = [v for v in VARIABLES if v in ds]
    df = pd.DataFrame({v: np.round(ds[v].values, 3) for v in cols})
    df.insert(0, "time", pd.DatetimeIndex(ds["time"].values).strftime("%Y-%m-%dT%H:%MZ"))
    head = [f"# {SIGNATURE} {__version__} metocean record"] + [
        f"# {v}: {VARIABLES[v][0]}, {VARIABLES[v][4]}" for v in cols]
    return atomic_write(path, "\n".join(head) + "\n" + df.to_csv(index=False))


#: The synthetic generator's declared values (:func:`synthetic_metocean`), each with its source; "loadarm
#: assumption" marks the ones chosen here, for a berth behind a coast open to an ocean's swell.
WEATHER = {
    # the 1-hour mean wind at 10 m: a two-parameter Weibull (the usual long-term model of the mean wind, e.g.
    # DNV-RP-C205), shape and scale of Johannessen, Meling & Haver (2001), "Joint distribution for wind and waves
    # in the northern North Sea", Proc. ISOPE-2001 (journal version: Int. J. Offshore Polar Eng. 12(1), 2002),
    # fitted to 1973-1999 measurements: an exposed site (wind exceeds 15 m/s 6.9 % of hours)
    "wind_shape": 1.708, "wind_scale_ms": 8.426,
    "wind_season": 0.2,          # scale +-20 % winter to summer (loadarm assumption)
    "wind_memory_h": 30.0,       # AR(1) time scale of the weather systems, about a day (loadarm assumption)
    # storms above the Weibull's own: Poisson, winter-heavy (rate x (1 + 0.6 season)), peaks 15-24 m/s,
    # Gaussian in time with half-widths 6-18 h; a storm veers the wind by up to 40 deg as it rises and falls
    # (loadarm assumption)
    "storms_per_year": 4.0, "storm_season": 0.6, "storm_peak_ms": (15.0, 24.0), "storm_width_h": (6.0, 18.0),
    "storm_veer_deg": 40.0,
    # the wind's direction: from the south-west (245 deg) swinging 25 deg over the year, wandering 20 deg with
    # a 12-hour memory (loadarm assumption: the prevailing sector of the North Sea's and Atlantic coasts' wind)
    "wind_from_deg": 245.0, "wind_from_season_deg": 25.0, "wind_from_wander_deg": 20.0, "wind_from_memory_h": 12.0,
    # the wind sea: fetch-limited growth of the Shore Protection Manual (SPM 1984, vol. I ch. 3; restated in the
    # Coastal Engineering Manual, EM 1110-2-1100 Part II-2), with the adjusted wind U_A = 0.71 U10^1.23, capped
    # at the fully developed sea (:func:`windsea`); a fetch for a berth open to the sea behind a coast, the
    # sea's response time (it lags the wind) and an 8 % log-normal scatter of its height (loadarm assumptions)
    "fetch_m": 10_000.0, "windsea_lag_h": 3.0, "windsea_scatter": 0.08,
    # the swell: from the ocean, apart from the local wind: log-normal AR(1) with a slow memory, an annual
    # cycle and swell events (Poisson, rate x (1 + 0.5 season), 1-3 m, half-widths 12-36 h); its period
    # 10 + 3 sqrt(Hs) s with a 0.8 s scatter, within 8-22 s; from 255 deg wandering 10 deg over two days
    # (loadarm assumption, shaped after Atlantic-facing coasts' swell climates: median 0.3-0.5 m, periods
    # 10-18 s)
    "swell_median_m": 0.35, "swell_season": 0.4, "swell_sigma": 0.55, "swell_memory_h": 72.0,
    "swell_events_per_year": 12.0, "swell_event_season": 0.5, "swell_event_hs_m": (1.0, 3.0),
    "swell_event_width_h": (12.0, 36.0),
    "swell_tp_s": (10.0, 3.0, 0.8), "swell_tp_range_s": (8.0, 22.0),
    "swell_from_deg": 255.0, "swell_from_wander_deg": 10.0, "swell_from_memory_h": 48.0,
    # the record's spreading exponent when the wind sea or the swell dominates (a swell is long-crested) and the
    # range of the wind sea's peak period kept (loadarm assumption)
    "windsea_spreading": 4.0, "swell_spreading": 15.0, "windsea_tp_range_s": (1.5, 25.0),
}


def _ar1(rng: np.random.Generator, n: int, memory_h: float) -> np.ndarray:
    """A stationary unit-variance AR(1) series of ``n`` hours with correlation time ``memory_h`` (scipy's
    recursion, started from the stationary distribution)."""
    phi = math.exp(-1.0 / memory_h)
    e = rng.normal(size=n)
    return lfilter([math.sqrt(1 - phi * phi)], [1.0, -phi], e, zi=[phi * rng.normal()])[0]


def _events(rng: np.random.Generator, n: int, rate: np.ndarray, peak: tuple, width: tuple) -> np.ndarray:
    """Poisson events (hourly ``rate``), each a Gaussian bump in time of a random peak and width, maximum
    taken."""
    out = np.zeros(n)
    for s0 in np.flatnonzero(rng.uniform(size=n) < rate):
        w = rng.uniform(*width)
        k = np.arange(max(0, int(s0 - 3 * w)), min(n, int(s0 + 3 * w) + 1))
        out[k] = np.maximum(out[k], rng.uniform(*peak) * np.exp(-0.5 * ((k - s0) / w) ** 2))
    return out


def windsea(u10, fetch: float) -> tuple[np.ndarray, np.ndarray]:
    """Fetch-limited wind sea of a steady wind (SPM 1984, CEM Part II-2): ``g Hm0 / U_A^2 = 1.6e-3 (g F /
    U_A^2)^(1/2)``, ``g Tp / U_A = 0.2857 (g F / U_A^2)^(1/3)``, at most the fully developed 0.2433 and 8.134,
    with ``U_A = 0.71 U10^1.23``.

    Parameters
    ----------
    u10 : array_like
        1-hour mean wind at 10 m, m/s.
    fetch : float
        m.

    Returns
    -------
    hs, tp : ndarray
        m and s.
    """
    g = 9.80665
    ua = 0.71 * np.maximum(np.asarray(u10, dtype=float), 0.1) ** 1.23
    x = g * fetch / ua ** 2
    hs = np.minimum(1.6e-3 * np.sqrt(x), 0.2433) * ua ** 2 / g
    tp = np.minimum(0.2857 * np.cbrt(x), 8.134) * ua / g
    return hs, tp


def synthetic_metocean(hours: int, *, seed: int = 0, start: str = "2025-01-01T00:00") -> "object":
    """A seeded synthetic record whose wind, wind sea and swell are drawn apart (for demos and tests, not a
    hindcast; every value in :data:`WEATHER`, with its source).

    * wind: the 1-hour mean at 10 m, Weibull (Johannessen et al. 2001: shape 1.708, scale 8.426 m/s) through a
      Gaussian AR(1) of a day's memory, its scale following the seasons, plus winter-heavy storms; from a
      prevailing direction that storms veer;
    * wind sea: grown from the wind over the berth's fetch (SPM / CEM fetch-limited growth), the wind filtered
      by the sea's response time first, so the waves follow the wind hours later (storms: wind ahead of
      waves); from the wind's direction;
    * swell: apart from the local wind, a log-normal AR(1) of three days' memory with swell events, its period
      growing with its height (10-18 s), from the ocean's sector;
    * the record's sea is the two together: ``hs`` the root sum of squares, ``tp``, direction and spreading
      (4 wind sea, 15 swell) those of the more energetic partition; the partitions are kept
      (``windsea_hs_m``, ``windsea_tp_s``, ``windsea_from_deg``, ``swell_hs_m``, ``swell_tp_s``,
      ``swell_from_deg``);
    * current and tide: semi-diurnal (M2, 12.42 h) with the spring-neap modulation of S2 (14.8 days).

    Parameters
    ----------
    hours : int
        Length (8760 for a year).
    seed : int
    start : str
        First hour, UTC.

    Returns
    -------
    xarray.Dataset
        Validated (:func:`validate_metocean`), no gaps.
    """
    import pandas as pd
    import xarray as xr

    if not 1 <= hours <= 30 * 8784:
        raise ValueError(f"hours must be in [1, {30 * 8784}], got {hours}")
    w = WEATHER
    rng = np.random.default_rng(seed)
    t = pd.date_range(pd.Timestamp(start), periods=hours, freq="h")
    day = (t.dayofyear.to_numpy() - 1) + t.hour.to_numpy() / 24.0
    season = np.cos(2 * math.pi * (day - 15) / 365.25)          # +1 mid-January, -1 mid-July
    # wind: a Weibull marginal through a Gaussian copula, plus storms
    p = np.clip(ndtr(_ar1(rng, hours, w["wind_memory_h"])), 1e-12, 1 - 1e-12)
    scale = w["wind_scale_ms"] * (1 + w["wind_season"] * season)
    wind = scale * (-np.log1p(-p)) ** (1 / w["wind_shape"])
    storm = _events(rng, hours, w["storms_per_year"] / 8766 * (1 + w["storm_season"] * season),
                    w["storm_peak_ms"], w["storm_width_h"])
    wind = np.clip(np.maximum(wind, storm), 0.0, 55.0)
    veer = np.where(storm > wind * 0.9, w["storm_veer_deg"] * np.tanh(np.gradient(storm)), 0.0)
    wind_from = (w["wind_from_deg"] + w["wind_from_season_deg"] * np.sin(2 * math.pi * day / 365.25) + veer
                 + w["wind_from_wander_deg"] * _ar1(rng, hours, w["wind_from_memory_h"])) % 360
    # wind sea: the wind filtered by the sea's response (first order, windsea_lag_h), then grown over the fetch
    a = math.exp(-1.0 / w["windsea_lag_h"])
    felt = lfilter([1 - a], [1.0, -a], wind, zi=[a * wind[0]])[0]
    ws_hs, ws_tp = windsea(felt, w["fetch_m"])
    ws_hs = ws_hs * rng.lognormal(0.0, w["windsea_scatter"], hours)
    # swell: its own slow process and events, period growing with height
    median = w["swell_median_m"] * np.exp(w["swell_season"] * season)
    sw_hs = median * np.exp(w["swell_sigma"] * _ar1(rng, hours, w["swell_memory_h"]))
    sw_hs = np.maximum(sw_hs, _events(rng, hours, w["swell_events_per_year"] / 8766
                                      * (1 + w["swell_event_season"] * season), w["swell_event_hs_m"],
                                      w["swell_event_width_h"]))
    t0, t1, scatter = w["swell_tp_s"]
    sw_tp = np.clip(t0 + t1 * np.sqrt(sw_hs) + rng.normal(0, scatter, hours), *w["swell_tp_range_s"])
    sw_from = (w["swell_from_deg"] + w["swell_from_wander_deg"] * _ar1(rng, hours, w["swell_from_memory_h"])) % 360
    # the sea: both; period and direction of the more energetic
    hs = np.clip(np.hypot(ws_hs, sw_hs), 0.05, 19.0)
    swell_wins = sw_hs > ws_hs
    ws_tp = np.clip(ws_tp, *w["windsea_tp_range_s"])
    tp = np.where(swell_wins, sw_tp, ws_tp)
    wave_from = np.where(swell_wins, sw_from, wind_from)
    spreading = np.where(swell_wins, w["swell_spreading"], w["windsea_spreading"])
    th = np.arange(hours, dtype=float)
    m2 = 2 * math.pi / 12.42
    spring = 1 + 0.3 * np.cos(2 * math.pi * th / (14.77 * 24))
    tide = 1.2 * spring * np.cos(m2 * th)
    cur = 0.5 * spring * np.abs(np.sin(m2 * th)) + 0.05
    cur_to = np.where(np.sin(m2 * th) >= 0, 0.0, 180.0)          # flood along the berth one way, ebb the other
    ds = xr.Dataset({"hs_m": ("time", hs), "tp_s": ("time", tp), "wave_from_deg": ("time", wave_from),
                     "wave_spreading": ("time", spreading), "wind_speed_ms": ("time", wind),
                     "wind_from_deg": ("time", wind_from), "current_speed_ms": ("time", cur),
                     "current_to_deg": ("time", cur_to), "tide_m": ("time", tide),
                     "windsea_hs_m": ("time", ws_hs), "windsea_tp_s": ("time", ws_tp),
                     "windsea_from_deg": ("time", wind_from), "swell_hs_m": ("time", sw_hs),
                     "swell_tp_s": ("time", sw_tp), "swell_from_deg": ("time", sw_from)},
                    coords={"time": t.to_numpy()})
    ds.attrs["generator"] = f"loadarm.studies.metocean.synthetic_metocean(hours={hours}, seed={seed})"
    return validate_metocean(ds, "synthetic")[0]


def compass_to_berth(to_bearing_deg, x_bearing_deg: float):
    """A compass bearing (the direction something goes to, clockwise from north) as a berth-frame angle (from
    berth +x towards +y, anticlockwise seen from above), deg in [-180, 180).

    Parameters
    ----------
    to_bearing_deg : float or array_like
    x_bearing_deg : float
        Compass bearing of berth +x.

    Returns
    -------
    float or ndarray
    """
    a = x_bearing_deg - np.asarray(to_bearing_deg, dtype=float)       # bearings clockwise, berth angles anticlockwise
    return (a + 180.0) % 360.0 - 180.0


def berth_directions(ds, x_bearing_deg: float) -> dict:
    """The record's directions in the berth frame (the direction each goes to, from berth +x towards +y, deg),
    as the berth file's ``[environment]`` keys take them.

    Parameters
    ----------
    ds : xarray.Dataset
    x_bearing_deg : float
        Compass bearing of berth +x (off the berth, towards the sea), clockwise from north.

    Returns
    -------
    dict
        ``wind_direction_deg``, ``wave_direction_deg``, ``current_direction_deg``: ndarrays in (-180, 180].
    """
    return {"wind_direction_deg": compass_to_berth(ds["wind_from_deg"].values + 180.0, x_bearing_deg),
            "wave_direction_deg": compass_to_berth(ds["wave_from_deg"].values + 180.0, x_bearing_deg),
            "current_direction_deg": compass_to_berth(ds["current_to_deg"].values, x_bearing_deg)}


#: A synthetic forecast ensemble's errors (:func:`perturbed_ensemble`), each ``(at the first hour, growth per hour
#: of lead)``: chosen (a loadarm assumption, not a fit to any forecast centre's scores) so that the members
#: spread over three days about as operational wave ensembles do (Hs by a quarter, wind by 3 m/s at 72 h).
ENSEMBLE_SPREAD = {"hs_m": (0.06, 0.0028), "tp_s": (0.04, 0.0012), "wind_speed_ms": (0.8, 0.03),
                   "direction_deg": (8.0, 0.25)}
#: Hours of memory of the members' errors along the lead time (an AR(1)): errors persist over half a day.
ENSEMBLE_MEMORY_H = 12.0


def perturbed_ensemble(ds, members: int, *, seed: int = 0) -> list:
    """A synthetic forecast ensemble about a record (taken as the truth): each member's Hs and Tp scaled by a
    log-normal error, its wind shifted and its directions turned, the errors growing with the lead time
    (:data:`ENSEMBLE_SPREAD`) and persistent along it (:data:`ENSEMBLE_MEMORY_H`). For demos and tests of
    ``loadarm forecast``: a real ensemble comes from a forecast centre.

    Parameters
    ----------
    ds : xarray.Dataset
        The record (:func:`read_metocean` or :func:`synthetic_metocean`).
    members : int
        1-100.
    seed : int

    Returns
    -------
    list of xarray.Dataset
        One record per member, the same hours.
    """
    if not 1 <= members <= 100:
        raise ValueError(f"members = {members} outside [1, 100]")
    rng = np.random.default_rng(seed)
    n = ds.sizes["time"]
    lead = np.arange(n, dtype=float)
    rho = math.exp(-1.0 / ENSEMBLE_MEMORY_H)

    def path(key):
        a, b = ENSEMBLE_SPREAD[key]
        e = np.empty(n)
        e[0] = rng.normal()
        for i in range(1, n):
            e[i] = rho * e[i - 1] + math.sqrt(1 - rho * rho) * rng.normal()
        return e * (a + b * lead)

    out = []
    for _ in range(members):
        m = ds.copy(deep=True)
        m["hs_m"] = m["hs_m"] * np.exp(path("hs_m"))
        m["tp_s"] = np.clip(m["tp_s"] * np.exp(path("tp_s")), VARIABLES["tp_s"][1], VARIABLES["tp_s"][2])
        m["wind_speed_ms"] = np.maximum(m["wind_speed_ms"] + path("wind_speed_ms"), 0.0)
        turn = path("direction_deg")
        for key in ("wave_from_deg", "wind_from_deg"):
            m[key] = (m[key] + turn) % 360.0
        for key in [k for k in m.data_vars if k.startswith(("windsea_", "swell_"))]:
            m = m.drop_vars(key)                  # the partitions are the truth's: a member carries its sea alone
        out.append(m)
    return out
