"""The mooring watch's measured basis: over a stored campaign's runs (each run's seed and draws, from its runs file),
the most lines slack at once and when the watch (:class:`loadarm.guidance.moorings.MooringWatch`, its judgement as
shipped) finds the moorings lost, from the moored ship's records alone (no arm: about 0.25 s a run).

It answers two questions a change to the watch's judgement raises (issue 30, 2026-12-06: the share went from a
half to a third): which stored runs could the change touch (a run where the watch never fires decides the same
under either judgement, the prediction never standing down for the moorings: its stored verdict stands), and how
far is the judgement from the waves (the most lines the waves slacken at once against the share).

Run it as ``python -m loadarm.studies.watch_basis RUNS.jsonl [...] --out FILE.json`` from the repository's root.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from loadarm import __version__
from loadarm.errors import ConfigError, OutputError
from loadarm.files import SIGNATURE, atomic_write, compact_json, guard_outputs
from loadarm.guidance.moorings import LOST_SHARE, SLACK_TIME, MooringWatch
from loadarm.results import Metric, Result
from loadarm.ship.flange import flange_motion
from loadarm.ship.model import moored_ship
from loadarm.sim.loop import LINE_LOAD_PERIOD
from loadarm.studies.campaign import ScenarioDraws
from loadarm.studies.runs_file import read_stored
from loadarm.studies.plots import watch_basis_figure

__all__ = ["WatchRun", "WatchBasis", "watch_over_record", "watch_basis", "main"]

#: The step the watch is updated at, s (a tenth of the 2 s slack time; the readings change once a second,
#: so updating at every 20 ms cycle finds the same times).
STEP = 0.2


@dataclass(frozen=True, slots=True)
class WatchRun:
    """One run's record under the watch: its seed and draws, the most lines slack at once (each for at least
    :data:`SLACK_TIME`) and when the moorings were found lost (None: never)."""

    seed: int
    draws: dict
    most_slack: int
    lost_at: float | None


def watch_over_record(motion, start: float, end: float, step: float = STEP) -> tuple[int, float | None]:
    """Run a fresh watch over a flange motion's line-load readings from ``start`` to ``end``.

    Parameters
    ----------
    motion : loadarm.ship.flange.MooredFlangeMotion
        The run's flange motion (its ``line_loads(t, period)``: what the monitoring reports).
    start, end : float
        Run times, s (both included, as the run's cycles are).
    step : float
        The update step, s.

    Returns
    -------
    (int, float or None)
        The most lines slack at once, and when the watch found the moorings lost (None: never).
    """
    watch, most = MooringWatch(), 0
    for t in np.arange(start, end + step / 2, step):                  # the end's cycle included
        now = float(t)
        watch.update(now, motion.line_loads(now, LINE_LOAD_PERIOD))
        if watch.low_since is not None:
            most = max(most, int(np.count_nonzero(watch.low_since <= now - SLACK_TIME + 1e-9)))
    return most, watch.lost_at


@dataclass(frozen=True)
class WatchBasis(Result):
    """The watch over every run of a runs file."""

    runs_file: str
    scenario: str
    lines: int
    runs: tuple[WatchRun, ...]

    METRICS = (
        Metric("scenario", "scenario"),
        Metric("runs", "runs", "", "d"),
        Metric("lines", "mooring lines", "", "d"),
        Metric("lost_share", "the watch's share: lost when more than it are slack", "", ".3f"),
        Metric("most_slack", "most lines slack at once, any run", "", "d"),
        Metric("lost_runs", "runs where the watch finds the moorings lost", "", "d"),
    )

    def _values(self) -> dict:
        return {"scenario": self.scenario, "runs": len(self.runs), "lines": self.lines, "lost_share": LOST_SHARE,
                "most_slack": max((r.most_slack for r in self.runs), default=0),
                "lost_runs": sum(r.lost_at is not None for r in self.runs)}

    def to_dict(self) -> dict:
        d = dict(self._values())
        d["runs_file"] = self.runs_file
        d["lost_seeds"] = [r.seed for r in self.runs if r.lost_at is not None]
        d["per_run"] = [[r.seed, r.most_slack, r.lost_at] for r in self.runs]      # seed, most slack, lost at
        return d

    def _figure(self):
        return watch_basis_figure(self)


def _read_runs(path: Path, scenarios: Path) -> tuple[dict, list[tuple[int, dict]]]:
    """A runs file read and checked (:func:`loadarm.studies.runs_file.read_stored`), and its runs' (seed, draws)
    by seed; a varied ship refused (the basis compiles the moored ship once)."""
    head, _, runs = read_stored(path, scenarios)
    out = []
    for seed, (n, run) in sorted(runs.items()):
        for key in run["draws"]:
            if str(key).startswith("ship."):
                raise ConfigError(f"{path}: line {n}: draws key {key!r}: the basis compiles the moored ship once; a "
                                  "varied ship is not supported")
        out.append((seed, dict(run["draws"])))
    return head, out


def watch_basis(runs_file: str | Path, scenarios: str | Path = "examples/scenarios",
                progress: Callable[[int, int], None] | None = None) -> WatchBasis:
    """The watch over every run of a runs file, each run's scenario built as the campaign built it.

    Parameters
    ----------
    runs_file : str or Path
        A single arm's campaign runs file (``loadarm campaign --runs``) of a moored-ship scenario.
    scenarios : str or Path
        The folder its header's scenario is in.
    progress : callable, optional
        Called with (runs done, runs) after each run.

    Returns
    -------
    WatchBasis
    """

    path = Path(runs_file)
    head, jobs = _read_runs(path, Path(scenarios))
    draw = ScenarioDraws(str(Path(scenarios) / head["scenario"]))
    ship, out, lines = None, [], 0
    for i, (seed, draws) in enumerate(jobs):
        sc = draw.scenario_of(seed, draws)
        if sc.ship.model != "moored":
            raise ConfigError(f"{path}: scenario {head['scenario']} has no moored ship: no lines to watch")
        if ship is None:
            ship = moored_ship(sc)
        motion = flange_motion(sc, ship)
        lines = int(np.size(motion.motion.mbl))
        most, lost = watch_over_record(motion, 0.0, sc.scenario.duration)      # every cycle, the last's too
        out.append(WatchRun(seed, draws, most, lost))
        if progress is not None:
            progress(i + 1, len(jobs))
    return WatchBasis(str(path), head["scenario"], lines, tuple(out))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m loadarm.studies.watch_basis RUNS.jsonl [...] --out FILE.json``: one summary line per file;
    the JSON holds every run.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default: the command line's).

    Returns
    -------
    int
        0, or 2 when a file is refused (one line naming it; nothing written).
    """

    ap = argparse.ArgumentParser(prog="python -m loadarm.studies.watch_basis", description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="campaign runs files (docs/campaigns/*_runs.jsonl)")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write (atomically; never a file loadarm "
                                                            "did not write, unless --force)")
    ap.add_argument("--force", action="store_true", help="replace an existing --out loadarm did not write")
    args = ap.parse_args(argv)
    try:
        guard_outputs({"--out": args.out}, args.runs, force=args.force)
    except OutputError as exc:
        print(exc, file=sys.stderr)
        return 2
    got = {}
    for f in args.runs:
        try:
            b = watch_basis(f, progress=lambda i, n: print(f"\r{f.name}: {i}/{n}", end="", file=sys.stderr))
        except (ConfigError, OSError) as exc:
            print(f"\n{exc}", file=sys.stderr)
            return 2
        v = b._values()
        print(f"\r{f.name}: {v['runs']} runs, at most {v['most_slack']} of {v['lines']} lines slack at once, "
              f"lost in {v['lost_runs']}", file=sys.stderr)
        got[f.name] = b.to_dict()
    doc = {"generator": f"{SIGNATURE} {__version__}", "lost_share": LOST_SHARE, "slack_time_s": SLACK_TIME,
           "files": got}
    atomic_write(args.out, compact_json(doc))                  # each innermost list on one line: a run a line
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
