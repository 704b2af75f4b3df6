"""``loadarm plan`` and ``loadarm envelope``: the approach and the operating envelope."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import (
    POINT_HELP,
    ConfigOpt,
    ForceOpt,
    JsonOpt,
    Table,
    Timing,
    UserError,
    check_outputs,
    err,
    out,
    parse_point,
    print_json,
    read_model,
)
from loadarm.design.plots import envelope_figure
from loadarm.design.trajectory import plan_approach, plan_approach_3d, plan_warnings
from loadarm.figures import save

__all__ = ["app"]

app = typer.Typer()


@app.command()
def plan(
    config: ConfigOpt,
    start: Annotated[Optional[str], typer.Option(help="Start point (default: the stored position). " + POINT_HELP)] = None,
    target: Annotated[Optional[str], typer.Option(help="Target point (default: the flange). " + POINT_HELP)] = None,
    timing: Annotated[Timing, typer.Option(help="Timing law: paper (Eq. 14), smooth (trapezoid), optimal (toppra).")] = Timing.smooth,
    samples: Annotated[int, typer.Option(help="Number of samples, evenly spaced in time.")] = 201,
    as_json: JsonOpt = False,
    csv: Annotated[Optional[Path], typer.Option("--csv", help="Also write every sample to this CSV file.")] = None,
    strict: Annotated[bool, typer.Option("--strict", help="Refuse (exit 2) a path that enters an alarm zone or "
                                                          "drives a cylinder past its end stop.")] = False,
    force: ForceOpt = False,
) -> None:
    """Plan the straight-line approach: joint angles, cylinder lengths, valve voltages and zones.

    Two numbers for --start/--target are (x, height) in the arm plane; three are (x, y along the berth, height).

    Warns when the path enters an alarm zone or a cylinder passes its end stop; --strict refuses such a path.

    Example: loadarm plan --config examples/paper.toml --target 14,1 --timing optimal
    """

    timing = timing.value
    check_outputs({"--csv": csv}, [config], force)
    model = read_model(config)
    a, b = parse_point(start, "--start"), parse_point(target, "--target")
    dims = {len(v) for v in (a, b) if v is not None}
    if len(dims) > 1:
        raise UserError("--start and --target must both be X,Y or both X,Y,Z")
    if dims == {3}:
        p3 = plan_approach_3d(model, start=a, target=b, timing=timing, samples=samples)
        _plan_warnings(plan_warnings(model, p3), strict)
        recs = p3.records()
        if csv is not None:
            p3.write_csv(csv)
        if as_json:
            print_json({**p3.summary(), "samples": recs})
            return
        t = Table(title=f"3D approach (x, y along the berth, height) {p3.start} -> {p3.target}, {timing} timing")
        t.add_column("quantity")
        t.add_column("value")
        for label, text in p3.summary().rows():
            t.add_row(label, text)
        out.print(t)
        return
    p = plan_approach(model, start=a, target=b, timing=timing, samples=samples)
    _plan_warnings(plan_warnings(model, p), strict)
    if csv is not None:
        p.write_csv(csv)
    if as_json:
        print_json({**p.summary(), "samples": p.records()})
        return
    s = p.summary()
    t = Table(title=f"approach (x, height) {tuple(round(v, 3) for v in p.start)} -> "
                    f"{tuple(round(v, 3) for v in p.target)}, {timing} timing")
    t.add_column("quantity")
    t.add_column("value")
    for label, text in s.rows():
        t.add_row(label, text)
    out.print(t)
    if csv is not None:
        out.print(f"samples written to {csv}")


def _plan_warnings(warnings: list[str], strict: bool) -> None:
    if warnings and strict:
        raise UserError("--strict: " + "; ".join(warnings))
    for w in warnings:
        err.print(f"warning: {w}")


@app.command()
def envelope(
    config: ConfigOpt,
    png: Annotated[Path, typer.Option("--png", help="Output PNG file.")],
    force: ForceOpt = False,
) -> None:
    """Draw the operating envelope with alarm zones (paper Fig. 4).

    Example: loadarm envelope --config examples/paper.toml --png out/envelope.png
    """

    check_outputs({"--png": png}, [config], force)
    model = read_model(config)
    save(envelope_figure(model), png)
    out.print(f"envelope written to {png}")
