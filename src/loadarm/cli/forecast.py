"""``loadarm forecast``: connect windows from a weather forecast or an ensemble."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import BerthOpt, ConfigOpt, ForceOpt, JsonOpt, check_outputs, lazy_progress, out, print_json
from loadarm.figures import save
from loadarm.results import format_rows
from loadarm.studies.cluster import check_workers
from loadarm.studies.forecast import run_forecast
from loadarm.studies.operability import OperabilitySettings

__all__ = ["app"]

app = typer.Typer()

#: The hourly table's columns.
COLUMNS = ("hour", "Hs m", "Tp s", "wind m/s", "connected", "ESD-1", "loading done", "governs")


def _table(rows: list[tuple[str, ...]]) -> str:
    """The hourly rows as a plain aligned table (no box: a terminal or a log reads it the same)."""
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(COLUMNS)]
    line = lambda cells: "  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths)))  # noqa: E731
    return "\n".join([line(COLUMNS), *(line(r) for r in rows)])


@app.command()
def forecast(
    config: ConfigOpt,
    berth: BerthOpt,
    metocean: Annotated[list[Path], typer.Option(
        "--metocean", "-m", help="A forecast (a metocean record of the hours ahead, CSV or NetCDF); repeat it for "
                                 "an ensemble, one file per member (see examples/metocean/forecast/).")],
    hours: Annotated[int, typer.Option("--hours", help="Hours ahead, from the forecast's first (1-240).")] = 72,
    seeds: Annotated[int, typer.Option("--seeds", help="Wave realisations per member and hour (1-20).")] = 1,
    duration_per_state: Annotated[Optional[float], typer.Option(
        "--duration-per-state", help="Seconds simulated per hour (default: the installation's [operability] "
                                     "duration_per_state).")] = None,
    workers: Annotated[Optional[int], typer.Option("--workers", help="Processes (default: every core).")] = None,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: the probabilities per hour, the weather "
                                                              "below.")] = None,
    force: ForceOpt = False,
) -> None:
    """Connect windows from a weather forecast: per hour ahead, the probability of staying connected without
    ESD-1, the ESD-1 expected, the weather that drives it and whether a loading starting then completes (the
    operability kernel over every member and seed).

    Example: loadarm forecast --config examples/paper.toml --berth examples/berths/lng150k.toml --metocean examples/metocean/sample.csv --hours 24
    """
    check_outputs({"--png": png}, [config, berth, *metocean], force)
    check_workers("--workers", workers)
    settings = OperabilitySettings(duration_per_state=duration_per_state)
    with lazy_progress("forecast") as bar:
        res = run_forecast(config, berth, metocean, hours=hours, seeds=seeds, settings=settings, workers=workers,
                           progress=bar)
    if png is not None:
        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
        return
    out.print(_table(res.rows()), markup=False, highlight=False)
    out.print(format_rows(res.summary().rows()), markup=False, highlight=False)
