"""``loadarm balance``, ``loadarm loads`` and ``loadarm simulate``: counterweights, actuator loads and
the\nelectro-hydraulic closed loop.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import (
    ConfigOpt,
    ForceOpt,
    JsonOpt,
    Table,
    Timing,
    TimingOrAll,
    UserError,
    check_fill,
    check_outputs,
    err,
    escape,
    out,
    print_json,
    read_model,
)
from loadarm.design.balancing import balance_counterweights
from loadarm.design.loads import CYLINDER_LOAD_METRICS, actuator_loads
from loadarm.design.plots import residual_torque_figure
from loadarm.design.timing import TIMING_LAWS
from loadarm.design.trajectory import plan_approach
from loadarm.figures import save
from loadarm.hydraulics.plots import simulation_figure
from loadarm.hydraulics.simulate import SIMULATION_METRICS, arrival_note, simulate_approach

__all__ = ["app"]

app = typer.Typer()


@app.command()
def balance(
    config: ConfigOpt,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Residual torque map.")] = None,
    spacing: Annotated[float, typer.Option(help="Envelope grid step, m.")] = 0.25,
    force: ForceOpt = False,
) -> None:
    """Counterweights that minimise the largest static joint torque over the envelope.

    Example: loadarm balance --config examples/paper.toml --png out/residual_torque.png
    """

    check_outputs({"--png": png}, [config], force)
    model = read_model(config)
    if not (0.01 <= spacing <= 5.0):
        raise UserError(f"--spacing must be in [0.01, 5] m, got {spacing!r}")
    res = balance_counterweights(model, spacing=spacing)
    if png is not None:

        save(residual_torque_figure(res), png)
    s = res.summary()
    if as_json:
        print_json(s)
        return
    out.print(f"counterweights: inboard {s['counterweight_inboard_kg']:.0f} kg at "
              f"{model.masses.counterweight_inboard_distance:g} m, outboard {s['counterweight_outboard_kg']:.0f} kg at "
              f"{model.masses.counterweight_outboard_distance:g} m (fills {s['fills']}, {s['poses']} poses)")
    out.print(f"largest residual static torque {s['max_residual_torque_Nm'] / 1e3:.2f} kN m "
              f"(alpha {s['max_residual_torque_alpha_Nm'] / 1e3:.2f}, beta {s['max_residual_torque_beta_Nm'] / 1e3:.2f}); "
              f"configured counterweights: alpha {s['configured_max_torque_alpha_Nm'] / 1e3:.2f}, "
              f"beta {s['configured_max_torque_beta_Nm'] / 1e3:.2f} kN m")


@app.command()
def loads(
    config: ConfigOpt,
    timing: Annotated[Timing, typer.Option(help="Timing law of the approach.")] = Timing.smooth,
    fill: Annotated[Optional[float], typer.Option(help="Product fill fraction 0..1 (default masses.fill).")] = None,
    as_json: JsonOpt = False,
) -> None:
    """Cylinder forces, pressures, speeds and flows along the approach.

    Example: loadarm loads --config examples/paper.toml --timing smooth --fill 1
    """

    timing = timing.value
    model = read_model(config)
    check_fill(fill)
    s = actuator_loads(model, plan_approach(model, timing=timing, samples=801), fill=fill).summary()
    if as_json:
        print_json(s)
        return

    t = Table(title=f"actuator loads, {timing} timing")
    for col in ("cylinder", *(m.header for m in CYLINDER_LOAD_METRICS)):
        t.add_column(col)
    for i in (1, 2):
        c = s[f"cylinder{i}"]
        cells = [m.format(c[m.key], unit=False) for m in CYLINDER_LOAD_METRICS]
        if not c["pressure_ok"]:
            cells[2] += " (over rating)"
        t.add_row(str(i), *cells)
    out.print(t)


@app.command()
def simulate(
    config: ConfigOpt,
    timing: Annotated[TimingOrAll, typer.Option(help="Timing law, or all three compared.")] = TimingOrAll.smooth,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Deviation, tracking, pressures, valves, pump.")] = None,
    fill: Annotated[Optional[float], typer.Option(help="Product fill fraction 0..1 (default masses.fill).")] = None,
    force: ForceOpt = False,
) -> None:
    """Simulate the electro-hydraulic closed loop (paper Fig. 11) driving the arm along the approach.

    --timing all compares the three timing laws in one table.

    Example: loadarm simulate --config examples/paper.toml --timing all
    """

    COMPARE_KEYS = ("timing", "plan_duration_s", "arrival_time_s", "max_deviation_mm", "rms_deviation_mm",
                    "final_position_error_mm", "max_chamber_pressure_bar")

    timing = timing.value
    check_outputs({"--png": png}, [config], force)
    model = read_model(config)
    check_fill(fill)
    if timing == "all":
        rows = {}
        with err.status("simulating the closed loop for every timing law"):
            for law in TIMING_LAWS:
                rows[law] = simulate_approach(model, plan_approach(model, timing=law, samples=2001), fill=fill).summary()
        if as_json:
            print_json(rows)
            return
        t = Table(title="timing laws compared (closed loop)")
        cols = [m for m in SIMULATION_METRICS if m.key in COMPARE_KEYS]
        for m in cols:
            t.add_column(m.header)
        for law, r in rows.items():
            t.add_row(*(m.format(r[m.key], unit=False) for m in cols))
        out.print(t)
        out.print(arrival_note(next(iter(rows.values()))["arrival_tolerance_mm"]))
        for law, r in rows.items():
            for w in r["warnings"]:
                out.print(f"[yellow]warning ({law}):[/] {escape(w)}", markup=True)
        return
    plan = plan_approach(model, timing=timing, samples=2001)
    with err.status("simulating the closed loop (first run compiles the simulator)"):
        res = simulate_approach(model, plan, fill=fill)
    if png is not None:

        save(simulation_figure(res), png)
    s = res.summary()
    if as_json:
        print_json(s)
        return
    t = Table(title=f"closed-loop approach, {timing} timing")
    t.add_column("quantity")
    t.add_column("value")
    for label, text in s.rows():
        t.add_row(label, text)
    out.print(t)
    for w in s["warnings"]:
        out.print(f"[yellow]warning:[/] {escape(w)}", markup=True)
