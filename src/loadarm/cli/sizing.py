"""``loadarm size``: the arm's lengths from the datasheet (paper Eq. 3)."""

from __future__ import annotations

import typer

from loadarm.cli.common import ConfigOpt, JsonOpt, Table, out, print_json
from loadarm.design.sizing import size_installation, sizing_summary
from loadarm.params.config import load_sizing_case

__all__ = ["app"]

app = typer.Typer()


@app.command()
def size(config: ConfigOpt, as_json: JsonOpt = False) -> None:
    """Size the inboard and outboard arms from the datasheet (paper Eqs 1-3) and check every corner.

    The file needs only [datasheet] and [arm] riser; [alarms] and [sizing] have defaults.

    Arm lengths, if given, are checked at the corners as the configured arm.

    Example: loadarm size --config examples/datasheet.toml
    """

    inst = load_sizing_case(config)
    res = size_installation(inst)
    data = sizing_summary(inst, res)
    corners, corners_conf = data["corners"], data["corners_configured_arm"]
    if as_json:
        print_json(data)
        return
    out.print(f"[bold]Sized arm[/]: b = {res.inboard:.4f} m, c = {res.outboard:.4f} m (b + c = {res.total:.4f} m)",
              markup=True)
    out.print(f"first-alarm corner ({res.corner[0]:.3f}, {res.corner[1]:.3f}) m, r_al = {res.r_alarm:.4f} m; "
              f"active bound: {res.active_bound}")
    for title, rows in (("corners, sized arm", corners), ("corners, configured arm", corners_conf)):
        if rows is None:
            continue
        t = Table(title=title)
        for col in ("corner", "x [m]", "y [m]", "beta [deg]", "zone"):
            t.add_column(col)
        for r in rows:
            beta = "n/a" if r["beta_deg"] is None else f"{r['beta_deg']:.2f}"
            t.add_row(r["corner"], f"{r['x_m']:.2f}", f"{r['y_m']:.2f}", beta, r["zone_label"])
        out.print(t)
