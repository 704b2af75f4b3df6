"""How far ahead the flange can be predicted, and whether the intervals hold: the predictors of
:mod:`loadarm.guidance.predict` run online over hold-out records of the moored-ship model.

The records are the model's flange (intact moorings, 10 Hz, turned into one-second means) in sea states, seeds
and drifts that tuned nothing: :data:`HOLD_OUT` (the predictors' constants were chosen on seeds 0-3 of other
states). Each route runs as it would in the guidance loop: the online AR refitted every
:data:`REFIT` seconds on the last 30 minutes, the model AR fitted once to the model's own records of the state
(two other seeds of two hours), both calibrated online from their own realised errors. Every :data:`EVERY` seconds a
forecast of the next :data:`loadarm.guidance.predict.HORIZON` seconds is issued; at each horizon its error and
whether its interval covered the truth are counted (only where the interval is claimed).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from loadarm.guidance.predict import (FIT_WINDOW, GATE_HORIZONS, HORIZON, LEVEL, MEMORY, MIN_ERRORS, ORDER,
                                      PREDICT_PERIOD, ArModel, Calibrator, ar_forecast, block_means, claimed_steps,
                                      fit_ar, gate_ratio, interval)
from loadarm.results import Metric, Result
from loadarm.studies.plots import prediction_figure
from loadarm.ship.motion import DT, flange_positions

__all__ = ["PredictionCase", "HOLD_OUT", "ROUTES", "RouteCalibration", "PredictionCalibration",
           "calibrate_predictors", "run_route", "COVERAGE_BAND"]

#: Seconds between two forecasts in the study (the guidance issues one every second; every fifth keeps the
#: study's cost down while each horizon still gets hundreds of forecasts per record).
EVERY = 5
#: Seconds between two refits of the online AR.
REFIT = 30
#: The coverage every claimed horizon must reach (the issue's 93-97 % for a 95 % interval).
COVERAGE_BAND = (0.93, 0.97)
#: How long a hold-out drift lasts, s (then the ship stays where it drifted to).
DRIFT_TIME = 600.0
#: The routes compared.
ROUTES = ("online AR", "model AR")
#: Seeds of the model's own records the model route is fitted to (never a hold-out's).
MODEL_SEEDS = (1000, 1001)


@dataclass(frozen=True, slots=True)
class PredictionCase:
    """One sea state of the hold-out set.

    Attributes
    ----------
    name : str
    hs, tp, direction_deg : float
        Significant height (m), peak period (s), waves' direction in the berth frame (deg, towards).
    drift : float
        A drift off the berth added to the record from its middle, for :data:`DRIFT_TIME` (m/s; 0: none): a drift
        the predictor has not seen.
    """

    name: str
    hs: float
    tp: float
    direction_deg: float
    drift: float = 0.0


#: The hold-out states: none of these heights, periods, directions or seeds tuned the predictors.
HOLD_OUT = (PredictionCase("Hs 0.75 m, 8.5 s", 0.75, 8.5, 45.0),
            PredictionCase("Hs 1.25 m, 12 s", 1.25, 12.0, 20.0),
            PredictionCase("Hs 1.75 m, 9.5 s", 1.75, 9.5, 0.0),
            PredictionCase("Hs 2.25 m, 10.5 s", 2.25, 10.5, 40.0),
            PredictionCase("swell 0.8 m, 14 s", 0.8, 14.0, 10.0),
            PredictionCase("Hs 1.5 m, 9 s, drift 0.01 m/s", 1.5, 9.0, 25.0, drift=0.01))


def _track(ship, env, case: PredictionCase, seed: int, duration: float) -> np.ndarray:
    """One record's one-second means (berth frame, about the calm position), the case's drift added."""
    flange, reference = flange_positions(ship, env, duration, seed=seed, dt=DT)
    track = block_means(flange - reference, int(round(PREDICT_PERIOD / DT)))
    if case.drift:
        t = np.arange(track.shape[0]) * PREDICT_PERIOD
        track[:, 0] += case.drift * np.clip(t - 0.5 * duration, 0.0, DRIFT_TIME)
    return track


def _state_env(base, case: PredictionCase):
    return base.model_copy(update={"hs": case.hs, "tp": case.tp, "wave_direction_deg": case.direction_deg})


@dataclass
class _Tally:
    """Per horizon and axis: forecasts issued with a claimed interval, covered, squared errors; the climatology's
    squared errors (the record's own mean as the forecast), the forecasts' cost, and the departure test's
    largest ratio of an error to its side's edge (:func:`loadarm.guidance.predict.gate_ratio`) at
    :data:`~loadarm.guidance.predict.GATE_HORIZONS` on x and y, over the records of the sea alone."""

    steps: int
    issued: np.ndarray = field(init=False)
    covered: np.ndarray = field(init=False)
    below: np.ndarray = field(init=False)
    above: np.ndarray = field(init=False)
    sq: np.ndarray = field(init=False)
    clim: np.ndarray = field(init=False)
    n: int = 0
    seconds: float = 0.0
    gate_ratio: float = 0.0

    def __post_init__(self):
        self.issued, self.covered = np.zeros((self.steps, 3)), np.zeros((self.steps, 3))
        self.below, self.above = np.zeros((self.steps, 3)), np.zeros((self.steps, 3))
        self.sq, self.clim = np.zeros((self.steps, 3)), np.zeros((self.steps, 3))

    def add(self, mean, lo, hi, truth, clim_mean, gate: bool = False) -> None:
        ok = np.isfinite(lo)
        j = np.array(GATE_HORIZONS) - 1
        if gate and np.all(ok[j, :2]):
            ratio = gate_ratio(truth[j, :2] - mean[j, :2], mean[j, :2] - lo[j, :2], hi[j, :2] - mean[j, :2])
            self.gate_ratio = max(self.gate_ratio, float(np.max(ratio)))
        self.issued += ok
        self.covered += ok & (truth >= lo) & (truth <= hi)
        self.below += ok & (truth < lo)
        self.above += ok & (truth > hi)
        self.sq += (truth - mean) ** 2
        self.clim += (truth - clim_mean) ** 2
        self.n += 1


def run_route(track: np.ndarray, route: str, tally: _Tally, *, model: ArModel | None = None,
              every: int = EVERY, gate: bool = False) -> None:
    """Run one route online over a record, counting into ``tally``.

    Parameters
    ----------
    track : ndarray (n, 3)
        One-second means.
    route : str
        ``"online AR"`` (refitted every :data:`REFIT` s) or ``"model AR"`` (``model`` given).
    tally : _Tally
    model : ArModel, optional
    every : int
    gate : bool
        Count the departure test's ratios (a record of the sea alone: no drift the model has not seen).
    """
    steps, window = tally.steps, int(FIT_WINDOW / PREDICT_PERIOD)
    cal = Calibrator(steps, memory=MEMORY // every, min_errors=MIN_ERRORS // every)   # the same minutes as live
    for t in range(ORDER, track.shape[0] - steps):
        cal.observe(t, track[t])
        if t < window or (t - window) % every:
            continue
        t0 = time.perf_counter()
        history = track[t - window + 1: t + 1]
        if route == "online AR" and (model is None or (t - window) % REFIT == 0):
            model = fit_ar(history)
        mean, sd = ar_forecast(model, history, steps)
        q = cal.quantiles()
        lo, hi = interval(mean, sd, q, claimed_steps(q))
        tally.seconds += time.perf_counter() - t0
        tally.add(mean, lo, hi, track[t + 1: t + 1 + steps], history.mean(axis=0), gate)
        cal.remember(t, mean, sd)


@dataclass(frozen=True)
class RouteCalibration:
    """One route's hold-out scores per horizon (1..k s) and axis (x off the berth, y along it, z up).

    Attributes
    ----------
    route : str
    coverage : ndarray (k, 3)
        Fraction of the claimed intervals that held the truth.
    issued : ndarray (k, 3)
        Claimed intervals counted.
    rmse, climatology : ndarray (k, 3)
        Root-mean-square error of the mean, and of the record's recent mean as the forecast (what no predictor
        gives), m.
    below, above : ndarray (k, 3)
        Fraction of the claimed intervals the truth fell below, and above: each side's tail, what the predictive
        alarms' one-sided reading of the interval assumes is 2.5 % (:data:`loadarm.guidance.predict.THRESHOLD`).
    gate_ratio : float
        The departure test's largest ratio of an error to its side's edge, at its horizons on x and y, over the
        records without a drift (what :data:`loadarm.guidance.predict.GATE_FACTOR` must exceed).
    forecasts : int
    cost : float
        Seconds per forecast (refits included), this machine.
    """

    route: str
    coverage: np.ndarray
    issued: np.ndarray
    rmse: np.ndarray
    climatology: np.ndarray
    forecasts: int
    cost: float
    below: np.ndarray | None = None
    above: np.ndarray | None = None
    gate_ratio: float = math.nan

    def tail_max(self, band=COVERAGE_BAND) -> float:
        """The largest one-sided tail on x and y over the horizons claimed (:meth:`claimed`), a fraction (nan when
        the tails were not counted or nothing is claimed)."""
        n = int(round(self.claimed(band) / PREDICT_PERIOD))
        if self.below is None or self.above is None or n == 0:
            return math.nan
        return float(max(np.max(self.below[:n, :2]), np.max(self.above[:n, :2])))

    def claimed(self, band=COVERAGE_BAND) -> float:
        """The longest horizon up to which every horizon's coverage is inside ``band`` on x and y (s)."""
        ok = np.all((self.coverage[:, :2] >= band[0]) & (self.coverage[:, :2] <= band[1]), axis=1)
        bad = np.flatnonzero(~ok)
        return float((bad[0] if bad.size else ok.size) * PREDICT_PERIOD)


PREDICTION_METRICS = (
    Metric("records", "hold-out records", fmt="d"),
    Metric("online_claimed_s", "online AR: horizon with 93-97 % coverage (x, y)", "s", ".0f"),
    Metric("model_claimed_s", "model AR: horizon with 93-97 % coverage (x, y)", "s", ".0f"),
    Metric("online_coverage_range", "online AR: coverage, 1-120 s (x, y, z)", fmt=".3f", sep=" - "),
    Metric("model_coverage_range", "model AR: coverage, 1-120 s (x, y, z)", fmt=".3f", sep=" - "),
    Metric("online_tail_max", "online AR: largest one-sided tail over its claim (x, y)", fmt=".4f"),
    Metric("model_tail_max", "model AR: largest one-sided tail over its claim (x, y)", fmt=".4f"),
    Metric("online_gate_ratio", "online AR: departure test's largest ratio, sea alone (x, y)", fmt=".2f"),
    Metric("online_skill_30s", "online AR: error at 30 s / climatology (x)", fmt=".2f"),
    Metric("model_skill_30s", "model AR: error at 30 s / climatology (x)", fmt=".2f"),
    Metric("online_cost_ms", "online AR: cost per forecast", "ms", ".2f"),
    Metric("model_cost_ms", "model AR: cost per forecast", "ms", ".2f"),
)


@dataclass(frozen=True)
class PredictionCalibration(Result):
    """The predictors' calibration on the hold-out records.

    Attributes
    ----------
    cases : tuple of PredictionCase
    seeds : tuple of int
    routes : dict of str to RouteCalibration
    band : tuple of float
        The coverage every claimed horizon must reach.
    """

    cases: tuple
    seeds: tuple
    routes: dict
    band: tuple = COVERAGE_BAND

    METRICS = PREDICTION_METRICS

    def _values(self) -> dict:
        v = {"records": len(self.cases) * len(self.seeds)}
        for key, route in (("online", "online AR"), ("model", "model AR")):
            r = self.routes[route]
            v[f"{key}_claimed_s"] = r.claimed()
            v[f"{key}_coverage_range"] = [float(np.min(r.coverage)), float(np.max(r.coverage))]
            v[f"{key}_tail_max"] = r.tail_max(self.band)
            if key == "online":
                v["online_gate_ratio"] = r.gate_ratio
            v[f"{key}_skill_30s"] = float(r.rmse[29, 0] / r.climatology[29, 0])
            v[f"{key}_cost_ms"] = 1e3 * r.cost
        return v

    def to_dict(self) -> dict:
        d = dict(self._values())
        d["horizon_s"] = (np.arange(1, next(iter(self.routes.values())).coverage.shape[0] + 1)
                          * PREDICT_PERIOD).tolist()
        d["routes"] = {name: {"coverage": r.coverage.tolist(), "issued": r.issued.tolist(), "rmse_m": r.rmse.tolist(),
                              "climatology_m": r.climatology.tolist(), "forecasts": r.forecasts,
                              "gate_ratio": r.gate_ratio,
                              **({"below": r.below.tolist(), "above": r.above.tolist()} if r.below is not None
                                 else {})}
                       for name, r in self.routes.items()}
        d["cases"] = [c.name for c in self.cases]
        d["seeds"] = list(self.seeds)
        d["level"] = LEVEL
        return d

    def _figure(self):
        return prediction_figure(self)


def calibrate_predictors(ship, base_env, *, cases=HOLD_OUT, seeds=(10, 11), duration: float = 7200.0,
                         every: int = EVERY, progress: Callable[[int, int], None] | None = None) \
        -> PredictionCalibration:
    """Run both routes over the hold-out records and score them.

    Parameters
    ----------
    ship : ShipModel
    base_env : Environment
        The berth's (wind and current stay; the waves are the case's).
    cases : sequence of PredictionCase
    seeds : sequence of int
    duration : float
        Each record, s (at least the fit window and the horizon, plus the calibration's first minutes).
    every : int
    progress : callable, optional
        ``progress(done, total)`` after each record.

    Returns
    -------
    PredictionCalibration
    """
    steps = int(HORIZON / PREDICT_PERIOD)
    if duration < FIT_WINDOW + 2 * HORIZON + 600:
        raise ValueError(f"duration = {duration:g} s is shorter than the fit window, the horizon twice and 10 "
                         f"minutes of calibration ({FIT_WINDOW + 2 * HORIZON + 600:g} s)")
    tallies = {r: _Tally(steps) for r in ROUTES}
    done, total = 0, len(cases) * len(seeds)
    for case in cases:
        env = _state_env(base_env, case)
        own = [_track(ship, env, PredictionCase(case.name, case.hs, case.tp, case.direction_deg), s, duration)
               for s in MODEL_SEEDS]
        prior = fit_ar(own, route="model AR")
        for seed in seeds:
            track = _track(ship, env, case, seed, duration)
            run_route(track, "online AR", tallies["online AR"], every=every, gate=not case.drift)
            run_route(track, "model AR", tallies["model AR"], model=prior, every=every)
            done += 1
            if progress is not None:
                progress(done, total)
    routes = {}
    for name, t in tallies.items():
        with np.errstate(invalid="ignore", divide="ignore"):
            routes[name] = RouteCalibration(name, t.covered / t.issued, t.issued, np.sqrt(t.sq / t.n),
                                            np.sqrt(t.clim / t.n), t.n, t.seconds / max(t.n, 1),
                                            t.below / t.issued, t.above / t.issued, t.gate_ratio)
    return PredictionCalibration(tuple(cases), tuple(seeds), routes)


