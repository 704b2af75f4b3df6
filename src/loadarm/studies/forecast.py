"""Connect windows from a weather forecast: the operability kernel over the next hours of one forecast or of an
ensemble of them.

A forecast is a metocean record (:func:`loadarm.studies.metocean.read_metocean`: the same CSV or NetCDF) of
the hours ahead; an ensemble is several, one per member. Every hour of every member is simulated and monitored
as an operability state (:func:`loadarm.studies.operability.run_states`: the moored ship, the terminal's
criteria, the arm's monitoring), ``seeds`` times with other wave realisations. Per hour:

* the probability of staying connected through the hour without ESD-1: the share of members and seeds in which
  the hour is up on every criterion and raises no ESD-1;
* the expected number of ESD-1 in the hour while connected (up on the terminal's other criteria; a state raises
  at most one: the share that raises it);
* the weather that drives it: the members' median Hs, Tp and wind, and the criterion down in the most states
  of the hour;
* for a loading of ``loading_hours`` starting then: the probability that it completes, every one of its hours
  connected without ESD-1 in the same member and seed.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import cloudpickle
import numpy as np

from loadarm.errors import ConfigError
from loadarm.params.berth import load_berth
from loadarm.params.compiler import compile_model
from loadarm.params.config import load_config
from loadarm.results import Metric, Result
from loadarm.ship.model import compile_ship
from loadarm.studies.operability import CRITERIA, OperabilitySettings, monitor_table, record_rows, run_states
from loadarm.studies.plots import forecast_figure
from loadarm.vocab import Severity

__all__ = ["ForecastResult", "run_forecast", "FORECAST_METRICS", "MAX_MEMBERS", "MAX_SEEDS"]

#: Members an ensemble may have (ECMWF's ensemble has 51).
MAX_MEMBERS = 100
#: Wave realisations per member and hour.
MAX_SEEDS = 20
#: Seeds of the forecast's states start here (apart from the operability's, which use the hour's index).
SEED_BASE = 100_000

FORECAST_METRICS = (
    Metric("hours", "hours forecast", "h", "d"),
    Metric("members", "members", "", "d"),
    Metric("seeds", "wave realisations per member", "", "d"),
    Metric("first_down", "first hour below 50 % connected", none="none"),
    Metric("expected_esd1", "ESD-1 expected over the forecast", "", ".2f"),
    Metric("best_start", "best start for a loading", none="none within the forecast"),
    Metric("best_start_probability", "  probability it completes", "%", ".0f", scale=100.0),
    Metric("wall_s", "wall time", "s", ".1f"),
)


@dataclass(frozen=True)
class ForecastResult(Result):
    """The connect windows of a forecast.

    Attributes
    ----------
    times : ndarray of datetime64 (k,)
        The hours.
    connected : ndarray (k,)
        Probability of staying connected through each hour without ESD-1.
    esd1 : ndarray (k,)
        Expected ESD-1 in each hour, while up on the terminal's other criteria (the operability's "connected").
    completes : ndarray (k,)
        Probability that a loading starting at each hour completes (``nan`` where it would run past the forecast).
    hs, tp, wind : ndarray (k,)
        The members' median significant height (m), peak period (s) and wind (m/s).
    governs : tuple of str (k,)
        The criterion that takes the most states of the hour down (``"none"``: none down).
    members : tuple of str
    seeds : int
    loading_hours : float
    wall_s : float
    """

    times: np.ndarray
    connected: np.ndarray
    esd1: np.ndarray
    completes: np.ndarray
    hs: np.ndarray
    tp: np.ndarray
    wind: np.ndarray
    governs: tuple
    members: tuple
    seeds: int
    loading_hours: float
    wall_s: float = field(default=math.nan)

    METRICS = FORECAST_METRICS

    def _hour(self, i) -> str:
        return str(np.datetime_as_string(self.times[i], unit="m")).replace("T", " ")

    def _values(self) -> dict:
        below = np.flatnonzero(self.connected < 0.5)
        ok = np.isfinite(self.completes) & (self.completes > 0)
        best = int(np.nanargmax(np.where(ok, self.completes, -1.0))) if ok.any() else None
        return {"hours": int(self.times.size), "members": len(self.members), "seeds": self.seeds,
                "first_down": self._hour(below[0]) if below.size else None,
                "expected_esd1": float(np.sum(self.esd1)),
                "best_start": self._hour(best) if best is not None else None,
                "best_start_probability": float(self.completes[best]) if best is not None else None,
                "loading_hours": self.loading_hours, "wall_s": self.wall_s}

    def to_dict(self) -> dict:
        """Headline numbers and one row per hour.

        Returns
        -------
        dict
        """
        rows = [{"time": self._hour(i), "connected_probability": float(self.connected[i]),
                 "expected_esd1": float(self.esd1[i]),
                 "loading_completes_probability": None if not np.isfinite(self.completes[i])
                 else float(self.completes[i]),
                 "hs_m": float(self.hs[i]), "tp_s": float(self.tp[i]), "wind_speed_ms": float(self.wind[i]),
                 "governs": self.governs[i]} for i in range(self.times.size)]
        return {**self._values(), "member_files": list(self.members), "hourly": rows}

    def rows(self) -> list[tuple[str, ...]]:
        """The hourly table as text cells: time, Hs, Tp, wind, P(connected), E[ESD-1], P(loading completes),
        governing criterion."""
        out = []
        for r in self.to_dict()["hourly"]:
            done = r["loading_completes_probability"]
            out.append((r["time"], f"{r['hs_m']:.2f}", f"{r['tp_s']:.1f}", f"{r['wind_speed_ms']:.1f}",
                        f"{100 * r['connected_probability']:.0f} %", f"{r['expected_esd1']:.2f}",
                        "-" if done is None else f"{100 * done:.0f} %", r["governs"]))
        return out

    def _figure(self):
        return forecast_figure(self)


def _job(compiled: bytes, rows: list[dict], settings, seed: int, first: int = 0, member: int = 0) \
        -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One member's hours with one wave realisation (a worker's task): whether each hour is up (connected without
    ESD-1), raises ESD-1 while up on the terminal's other criteria (as the operability counts ESD-1 connected),
    and the criteria that take it down (a tuple, ESD-1 counted as ``"arm"``).
    ``compiled`` is the model, ship, table, bearing and environment by cloudpickle (the compiled model's record
    types are made at run time, which the standard pickle cannot name: Dask sends them the same way); ``rows``
    are the member's hours from its ``first``-th. Every member, seed and hour has waves of its own (the seed is
    made of the three: found, members sharing their waves were more alike than an ensemble is), and a member cut
    into parts gives the same states."""
    model, ship, table, bearing, env = cloudpickle.loads(compiled)
    base = SEED_BASE * (1 + seed + MAX_SEEDS * member)
    seeded = [{**r, "index": base + first + j} for j, r in enumerate(rows)]
    states = run_states(model, ship, table, seeded, settings, bearing, env)
    raised = np.array([int(st["stage"]) >= Severity.ESD1 for st in states], dtype=bool)
    others = np.array([any(st[f"down_{c}"] for c in CRITERIA if c != "arm") for st in states], dtype=bool)
    up = np.array([not st["down"] for st in states], dtype=bool) & ~raised
    why = np.empty(len(states), dtype=object)
    why[:] = [tuple(c for c in CRITERIA if st[f"down_{c}"] or (c == "arm" and e))
              for st, e in zip(states, raised, strict=True)]
    return up, raised & ~others, why


def _run_jobs(args: list[tuple], workers: int, progress) -> list:
    """Every job's result in order: in this process for one worker, else in spawned processes."""
    if workers == 1:
        out = []
        for k, a in enumerate(args):
            out.append(_job(*a))
            if progress is not None:
                progress(k + 1, len(args))
        return out
    spawn = multiprocessing.get_context("spawn")           # never fork a process that holds numba's threads
    with ProcessPoolExecutor(max_workers=min(workers, len(args)), mp_context=spawn) as pool:
        futures = [pool.submit(_job, *a) for a in args]
        out = []
        for k, f in enumerate(futures):
            out.append(f.result())
            if progress is not None:
                progress(k + 1, len(futures))
        return out


def _gapless(member: Path, rows: list[dict], gaps) -> list[dict]:
    """A forecast's rows, refused in one line if its hours are not consecutive: a connect window runs over whole
    hours, and a gap (an hour missing, or a value) would join two hours that are not neighbours (found in
    review: the probability that a loading completes ran straight across a gap)."""
    if len(rows) > 1:
        step = np.diff(np.array([r["index"] for r in rows]))
        if np.any(step != 1):
            k = int(np.flatnonzero(step != 1)[0])
            raise ConfigError(f"{member}: time: the forecast has a gap after {rows[k]['time']:%Y-%m-%d %H:%M} "
                              f"({int(step[k]) - 1} hour(s) missing or unusable; {gaps.summary()}); a forecast "
                              "must be hourly without gaps")
    return rows


def _completes(up: np.ndarray, length: int) -> np.ndarray:
    """Probability (over the first axis) that ``length`` hours from each start are all up; ``nan`` past the end."""
    k = up.shape[-1]
    out = np.full(k, np.nan)
    if length <= k:
        run = np.stack([up[..., i: k - length + 1 + i] for i in range(length)]).all(axis=0)
        out[: k - length + 1] = run.reshape(-1, k - length + 1).mean(axis=0)
    return out


def run_forecast(config, berth, members, *, hours: int = 72, seeds: int = 1,
                 settings: OperabilitySettings = OperabilitySettings(), workers: int | None = None,
                 progress: Callable[[int, int], None] | None = None) -> ForecastResult:
    """Run the operability kernel over the next ``hours`` of a forecast or an ensemble.

    Parameters
    ----------
    config, berth : path
        Installation and berth file.
    members : sequence of path
        One metocean record per member (one: a deterministic forecast); every member covers the same hours.
    hours : int
        The first hours of each member (1-240).
    seeds : int
        Wave realisations per member and hour (1-:data:`MAX_SEEDS`).
    settings : OperabilitySettings
    workers : int, optional
        Processes (default: every core; 1: this process); each takes a member's hours (or a part of them) with
        one seed at a time.
    progress : callable, optional
        ``progress(done, total)`` after each member and seed.

    Returns
    -------
    ForecastResult

    Raises
    ------
    ConfigError
        A bad argument, record or member whose hours differ from the first's.
    """
    members = [Path(m) for m in members]
    if not 1 <= len(members) <= MAX_MEMBERS:
        raise ConfigError(f"--metocean: {len(members)} members; give 1 to {MAX_MEMBERS}")
    if not 1 <= hours <= 240:
        raise ConfigError(f"--hours = {hours} is outside [1, 240]")
    if not 1 <= seeds <= MAX_SEEDS:
        raise ConfigError(f"--seeds = {seeds} is outside [1, {MAX_SEEDS}]")
    t0 = time.perf_counter()
    records = [_gapless(m, *record_rows(m, hours)) for m in members]
    times = np.array([r["time"].to_datetime64() for r in records[0]])
    for m, rec in zip(members[1:], records[1:], strict=True):
        got = np.array([r["time"].to_datetime64() for r in rec])
        if got.shape != times.shape or np.any(got != times):
            raise ConfigError(f"{m}: its hours are not those of {members[0]} ({got.size} usable hours from "
                              f"{got[0] if got.size else 'none'}; expected {times.size} from {times[0]})")
    inst = load_config(config)
    settings = settings.resolved(inst.operability)
    model = compile_model(inst, source=str(config))
    bf = load_berth(berth)
    ship = compile_ship(bf, source=str(berth))
    table = monitor_table(model, [r for rec in records for r in rec])
    compiled = cloudpickle.dumps((model, ship, table, bf.berth.x_bearing_deg, bf.environment))
    n_workers = max(1, workers or os.cpu_count() or 1)
    parts = max(1, -(-n_workers // (len(records) * seeds)))           # a member cut in parts when the cores outnumber
    cuts = [c for c in np.array_split(np.arange(times.size), parts) if c.size]   # the members and seeds
    jobs = [(r, seed, c) for r in range(len(records)) for seed in range(seeds) for c in cuts]
    args = [(compiled, records[r][c[0]: c[-1] + 1], settings, seed, int(c[0]), r) for r, seed, c in jobs]
    results = _run_jobs(args, n_workers, progress)
    per_run = len(cuts)                                   # consecutive jobs: one member and seed, its parts in order
    up, esd, why = (np.stack([np.concatenate([results[g * per_run + p][i] for p in range(per_run)])
                              for g in range(len(records) * seeds)]) for i in range(3))
    governs = []
    for j in range(times.size):                # the criterion down in the most states of the hour (CRITERIA's order on ties)
        counts = [sum(c in w for w in why[:, j]) for c in CRITERIA]
        governs.append(CRITERIA[int(np.argmax(counts))] if max(counts) else "none")
    med = {k: np.median([[r[k] for r in rec] for rec in records], axis=0)
           for k in ("hs_m", "tp_s", "wind_speed_ms")}
    length = max(1, int(math.ceil(settings.criteria.loading_hours)))
    return ForecastResult(times, up.mean(axis=0), esd.mean(axis=0), _completes(up, length), med["hs_m"],
                          med["tp_s"], med["wind_speed_ms"], tuple(governs), tuple(str(m) for m in members), seeds,
                          float(settings.criteria.loading_hours), time.perf_counter() - t0)
