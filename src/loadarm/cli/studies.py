"""``loadarm operability`` and ``loadarm campaign``: studies over sea states and seeds."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import (
    BerthOpt,
    ForceOpt,
    JsonOpt,
    PlantKind,
    UserError,
    check_outputs,
    lazy_progress,
    out,
    print_json,
    progress_bar,
)
from loadarm.figures import save
from loadarm.results import format_rows
from loadarm.studies.bank_campaign import check_bank_campaign, run_bank_campaign
from loadarm.studies.bank_operability import run_bank_operability
from loadarm.studies.campaign import check_campaign, parse_vary, run_campaign
from loadarm.studies.cluster import check_workers
from loadarm.studies.operability import OperabilitySettings, run_operability

__all__ = ["app"]

app = typer.Typer()


@app.command()
def operability(
    berth: BerthOpt,
    metocean: Annotated[Path, typer.Option("--metocean", "-m", help="Metocean record, CSV or NetCDF (see "
                                                                    "examples/metocean/).")],
    hours: Annotated[Optional[int], typer.Option("--hours", help="Only the first N usable hours.")] = None,
    duration_per_state: Annotated[Optional[float], typer.Option(
        "--duration-per-state", help="Seconds simulated per hourly state (default: the installation's "
                                     "[operability] duration_per_state, 3600).")] = None,
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="A running Dask scheduler "
                                                                         "(tcp://HOST:8786); default a local "
                                                                         "cluster.")] = None,
    workers: Annotated[Optional[int], typer.Option("--workers", help="Local cluster workers (default: every "
                                                                     "core).")] = None,
    chunks: Annotated[int, typer.Option("--chunks", help="Dask tasks the record is cut into.")] = 100,
    out_file: Annotated[Path, typer.Option("--out", help="Per-state results (Parquet); chunks kept beside it "
                                                         "for resuming.")] = Path("operability.parquet"),
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: monthly downtime, Hs-Tp map, the worst "
                                                              "week.")] = None,
    force: ForceOpt = False,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML file (see "
                                                                          "examples/paper.toml): one arm.")] = None,
    bank: Annotated[Optional[Path], typer.Option("--bank", help="A bank of arms (examples/banks/) instead of "
                                                                "--config: the ship once per state, every arm's "
                                                                "own monitoring; down when any arm is (see "
                                                                "docs/bank.md).")] = None,
    manifold_loads: Annotated[bool, typer.Option("--manifold-loads", help="With --bank: judge each state's loads "
                                                                          "on the ship's manifold too (down when "
                                                                          "any arm's is past its allowable; about "
                                                                          "five times the cost).")] = False,
) -> None:
    """Operability of this arm (--config) or this bank of arms (--bank) at this berth over a metocean record, on
    Dask: per hourly sea state the moored ship's motion and the connected-mode monitoring; downtime, events per
    stage, breakdowns by month, year, Hs, Tp and wind; for a bank, the downtime by arm and the governing arm. A
    stopped run resumes from the chunks already written.

    Example: loadarm operability --config examples/paper.toml --berth examples/berths/lng150k.toml --metocean examples/metocean/sample.csv --hours 48 --duration-per-state 600
    """

    if (config is None) == (bank is None):
        raise UserError("loadarm operability takes --config INSTALLATION (one arm) or --bank BANK (a bank of arms)"
                        + (", not both" if bank is not None else ": give one"))
    check_outputs({"--png": png, "--out": out_file}, [config, bank, berth, metocean], force)
    if not 1 <= chunks <= 10000:
        raise UserError(f"--chunks must be in [1, 10000], got {chunks}")
    check_workers("--workers", workers)
    if manifold_loads and bank is None:
        raise UserError("loadarm operability --manifold-loads needs --bank: the loads on the ship's manifold are a "
                        "bank's (its file gives the flanges and their allowable loads)")
    settings = OperabilitySettings(duration_per_state=duration_per_state, chunks=chunks)
    with lazy_progress("operability (Dask)") as bar:
        if bank is None:
            res = run_operability(config, berth, metocean, out_file, hours=hours, settings=settings,
                                  scheduler=scheduler, workers=workers, fresh=force, progress=bar)
        else:
            res = run_bank_operability(bank, berth, metocean, out_file, hours=hours, settings=settings,
                                       scheduler=scheduler, workers=workers, fresh=force, progress=bar,
                                       manifold_loads=manifold_loads)
    if png is not None:

        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
    else:
        out.print(format_rows(res.headline()))
        out.print(f"per-state results: {out_file}")


@app.command()
def campaign(
    scenario: Annotated[Path, typer.Option("--scenario", "-s", help="Scenario TOML (see examples/scenarios/).")],
    seeds: Annotated[int, typer.Option("--seeds", "-n", help="Number of runs (seeds 0..N-1).")] = 100,
    vary: Annotated[Optional[list[str]], typer.Option(
        "--vary", help="key=lo:hi drawn uniformly per run (repeatable); scenario keys like drift.speed, "
                       "installation keys like installation.sequence.margin.")] = None,
    first_seed: Annotated[int, typer.Option("--first-seed", help="First seed.")] = 0,
    workers: Annotated[Optional[int], typer.Option("--workers", help="Processes (default: every core).")] = None,
    plant: Annotated[Optional[PlantKind], typer.Option(help="Arm plant (default: the scenario's).")] = None,
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="A running Dask scheduler "
                                                                         "(tcp://HOST:8786) instead of local "
                                                                         "processes.")] = None,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Histogram of the release margins.")] = None,
    bank: Annotated[Optional[Path], typer.Option("--bank", help="A bank of arms (examples/banks/): every arm "
                                                                "connected to the scenario's moored ship, the "
                                                                "bank's sequence (the kernel's route, see "
                                                                "docs/bank.md).")] = None,
    runs: Annotated[Optional[Path], typer.Option(
        "--runs", help="A JSON-lines file of the runs, appended as they end: run again with the same scenario, "
                       "plant and --vary, only the seeds it lacks are run and the result covers the whole range "
                       "(a long campaign in parts, merged exactly).")] = None,
    force: ForceOpt = False,
) -> None:
    """Run a scenario over many seeds and parameter draws on every core: overstretches, releases before the ERS
    valves closed, false and missed alarms, and the distribution of release margins. With --bank: the bank's
    drift-off (overstretch on any arm, a coupler opened before its ERS valves confirm, a clash; the bank stops
    when any arm does).

    Example: loadarm campaign --scenario examples/scenarios/driftoff.toml --seeds 200 --vary drift.speed=0.05:0.3
    """

    check_outputs({"--png": png, "--runs": runs}, [scenario, bank], force, appended=("--runs",))
    check_workers("--workers", workers)
    if bank is not None:
        _bank_campaign(bank, scenario, seeds, first_seed, workers, as_json, png, runs,
                       bool(vary) or plant is not None or scheduler is not None)
        return
    varied = [parse_vary(v) for v in vary or ()]
    check_campaign(scenario, seeds, vary=varied, first_seed=first_seed,       # refused before the bar starts
                   plant=None if plant is None else plant.value, runs_file=runs)
    with progress_bar() as prog:
        task = prog.add_task(f"campaign {scenario.name}", total=seeds)
        res = run_campaign(scenario, seeds, vary=varied, first_seed=first_seed, workers=workers,
                           plant=None if plant is None else plant.value,
                           progress=lambda done, total: prog.update(task, completed=done), scheduler=scheduler,
                           runs_file=runs)
    if png is not None:

        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
        return
    out.print(str(res.summary()))


def _bank_campaign(bank: Path, scenario: Path, seeds: int, first_seed: int, workers: Optional[int], as_json: bool,
                   png: Optional[Path], runs: Optional[Path], other: bool) -> None:
    """``loadarm campaign --bank``: the bank's drift-off over seeds."""
    if other:
        raise UserError("loadarm campaign --bank takes no --vary, --plant or --scheduler: the bank's route has no "
                        "plant and runs on local processes")
    check_bank_campaign(bank, scenario, seeds, first_seed, runs)         # refused before the bar starts
    with progress_bar() as prog:
        task = prog.add_task(f"bank campaign {bank.name}", total=seeds)
        res = run_bank_campaign(bank, scenario, seeds, first_seed=first_seed, workers=workers, runs_file=runs,
                                progress=lambda done, total: prog.update(task, completed=done))
    if png is not None:
        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
        return
    out.print(str(res.summary()))
