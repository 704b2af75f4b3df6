"""Campaigns: one scenario over many seeds and parameter draws, on every core.

A campaign proves the safety chain statistically: each run is the full closed loop (:func:`run_scenario`) with
its own seed (waves, sensor noise, outliers) and, for each ``--vary key=lo:hi``, a value drawn uniformly from
the range (seeded too, so a campaign is repeatable). Keys are dotted scenario keys (``drift.speed``,
``operator.estop_at``) or installation keys prefixed ``installation.`` (``installation.sequence.margin``).

Every run is judged on what matters at the jetty:

* **overstretch**: the attached arm was driven past a face of its envelope (the failure the alarms exist for);
* **overstretch before isolation**: of those, the ones before the ERS valves were confirmed closed (product still
  live in the arm: the worst case, a spill);
* **opened on live product**: the coupler began to open before the ERS valves were confirmed closed;
* **false alarm**: the first alarm (ESD-1) or worse was raised in a run where the flange never reaches a face
  (in the run, or on its own trajectory up to 10 minutes after it);
* **missed alarm**: the flange reached a face in the run and the release had not completed before it;
* **release margin**: from the release complete to the flange's crossing of the face, s;
* **exposure**: the runs that connected and the time connected (what a count of false alarms is out of).

Runs go to a process pool in batches (a task costs about a millisecond; a run seconds), with a progress
callback for the bar.
"""

from __future__ import annotations

import copy
import math
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from loadarm.errors import ConfigError
from loadarm.figures import subplots
from loadarm.guidance.monitor import stage_leads
from loadarm.params.compiler import compile_model
from loadarm.params.config import paper_installation, parse_config, read_toml
from loadarm.params.scenario import Scenario, check_scenario, parse_scenario, parse_scenario_file, resolve_berth
from loadarm.results import Metric, Result
from loadarm.ship.model import moored_ship
from loadarm.sim.loop import run_scenario
from loadarm.studies.cluster import connect_scheduler, plan_workers
from loadarm.studies.runs_file import RUNS_FILE_BATCH, RunsFile, Tally
from loadarm.vocab import ALARM_RULES, SHARED_ALARM_RULES, Severity

__all__ = [
    "CAMPAIGN_METRICS",
    "capped_alarm1",
    "merged_calls",
    "run_batch",
    "with_bounds",
    "MAX_SEEDS",
    "CampaignResult",
    "CampaignRun",
    "ScenarioDraws",
    "Vary",
    "check_campaign",
    "parse_vary",
    "run_campaign",
]


@dataclass(frozen=True, slots=True)
class Vary:
    """One parameter drawn uniformly in ``[lo, hi]`` for every run.

    Attributes
    ----------
    key : str
        Dotted key: a scenario key (``drift.speed``) or ``installation.<section>.<key>``.
    lo, hi : float
        The range.
    """

    key: str
    lo: float
    hi: float


def parse_vary(text: str) -> Vary:
    """Parse ``key=lo:hi``.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    Vary

    Raises
    ------
    ConfigError
        Malformed text, non-finite bounds or ``lo > hi``.
    """
    key, eq, rng = text.partition("=")
    lo_s, colon, hi_s = rng.partition(":")
    try:
        if not (eq and colon and key.strip()):
            raise ValueError
        lo, hi = float(lo_s), float(hi_s)
    except ValueError:
        raise ConfigError(f"--vary must be key=lo:hi (e.g. drift.speed=0.1:0.3), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ConfigError(f"--vary {key.strip()}: the range must be finite with lo <= hi, got {lo_s}:{hi_s}")
    return Vary(key.strip(), lo, hi)


def _set(data: dict, dotted: str, value: float, source: str) -> None:
    parts = dotted.split(".")
    node = data
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f"{source}: --vary {dotted}: {part} is not a section")
    node[parts[-1]] = value


@dataclass(frozen=True, slots=True)
class CampaignRun:
    """The verdict on one run.

    Attributes
    ----------
    seed : int
        The run's seed.
    draws : dict of str to float
        The varied parameters' values.
    overstretched : bool
    overstretched_before_isolation : bool
        Overstretched before the ERS valves were confirmed closed (or with none).
    opened_on_live_product : bool
    false_alarm : bool
    missed_alarm : bool
    alarm1_s, release_complete_s, limit_s : float or None
        First alarm, release complete and the flange's first crossing of a face, s.
    release_margin_s : float or None
        ``limit_s - release_complete_s``.
    limit_face : str
        The face crossed.
    connected_s : float
        Time the coupler was on the flange, s (the exposure a false-alarm count is out of).
    alarm1_measured_s : float or None
        When the rule without the prediction (the measured drift and the floor) first called for ESD-1, s: the
        same as ``alarm1_s`` unless the prediction held it back or raised it sooner.
    alarm1_rule : str
        The rule that raised ESD-1 (:data:`loadarm.vocab.ALARM_RULES`; ``""``: none).
    alarm1_measured_first_s : float or None
        The first time that rule called for ESD-1 at all (a false alarm of that rule, in a run without a face).
    end_s : float or None
        The run's end, s (the scenario's duration; None: not known).
    esd1_lead_s : float or None
        The time ESD-1 needs before a face, s (the installation's whole sequence and margin, the ERS valves at
        their timeout: :func:`loadarm.guidance.monitor.stage_leads`), which no rule may call later than.
    held_calls : list of [float, float] or None
        The rule without the prediction's calls for ESD-1 that the prediction held, ``[onset, end]`` each, s
        (:meth:`loadarm.sim.result.RunResult.held_calls`); None: stored before they were kept.
    departed_s : float or None
        When the prediction's departure test found the track outside its intervals and the prediction stood down
        (``info.prediction_departed``), s; None: it did not (or, ``departure_kept`` false, not recorded).
    departure_kept : bool
        The run recorded its departure (false for runs stored before departures were kept).
    """

    seed: int
    draws: dict
    overstretched: bool
    overstretched_before_isolation: bool
    opened_on_live_product: bool
    false_alarm: bool
    missed_alarm: bool
    alarm1_s: float | None
    release_complete_s: float | None
    limit_s: float | None
    release_margin_s: float | None
    limit_face: str
    connected_s: float = 0.0
    alarm1_measured_s: float | None = None
    alarm1_rule: str = ""
    alarm1_measured_first_s: float | None = None
    end_s: float | None = None
    esd1_lead_s: float | None = None
    held_calls: list | None = None
    departed_s: float | None = None
    departure_kept: bool = False

    @property
    def false_alarm_measured(self) -> bool:
        """The rule without the prediction would have raised a false alarm (ESD-1 without a face reached)."""
        return self.alarm1_measured_first_s is not None and self.limit_s is None

    def short_of_lead(self, at: float | None) -> bool | None:
        """Whether an ESD-1 at ``at`` (None: none in the run) came less than :attr:`esd1_lead_s` before the face:
        None where there is no face, the bounds are not known, or there is no ESD-1 in the run and none was due
        by its end (the face more than the lead past it: the run cannot say, right-censored)."""
        if self.limit_s is None or self.esd1_lead_s is None:
            return None
        due = self.limit_s - self.esd1_lead_s
        if at is not None:
            return at > due
        if self.end_s is None or due > self.end_s:
            return None
        return True

    @property
    def alarm1_undecided(self) -> bool:
        """Whether ESD-1 came in time the run cannot say: a face, no ESD-1 in the run, and the face more than
        ESD-1's lead past the run's end, so that none was due before the end (right-censored). Such a run is still
        counted later than the rule without the prediction when that rule called within the run (it certainly
        is: by at least the end less that call). Found (issue 30): Hs 2.0-2.5 m seed 533, its face 120 s past the
        end (``tests/test_predictive_alarms.py`` carries it on).

        Returns
        -------
        bool
        """
        return self.limit_s is not None and self.alarm1_s is None and self.short_of_lead(None) is None \
            and self.esd1_lead_s is not None and self.end_s is not None

    @property
    def lead_gained_s(self) -> float | None:
        """How much sooner ESD-1 came than the rule without the prediction would have raised it, s (negative:
        later; with no ESD-1 at all, as if it came when the face was reached), for a run whose flange reaches a
        face; None otherwise."""
        if self.limit_s is None or self.alarm1_measured_s is None:
            return None
        return self.alarm1_measured_s - (self.alarm1_s if self.alarm1_s is not None else self.limit_s)

    @property
    def alarm1_today_s(self) -> float | None:
        """ESD-1 by today's rule, the rule without the prediction, which latches: its first call
        (:attr:`alarm1_measured_first_s`), or the ESD-1 of a rule both share (the position alarms, the floor, the
        operator, a fault: :data:`loadarm.vocab.SHARED_ALARM_RULES`) when that came first. None: neither came in the run (or only the
        prediction raised ESD-1 and that rule never called: when it would have, the run cannot say)."""
        shared = self.alarm1_s if self.alarm1_rule in SHARED_ALARM_RULES else None
        times = [a for a in (self.alarm1_measured_first_s, shared) if a is not None]
        return min(times) if times else None

    @property
    def lead_gained_first_s(self) -> float | None:
        """As :attr:`lead_gained_s`, against today's rule (:attr:`alarm1_today_s`). :attr:`lead_gained_s`
        compares with the rule's call in progress at ESD-1, which a held wave's call before a failure makes look
        nearer than it is (found by review, 2026-12-07: in the squall's partial break-outs the prediction's ESD-1
        came minutes after a wave's call that today's rule would have latched on)."""
        today = self.alarm1_today_s
        if self.limit_s is None or today is None:
            return None
        return today - (self.alarm1_s if self.alarm1_s is not None else self.limit_s)


def _judge(seed: int, draws: dict, v: dict, bounds: tuple[float, float] | None = None) -> CampaignRun:
    """The verdict from a run's summary values (its failures are the run's own, :meth:`RunResult.failures`) and
    its ``bounds``, ``(end_s, esd1_lead_s)`` (:func:`_bounds`)."""
    fails = set(v["failures"])
    limit, done, alarm1 = v["limit_s"], v["release_complete_s"], v["alarm1_s"]
    return CampaignRun(
        seed=seed, draws=draws,
        overstretched=bool(fails & {"overstretch", "overstretch_before_isolation"}),
        overstretched_before_isolation="overstretch_before_isolation" in fails,
        opened_on_live_product="opened_on_live_product" in fails,
        false_alarm=bool(alarm1 is not None and limit is None),
        missed_alarm="missed_alarm" in fails,
        alarm1_s=alarm1, release_complete_s=done, limit_s=limit, release_margin_s=v["release_margin_s"],
        limit_face=v["limit_face"], connected_s=v["connected_s"], alarm1_measured_s=v.get("alarm1_measured_s"),
        alarm1_rule=v.get("alarm1_rule", ""), alarm1_measured_first_s=v.get("alarm1_measured_first_s"),
        end_s=None if bounds is None else bounds[0], esd1_lead_s=None if bounds is None else bounds[1],
        held_calls=v.get("held_calls"), departed_s=v.get("departed_s"), departure_kept="departed_s" in v)


def merged_calls(calls, off_delay: float) -> list[list[float]]:
    """Held calls with every gap shorter than ``off_delay`` closed: a call that drops out for less than that and
    comes back counted as one (what a hold limit with an off-delay on the call's end would see).

    Parameters
    ----------
    calls : list of [float, float]
        ``[onset, end]`` in time order, s.
    off_delay : float
        s (0: as the controller counts today, every return a new call).

    Returns
    -------
    list of [float, float]
    """
    out: list[list[float]] = []
    for onset, end in calls:
        if out and onset - out[-1][1] < off_delay - 1e-9:     # the controller's test, its tolerance too
            out[-1][1] = max(out[-1][1], end)
        else:
            out.append([onset, end])
    return out


def capped_alarm1(run: CampaignRun, limit: float, off_delay: float = 0.0) -> float | None:
    """The run's ESD-1 had the prediction held no call for ESD-1 longer than ``limit`` (the hold limit,
    :func:`loadarm.arm.sequence.hold_limit`): the earlier of its ESD-1 and the first held call's onset plus
    the limit, where that call still stood then (within a guidance cycle of the controller's own: it checks the
    limit once a cycle). Everything before that instant is the run as stored, so this is exact for a run stored
    without a limit, or with a longer one.

    Parameters
    ----------
    run : CampaignRun
        With :attr:`CampaignRun.held_calls`.
    limit : float
        The hold limit, s (``inf``: none).
    off_delay : float
        Calls apart by less than this counted as one (:func:`merged_calls`), s; the controller's is
        :data:`loadarm.guidance.modes.ALARM_OFF_DELAY` (from 2026-12-07; 0: its count before). Where the limit
        passes in a gap of a joined call, ESD-1 comes when the call returns, as in the controller (it cannot know
        the call will).

    Returns
    -------
    float or None
        ESD-1, s (None: none in the run).

    Raises
    ------
    ValueError
        A run stored before the held calls were kept (it cannot say).
    """
    if run.held_calls is None:
        raise ValueError(f"seed {run.seed}: stored before the held calls were kept; run it again")
    fired = []
    for onset, end in merged_calls(run.held_calls, off_delay):
        due = onset + limit
        # the joined call outlasts the limit (by more than the controller's 1e-9 s tolerance: found by the
        # thorough profile, a call of exactly the limit's length, 11.4-26.4 s, that the controller never raised on)
        if due < end - 1e-9:
            fired.append(next(max(due, a) for a, b in run.held_calls if onset <= a and due < b - 1e-9))
    times = [t for t in (run.alarm1_s, *fired) if t is not None]
    return min(times) if times else None


def _bounds(sc, model) -> tuple[float, float]:
    """A run's end and the time its ESD-1 needs before a face, s (no valve commanded yet: the whole sequence)."""
    return float(sc.scenario.duration), float(stage_leads(model.sequence)[Severity.ESD1])


class ScenarioDraws:
    """The scenario file and its installation, read once; :meth:`build` applies one run's seed and draws (the
    campaign's route, also :mod:`loadarm.studies.watch_basis`'s).

    Parameters
    ----------
    scenario : str
        The scenario file.
    """

    def __init__(self, scenario: str):

        self.scenario = scenario
        path = Path(scenario)
        self.raw = read_toml(path, "scenario")

        # validated first, so that a malformed file is refused in one line before any key is looked up (found by
        # the fuzz suite: `scenario = 0.0` raised AttributeError)
        inst_file = parse_scenario_file(path).scenario.installation
        self.inst_source = "installation" if inst_file is None else str(path.parent / inst_file)
        self.inst_raw = paper_installation().model_dump() if inst_file is None else read_toml(path.parent / inst_file)

    def check_keys(self, draws: dict) -> None:
        """Every varied key names an existing numeric parameter.

        Parameters
        ----------
        draws : dict
            Dotted key to value.

        Raises
        ------
        ConfigError
            A key that names no numeric parameter.
        """

        inst_full = parse_config(self.inst_raw, source=self.inst_source).model_dump()
        for key in draws:
            if key.startswith("installation."):
                _check_key(key.removeprefix("installation."), inst_full, self.inst_source)
            else:
                _check_key(key, Scenario().model_dump(), self.scenario)

    def scenario_of(self, seed: int | None, draws: dict):
        """The scenario of one run (its seed and the draws of scenario keys; its berth resolved), not checked
        against the installation: what the ship's records depend on.

        Parameters
        ----------
        seed : int or None
            The run's seed (None: the file's).
        draws : dict
            Dotted key to value (``installation.`` keys are not the scenario's: skipped).

        Returns
        -------
        loadarm.params.scenario.Scenario
        """

        sc_data = copy.deepcopy(self.raw)
        for key, value in draws.items():
            if not key.startswith("installation."):
                _set(sc_data, key, value, self.scenario)
        if seed is not None:
            _set(sc_data, "scenario.seed", seed, self.scenario)
        return resolve_berth(parse_scenario(sc_data, source=self.scenario), self.scenario)

    def build(self, seed: int | None, draws: dict):
        """The scenario and the compiled installation of one run (validated and cross-checked).

        Parameters
        ----------
        seed : int or None
            The run's seed (None: the file's).
        draws : dict
            Dotted key to value.

        Returns
        -------
        (loadarm.params.scenario.Scenario, loadarm.arm.model.ArmModel)
        """

        inst_data = copy.deepcopy(self.inst_raw)
        for key, value in draws.items():
            if key.startswith("installation."):
                _set(inst_data, key.removeprefix("installation."), value, self.inst_source)
        sc = self.scenario_of(seed, draws)
        model = compile_model(parse_config(inst_data, source=self.inst_source), source=self.inst_source)
        check_scenario(sc, model, source=self.scenario)
        return sc, model


def run_batch(scenario: str, plant: str | None, jobs: list[tuple[int, dict]]) -> list[CampaignRun]:
    """Worker: run a batch of (seed, draws) of one scenario file (also :mod:`loadarm.studies.hold_limit`'s).

    Parameters
    ----------
    scenario : str
        The scenario file.
    plant : str or None
        The arm plant (None: the scenario's).
    jobs : list of (int, dict)
        Seed and draws of each run.

    Returns
    -------
    list of CampaignRun
    """

    draw = ScenarioDraws(scenario)
    results = []
    ships: dict = {}                      # the moored ship compiled once per berth file in a batch
    for seed, draws in jobs:
        sc, model = draw.build(seed, draws)
        ship = None
        if sc.ship.model == "moored":
            ship = ships.get(sc.ship.berth) or ships.setdefault(sc.ship.berth, moored_ship(sc))
        res = run_scenario(sc, model, plant=plant, ship=ship)
        results.append(_judge(seed, draws, res._values(), _bounds(sc, model)))
    return results


#: The headline numbers of a campaign, declared once.
CAMPAIGN_METRICS = (
    Metric("scenario", "scenario"),
    Metric("runs", "runs", "", "d"),
    Metric("connected_runs", "runs that connected", "", "d"),
    Metric("connected_h", "time connected, all runs", "h", ".1f"),
    Metric("overstretches", "overstretches", "", "d"),
    Metric("overstretches_before_isolation", "overstretch before isolation (product live)", "", "d"),
    Metric("opened_on_live_product", "coupler opened before the ERS valves closed", "", "d"),
    Metric("false_alarms", "false alarms (ESD-1 without reaching a face)", "", "d"),
    Metric("false_alarms_measured", "false alarms by the rule without the prediction", "", "d"),
    Metric("alarm1_later", "ESD-1 later than the rule without the prediction's call in progress", "", "d"),
    Metric("alarm1_short_measured", "ESD-1 short of its lead before the face, that call in progress", "", "d"),
    Metric("alarm1_short", "ESD-1 short of its lead before the face", "", "d"),
    Metric("alarm1_undecided", "ESD-1 in time undecided (no ESD-1, the face past the end by more than its lead)",
           "", "d"),
    Metric("lead_gained_min_s", "ESD-1 lead gained on that call in progress, min", "s", ".1f", none="-"),
    Metric("lead_gained_median_s", "ESD-1 lead gained on that call in progress, median", "s", ".1f", none="-"),
    Metric("alarm1_later_first", "ESD-1 later than today's rule (the rule without the prediction, latching)", "",
           "d"),
    Metric("lead_gained_first_min_s", "ESD-1 lead gained on today's rule, min", "s", ".1f", none="-"),
    Metric("lead_gained_first_median_s", "ESD-1 lead gained on today's rule, median", "s", ".1f", none="-"),
    Metric("alarm1_short_first", "ESD-1 short of its lead before the face, today's rule", "", "d"),
    Metric("departures", "the prediction stood down: the track left its intervals (runs that kept it)", "", "d"),
    Metric("missed_alarms", "missed alarms (face reached before the release completed)", "", "d"),
    Metric("releases", "releases", "", "d"),
    Metric("false_releases", "releases without reaching a face (false: the coupler opened for nothing)", "", "d"),
    Metric("margin_min_s", "release margin, min", "s", ".2f", none="-"),
    Metric("margin_p5_s", "release margin, 5th percentile", "s", ".2f", none="-"),
    Metric("margin_median_s", "release margin, median", "s", ".2f", none="-"),
    Metric("margin_max_s", "release margin, max", "s", ".2f", none="-"),
    Metric("lead_median_s", "first alarm to the face, median", "s", ".1f", none="-"),
)


@dataclass(frozen=True)
class CampaignResult(Result):
    """All runs of a campaign and their statistics.

    Attributes
    ----------
    scenario : str
        Scenario file.
    varied : tuple of Vary
        The varied parameters.
    runs : tuple of CampaignRun
        In seed order.
    codes : dict
        With a runs file: how many runs each version of loadarm's code ran (its digest's first 16 hex digits:
        :func:`loadarm.studies.runs_file.code_digest`); empty otherwise.
    """

    scenario: str
    varied: tuple
    runs: tuple = field(repr=False)
    codes: dict = field(default_factory=dict)

    METRICS = CAMPAIGN_METRICS

    def _values(self) -> dict:
        runs = self.runs
        margins = np.array([r.release_margin_s for r in runs if r.release_margin_s is not None])
        leads = np.array([r.limit_s - r.alarm1_s for r in runs if r.limit_s is not None and r.alarm1_s is not None])
        gained = np.array([r.lead_gained_s for r in runs if r.lead_gained_s is not None])
        first = np.array([r.lead_gained_first_s for r in runs if r.lead_gained_first_s is not None])

        def q(a, p):
            return float(np.percentile(a, p)) if a.size else None

        worst = sorted((r for r in runs if r.release_margin_s is not None), key=lambda r: r.release_margin_s)[:5]
        return {
            "scenario": self.scenario,
            "runs": len(runs),
            "connected_runs": sum(r.connected_s > 0 for r in runs),
            "connected_h": sum(r.connected_s for r in runs) / 3600.0,
            "varied": [f"{v.key}={v.lo:g}:{v.hi:g}" for v in self.varied],
            "overstretches": sum(r.overstretched for r in runs),
            "overstretches_before_isolation": sum(r.overstretched_before_isolation for r in runs),
            "opened_on_live_product": sum(r.opened_on_live_product for r in runs),
            "false_alarms": sum(r.false_alarm for r in runs),
            "false_alarms_measured": sum(r.false_alarm_measured for r in runs),
            "alarm1_later": int(np.sum(gained < 0)),
            "alarm1_short_measured": sum(r.short_of_lead(r.alarm1_measured_s) is True for r in runs),
            "alarm1_short": sum(r.short_of_lead(r.alarm1_s) is True for r in runs),
            "alarm1_undecided": sum(r.alarm1_undecided for r in runs),
            "lead_gained_min_s": q(gained, 0), "lead_gained_median_s": q(gained, 50),
            "alarm1_later_first": int(np.sum(first < 0)), "lead_gained_first_min_s": q(first, 0),
            "lead_gained_first_median_s": q(first, 50),
            "alarm1_short_first": sum(r.short_of_lead(r.alarm1_today_s) is True for r in runs),
            "departures": sum(r.departed_s is not None for r in runs),
            "departures_kept": sum(r.departure_kept for r in runs),
            "departed_seeds": [r.seed for r in runs if r.departed_s is not None],
            "missed_alarms": sum(r.missed_alarm for r in runs),
            "releases": sum(r.release_complete_s is not None for r in runs),
            "false_releases": sum(r.release_complete_s is not None and r.limit_s is None for r in runs),
            "margin_min_s": q(margins, 0), "margin_p5_s": q(margins, 5), "margin_median_s": q(margins, 50),
            "margin_max_s": q(margins, 100),
            "lead_median_s": q(leads, 50),
            "failed_seeds": [r.seed for r in runs if r.overstretched or r.opened_on_live_product or r.missed_alarm],
            "false_alarm_seeds": [r.seed for r in runs if r.false_alarm],
            "later_seeds": [r.seed for r in runs if r.lead_gained_s is not None and r.lead_gained_s < 0],
            "later_first_seeds": [r.seed for r in runs
                                  if r.lead_gained_first_s is not None and r.lead_gained_first_s < 0],
            "short_seeds": [r.seed for r in runs if r.short_of_lead(r.alarm1_s) is True],
            "undecided_seeds": [r.seed for r in runs if r.alarm1_undecided],
            "false_alarms_by_rule": {rule: n for rule in ALARM_RULES
                                     if (n := sum(r.false_alarm and r.alarm1_rule == rule for r in runs))},
            "worst": [{"seed": r.seed, "release_margin_s": r.release_margin_s, "face": r.limit_face, **r.draws}
                      for r in worst],
            "seeds": [runs[0].seed, runs[-1].seed] if runs else [],
            "codes": dict(self.codes),
        }

    def _figure(self):

        fig, ax = subplots(figsize=(7, 3.5))
        m = [r.release_margin_s for r in self.runs if r.release_margin_s is not None]
        if m:
            ax.hist(m, bins=min(40, max(5, len(m) // 5)), color="0.5", edgecolor="0.2")
        ax.axvline(0.0, color="tab:red", lw=1.5, label="face reached at release complete")
        ax.set_xlabel("release margin: release complete to the flange's crossing of a face, s")
        ax.set_ylabel("runs")
        ax.set_title(f"{Path(self.scenario).name}: {len(self.runs)} runs, {len(m)} releases")
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        return fig


def run_campaign(scenario: str | Path, seeds: int, *, vary: Sequence[Vary] = (), first_seed: int = 0,
                 plant: str | None = None, workers: int | None = None, batch: int | None = None,
                 progress: Callable[[int, int], None] | None = None, scheduler: str | None = None,
                 runs_file: str | Path | None = None) -> CampaignResult:
    """Run a scenario over ``seeds`` seeds and parameter draws.

    Parameters
    ----------
    scenario : str or Path
        Scenario TOML.
    seeds : int
        Number of runs (seeds ``first_seed .. first_seed + seeds - 1``).
    vary : sequence of Vary
        Parameters drawn uniformly per run (seeded with the run's seed).
    first_seed : int
        First seed.
    plant : {'hydraulic', 'kinematic'}, optional
        Arm plant (default: the scenario's).
    workers : int, optional
        Processes (default: every core; 1 runs in this process).
    batch : int, optional
        Runs per task (default: enough for about four tasks per worker).
    progress : callable, optional
        ``progress(done, total)`` after each batch.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``): the batches run on its workers (which need
        loadarm and see the same files) instead of a local process pool; a batch whose worker dies is run again.
    runs_file : str or Path, optional
        A JSON-lines file of the campaign's runs (:mod:`loadarm.studies.runs_file`): each batch's runs are
        appended as it ends; the seeds it already holds are not run again, and the result covers every seed of
        the range, stored or new (a campaign run in parts, merged exactly).

    Returns
    -------
    CampaignResult

    Raises
    ------
    ConfigError
        A bad scenario, installation or varied key (checked on the first draw before anything is spread out), or
        a runs file of another campaign.
    """
    _check_seeds(seeds, first_seed)
    scenario = str(scenario)
    _validate(scenario, _job(first_seed, vary), plant)
    store = None if runs_file is None else RunsFile(runs_file, scenario, plant, [(v.key, v.lo, v.hi) for v in vary])
    wanted = range(first_seed, first_seed + seeds)
    stored = [] if store is None else store.runs(wanted)
    done: list[CampaignRun] = with_bounds(scenario, [CampaignRun(**fields) for fields, _ in stored])
    codes = Counter(code for _, code in stored)
    held = {r.seed for r in done}
    pending = seeds - len(held)
    workers = plan_workers(workers, max(1, pending))
    if batch is None:                    # about four batches a worker; with a runs file, runs are kept as they end:
        batch = math.ceil(pending / (4 * workers))       # at most RUNS_FILE_BATCH a batch (found: 250 runs of a
        if store is not None:                            # worker, an hour, would be lost to a kill)
            batch = min(batch, RUNS_FILE_BATCH)
    batch = max(1, batch)
    chunks = _chunks((s for s in wanted if s not in held), vary, batch)   # built as they are submitted
    report = Tally(done, store, codes, seeds, progress)

    if scheduler is not None:
        from distributed import as_completed as dask_completed

        path = str(Path(scenario).resolve())
        with connect_scheduler(scheduler) as client:
            futures = [client.submit(run_batch, path, plant, chunk, retries=2, pure=False) for chunk in chunks]
            for fut in dask_completed(futures):
                report(fut.result())
    elif workers == 1:
        for chunk in chunks:
            report(run_batch(scenario, plant, chunk))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            _bounded_map(pool, lambda chunk: pool.submit(run_batch, scenario, plant, chunk), chunks, 2 * workers,
                         report)
    return CampaignResult(scenario, tuple(vary), tuple(sorted(done, key=lambda r: r.seed)), codes=dict(codes))


def with_bounds(scenario: str, runs: list[CampaignRun]) -> list[CampaignRun]:
    """Runs stored before the runs kept their end and ESD-1's lead, given them from their scenario and draws
    (built once per distinct draw of the keys that change them: the duration and the installation).

    Parameters
    ----------
    scenario : str
        The scenario file the runs were run from.
    runs : list of CampaignRun

    Returns
    -------
    list of CampaignRun
        The same runs, each with ``end_s`` and ``esd1_lead_s``.
    """
    if all(r.end_s is not None for r in runs):
        return runs
    draw, memo, out = ScenarioDraws(scenario), {}, []
    for r in runs:
        if r.end_s is None:
            key = tuple(sorted((k, v) for k, v in r.draws.items()
                               if k == "scenario.duration" or k.startswith("installation.")))
            if key not in memo:
                memo[key] = _bounds(*draw.build(r.seed, r.draws))
            r = replace(r, end_s=memo[key][0], esd1_lead_s=memo[key][1])
        out.append(r)
    return out


#: The most runs one campaign takes (a campaign of a hundred thousand kinematic runs takes a day on 8 cores).
MAX_SEEDS = 100_000
def _bounded_map(pool, submit, items, in_flight: int, report) -> None:
    """Submit ``items`` to a process pool with at most ``in_flight`` pending, reporting each result as it comes."""
    from concurrent.futures import FIRST_COMPLETED, wait

    items = iter(items)
    pending = set()
    while True:
        for item in items:
            pending.add(submit(item))
            if len(pending) >= in_flight:
                break
        if not pending:
            return
        finished, pending = wait(pending, return_when=FIRST_COMPLETED)
        for fut in finished:
            report(fut.result())


def _check_seeds(seeds: int, first_seed: int) -> None:
    if not 1 <= seeds <= MAX_SEEDS:
        raise ConfigError(f"--seeds must be in [1, {MAX_SEEDS}], got {seeds}")
    if not 0 <= first_seed <= 2 ** 32 - 1:
        raise ConfigError(f"--first-seed must be in [0, 4294967295], got {first_seed}")


def _job(seed: int, vary: Sequence[Vary]) -> tuple[int, dict]:
    """One run's seed and draws (seeded by the run's seed, so the same on any pool)."""
    rng = np.random.default_rng([seed, 0x5EED])
    return seed, {v.key: float(rng.uniform(v.lo, v.hi)) for v in vary}


def _chunks(seeds: Iterable[int], vary: Sequence[Vary], batch: int):
    """The campaign's batches of jobs, made as they are asked for (found: ``--seeds 1e13`` built its whole list
    in memory first and gave no answer in a minute)."""
    part: list = []
    for seed in seeds:
        part.append(_job(seed, vary))
        if len(part) == batch:
            yield part
            part = []
    if part:
        yield part


def check_campaign(scenario: str | Path, seeds: int, *, vary: Sequence[Vary] = (), first_seed: int = 0,
                   plant: str | None = None, runs_file: str | Path | None = None) -> None:
    """Refuse a campaign's bad input without running it (what :func:`run_campaign` checks first).

    Parameters
    ----------
    scenario, seeds, vary, first_seed, plant, runs_file
        As for :func:`run_campaign`.

    Raises
    ------
    ConfigError
    """
    _check_seeds(seeds, first_seed)
    _validate(str(scenario), _job(first_seed, vary), plant)
    if runs_file is not None:
        RunsFile(runs_file, str(scenario), plant, [(v.key, v.lo, v.hi) for v in vary])


def _validate(scenario: str, job: tuple[int, dict], plant: str | None) -> None:
    """Refuse bad input before forking: the keys, then the scenario with the first draw (no run)."""
    if plant not in (None, "hydraulic", "kinematic"):
        raise ConfigError(f"plant must be 'hydraulic' or 'kinematic', got {plant!r}")
    draw = ScenarioDraws(scenario)
    draw.check_keys(job[1])
    draw.build(job[0], job[1])


def _check_key(dotted: str, reference: dict, source: str) -> None:
    """A varied key must name an existing numeric parameter (a typo is not silently a new key)."""
    import difflib

    node = reference
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if not isinstance(node, dict) or part not in node:
            options = list(node) if isinstance(node, dict) else []
            hint = difflib.get_close_matches(part, options, n=1)
            where = ".".join(parts[:i]) or "the top level"
            raise ConfigError(f"{source}: --vary {dotted}: no key {part!r} in {where}"
                              + (f" (did you mean {hint[0]!r}?)" if hint else f"; keys: {', '.join(options)}"))
        node = node[part]
    if isinstance(node, bool) or not (isinstance(node, (int, float)) or node is None):
        raise ConfigError(f"{source}: --vary {dotted}: not a numeric parameter (value {node!r})")
