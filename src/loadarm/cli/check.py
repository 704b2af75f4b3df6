"""``loadarm check``: the design check before operation."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import (
    ConfigOpt,
    ForceOpt,
    JsonOpt,
    Table,
    UserError,
    check_outputs,
    out,
    print_json,
    read_model,
)
from loadarm.design.check import design_check
from loadarm.figures import save

__all__ = ["app"]

app = typer.Typer()


@app.command()
def check(
    config: ConfigOpt,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: distance needed against available, per "
                                                              "direction.")] = None,
    force: ForceOpt = False,
) -> None:
    """Design check before operation: the largest drift each direction absorbs, from the alarm angles, the
    sequence times and the arm's limits; refuses (exit 2) an installation whose alarms cannot absorb its own
    design drift.

    Example: loadarm check --config examples/paper.toml --png out/check.png
    """

    check_outputs({"--png": png}, [config], force)
    res = design_check(read_model(config))
    if png is not None:

        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
    else:
        s = res.summary()
        out.print(str(s))
        t = Table("direction", "first face", "available m", "alarm at m", "needed m", "absorbs m/s")
        for r in res.rows:
            t.add_row(r.direction, r.face or "-", f"{r.available:.2f}", f"{r.alarm_at:.2f}", f"{r.needed:.2f}",
                      f"{r.max_speed:.3f}")
        out.print(t)
    if not res.ok:
        raise UserError(f"{config}: refused: " + "; ".join(res.problems))
