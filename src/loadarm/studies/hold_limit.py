"""The hold limit's basis: how long the prediction held the rule without the prediction's calls for ESD-1, over stored runs.

A trusted prediction holds the rule without the prediction's call for ESD-1 (the measured drift, its change detectors and the
floor) unless a witness says the ship changed (:meth:`loadarm.guidance.rules.SafetyRules._forecast_stage`). That
is how the waves' false calls are held, and also how ESD-1 came later than that rule in the cases the witnesses
cannot see (a wave's call just before a failure; a third of the lines or fewer parting). A hold limit ``H`` bounds
it: a call standing ``H`` seconds raises ESD-1 (:func:`loadarm.arm.sequence.hold_limit`: ESD-1's lead less the
release's, 15 s for the paper's sequence).

What a limit changes in a run follows from the run as stored without one, given its held calls
(:meth:`loadarm.sim.result.RunResult.held_calls`): ESD-1 at the first onset plus ``H`` of a call still standing
then, nothing before that instant changed (:func:`loadarm.studies.campaign.capped_alarm1`). A run with no call
before its ESD-1 cannot change at all; so only the runs of a stored campaign with such a call (the *candidates*)
are run again, with the code that records the calls, into a runs file of their own (:func:`rerun_candidates`,
the same header as the stored file's). :func:`limit_effect` then counts, for each limit, the runs whose ESD-1 it
makes earlier, the false ESD-1 it adds, and how much later than the rule without the prediction ESD-1 can still
come.

Run as ``python -m loadarm.studies.hold_limit STORED_runs.jsonl --out RERUN_runs.jsonl [--scenarios DIR] [--seeds N]
[--workers W] [--keep-others]``, ``python -m loadarm.studies.hold_limit STORED HELD [STORED HELD ...] --basis
FILE.json``, and ``python -m loadarm.studies.hold_limit BEFORE AFTER --compare FILE.json`` (:func:`rule_change`: a
campaign and the same campaign under a changed rule, run by run). The basis needs its reruns made with the limit off (the stored ``*_held_runs.jsonl`` were, at
``ef67a00``): run with the limit on, a rerun the limit changed disagrees with its stored run and the basis refuses
it. With the limit on, ``--keep-others`` gives the campaign under the limit instead (only its candidates change).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from loadarm import __version__
from loadarm.arm.sequence import hold_limit
from loadarm.errors import ConfigError, OutputError
from loadarm.files import SIGNATURE, atomic_write, compact_json, guard_outputs
from loadarm.guidance.modes import ALARM_OFF_DELAY
from loadarm.results import Metric, Result, round_floats
from loadarm.studies.campaign import (CampaignResult, CampaignRun, ScenarioDraws, capped_alarm1, merged_calls,
                                     run_batch, with_bounds)
from loadarm.studies.plots import hold_limit_figure, rule_change_figure
from loadarm.studies.runs_file import RUNS_FILE_BATCH, RunsFile, read_stored

__all__ = ["candidates", "rerun_candidates", "limit_effect", "HoldLimitBasis", "hold_limit_basis", "LIMITS",
           "RuleChange", "rule_change"]

#: The limits the basis tabulates, s (the installation's own is added).
LIMITS = (5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 120.0)


def _scaled_share(k: int, n: int, total: int) -> tuple[float, float]:
    """``k`` of a sample of ``n`` scaled to ``total``: exact when the sample is all of them, else its 95 % Wilson
    interval scaled (the samples here are the first candidates in seed order, and seeds draw the sea
    independently)."""
    if n == total:
        return float(k), float(k)
    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    return ci.low * total, ci.high * total


def candidates(runs: dict[int, dict]) -> list[int]:
    """The seeds whose rule without the prediction called for ESD-1 before the run's ESD-1 (or in a run without
    one): only these can a hold limit change.

    Parameters
    ----------
    runs : dict of int to dict
        Stored runs by seed (a runs file's ``run`` objects).

    Returns
    -------
    list of int
    """
    out = []
    for seed, r in sorted(runs.items()):
        first, esd1 = r.get("alarm1_measured_first_s"), r.get("alarm1_s")
        if first is not None and (esd1 is None or first < esd1):
            out.append(seed)
    return out


def rerun_candidates(stored: str | Path, out: str | Path, *, scenarios: str | Path = "examples/scenarios",
                     limit: int | None = None, workers: int = 1, progress=None,
                     keep_others: bool = False) -> list[CampaignRun]:
    """Run the candidates of a stored campaign again (the code that keeps the held calls) into a runs file of
    their own, with the stored file's header; the seeds ``out`` already holds are not run again.

    Parameters
    ----------
    stored : str or Path
        The campaign's runs file (only read).
    out : str or Path
        The reruns' runs file (created or resumed).
    scenarios : str or Path
        The folder the stored header's scenario is in (its contents must digest as the header says).
    limit : int, optional
        Only the first ``limit`` candidates (a sample, in seed order).
    workers : int
        Processes.
    progress : callable, optional
        ``progress(done, total)`` after each batch.
    keep_others : bool
        Start a new ``out`` with the stored file's header and every run that is no candidate, line for line (a
        limit cannot change them): the reruns then complete it into the whole campaign under the code that runs
        them (``loadarm campaign --runs out`` gives its result, running nothing).

    Returns
    -------
    list of CampaignRun
        The reruns, stored and new.
    """
    header, scenario, lines = read_stored(stored, scenarios)
    runs = {seed: run for seed, (_, run) in lines.items()}
    seeds = candidates(runs)[:limit]
    if keep_others and not Path(out).exists():
        raw = Path(stored).read_text(encoding="utf-8").splitlines()
        cand = set(candidates(runs))
        kept = [raw[n - 1] for seed, (n, _) in sorted(lines.items()) if seed not in cand]
        atomic_write(Path(out), "\n".join([raw[0], *kept]) + "\n")
    store = RunsFile(out, str(scenario), header.get("plant"), [tuple(v) for v in header.get("vary", [])])
    have = store.seeds()
    jobs = [(s, runs[s]["draws"]) for s in seeds if s not in have]
    chunks = [jobs[k:k + RUNS_FILE_BATCH] for k in range(0, len(jobs), RUNS_FILE_BATCH)]
    done = len(seeds) - len(jobs)
    args = ([str(scenario)] * len(chunks), [header.get("plant")] * len(chunks), chunks)
    with ExitStack() as stack:
        pool = stack.enter_context(ProcessPoolExecutor(max_workers=workers)) if workers > 1 else None
        for part in (map if pool is None else pool.map)(run_batch, *args):
            store.append(part)
            done += len(part)
            if progress:
                progress(done, len(seeds))
    return [CampaignRun(**fields) for fields, _ in store.runs(seeds)]


def limit_effect(stored: dict[int, dict], reruns: Sequence[CampaignRun], limit: float,
                 off_delay: float = 0.0) -> dict:
    """What a hold limit changes in a campaign: the runs whose ESD-1 it makes earlier, the false ESD-1 it adds
    and how much later than the rule without the prediction ESD-1 still comes.

    Parameters
    ----------
    stored : dict of int to dict
        Every run of the campaign by seed.
    reruns : sequence of CampaignRun
        Its candidates run again (with their held calls).
    limit : float
        The hold limit, s.
    off_delay : float
        Calls apart by less than this counted as one, s (0: the controller's count).

    Returns
    -------
    dict
        ``earlier`` (seeds), ``added_false`` (seeds: ESD-1 now, none before, no face), ``later`` (seed to how much
        ESD-1 comes after the rule without the prediction's call in progress at it, as the campaign counts, s, in
        runs that reach a face: at most the limit), ``later_than_first`` (the same against that rule's first call,
        where it would have latched ESD-1: not bounded by the limit, since a call that drops out and comes back
        starts again), ``limit_s``, ``off_delay_s``, ``candidates``, ``rerun``.
    """
    earlier, added, later, later_first = [], [], {}, {}
    for r in reruns:
        at, m = capped_alarm1(r, limit, off_delay), r.alarm1_measured_s
        if at is not None and (r.alarm1_s is None or at < r.alarm1_s - 1e-9):
            earlier.append(r.seed)
            # the rule without the prediction's call in progress at that ESD-1 is the one held to the limit
            m = next(on for on, end in merged_calls(r.held_calls, off_delay) if on <= at < end)
            if r.alarm1_s is None and r.limit_s is None:
                added.append(r.seed)
        if r.limit_s is not None and m is not None:
            when = at if at is not None else r.limit_s
            if when > m + 1e-9:
                later[r.seed] = round(when - m, 2)
            first = r.alarm1_measured_first_s
            if first is not None and when > first + 1e-9:
                later_first[r.seed] = round(when - first, 2)
    return {"limit_s": limit, "off_delay_s": off_delay, "candidates": len(candidates(stored)), "rerun": len(reruns),
            "earlier": earlier, "added_false": added, "later": later, "later_than_first": later_first}


@dataclass(frozen=True)
class HoldLimitBasis(Result):
    """A stored campaign's held calls (its candidates run again) and what each hold limit changes in it."""

    stored_file: str
    rerun_file: str
    scenario: str
    runs: int
    limit_s: float
    reruns: tuple[CampaignRun, ...]
    effects: tuple[dict, ...]
    n_candidates: int
    debounced: dict

    METRICS = (
        Metric("scenario", "scenario"),
        Metric("runs", "runs stored", "", "d"),
        Metric("candidates", "runs with a call held before their ESD-1", "", "d"),
        Metric("rerun", "of them run again (their held calls kept)", "", "d"),
        Metric("calls", "held calls", "", "d"),
        Metric("call_median_s", "held call, median", "s", ".1f", none="-"),
        Metric("call_max_s", "held call, longest", "s", ".1f", none="-"),
        Metric("limit_s", "the installation's hold limit", "s", ".1f"),
        Metric("earlier", "ESD-1 earlier with it", "", "d"),
        Metric("added_false", "false ESD-1 it adds", "", "d"),
        Metric("added_false_all_lo", "over every candidate, 95 % interval from", "", ".0f"),
        Metric("added_false_all_hi", "to", "", ".0f"),
        Metric("later", "ESD-1 still later than the rule without the prediction", "", "d"),
        Metric("later_max_s", "by at most", "s", ".1f", none="-"),
        Metric("later_first_max_s", "later than that rule's first call, at most", "s", ".1f", none="-"),
        Metric("debounced_added_false", f"false ESD-1 added with calls apart by under {ALARM_OFF_DELAY:g} s counted as one",
               "", "d"),
        Metric("debounced_later_first_max_s", "then later than the first call, at most", "s", ".1f", none="-"),
    )

    def durations(self) -> np.ndarray:
        """Every held call's length, s."""
        return np.array([b - a for r in self.reruns for a, b in r.held_calls], dtype=float)

    def at(self, limit: float) -> dict:
        """The effect of one tabulated limit (:func:`limit_effect`)."""
        return next(e for e in self.effects if e["limit_s"] == limit)

    def added_false_all(self) -> tuple[float, float]:
        """The false ESD-1 the installation's limit adds over every candidate: exact when every candidate was run
        again, else the sample's share scaled to them, its 95 % Wilson interval (the reruns are the first
        candidates in seed order, and seeds draw the sea independently)."""
        return _scaled_share(len(self.at(self.limit_s)["added_false"]), len(self.reruns), self.n_candidates)

    def _values(self) -> dict:
        d, e = self.durations(), self.at(self.limit_s)
        lo, hi = self.added_false_all()
        return {"added_false_all_lo": lo, "added_false_all_hi": hi,"scenario": self.scenario, "runs": self.runs, "candidates": self.n_candidates,
                "rerun": len(self.reruns), "calls": int(d.size),
                "call_median_s": float(np.median(d)) if d.size else None,
                "call_max_s": float(d.max()) if d.size else None, "limit_s": self.limit_s,
                "earlier": len(e["earlier"]), "added_false": len(e["added_false"]), "later": len(e["later"]),
                "later_max_s": max(e["later"].values(), default=None),
                "later_first_max_s": max(e["later_than_first"].values(), default=None),
                "debounced_added_false": len(self.debounced["added_false"]),
                "debounced_later_first_max_s": max(self.debounced["later_than_first"].values(), default=None)}

    def to_dict(self) -> dict:
        d = dict(self._values())
        d.update(stored_file=self.stored_file, rerun_file=self.rerun_file,
                 effects=[_jsonable(e) for e in self.effects], debounced=_jsonable(self.debounced),
                 held_calls=[[r.seed, r.held_calls] for r in self.reruns])
        return d

    def _figure(self):
        return hold_limit_figure(self)


def _jsonable(effect: dict) -> dict:
    return {**effect, **{k: {str(s): v for s, v in effect[k].items()} for k in ("later", "later_than_first")}}


def hold_limit_basis(stored: str | Path, rerun: str | Path, *, scenarios: str | Path = "examples/scenarios",
                     limits: Sequence[float] = LIMITS) -> HoldLimitBasis:
    """A stored campaign and its candidates' reruns (:func:`rerun_candidates`): the held calls and each limit's
    effect, the installation's own limit among them. Both files are only read; the reruns must be the stored
    file's campaign (the same header) and agree with it on every run they hold (the same ESD-1, the same call of
    the rule without the prediction, the same face: the code that kept the held calls changed no decision).

    Parameters
    ----------
    stored, rerun : str or Path
        The campaign's runs file and its reruns' runs file.
    scenarios : str or Path
        The folder of their scenario.
    limits : sequence of float
        The limits to tabulate, s.

    Returns
    -------
    HoldLimitBasis

    Raises
    ------
    ConfigError
        Either file refused (:func:`loadarm.studies.runs_file.read_stored`), another campaign's reruns, or a rerun
        that disagrees with the stored run.
    """
    head, scenario, lines = read_stored(stored, scenarios)
    head_r, _, lines_r = read_stored(rerun, scenarios)
    if (head_r["scenario"], head_r.get("plant"), head_r.get("vary")) != (head["scenario"], head.get("plant"),
                                                                         head.get("vary")):
        raise ConfigError(f"{rerun}: line 1: not {stored}'s campaign (scenario, plant or draws differ)",
                          source=str(rerun))
    runs = {seed: run for seed, (_, run) in lines.items()}
    reruns = []
    for seed, (n, run) in sorted(lines_r.items()):
        old = runs.get(seed)
        keys = ("alarm1_s", "alarm1_measured_s", "alarm1_measured_first_s", "limit_s", "limit_face")
        if old is None or any(old.get(k) != run.get(k) for k in keys) or run.get("held_calls") is None:
            raise ConfigError(f"{rerun}: line {n}: seed {seed} is not the stored run again ({', '.join(keys)} and "
                              "held_calls expected as stored)", source=str(rerun))
        reruns.append(CampaignRun(**run))
    _, model = ScenarioDraws(str(scenario)).build(None, {})
    own = hold_limit(model.sequence)
    grid = sorted(set(float(x) for x in limits) | {own})
    return HoldLimitBasis(str(stored), str(rerun), head["scenario"], len(runs), own, tuple(reruns),
                          tuple(limit_effect(runs, reruns, h) for h in grid), len(candidates(runs)),
                          limit_effect(runs, reruns, own, ALARM_OFF_DELAY))


@dataclass(frozen=True)
class RuleChange(Result):
    """One campaign under two rules, run by run: a stored runs file and the same campaign under a changed rule (its
    candidates run again, the others kept: :func:`rerun_candidates` with ``keep_others``). What the campaign's own
    "later" cannot say: it compares ESD-1 with the rule without the prediction's call in progress, so an ESD-1 the
    new rule brings forward onto a wave's call long before a failure counts as "later" by the hold (found: the
    squall's partial break-outs, 3 "later" before the hold rule, 11 with it, every one of the 11 earlier than
    before, by 99-232 s).

    Attributes
    ----------
    before_file, after_file : str
    scenario : str
    shifts : tuple of (int, float or None, float or None, float or None)
        ``(seed, ESD-1 before, ESD-1 after, face)`` for each run whose ESD-1 changed, s (None: none).
    before, after : dict
        Each file's campaign statistics (:class:`loadarm.studies.campaign.CampaignResult`); the after file still
        being run, its missing candidates counted as before ("so far").
    candidates : int
        The before file's candidates (:func:`candidates`).
    rerun : int
        How many of them the after file holds (all when complete; a partial one holds the first in seed order).
    added_in_sample : int
        False ESD-1 added among those.
    """

    before_file: str
    after_file: str
    scenario: str
    shifts: tuple
    before: dict
    after: dict
    candidates: int = 0
    rerun: int = 0
    added_in_sample: int = 0

    METRICS = (
        Metric("scenario", "scenario"),
        Metric("runs", "runs", "", "d"),
        Metric("changed", "runs whose ESD-1 changed", "", "d"),
        Metric("earlier", "ESD-1 earlier than before", "", "d"),
        Metric("earlier_max_s", "by at most", "s", ".1f", none="-"),
        Metric("added", "ESD-1 where none came before", "", "d"),
        Metric("later", "ESD-1 later than before", "", "d"),
        Metric("later_max_s", "by at most", "s", ".1f", none="-"),
        Metric("removed", "no ESD-1 where one came before", "", "d"),
        Metric("false_before", "false ESD-1 before", "", "d"),
        Metric("false_after", "false ESD-1 after", "", "d"),
        Metric("releases_before", "releases before", "", "d"),
        Metric("releases_after", "releases after", "", "d"),
        Metric("false_releases_before", "false releases before", "", "d"),
        Metric("false_releases_after", "false releases after", "", "d"),
        Metric("failures_after", "overstretch, coupler opened on live product or missed alarm, after", "", "d"),
        Metric("short_before", "ESD-1 short of its lead before the face, before", "", "d"),
        Metric("short_after", "ESD-1 short of its lead before the face, after", "", "d"),
        Metric("candidates", "candidates (the runs the rule can change)", "", "d"),
        Metric("rerun", "of them in the after file", "", "d"),
        Metric("added_false_all_lo", "false ESD-1 added over every candidate, 95 % interval from", "", ".0f"),
        Metric("added_false_all_hi", "to", "", ".0f"),
    )

    def added_false_all(self) -> tuple[float, float]:
        """The false ESD-1 the rule adds over every candidate: exact when the after file is complete, else the
        sample's share scaled to them, its 95 % Wilson interval (the sample is the first candidates in seed
        order, and seeds draw the sea independently)."""
        return _scaled_share(self.added_in_sample, self.rerun, self.candidates)

    def _values(self) -> dict:
        both = [(s, a, b) for s, a, b, _ in self.shifts if a is not None and b is not None]
        early = [a - b for _, a, b in both if b < a]
        late = [b - a for _, a, b in both if b > a]
        b, a = self.before, self.after
        lo, hi = self.added_false_all() if self.rerun else (None, None)
        return {"scenario": self.scenario, "runs": a["runs"], "changed": len(self.shifts),
                "earlier": len(early), "earlier_max_s": max(early, default=None),
                "added": sum(x is None and y is not None for _, x, y, _ in self.shifts),
                "later": len(late), "later_max_s": max(late, default=None),
                "removed": sum(x is not None and y is None for _, x, y, _ in self.shifts),
                "false_before": b["false_alarms"], "false_after": a["false_alarms"],
                "releases_before": b["releases"], "releases_after": a["releases"],
                "false_releases_before": b["false_releases"], "false_releases_after": a["false_releases"],
                "failures_after": len(a["failed_seeds"]),
                "short_before": b["alarm1_short"], "short_after": a["alarm1_short"],
                "candidates": self.candidates, "rerun": self.rerun,
                "added_false_all_lo": lo, "added_false_all_hi": hi}

    def to_dict(self) -> dict:
        return {**self._values(), "before_file": self.before_file, "after_file": self.after_file,
                "shifts": [list(x) for x in self.shifts]}

    def _figure(self):
        return rule_change_figure(self)


def rule_change(before: str | Path, after: str | Path, *, scenarios: str | Path = "examples/scenarios") -> RuleChange:
    """Compare a stored campaign with the same campaign under a changed rule, run by run (both files only read); the
    after file may still be being run (:func:`rerun_candidates` with ``keep_others``): its missing seeds must be
    candidates, counted as before, and the false ESD-1 added is then estimated over every candidate.

    Parameters
    ----------
    before, after : str or Path
        The two runs files: the same campaign (scenario, plant, draws) and the same seeds.
    scenarios : str or Path
        The folder of their scenario.

    Returns
    -------
    RuleChange

    Raises
    ------
    ConfigError
        Either file refused (:func:`loadarm.studies.runs_file.read_stored`), or not the same campaign and seeds.
    """
    head, scenario, lines = read_stored(before, scenarios)
    head_a, _, lines_a = read_stored(after, scenarios)
    same = ("scenario", "plant", "vary")
    cand = candidates({seed: run for seed, (_, run) in lines.items()})
    missing = set(lines) - set(lines_a)
    if [head.get(k) for k in same] != [head_a.get(k) for k in same] or set(lines_a) - set(lines) \
            or not missing <= set(cand):
        raise ConfigError(f"{after}: not {before}'s campaign (scenario, plant, draws or seeds differ)",
                          source=str(after))
    both = {**lines, **lines_a}                              # the after file's runs, the missing ones as before
    runs = [with_bounds(str(scenario), [CampaignRun(**r) for _, (_, r) in sorted(x.items())]) for x in (lines, both)]
    stats = [CampaignResult(str(scenario), (), tuple(r))._values() for r in runs]
    shifts = tuple((x.seed, x.alarm1_s, y.alarm1_s, y.limit_s) for x, y in zip(*runs, strict=True)
                   if x.alarm1_s != y.alarm1_s)
    done = set(cand) - missing
    added = sum(y.false_alarm and not x.false_alarm for x, y in zip(*runs, strict=True) if x.seed in done)
    return RuleChange(str(before), str(after), head["scenario"], shifts, *stats, len(cand), len(done), added)


def _basis_main(pairs: Sequence[str], out: Path, force: bool, scenarios: str) -> int:
    if len(pairs) % 2:
        print("error: --basis takes pairs: STORED_runs.jsonl RERUN_runs.jsonl ...", file=sys.stderr)
        return 2
    files = [Path(p) for p in pairs]
    try:
        guard_outputs({"--json": out}, files, force=force)
        got = {}
        for stored, rerun in zip(files[::2], files[1::2]):
            b = hold_limit_basis(stored, rerun, scenarios=scenarios)
            print(b.summary())
            got[stored.name] = b.to_dict()
    except (ConfigError, OutputError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    doc = {"generator": f"{SIGNATURE} {__version__}", "files": got}
    atomic_write(out, compact_json(doc, allow_nan=False))
    return 0


def _compare_main(files: Sequence[str], out: Path, force: bool, scenarios: str) -> int:
    if len(files) != 2:
        print("error: --compare takes two runs files: BEFORE_runs.jsonl AFTER_runs.jsonl", file=sys.stderr)
        return 2
    try:
        guard_outputs({"--compare": out}, [Path(f) for f in files], force=force)
        got = rule_change(files[0], files[1], scenarios=scenarios)
    except (ConfigError, OutputError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(got.summary())
    atomic_write(out, compact_json(round_floats({"generator": f"{SIGNATURE} {__version__}", **got.to_dict()}),
                                   allow_nan=False))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Command line (see the module docstring): rerun a stored campaign's candidates, or with ``--basis`` tabulate
    pairs of stored and rerun files into a JSON.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default: the command line's).

    Returns
    -------
    int
        0, or 2 with one line when a file or an argument is refused.
    """
    ap = argparse.ArgumentParser(prog="python -m loadarm.studies.hold_limit", description=__doc__.split("\n")[0])
    ap.add_argument("stored", nargs="+", help="a stored campaign's runs file (with --basis: pairs of it and its "
                                              "reruns' file)")
    ap.add_argument("--out", help="the reruns' runs file (created or resumed)")
    ap.add_argument("--basis", metavar="JSON", help="tabulate the pairs into this JSON (atomically)")
    ap.add_argument("--force", action="store_true", help="with --basis or --compare, replace a JSON loadarm did "
                                                         "not write")
    ap.add_argument("--scenarios", default="examples/scenarios", help="the folder of the stored file's scenario")
    ap.add_argument("--seeds", type=int, default=None, help="only the first N candidates")
    ap.add_argument("--keep-others", action="store_true", help="a new --out starts with every run that is no "
                                                              "candidate, as stored (the whole campaign)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--compare", metavar="JSON", help="the two files (before, after: the same campaign under a "
                                                      "changed rule) compared run by run, into this JSON")
    a = ap.parse_args(argv)
    if a.basis:
        return _basis_main(a.stored, Path(a.basis), a.force, a.scenarios)
    if a.compare:
        return _compare_main(a.stored, Path(a.compare), a.force, a.scenarios)
    if a.out is None or len(a.stored) != 1:
        print("error: one stored runs file and --out (or --basis JSON with pairs)", file=sys.stderr)
        return 2
    try:
        if Path(a.out).resolve() == Path(a.stored[0]).resolve():
            raise ConfigError(f"{a.out}: --out is the stored file: the reruns go to a file of their own")
        runs = rerun_candidates(a.stored[0], a.out, scenarios=a.scenarios, limit=a.seeds, workers=max(1, a.workers),
                                progress=lambda d, n: print(f"{d}/{n}", file=sys.stderr, flush=True),
                                keep_others=a.keep_others)
    except (ConfigError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{len(runs)} runs in {a.out}")
    return 0


if __name__ == "__main__":                      # pragma: no cover
    raise SystemExit(main())
