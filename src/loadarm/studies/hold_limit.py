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
[--workers W]``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from loadarm.errors import ConfigError
from loadarm.studies.campaign import CampaignRun, run_batch, capped_alarm1
from loadarm.studies.runs_file import RUNS_FILE_BATCH, RunsFile, read_stored

__all__ = ["candidates", "rerun_candidates", "limit_effect"]


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
                     limit: int | None = None, workers: int = 1, progress=None) -> list[CampaignRun]:
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

    Returns
    -------
    list of CampaignRun
        The reruns, stored and new.
    """
    header, scenario, lines = read_stored(stored, scenarios)
    runs = {seed: run for seed, (_, run) in lines.items()}
    store = RunsFile(out, str(scenario), header.get("plant"), [tuple(v) for v in header.get("vary", [])])
    seeds = candidates(runs)[:limit]
    have = store.seeds()
    jobs = [(s, runs[s]["draws"]) for s in seeds if s not in have]
    chunks = [jobs[k:k + RUNS_FILE_BATCH] for k in range(0, len(jobs), RUNS_FILE_BATCH)]
    done = len(seeds) - len(jobs)
    if workers <= 1:
        parts = (run_batch(str(scenario), header.get("plant"), c) for c in chunks)
        for part in parts:
            store.append(part)
            done += len(part)
            if progress:
                progress(done, len(seeds))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for part in pool.map(run_batch, [str(scenario)] * len(chunks), [header.get("plant")] * len(chunks), chunks):
                store.append(part)
                done += len(part)
                if progress:
                    progress(done, len(seeds))
    return [CampaignRun(**fields) for fields, _ in store.runs(seeds)]


def limit_effect(stored: dict[int, dict], reruns: Sequence[CampaignRun], limit: float) -> dict:
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

    Returns
    -------
    dict
        ``earlier`` (seeds), ``added_false`` (seeds: ESD-1 now, none before, no face), ``later`` (seed to how much
        ESD-1 comes after the rule without the prediction's, s, where it still does), ``candidates``, ``rerun``.
    """
    earlier, added, later = [], [], {}
    for r in reruns:
        at = capped_alarm1(r, limit)
        if at is not None and (r.alarm1_s is None or at < r.alarm1_s - 1e-9):
            earlier.append(r.seed)
            if r.alarm1_s is None and r.limit_s is None:
                added.append(r.seed)
        m = r.alarm1_measured_s
        if r.limit_s is not None and m is not None:
            when = at if at is not None else r.limit_s
            if when > m + 1e-9:
                later[r.seed] = round(when - m, 2)
    return {"limit_s": limit, "candidates": len(candidates(stored)), "rerun": len(reruns), "earlier": earlier,
            "added_false": added, "later": later}


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: rerun a stored campaign's candidates (see the module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m loadarm.studies.hold_limit", description=__doc__.split("\n")[0])
    ap.add_argument("stored")
    ap.add_argument("--out", required=True)
    ap.add_argument("--scenarios", default="examples/scenarios", help="the folder of the stored file's scenario")
    ap.add_argument("--seeds", type=int, default=None, help="only the first N candidates")
    ap.add_argument("--workers", type=int, default=1)
    a = ap.parse_args(argv)
    try:
        if Path(a.out).resolve() == Path(a.stored).resolve():
            raise ConfigError(f"{a.out}: --out is the stored file: the reruns go to a file of their own")
        runs = rerun_candidates(a.stored, a.out, scenarios=a.scenarios, limit=a.seeds, workers=max(1, a.workers),
                                progress=lambda d, n: print(f"{d}/{n}", file=sys.stderr, flush=True))
    except (ConfigError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{len(runs)} runs in {a.out}")
    return 0


if __name__ == "__main__":                      # pragma: no cover
    raise SystemExit(main())
