"""Operability over a metocean record, on Dask (issue 13): how many hours the arm can stay connected at this berth,
how often ESD-1 and the release fire, and which weather causes it.

Every usable hour of the record (:mod:`loadarm.studies.metocean`) is one sea state: the berth's design ship in
that hour's wind, current, waves and tide (:func:`state_environment`), its flange's motion for
``duration_per_state`` seconds (:func:`loadarm.ship.motion.flange_positions`: the flange of
:func:`loadarm.ship.motion.simulate`, seeded per hour), and the connected-mode
monitoring of it (:func:`loadarm.studies.kernel.monitor_record`). The hours are cut into chunks (50-200 tasks,
many states each: a Dask task costs about 2 ms to schedule), each chunk runs on a worker and writes its rows to
``<out>.chunks/chunk-NNNNN.parquet`` as soon as it is done, so a run that stops (a killed worker, a killed
client) resumes from the chunks already written; the rows are then gathered into one Parquet file.

A state is **down** (not operable) on any of the terminal's criteria (the installation's ``[operability]``,
issue 28), each a column of its own so that the result says which governs:

* **lines**: a line's tension, first-order motion included, above ``line_limit`` of its MBL (MEG4's working
  load limit), or a line parted;
* **wind**: the hour's mean wind above ``wind_limit``, or above ``wind_limit_off_berth`` when it blows off the
  berth;
* **fenders**: a fender deflected past ``fender_limit`` of its rated deflection;
* **motion**: PIANC's criteria for gas tankers with loading arms (surge, sway off the berth, roll, pitch, yaw);
* **arm**: the arm could not connect (the flange's significant motion above ``connect_motion_limit``) or,
  connected, the monitoring reached ESD-1 or worse.

Persistence (:func:`persistence`): the share of the hours a loading of ``loading_hours`` could start and run
uninterrupted, and loadings back to back through the record with ``reconnect_hours`` lost after each
disconnection: loadings per year and the share that complete without one. ESD-1 per year is counted apart
from the downtime, over the hours the arm would be connected (the terminal's other criteria met).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from loadarm import __version__
from loadarm.errors import ConfigError
from loadarm.files import SIGNATURE, atomic_open, atomic_write
from loadarm.params.berth import load_berth
from loadarm.params.compiler import compile_model
from loadarm.params.config import load_config
from loadarm.params.declare import in_range, range_text
from loadarm.params.sections import Operability
from loadarm.results import Metric, Result, Summary
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import DT, moored_state
from loadarm.studies.cluster import check_scheduler, check_workers, connect_scheduler, plan_workers
from loadarm.studies.kernel import floor_table, monitor_record, relative_record
from loadarm.studies.metocean import compass_to_berth, read_metocean
from loadarm.studies.plots import operability_figure
from loadarm.studies.runs_file import code_digest
from loadarm.vocab import Severity

__all__ = ["record_rows", "monitor_table", "STATE_VARIABLES", "block_bootstrap", "BOOTSTRAP_BLOCK_H", "CI_LEVEL", "OperabilitySettings", "state_environment", "run_states", "run_operability", "OperabilityResult",
           "plan_chunks", "write_parquet", "COLUMNS", "CRITERIA", "headline_rows", "persistence", "judge_state",
           "monitor_table_at", "run_chunked", "state_ship"]

#: The environment of the local cluster's worker processes (start a cluster of your own's workers with the same):
#: single-threaded numerical libraries (one worker process per core), glibc keeping freed memory (Dask's default
#: trim threshold, 64 KiB, returns every large temporary to the kernel; the mmap threshold at its largest, 32 MiB,
#: so an hour's arrays come from the heap and are reused).
WORKER_ENVIRONMENT = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                      "MKL_NUM_THREADS": "1", "MALLOC_TRIM_THRESHOLD_": str(512 * 1024 ** 2),
                      "MALLOC_MMAP_THRESHOLD_": str(32 * 1024 ** 2)}
#: The local cluster's Dask settings for its workers (a cluster of your own: ``DASK_DISTRIBUTED__WORKER__PROFILE__
#: ENABLED=False`` in the workers' environment): no statistical profiler (it samples every thread's stack every
#: 10 ms; found: the workers ran the kernel about 20 % slower than plain processes).
WORKER_CONFIG = {"distributed.worker.profile.enabled": False}
#: Result columns, one row per state (units in the names).
COLUMNS = ("time", "hs_m", "tp_s", "wind_speed_ms", "current_speed_ms", "tide_m", "stage", "esd1_s", "release_s",
           "max_beta_deg", "max_slew_deg", "z_range_m", "min_time_to_limit_s", "flange_motion_m", "connectable",
           "outside", "line_tension_mbl", "fender_rated", "surge_pp_m", "sway_off_m", "roll_pp_deg", "pitch_pp_deg",
           "yaw_pp_deg", "down_lines", "down_wind", "down_fenders", "down_motion", "down_arm", "down")
#: The terminal's criteria, in the order the result lists them (a column ``down_<name>`` each).
CRITERIA = ("lines", "wind", "fenders", "motion", "arm")

#: Block of the bootstrap, hours: a week, longer than a storm's persistence (one to three days), so that the
#: weeks drawn are close to independent while the hours within a week keep their order (Künsch 1989).
BOOTSTRAP_BLOCK_H = 168
#: Resamples of the bootstrap (the 5 % and 95 % quantiles of 2000 move by about 0.1 % of downtime between seeds).
BOOTSTRAP_RESAMPLES = 2000
#: Two-sided level of the operability's confidence intervals.
CI_LEVEL = 0.90
#: Blocks a record must hold for an interval (fewer: none is given; a bootstrap of two or three weeks would
#: only reshuffle them).
MIN_BLOCKS = 8


def block_bootstrap(values, *, block: int = BOOTSTRAP_BLOCK_H, resamples: int = BOOTSTRAP_RESAMPLES,
                    level: float = CI_LEVEL, seed: int = 0) -> tuple[float, float]:
    """A confidence interval of the mean of an hourly series by the circular block bootstrap (Politis & Romano
    1992): ``ceil(n / block)`` blocks of ``block`` consecutive hours, starting anywhere and wrapping round the
    record's end, drawn with replacement; the mean of each resample; the interval between its quantiles.

    Parameters
    ----------
    values : array_like (n,)
        One value per hour (0/1 for a fraction of hours, a count per hour for a rate).
    block, resamples : int
    level : float
        Two-sided, in (0, 1).
    seed : int

    Returns
    -------
    tuple of float
        The interval's ends (``nan`` for an empty series). A series of zeros (no event at all) has no spread to
        resample: its interval is ``(0, -ln((1 - level) / 2) / m)`` over its ``m`` blocks (the rule of three
        for a 95 % one-sided bound, Hanley & Lippman-Hand 1983), as if an event filled the whole of each block
        it fell in (the events of a record cluster in storms: counting hours as independent would claim too
        much).
    """
    x = np.asarray(values, dtype=float)
    n = x.size
    if n == 0:
        return math.nan, math.nan
    if not 0 < level < 1 or block < 1 or resamples < 1:
        raise ValueError(f"block_bootstrap: level {level} in (0, 1), block {block} >= 1, resamples {resamples} >= 1")
    block = min(block, n)
    m = -(-n // block)
    if not np.any(x):
        return 0.0, float(-math.log((1 - level) / 2) / m)
    circular = np.concatenate([x, x[: block - 1]])
    sums = np.convolve(circular, np.ones(block), mode="valid")         # the sum of the block starting at each hour
    starts = np.random.default_rng(seed).integers(0, n, size=(resamples, m))
    means = sums[starts].sum(axis=1) / (m * block)
    lo, hi = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return float(lo), float(hi)


@dataclass(frozen=True)
class OperabilitySettings:
    """How each sea state is simulated and judged; None takes the installation's ``[operability]`` value.

    Attributes
    ----------
    duration_per_state : float, optional
        Seconds simulated per hourly state (3600: the whole hour).
    connect_motion_limit : float, optional
        Largest significant flange motion (4 standard deviations of the flange's motion, the worst axis) at
        which the arm can still connect, m (the coupler's capture range with the guidance's tracking; about an
        Hs of 2.5-3 m for the example ship).
    seed : int
        Base of the per-hour seeds (hour index + seed).
    chunks : int
        Tasks the record is cut into (50-200 for a year; fewer for short records).
    criteria : Operability, optional
        The terminal's criteria (the installation's ``[operability]``; None: its defaults).
    """

    duration_per_state: float | None = None
    connect_motion_limit: float | None = None
    seed: int = 0
    chunks: int = 100
    criteria: Operability | None = None

    def __post_init__(self):

        # the ranges are those declared for [operability] (found: written here again, connect_motion_limit
        # had lost its upper bound)
        for key, name in (("duration_per_state", "--duration-per-state"), ("connect_motion_limit",
                                                                            "connect_motion_limit")):
            value = getattr(self, key)
            if value is not None and not in_range(Operability, key, value):
                raise ConfigError(f"{name} must be in {range_text(Operability, key)}, got {value:g}")

    def resolved(self, section) -> "OperabilitySettings":
        """These settings with the installation's ``[operability]`` where they are None.

        Parameters
        ----------
        section : loadarm.params.sections.Operability

        Returns
        -------
        OperabilitySettings
        """
        from dataclasses import replace

        return replace(self, duration_per_state=section.duration_per_state if self.duration_per_state is None
                       else self.duration_per_state,
                       connect_motion_limit=section.connect_motion_limit if self.connect_motion_limit is None
                       else self.connect_motion_limit, criteria=section if self.criteria is None else self.criteria)


def state_environment(base, row: dict, x_bearing_deg: float):
    """The berth environment of one hour of the record.

    Parameters
    ----------
    base : Environment
        The berth file's (its keys not in the record, none today, stay).
    row : dict
        One hour: the record's variables.
    x_bearing_deg : float

    Returns
    -------
    Environment
    """

    def turn(to_bearing):
        return float(compass_to_berth(to_bearing, x_bearing_deg))

    return base.model_copy(update={
        "hs": float(row["hs_m"]), "tp": float(row["tp_s"]), "spreading": float(row["wave_spreading"]),
        "wave_direction_deg": turn(float(row["wave_from_deg"]) + 180.0),
        "wind_speed": float(row["wind_speed_ms"]), "wind_direction_deg": turn(float(row["wind_from_deg"]) + 180.0),
        "current_speed": float(row["current_speed_ms"]),
        "current_direction_deg": turn(float(row["current_to_deg"]))})


def run_states(model, ship, table, rows: list[dict], settings: OperabilitySettings, x_bearing_deg: float,
               base_env) -> list[dict]:
    """Simulate and monitor a batch of hourly states (one Dask task).

    Parameters
    ----------
    model : ArmModel
    ship : ShipModel
    table : FloorTable
    rows : list of dict
        Hours of the record (with ``index``, ``time`` and the variables).
    settings : OperabilitySettings
    x_bearing_deg : float
    base_env : Environment

    Returns
    -------
    list of dict
        One row per state (:data:`COLUMNS`).
    """

    if settings.duration_per_state is None or settings.connect_motion_limit is None:
        raise ValueError("run_states needs resolved settings (OperabilitySettings.resolved)")
    crit = settings.criteria or Operability()
    ship = state_ship(ship, crit)
    fx, fz = model.approach.flange
    rel = np.empty((3, 0))
    out = []
    for row in rows:
        env = state_environment(base_env, row, x_bearing_deg)
        flange, reference, loads = moored_state(ship, env, settings.duration_per_state,
                                                seed=settings.seed + int(row["index"]))
        if rel.shape[1] != flange.shape[0]:
            rel = np.empty((3, flange.shape[0]))          # reused by the chunk's states
        std = relative_record(flange, reference, np.array([fx, 0.0, fz + float(row["tide_m"])]), rel)
        r = monitor_record(model, table, rel.T, DT)
        motion = 4.0 * float(np.max(std))
        connectable = motion <= settings.connect_motion_limit
        verdict = judge_state(crit, ship.moorings, loads, env, connectable, r.stage)
        out.append({"time": row["time"], "hs_m": row["hs_m"], "tp_s": row["tp_s"],
                    "wind_speed_ms": row["wind_speed_ms"], "current_speed_ms": row["current_speed_ms"],
                    "tide_m": row["tide_m"], "stage": r.stage, "esd1_s": r.esd1_s, "release_s": r.release_s,
                    "max_beta_deg": r.max_beta_deg, "max_slew_deg": r.max_slew_deg, "z_range_m": r.z_range_m,
                    "min_time_to_limit_s": r.min_time_to_limit_s, "flange_motion_m": motion,
                    "connectable": connectable, "outside": r.outside, **verdict})
    return out


def state_ship(ship, crit: Operability):
    """The ship the hourly states are simulated with: the berth's passing ship in every state with
    ``[operability] passing_ship = true``, else none.

    Parameters
    ----------
    ship : ShipModel
    crit : Operability

    Returns
    -------
    ShipModel

    Raises
    ------
    ConfigError
        ``passing_ship = true`` and the berth declares no ``[passing_ship]``.
    """
    if crit.passing_ship:
        if ship.passing is None:
            raise ConfigError("operability.passing_ship = true needs a [passing_ship] table in the berth file")
        return ship
    return ship if ship.passing is None else replace(ship, passing=None)


def judge_state(crit: Operability, moorings, loads, env, connectable: bool, stage: int) -> dict:
    """One state judged by the terminal's criteria: the measures and a ``down_<criterion>`` each, and ``down``.

    Parameters
    ----------
    crit : Operability
    moorings : Moorings
    loads : StateLoads
    env : Environment
        The state's (berth-frame directions: wind towards, from berth +x).
    connectable : bool
    stage : int
        The monitoring's worst stage (:class:`loadarm.vocab.Severity`).

    Returns
    -------
    dict
    """
    line = float(np.max(loads.tension_max / moorings.mbl))
    rated = moorings.fender_prop[2]
    fender = float(np.max(loads.fender_deflection_max / rated)) if rated.size else 0.0
    off_berth = abs((env.wind_direction_deg + 180.0) % 360.0 - 180.0) <= crit.off_berth_sector_deg
    wind_cap = min(crit.wind_limit, crit.wind_limit_off_berth) if off_berth else crit.wind_limit
    roll, pitch, yaw = (math.degrees(v) for v in (loads.roll_pp, loads.pitch_pp, loads.yaw_pp))
    down = {"down_lines": bool(line > crit.line_limit or loads.parted > 0),
            "down_wind": bool(env.wind_speed > wind_cap),
            "down_fenders": bool(fender > crit.fender_limit),
            "down_motion": bool(loads.surge_pp > crit.surge_limit or loads.sway_off > crit.sway_limit
                                or roll > crit.roll_limit_deg or pitch > crit.pitch_limit_deg
                                or yaw > crit.yaw_limit_deg),
            "down_arm": bool((not connectable) or stage >= Severity.ESD1)}
    return {"line_tension_mbl": line, "fender_rated": fender, "surge_pp_m": loads.surge_pp,
            "sway_off_m": loads.sway_off, "roll_pp_deg": roll, "pitch_pp_deg": pitch, "yaw_pp_deg": yaw, **down,
            "down": any(down.values())}


def persistence(down, times, loading_hours: float, reconnect_hours: float) -> dict:
    """Persistence of the operable hours (PIANC): how often a loading could run uninterrupted, and loadings run
    back to back through the record.

    Parameters
    ----------
    down : array_like of bool
        Hour by hour.
    times : array_like of datetime64
        The hours' times (a step other than one hour breaks the record: no window spans a gap).
    loading_hours : float
        Connected hours a loading needs.
    reconnect_hours : float
        Operable hours lost after each disconnection before the transfer resumes.

    Returns
    -------
    dict
        ``windows_fraction``: of the operable hours with a loading's length of record after them, the share
        from which ``loading_hours`` uninterrupted operable hours follow; ``loadings``: loadings completed back to back; ``loadings_uninterrupted``: of
        those, how many without a disconnection; ``hours_per_loading``: mean hours at the berth per completed
        loading.
    """
    up = ~np.asarray(down, dtype=bool)
    t = np.asarray(times, dtype="datetime64[s]").astype(np.int64)
    need = int(math.ceil(loading_hours))
    breaks = np.concatenate([[True], np.diff(t) != 3600]) if t.size else np.zeros(0, dtype=bool)
    # each hour's segment (the record cut at its gaps) and how many operable hours follow it unbroken
    seg_end = np.empty(up.size, dtype=np.int64)
    run_up = np.zeros(up.size + 1, dtype=np.int64)
    end = up.size
    for k in range(up.size - 1, -1, -1):
        seg_end[k] = end
        if up[k]:
            run_up[k] = 1 + (run_up[k + 1] if k + 1 < end else 0)
        if breaks[k]:
            end = k
    # a start counts when the segment leaves a whole loading's hours after it (the record's end is no weather)
    eligible = up & (np.arange(up.size) + need <= seg_end)
    starts = int(np.sum(eligible))
    full = int(np.sum(eligible & (run_up[:-1] >= need)))
    done = clean = 0
    progress, debt, interrupted, hours, spent = 0, 0, False, 0, []
    for k in range(up.size):
        if breaks[k] and k > 0:
            progress, debt, interrupted, hours = 0, 0, False, 0   # a gap: the loading under way is not counted
        hours += 1
        if not up[k]:
            if progress > 0:
                interrupted, debt = True, int(math.ceil(reconnect_hours))
            continue
        if debt > 0:
            debt -= 1
            continue
        progress += 1
        if progress >= need:
            done += 1
            clean += not interrupted
            spent.append(hours)
            progress, interrupted, hours = 0, False, 0
    return {"windows_fraction": full / starts if starts else None, "loadings": done,
            "loadings_uninterrupted": clean, "hours_per_loading": float(np.mean(spent)) if spent else None}


def write_parquet(df, path: str | Path) -> Path:
    """Write a table as Parquet, atomically, with loadarm's ``generator`` in its metadata (so that a rerun may
    replace it: :func:`loadarm.files.written_by_loadarm`).

    Parameters
    ----------
    df : pandas.DataFrame
    path : str or Path

    Returns
    -------
    Path
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[b"generator"] = f"{SIGNATURE} {__version__}".encode()
    with atomic_open(path, "wb") as fh:
        pq.write_table(table.replace_schema_metadata(meta), fh)
    return Path(path)


def plan_chunks(n: int, chunks: int) -> list[tuple[int, int]]:
    """Cut ``n`` states into at most ``chunks`` contiguous ranges of nearly equal size.

    Parameters
    ----------
    n, chunks : int

    Returns
    -------
    list of (start, stop)
    """
    k = max(1, min(chunks, n))
    edges = np.linspace(0, n, k + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


# --------------------------------------------------------------------------- worker side


def _chunk_task(compiled: tuple, rows: list[dict], settings: OperabilitySettings, path: str):
    """A Dask task: run the chunk's states and write them to ``path`` (atomically, for a run that resumes);
    return them (a ``pandas.DataFrame``: found, reading the chunks back was half of a study's last second).

    ``compiled`` is ``(model, ship, table, x_bearing_deg, base_env)``: compiled once by the client and
    scattered to every worker (found: each worker compiling the ship, its mean drift by capytaine, and the
    design-drift table took 3.5-4.5 s of a two-worker year's minute).
    """
    import pandas as pd

    model, ship, table, x_bearing_deg, base_env = compiled
    res = pd.DataFrame(run_states(model, ship, table, rows, settings, x_bearing_deg, base_env), columns=list(COLUMNS))
    write_parquet(res, path)
    return res


# --------------------------------------------------------------------------- result


@dataclass(frozen=True)
class OperabilityResult(Result):
    """The operability of an arm at a berth over a metocean record."""

    table: object = field(repr=False)          # pandas.DataFrame, one row per state
    gaps: dict = field(default_factory=dict)
    wall_s: float = math.nan
    workers: int = 0
    criteria: Operability = field(default_factory=Operability)

    #: The criteria its rows judge (a ``down_<name>`` column each): the terminal's; a bank's adds its own.
    JUDGED = CRITERIA

    METRICS = (
        Metric("states", "sea states", "", "d"),
        Metric("downtime_fraction", "downtime", "%", ".1f", scale=100.0),
        Metric("downtime_ci", f"  its {100 * CI_LEVEL:.0f} % confidence interval (weeks resampled)", "%", ".1f",
               sep=" - ", scale=100.0, none=f"none: the record holds under {MIN_BLOCKS} weeks"),
        Metric("down_lines_fraction", "  lines above their limit (MEG4)", "%", ".1f", scale=100.0),
        Metric("down_wind_fraction", "  wind above its limit", "%", ".1f", scale=100.0),
        Metric("down_fenders_fraction", "  fenders above their rating", "%", ".1f", scale=100.0),
        Metric("down_motion_fraction", "  motions above PIANC's", "%", ".1f", scale=100.0),
        Metric("down_arm_fraction", "  the arm (connect, ESD-1)", "%", ".1f", scale=100.0),
        Metric("operable_h", "hours operable", "h", ".0f"),
        Metric("not_connectable_h", "hours the arm could not connect", "h", ".0f"),
        Metric("windows_fraction", "loading windows (operable hours a loading can start uninterrupted)", "%",
               ".1f", scale=100.0),
        Metric("loadings_per_year", "loadings per year, back to back", "", ".0f"),
        Metric("loadings_uninterrupted_fraction", "loadings that complete without a disconnection", "%", ".1f",
               scale=100.0),
        Metric("esd1_connected_per_year", "ESD-1 per year, connected", "", ".1f"),
        Metric("esd1_connected_per_year_ci", f"  its {100 * CI_LEVEL:.0f} % confidence interval (weeks resampled)",
               "", ".1f", sep=" - ", none=f"none: the record holds under {MIN_BLOCKS} weeks"),
        Metric("releases_connected_per_year", "releases per year, connected", "", ".1f"),
        Metric("esd1_per_year", "ESD-1 per year, whatever the other criteria", "", ".1f"),
        Metric("releases_per_year", "releases per year, whatever the other criteria", "", ".1f"),
        Metric("max_beta_deg", "largest beta", "deg", ".1f"),
        Metric("line_tension_max_mbl", "largest line tension / MBL", "", ".2f"),
        Metric("wall_s", "wall time", "s", ".1f"),
    )

    def _values(self) -> dict:
        df = self.table
        n = len(df)
        years = max(n / 8766.0, 1e-9)
        c = self.criteria
        others = np.zeros(n, dtype=bool)
        for name in CRITERIA[:-1]:
            others |= df[f"down_{name}"].to_numpy(dtype=bool)
        connected = df["connectable"].to_numpy(dtype=bool) & ~others
        p = persistence(df["down"].to_numpy(dtype=bool), df["time"].to_numpy(), c.loading_hours,
                        c.reconnect_hours)
        per = {f"down_{k}_fraction": float(df[f"down_{k}"].mean()) if n else math.nan for k in self.JUDGED}
        esd1 = ((df["stage"] >= Severity.ESD1) & connected).to_numpy(dtype=float)
        enough = n >= MIN_BLOCKS * BOOTSTRAP_BLOCK_H
        ci = {"downtime_ci": list(block_bootstrap(df["down"].to_numpy(dtype=float))) if enough else None,
              "esd1_connected_per_year_ci": [8766.0 * v for v in block_bootstrap(esd1)] if enough else None}
        return {"states": n, "downtime_fraction": float(df["down"].mean()) if n else math.nan, **per, **ci,
                "operable_h": int((~df["down"]).sum()), "not_connectable_h": int((~df["connectable"]).sum()),
                "windows_fraction": p["windows_fraction"], "loadings_per_year": p["loadings"] / years,
                "loadings_uninterrupted_fraction": p["loadings_uninterrupted"] / p["loadings"] if p["loadings"]
                else None, "hours_per_loading": p["hours_per_loading"],
                "esd1_per_year": float((df["stage"] >= Severity.ESD1).sum() / years),
                "esd1_connected_per_year": float(((df["stage"] >= Severity.ESD1) & connected).sum() / years),
                "releases_per_year": float(df["release_s"].notna().sum() / years),
                "releases_connected_per_year": float((df["release_s"].notna() & connected).sum() / years),
                "max_beta_deg": float(df["max_beta_deg"].max()) if n else math.nan,
                "line_tension_max_mbl": float(df["line_tension_mbl"].max()) if n else math.nan,
                "wall_s": self.wall_s}

    def to_dict(self) -> dict:
        """Headline numbers and the breakdowns (per month, per year, per stage, over Hs and Tp, over wind).

        Returns
        -------
        dict
        """
        import pandas as pd

        df = self.table.copy()
        t = pd.DatetimeIndex(df["time"])
        df.index = t
        by_month = df["down"].groupby(t.to_period("M")).mean()
        by_year = df["down"].groupby(t.year).mean()
        stages = {Severity(int(s)).label: int((df["stage"] == s).sum()) for s in sorted(df["stage"].unique())}
        hs_bins = [0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 20.0]
        tp_bins = [0, 6, 8, 10, 12, 30]
        grid = df.groupby([pd.cut(df["hs_m"], hs_bins), pd.cut(df["tp_s"], tp_bins)], observed=True)["down"]
        wind = df.groupby(pd.cut(df["wind_speed_ms"], [0, 5, 10, 15, 20, 25, 60]), observed=True)["down"]
        per_month = {str(k): {c: float(g[f"down_{c}"].mean()) for c in self.JUDGED}
                     for k, g in df.groupby(t.to_period("M"))}
        return {**self._values(), "gaps": dict(self.gaps), "workers": self.workers,
                "criteria": self.criteria.model_dump(),
                "downtime_by_month": {str(k): float(v) for k, v in by_month.items()},
                "downtime_by_criterion_by_month": per_month,
                "governing_by_month": {k: max(v, key=v.get) if max(v.values()) > 0 else "none"
                                       for k, v in per_month.items()},
                "downtime_by_year": {str(k): float(v) for k, v in by_year.items()},
                "states_by_stage": stages,
                "downtime_by_hs_tp": [{"hs_m": str(a), "tp_s": str(b), "downtime_fraction": float(v),
                                       "states": int(c)} for ((a, b), v), c in zip(grid.mean().items(),
                                                                                   grid.size().values)],
                "downtime_by_wind": [{"wind_speed_ms": str(k), "downtime_fraction": float(v)}
                                     for k, v in wind.mean().items()]}

    def headline(self) -> list[tuple[str, str]]:
        """The headline as ``(label, text)`` rows (:func:`headline_rows` of :meth:`to_dict`): what
        ``loadarm operability`` prints.

        Returns
        -------
        list of tuple of str
        """
        return headline_rows(self.to_dict())

    def _figure(self):

        return operability_figure(self)


def headline_rows(d: dict) -> list[tuple[str, str]]:
    """The operability's headline as ``(label, text)`` rows, from :meth:`OperabilityResult.to_dict` (or the
    report's copy of it, without the machine's wall time): the declared metrics it holds, then the worst and the
    best month and the record's gaps. One formatting for ``loadarm operability`` and the report.

    Parameters
    ----------
    d : dict

    Returns
    -------
    list of tuple of str
    """
    rows = Summary(d, OperabilityResult.METRICS).rows()
    months = d.get("downtime_by_month") or {}
    if months:
        worst, best = max(months, key=months.get), min(months, key=months.get)
        rows += [("worst month", f"{worst}: {100 * months[worst]:.1f} %"),
                 ("best month", f"{best}: {100 * months[best]:.1f} %")]
    governs = d.get("governing_by_month") or {}
    if governs:
        rows.append(("governing criterion, by month", ", ".join(f"{k} {v}" for k, v in governs.items())))
    gaps = d.get("gaps") or {}
    if gaps and gaps["usable_hours"] < gaps["hours"]:
        rows.append(("gaps in the record (skipped, never filled)",
                     f"{gaps['hours'] - gaps['usable_hours']} h, the longest {gaps['longest_gap_h']} h"))
    return rows


#: The record's variables a state is simulated from.
STATE_VARIABLES = ("hs_m", "tp_s", "wave_from_deg", "wave_spreading", "wind_speed_ms", "wind_from_deg",
                   "current_speed_ms", "current_to_deg", "tide_m")


def record_rows(metocean, hours: int | None = None) -> tuple[list[dict], object]:
    """A metocean record's usable hours as the rows :func:`run_states` takes.

    Parameters
    ----------
    metocean : path
    hours : int, optional
        Only the first ``hours`` usable ones (>= 1).

    Returns
    -------
    rows : list of dict
        ``index`` (the hour's place in the record: its seed), ``time`` and :data:`STATE_VARIABLES`.
    gaps : GapReport
    """
    import pandas as pd

    ds, gaps = read_metocean(metocean)
    use = np.flatnonzero(ds["usable"].values)
    if hours is not None:
        if hours < 1:
            raise ConfigError(f"--hours must be at least 1, got {hours}")
        use = use[:hours]
    values = {k: ds[k].values[use] for k in STATE_VARIABLES}
    times = pd.DatetimeIndex(ds["time"].values[use])
    rows = [{"index": int(i), "time": times[j], **{k: float(values[k][j]) for k in STATE_VARIABLES}}
            for j, i in enumerate(use)]
    return rows, gaps


def monitor_table(model, rows: list[dict]):
    """The compiled monitor's floor table over the flange's reach in these hours' tides (:func:`floor_table`).

    Parameters
    ----------
    model : ArmModel
    rows : list of dict
        Hours (:func:`record_rows`), their ``tide_m`` read.

    Returns
    -------
    FloorTable
    """
    fx, fz = model.approach.flange
    return monitor_table_at(model, (fx, 0.0, fz), rows)


def monitor_table_at(model, flange, rows: list[dict]):
    """:func:`monitor_table` about a flange of the arm's own frame (a bank's arm: its presentation flange,
    :meth:`loadarm.params.bank.Bank.flange_position`).

    Parameters
    ----------
    model : ArmModel
    flange : sequence of float, (3,)
        m, the arm's frame, at mean tide zero.
    rows : list of dict

    Returns
    -------
    FloorTable
    """
    tides = [r["tide_m"] for r in rows] or [0.0]
    return floor_table(model, *_box(flange, float(np.min(tides)), float(np.max(tides))))


def _box(flange, tide_lo: float, tide_hi: float):
    fx, fy, fz = (float(v) for v in flange)
    margin = 2.5
    return ((fx - margin, fy - margin, fz + tide_lo - margin), (fx + margin, fy + margin, fz + tide_hi + margin))


def _manifest(config, berth, metocean, hours, settings: OperabilitySettings, plan, extra=(),
              variant: str = "") -> str:
    """What the chunks of a run depend on: the three input files' contents (and ``extra`` files': a bank's
    installations), the hours, the settings, the plan, what else the run judges (``variant``: a bank's manifold
    loads), and loadarm's own code (every module's source: found, a chunk computed by an older kernel of the same
    version number would have been resumed into a newer run)."""
    import hashlib
    import json

    h = hashlib.sha256()
    for f in (config, berth, metocean, *extra):
        h.update(Path(f).read_bytes())
    h.update(code_digest().encode())
    given = dict(settings.__dict__, criteria=None if settings.criteria is None else settings.criteria.model_dump())
    h.update(json.dumps({"hours": hours, "settings": given, "plan": plan, "version": __version__,
                         **({"variant": variant} if variant else {})}, sort_keys=True).encode())
    return h.hexdigest()


def _check_manifest(chunk_dir: Path, digest: str, fresh: bool) -> None:
    """Resume only the same run: chunks from other inputs or settings are refused (or, with ``fresh``, removed)."""
    chunk_dir.mkdir(parents=True, exist_ok=True)
    manifest = chunk_dir / "MANIFEST"
    old = manifest.read_text().strip() if manifest.is_file() else None
    stale = sorted(chunk_dir.glob("chunk-*.parquet"))
    if old != digest and (stale or old is not None):
        if not fresh:
            raise ConfigError(f"{chunk_dir}: its chunks are from another run (other inputs, hours, settings or "
                              "loadarm code); remove the folder, or pass --force to start again")
        for f in stale:
            f.unlink()

    atomic_write(manifest, digest + "\n")


#: A chunk whose worker is lost (killed, its connection cut, its data gone) is submitted again, at most this many
#: times (besides Dask's own ``retries`` of a task that raised).
RESUBMITS = 5


def _lost(exc: BaseException) -> bool:
    """Whether a task failed because its worker or its data was lost (not because the task itself raised)."""
    import asyncio
    import concurrent.futures

    from distributed.comm import CommClosedError

    # not KilledWorker: Dask raises it for a task that took its workers down more than its allowed failures (a
    # crashing chunk); running it again would only kill more workers
    return isinstance(exc, (CommClosedError, asyncio.CancelledError, concurrent.futures.CancelledError))


def _shared(compiled):
    """The data every chunk of a study shares, as the result of a task (Dask keeps a task's inputs: it recomputes
    a lost result, where scattered data lost with its workers is gone)."""
    return compiled


def gather_resilient(client, items, submit, share, *, progress=None, resubmits: int = RESUBMITS) -> dict:
    """Run one task per item and gather the results; a task lost with its worker is submitted again.

    Found: with a worker killed at 12 s, ``operability`` failed with ``FutureCancelledError ... lost
    dependencies`` (1 of 2 tries): the data every task depends on was scattered to the workers, and its lost
    replicas took the tasks with them. The shared data is now a task's result (recomputed when lost), and a task
    lost all the same is submitted again: a loss costs a retry of the chunks it took, never the run.

    Parameters
    ----------
    client : distributed.Client
    items : list of tuple
        ``(key, ...)`` each.
    submit : callable
        ``submit(item, shared) -> Future``.
    share : callable
        ``share() -> Future`` of the data every task shares (called again when it was lost).
    progress : callable, optional
        ``progress(done, total)``.
    resubmits : int
        Times a lost item may be submitted again.

    Returns
    -------
    dict
        Key to result.

    Raises
    ------
    Exception
        A task's own error, or a loss past ``resubmits``.
    """
    from distributed import as_completed

    shared = share()
    futures = {submit(item, shared): item for item in items}
    tries: dict = {}
    done: dict = {}
    pending = as_completed(list(futures))
    for fut in pending:
        item = futures.pop(fut)
        try:
            done[item[0]] = fut.result()
        except Exception as exc:
            if not _lost(exc) or tries.get(item[0], 0) >= resubmits:
                raise
            tries[item[0]] = tries.get(item[0], 0) + 1
            if shared.status != "finished":                 # lost with its workers: share it again
                shared = share()
            new = submit(item, shared)
            futures[new] = item
            pending.add(new)
            continue
        if progress is not None:
            progress(len(done), len(items))
    return done


def _read_chunk(path: Path, *, metadata_only: bool = False):
    """A chunk written by an earlier run, or its metadata; a damaged one is named (found: Parquet's error named
    ``'<Buffer>'``, or nothing at all)."""
    import pyarrow
    import pyarrow.parquet as pq

    try:
        if metadata_only:
            return pq.read_metadata(path)
        return pq.read_table(path).to_pandas()
    except (pyarrow.ArrowException, OSError) as exc:
        raise ConfigError(f"{path}: a damaged chunk of an earlier run ({' '.join(str(exc).split())[:160]}); "
                          "remove it to have it computed again") from None


def _close_client(connecting) -> None:
    """Close the client (and the local cluster it started) once it has connected, whatever happened meanwhile."""
    if connecting.exception() is not None:           # it never connected: nothing to close
        return
    client = connecting.result()
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


def run_operability(config: str | Path, berth: str | Path, metocean: str | Path, out: str | Path, *,
                    hours: int | None = None, settings: OperabilitySettings = OperabilitySettings(),
                    scheduler: str | None = None, workers: int | None = None,
                    progress: Callable[[int, int], None] | None = None, fresh: bool = False, ship=None):
    """Run a record on Dask and gather the result (resuming from chunks already written).

    Parameters
    ----------
    config, berth, metocean : path
        Installation, berth file, metocean record.
    out : path
        Parquet file of the per-state rows; its chunks go to ``<out>.chunks/``.
    hours : int, optional
        Only the first ``hours`` usable states.
    settings : OperabilitySettings
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); default a ``LocalCluster`` on this machine
        (one single-threaded worker process per core, dashboard off, loopback).
    workers : int, optional
        Workers of the local cluster (default: every core).
    progress : callable, optional
        ``progress(done, total)`` after each chunk.
    fresh : bool
        Discard chunks of another run (other inputs, hours or settings) instead of refusing them.
    ship : ShipModel, optional
        The berth file's ship, compiled already (the report has it); compiled here otherwise.

    Returns
    -------
    OperabilityResult

    Raises
    ------
    ConfigError
        A bad record or setting; chunks beside ``out`` from another run (without ``fresh``).
    """
    check_workers("--workers", workers)
    rows, gaps = record_rows(metocean, hours)

    inst = load_config(config)
    settings = settings.resolved(inst.operability)
    model = compile_model(inst, source=str(config))
    bf = load_berth(berth)
    if settings.criteria.passing_ship and bf.passing_ship is None:
        raise ConfigError(f"{config}: operability.passing_ship = true needs a [passing_ship] table in the berth file "
                          f"{berth}")

    def compiled(ship):
        return (model, ship, monitor_table(model, rows), bf.berth.x_bearing_deg, bf.environment)

    digest = (config, berth, metocean, hours, settings)
    table, wall, n_workers = run_chunked(rows, out, digest, compiled, _chunk_task, COLUMNS, settings=settings,
                                         scheduler=scheduler, workers=workers, progress=progress, fresh=fresh,
                                         ship=ship, berth_file=bf, berth=berth)
    return OperabilityResult(table, gaps.to_dict(), wall, n_workers, settings.criteria)


def run_chunked(rows: list[dict], out, digest: tuple, compiled: Callable, task: Callable, columns, *,
                settings: OperabilitySettings, scheduler=None, workers=None, progress=None, fresh: bool = False,
                ship=None, berth_file=None, berth=None, extra=(), variant: str = ""):
    """The operability's chunks on Dask, resumed from those already written (one driver for an arm and a bank).

    Parameters
    ----------
    rows : list of dict
        The record's hours (:func:`record_rows`).
    out : path
        The gathered Parquet; its chunks in ``<out>.chunks/``.
    digest : tuple
        ``(config, berth, metocean, hours, settings)``: what :func:`_manifest` hashes (with ``extra``).
    compiled : callable
        ``compiled(ship) -> tuple``: the data every chunk shares, made while the cluster starts.
    task : callable
        ``task(compiled, rows, settings, path) -> DataFrame`` (a module-level function: it is pickled).
    columns : sequence of str
        The rows' columns (an empty record's table).
    settings : OperabilitySettings
        Resolved.
    scheduler, workers, progress, fresh, ship
        As :func:`run_operability`.
    berth_file : BerthFile
    berth : path
    extra : sequence of path
        More files the chunks depend on (a bank's installations).
    variant : str
        What else the chunks judge (a bank's manifold loads): part of the manifest.

    Returns
    -------
    table : pandas.DataFrame
    wall : float
        s.
    workers : int
    """
    import time

    import pandas as pd

    out = Path(out)
    chunk_dir = out.with_name(out.name + ".chunks")
    plan = plan_chunks(len(rows), settings.chunks)
    _check_manifest(chunk_dir, _manifest(*digest, plan, extra=extra, variant=variant), fresh)
    todo = [(k, a, b) for k, (a, b) in enumerate(plan) if not (chunk_dir / f"chunk-{k:05d}.parquet").is_file()]
    for k in sorted(set(range(len(plan))) - {k for k, _, _ in todo}):
        _read_chunk(chunk_dir / f"chunk-{k:05d}.parquet", metadata_only=True)   # a damaged one: before any work
    if scheduler is not None:
        check_scheduler(scheduler)             # even when every chunk is written (found: a resume skipped it)
    done = {}
    t0 = time.perf_counter()
    n_workers = 0
    if todo:
        import contextlib
        import logging
        from concurrent.futures import ThreadPoolExecutor

        import dask
        from distributed import Client, LocalCluster

        # the local cluster's worker processes: one thread, numba and BLAS single-threaded, and they keep freed
        # memory (found: Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536, which also freezes glibc's mmap threshold
        # at 128 KiB, so every large temporary was mapped, faulted in and unmapped again: a year took 339 s with
        # 353 s of system time for 315 s of user time)
        env = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_ENVIRONMENT.items()}
        env.update(WORKER_CONFIG)
        with dask.config.set(env), contextlib.ExitStack() as stack:
            # the cluster starts (its workers spawn and import) while this process compiles the ship and the
            # table once, to send them to every worker (found: the two in turn cost a month's run 4-5 s)
            connecting = stack.enter_context(ThreadPoolExecutor(1)).submit(
                lambda: connect_scheduler(scheduler) if scheduler is not None else Client(LocalCluster(
                    n_workers=plan_workers(workers, len(todo)), threads_per_worker=1, processes=True,
                    dashboard_address=None, host="127.0.0.1", silence_logs=logging.CRITICAL,
                    # no dashboard, but the scheduler's health/metrics HTTP server: an ephemeral loopback port
                    # (found: it took 8787, so two studies at once collided and warned)
                    scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                    preload=["loadarm.studies._worker"])))
            stack.callback(lambda: _close_client(connecting))
            if ship is None:
                ship = compile_ship(berth_file, source=str(berth))
            shared = compiled(ship)
            client = connecting.result()
            n_workers = len(client.scheduler_info()["workers"])

            def submit(item, shared):
                k, a, b = item
                return client.submit(task, shared, rows[a:b], settings,
                                     str((chunk_dir / f"chunk-{k:05d}.parquet").resolve()), retries=2, pure=False)

            # the shared data as a task's result, not scattered data: a task the scheduler can run again when the
            # workers holding it are lost (found: scattered data lost with its workers cancelled the chunks
            # waiting on it, or left them waiting for ever)
            done = gather_resilient(client, todo, submit, lambda: client.submit(_shared, shared, pure=False),
                                    progress=progress)
    parts = [done[k] if k in done else _read_chunk(chunk_dir / f"chunk-{k:05d}.parquet") for k in range(len(plan))]
    table = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(columns))
    write_parquet(table, out)
    return table, time.perf_counter() - t0, n_workers
