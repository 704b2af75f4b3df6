"""Command line: ``loadarm size | plan | envelope | check | verify | balance | loads | simulate | run | campaign | log |
mjcf | demo``.

Bad input of any kind (missing file, invalid config, unreachable target,
malformed option) prints one line on stderr and exits with status 2; there is
never a Python traceback for a user error. Exit codes: 0 ok, 1 internal error
(a bug: one line, the traceback with ``LOADARM_DEBUG=1``), 2 bad input,
130 interrupted.
"""

from __future__ import annotations

import json
import math
import os
import sys
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.params.config import Installation, load_config
from loadarm.errors import LoadarmError
from loadarm.eventlog import KINDS
from loadarm.vocab import alarm_label

EXIT_CODES = "Exit codes: 0 ok, 1 internal error (a bug; LOADARM_DEBUG=1 shows the traceback), 2 bad input, 130 interrupted."

#: Exit status of `loadarm run` when the run's verdict is FAILED (0 success, 1 internal error, 2 bad input).
SAFETY_FAILED = 3

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Automatic guidance of marine loading arms: sizing, envelope, straight-line approach, "
                       "hydraulics, live guidance, event log, report.",
                  epilog=EXIT_CODES)
class _LazyConsole:
    """A rich Console created on first use: `plan --json` and other machine-facing paths never import rich."""

    def __init__(self, **kwargs):
        self._kwargs = kwargs
        self._console = None

    def get(self):
        """The real Console (for rich objects that take one, such as a progress bar)."""
        if self._console is None:
            from rich.console import Console

            self._console = Console(**self._kwargs)
        return self._console

    def __getattr__(self, name):
        return getattr(self.get(), name)


def escape(text: str) -> str:
    """Escape rich markup in user text (rich imported on first use)."""
    from rich.markup import escape as _escape

    return _escape(text)


def Table(*args, **kwargs):  # noqa: N802 - stands in for rich.table.Table
    """A rich Table (rich imported on first use)."""
    from rich.table import Table as _Table

    return _Table(*args, **kwargs)


# Markup off: user strings (scenario names, paths, log reasons) are printed as they are, never parsed ("[/x]" in a
# path once raised rich's MarkupError, "[link=...]" changed what was printed). The few styled lines opt in with
# markup=True and escape what they interpolate.
out = _LazyConsole(soft_wrap=True, markup=False, highlight=False)
err = _LazyConsole(stderr=True, soft_wrap=True, markup=False, highlight=False)

ConfigOpt = Annotated[Path, typer.Option("--config", "-c", help="Installation TOML file (see examples/paper.toml).")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]
ForceOpt = Annotated[bool, typer.Option("--force", help="Replace existing output files that loadarm did not write "
                                                        "(its own are replaced without it).")]


class UserError(Exception):
    """A CLI-level bad input (exit status 2)."""


class Timing(str, Enum):
    """Timing laws of the approach."""

    paper = "paper"
    smooth = "smooth"
    optimal = "optimal"


class TimingOrAll(str, Enum):
    """Timing laws, or all three compared."""

    paper = "paper"
    smooth = "smooth"
    optimal = "optimal"
    all = "all"


class PlantKind(str, Enum):
    """Arm plants of a guidance run."""

    hydraulic = "hydraulic"
    kinematic = "kinematic"


EventKind = Enum("EventKind", {k: k for k in KINDS}, type=str)


def _version(value: bool) -> None:
    if value:
        from loadarm import __version__

        out.print(f"loadarm {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """Automatic guidance of marine loading arms: sizing, envelope, straight-line approach, hydraulics, live
    guidance, event log, report."""

POINT_HELP = ("X,Y: x out from the riser centre line and height above the jetty deck (arm plane); X,Y,Z: x out, "
              "y along the berth, z height (3D with slew); metres")


def _point(text: Optional[str], name: str) -> Optional[tuple[float, ...]]:
    if text is None:
        return None
    parts = text.split(",")
    try:
        if len(parts) not in (2, 3):
            raise ValueError
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise UserError(f"{name} must be X,Y (arm plane) or X,Y,Z (3D) in metres, separated by commas, "
                        f"got {text!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise UserError(f"{name} must be finite numbers, got {text!r}")
    return vals


def _check_png(png: Optional[Path]) -> None:
    if png is not None and png.suffix.lower() != ".png":
        raise UserError(f"--png must name a .png file, got {str(png)!r}")


def _outputs(outputs: dict, inputs=(), force: bool = False, appended=()) -> None:
    """Check the output files before any work (:func:`loadarm.files.guard_outputs`), and a PNG's suffix."""
    from loadarm.files import guard_outputs

    _check_png(outputs.get("--png"))
    guard_outputs(outputs, [Path(i) for i in inputs if i is not None], force=force, appended=appended)


def _check_fill(fill: Optional[float]) -> None:
    if fill is not None and not (0.0 <= fill <= 1.0):
        raise UserError(f"--fill must be in [0, 1], got {fill!r}")


def _print_wide(renderable, width: int) -> None:
    """Print on stdout at least ``width`` columns wide (rich squeezes a table into 80 columns when piped)."""
    from rich.console import Console

    Console(width=max(out.width, width), soft_wrap=True, markup=False, highlight=False,
            file=out.file).print(renderable)


def _model(config: Path):
    """Read an installation file and compile it (the CLI is an edge: configuration stops here)."""
    from loadarm.params.compiler import compile_model

    return compile_model(load_config(config), source=str(config))


def _progress():
    """A progress bar on stderr (rich.progress is imported only by the commands that show one). Transient: it
    leaves nothing behind, so a refusal mid-way is still the one line on stderr (found by the fuzz suite: a
    bad scenario in a campaign printed the bar's last state above the error)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description}", style="bold", markup=False), BarColumn(), TimeElapsedColumn(),
                    console=err.get(), transient=True)


def _round_floats(obj, digits: int = 12):
    """Floats to ``digits`` significant digits: 233.14000000000001 prints as 233.14. Twelve digits keep
    every physical quantity here far below its measurement or model precision (0.1 um on 100 m)."""
    if isinstance(obj, float):
        return float(f"{obj:.{digits}g}") if math.isfinite(obj) else obj
    if isinstance(obj, dict):
        return {k: _round_floats(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_round_floats(v, digits) for v in obj]
    return obj


def _json(obj) -> None:
    try:
        text = json.dumps(_round_floats(obj), indent=2, allow_nan=False)
    except ValueError as exc:                 # a NaN or infinity in a result is a bug, not bad input: exit 1
        raise RuntimeError(f"a result is not a finite number ({exc})") from None
    sys.stdout.write(text + "\n")


@app.command()
def size(config: ConfigOpt, as_json: JsonOpt = False) -> None:
    """Size the inboard and outboard arms from the datasheet (paper Eqs 1-3) and check every corner.

    The file needs only [datasheet] and [arm] riser; [alarms] and [sizing] have defaults.

    Arm lengths, if given, are checked at the corners as the configured arm.

    Example: loadarm size --config examples/datasheet.toml
    """
    from loadarm.params.config import load_sizing_case
    from loadarm.design.sizing import size_installation, sizing_summary

    inst = load_sizing_case(config)
    res = size_installation(inst)
    data = sizing_summary(inst, res)
    corners, corners_conf = data["corners"], data["corners_configured_arm"]
    if as_json:
        _json(data)
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
    from loadarm.design.trajectory import plan_approach, plan_approach_3d, plan_warnings

    timing = timing.value
    _outputs({"--csv": csv}, [config], force)
    model = _model(config)
    a, b = _point(start, "--start"), _point(target, "--target")
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
            _json({**p3.summary(), "samples": recs})
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
        _json({**p.summary(), "samples": p.records()})
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
    from loadarm.design.plots import envelope_figure
    from loadarm.figures import save

    _outputs({"--png": png}, [config], force)
    model = _model(config)
    save(envelope_figure(model), png)
    out.print(f"envelope written to {png}")


@app.command()
def verify(
    config: ConfigOpt,
    timing: Annotated[Timing, typer.Option(help="Timing law of the approach to verify.")] = Timing.paper,
    samples: Annotated[int, typer.Option(help="Number of samples along the approach.")] = 201,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Draw closed form and MuJoCo over each other.")] = None,
    force: ForceOpt = False,
) -> None:
    """Verify the closed-form kinematics in MuJoCo (paper Section 4, Fig. 8).

    Example: loadarm verify --config examples/paper.toml --png out/verification.png
    """
    from loadarm.design.multibody import verify_kinematics
    from loadarm.design.trajectory import plan_approach

    timing = timing.value
    _outputs({"--png": png}, [config], force)
    model = _model(config)
    p = plan_approach(model, timing=timing, samples=samples)
    with err.status("stepping the MuJoCo arm along the line"):
        res = verify_kinematics(model, p)
    if png is not None:
        from loadarm.figures import save
        from loadarm.design.plots import verification_figure

        save(verification_figure(res), png)
    s = res.summary()
    if as_json:
        _json(s)
        return
    out.print(f"MuJoCo against the closed form, {s['samples']} samples ({timing} timing):")
    out.print(f"  max |alpha| difference {s['max_alpha_diff_deg']:.3e} deg, max |beta| difference "
              f"{s['max_beta_diff_deg']:.3e} deg")
    out.print(f"  max |r_ac1| difference {s['max_r_ac1_diff_mm']:.3e} mm, max |r_ac2| difference "
              f"{s['max_r_ac2_diff_mm']:.3e} mm")
    if png is not None:
        out.print(f"figure written to {png}")


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
    from loadarm.design.balancing import balance_counterweights

    _outputs({"--png": png}, [config], force)
    model = _model(config)
    if not (0.01 <= spacing <= 5.0):
        raise UserError(f"--spacing must be in [0.01, 5] m, got {spacing!r}")
    res = balance_counterweights(model, spacing=spacing)
    if png is not None:
        from loadarm.design.plots import residual_torque_figure
        from loadarm.figures import save

        save(residual_torque_figure(res), png)
    s = res.summary()
    if as_json:
        _json(s)
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
    from loadarm.design.loads import actuator_loads
    from loadarm.design.trajectory import plan_approach

    timing = timing.value
    model = _model(config)
    _check_fill(fill)
    s = actuator_loads(model, plan_approach(model, timing=timing, samples=801), fill=fill).summary()
    if as_json:
        _json(s)
        return
    from loadarm.design.loads import CYLINDER_LOAD_METRICS

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
    from loadarm.hydraulics.simulate import SIMULATION_METRICS, simulate_approach
    from loadarm.design.timing import TIMING_LAWS

    COMPARE_KEYS = ("timing", "plan_duration_s", "arrival_time_s", "max_deviation_mm", "rms_deviation_mm",
                    "final_position_error_mm", "max_chamber_pressure_bar")
    from loadarm.design.trajectory import plan_approach

    timing = timing.value
    _outputs({"--png": png}, [config], force)
    model = _model(config)
    _check_fill(fill)
    if timing == "all":
        rows = {}
        with err.status("simulating the closed loop for every timing law"):
            for law in TIMING_LAWS:
                rows[law] = simulate_approach(model, plan_approach(model, timing=law, samples=2001), fill=fill).summary()
        if as_json:
            _json(rows)
            return
        t = Table(title="timing laws compared (closed loop)")
        cols = [m for m in SIMULATION_METRICS if m.key in COMPARE_KEYS]
        for m in cols:
            t.add_column(m.header)
        for law, r in rows.items():
            t.add_row(*(m.format(r[m.key], unit=False) for m in cols))
        out.print(t)
        for law, r in rows.items():
            for w in r["warnings"]:
                out.print(f"[yellow]warning ({law}):[/] {escape(w)}", markup=True)
        return
    plan = plan_approach(model, timing=timing, samples=2001)
    with err.status("simulating the closed loop (first run compiles the simulator)"):
        res = simulate_approach(model, plan, fill=fill)
    if png is not None:
        from loadarm.figures import save
        from loadarm.hydraulics.plots import simulation_figure

        save(simulation_figure(res), png)
    s = res.summary()
    if as_json:
        _json(s)
        return
    t = Table(title=f"closed-loop approach, {timing} timing")
    t.add_column("quantity")
    t.add_column("value")
    for label, text in s.rows():
        t.add_row(label, text)
    out.print(t)
    for w in s["warnings"]:
        out.print(f"[yellow]warning:[/] {escape(w)}", markup=True)


@app.command()
def run(
    scenario: Annotated[Path, typer.Option("--scenario", "-s", help="Scenario TOML (see examples/scenarios/).")],
    db: Annotated[Path, typer.Option("--db", help="SQLite event log to append to.")] = Path("loadarm-events.db"),
    no_db: Annotated[bool, typer.Option("--no-db", help="Do not log events.")] = False,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Timeline figure.")] = None,
    realtime: Annotated[bool, typer.Option("--realtime", help="Pace the run with the wall clock.")] = False,
    plant: Annotated[Optional[PlantKind], typer.Option(help="Arm plant (default: the scenario's).")] = None,
    force: ForceOpt = False,
) -> None:
    """Run a scenario in closed loop: ship, sensor, estimator, guidance controller, arm; log every event.

    Example: loadarm run --scenario examples/scenarios/driftoff.toml --db out/events.db --png out/timeline.png
    """
    from loadarm.eventlog import EventLog
    from loadarm.sim.loop import run_scenario, wall_clock_pacer
    from loadarm.params.scenario import load_scenario

    if not no_db and str(db) == ":memory:":
        raise UserError("--db :memory: would throw the events away; name a file, or give --no-db to run without a log")
    sc, model = load_scenario(scenario)
    inst_file = None if sc.scenario.installation is None else scenario.parent / sc.scenario.installation
    _outputs({"--png": png, "--db": None if no_db else db}, [scenario, inst_file], force, appended=("--db",))
    from datetime import datetime, timezone

    run_id = f"{sc.scenario.name}@{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S.%fZ')}"
    log = None if no_db else EventLog(db, run=run_id)
    try:
        with _progress() as prog:
            task = prog.add_task(f"scenario {sc.scenario.name}", total=1.0)
            res = run_scenario(sc, model, log=log, progress=lambda f: prog.update(task, completed=f),
                               plant=None if plant is None else plant.value,
                               pace=wall_clock_pacer() if realtime else None)
    finally:
        if log is not None:
            log.close()
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    s = res.summary()
    if as_json:
        _json(s)
    else:
        _print_run(s, None if log is None else f"  events logged to {db} (run {run_id})")
    if s["failures"]:
        raise typer.Exit(SAFETY_FAILED)          # the safety chain failed: a script must not read success


def _print_run(s: dict, logged: str | None) -> None:
    """``loadarm run``'s text: the verdict, the sequence and its times."""
    out.print(f"scenario {s['scenario']}: {' -> '.join(s['mode_sequence'])}")
    out.print(f"  verdict: {s['verdict']}")
    over = s["overstretched_s"]
    for key in ("alarm1_s", "alarm2_s", "release_s", "release_complete_s", "overstretched_s"):
        if s[key] is not None:
            late = " (after the arm overstretched)" if key == "release_complete_s" and over is not None \
                and s[key] > over else ""
            out.print(f"  {key[:-2].replace('_', ' ')} at {s[key]:.2f} s{late}")
    if s["valves_confirmed_s"] is not None:
        out.print(f"  ERS valves confirmed closed at {s['valves_confirmed_s']:.2f} s"
                  + ("" if s["coupler_opening_s"] is None else f", coupler opening at {s['coupler_opening_s']:.2f} s"))
    if s["release_margin_s"] is not None:
        m = s["release_margin_s"]
        out.print(f"  release complete {abs(m):.2f} s {'before' if m >= 0 else 'AFTER'} the flange reached the "
                  f"{s['limit_face']} face" + ("" if s["cleared_s"] is None
                                               else f"; coupler clear of the manifold at {s['cleared_s']:.2f} s"))
    if s["retracted_s"] is not None:
        out.print(f"  arm retracted clear of its release point at {s['retracted_s']:.2f} s")
    out.print(f"  max beta {s['max_beta_deg']:.1f} deg, max |slew| {s['max_abs_slew_deg']:.1f} deg, {s['events']} events"
              f"; controller cycle median {s['cycle_us_median']:.0f} us, p99 {s['cycle_us_p99']:.0f} us")
    if logged:
        out.print(logged)


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
    from loadarm.design.check import design_check

    _outputs({"--png": png}, [config], force)
    res = design_check(_model(config))
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    if as_json:
        _json(res.to_dict())
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


BerthOpt = Annotated[Path, typer.Option("--berth", "-b", help="Berth TOML file (see examples/berths/).")]


@app.command()
def hydro(
    berth: BerthOpt,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: RAOs of the six motions.")] = None,
    force: ForceOpt = False,
) -> None:
    """The berth's design ship: hydrodynamics (capytaine, solved once and cached when not shipped), natural
    periods, mooring stiffness and the static offset under the berth's design environment.

    Example: loadarm hydro --berth examples/berths/lng150k.toml --png out/rao.png
    """
    from loadarm.params.berth import load_berth
    from loadarm.ship.model import compile_ship
    from loadarm.ship.summary import ship_summary

    _outputs({"--png": png}, [berth], force)
    b = load_berth(berth)
    ship = compile_ship(b, solve=True, progress=not as_json, source=str(berth))
    res = ship_summary(ship, b.environment)
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    if as_json:
        _json(res.to_dict())
    else:
        out.print(str(res.summary()))


@app.command()
def alarms(
    config: ConfigOpt,
    berth: BerthOpt,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: the alarm zones and the break-out "
                                                              "stages.")] = None,
    seeds: Annotated[int, typer.Option("--seeds", help="Realisations of the design sea state per case.")] = 5,
    force: ForceOpt = False,
) -> None:
    """Design the alarm settings of this arm at this berth from a mooring analysis of its design ship (intact
    and break-out, Choi et al. 2018; Lanquetin): per face, the drift allowance, the break-out drift per stage
    and the recommended beta, slew and design-drift settings as blocks to paste into the installation. Refuses
    (exit 2), naming the face and the shortfall, when the arm cannot absorb the design drift.

    Example: loadarm alarms --config examples/paper.toml --berth examples/berths/lng150k.toml --png out/alarms.png
    """
    from loadarm.design.alarm_design import DesignSettings, design_alarms
    from loadarm.params.berth import load_berth
    from loadarm.ship.model import compile_ship

    _outputs({"--png": png}, [config, berth], force)
    if not 1 <= seeds <= 100:
        raise UserError(f"--seeds must be in [1, 100], got {seeds}")
    model = _model(config)
    b = load_berth(berth)
    ship = compile_ship(b, source=str(berth))
    with _progress() as prog:
        task = prog.add_task("mooring analysis", total=1.0)
        res = design_alarms(model, ship, b.environment, settings=DesignSettings(seeds=seeds),
                            progress=lambda f: prog.update(task, completed=f))
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    if as_json:
        _json(res.to_dict())
    else:
        out.print(str(res.summary()))
        from rich import box

        t = Table("dir", "face", "case", "allow m", "ESD-1 m", "ERS-2 m", "lead m", "avail m", "alarms deg",
                  box=box.SIMPLE_HEAD, pad_edge=False)
        for r in res.rows:
            angles = "-" if r.first is None else "/".join(f"{math.degrees(v):.1f}" for v in (r.first, r.second,
                                                                                               r.release))
            t.add_row(r.direction.split("(")[-1].rstrip(")"), r.face or "-", r.short_case, f"{r.allowance_m:.2f}",
                      f"{r.esd_m:.2f}", f"{r.release_m:.2f}", f"{r.lead_m:.2f}", f"{r.available_m:.2f}", angles)
        _print_wide(t, 100)
        out.print("Paste into the installation:")
        out.print(res.toml().rstrip("\n"))
        for w in res.warnings:
            err.print(f"loadarm: note: {w}")
    if not res.ok:
        raise UserError(f"{berth}: refused: " + "; ".join(res.problems))


@app.command()
def operability(
    config: ConfigOpt,
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
) -> None:
    """Operability of this arm at this berth over a metocean record, on Dask: per hourly sea state the moored
    ship's motion and the connected-mode monitoring; downtime, events per stage, breakdowns by month, year, Hs,
    Tp and wind. A stopped run resumes from the chunks already written.

    Example: loadarm operability --config examples/paper.toml --berth examples/berths/lng150k.toml --metocean examples/metocean/sample.csv --hours 48 --duration-per-state 600
    """
    from loadarm.results import format_rows
    from loadarm.studies.operability import OperabilitySettings, run_operability

    _outputs({"--png": png, "--out": out_file}, [config, berth, metocean], force)
    if workers is not None and workers < 1:
        raise UserError(f"--workers must be at least 1, got {workers}")
    if not 1 <= chunks <= 10000:
        raise UserError(f"--chunks must be in [1, 10000], got {chunks}")
    settings = OperabilitySettings(duration_per_state=duration_per_state, chunks=chunks)
    res = run_operability(config, berth, metocean, out_file, hours=hours, settings=settings, scheduler=scheduler,
                          workers=workers, progress=not as_json, fresh=force)
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    if as_json:
        _json(res.to_dict())
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
    force: ForceOpt = False,
) -> None:
    """Run a scenario over many seeds and parameter draws on every core: overstretches, releases before the ERS
    valves closed, false and missed alarms, and the distribution of release margins.

    Example: loadarm campaign --scenario examples/scenarios/driftoff.toml --seeds 200 --vary drift.speed=0.05:0.3
    """
    from loadarm.studies.campaign import check_campaign, parse_vary, run_campaign

    _outputs({"--png": png}, [scenario], force)
    if workers is not None and workers < 1:
        raise UserError(f"--workers must be at least 1, got {workers}")
    varied = [parse_vary(v) for v in vary or ()]
    check_campaign(scenario, seeds, vary=varied, first_seed=first_seed,       # refused before the bar starts
                   plant=None if plant is None else plant.value)
    with _progress() as prog:
        task = prog.add_task(f"campaign {scenario.name}", total=seeds)
        res = run_campaign(scenario, seeds, vary=varied, first_seed=first_seed, workers=workers,
                           plant=None if plant is None else plant.value,
                           progress=lambda done, total: prog.update(task, completed=done), scheduler=scheduler)
    if png is not None:
        from loadarm.figures import save

        save(res.plot(), png)
    if as_json:
        _json(res.to_dict())
        return
    out.print(str(res.summary()))


@app.command("log")
def log_cmd(
    db: Annotated[Path, typer.Option("--db", help="SQLite event log.")] = Path("loadarm-events.db"),
    since: Annotated[Optional[float], typer.Option(help="Only events at or after this time, s.")] = None,
    kind: Annotated[Optional[list[EventKind]], typer.Option(help="Only these kinds (repeatable).")] = None,
    run_id: Annotated[Optional[str], typer.Option("--run", help="Only this run (as printed by loadarm run).")] = None,
    samples: Annotated[bool, typer.Option("--samples", help="Also list the once-a-second state samples.")] = False,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Replay the samples into a timeline figure.")] = None,
    force: ForceOpt = False,
) -> None:
    """Query the event log (and replay it into a timeline).

    Example: loadarm log --db out/events.db --kind alarm --kind mode
    """
    from loadarm.eventlog import EventLog

    _outputs({"--png": png}, [db], force)
    if since is not None and not math.isfinite(since):
        raise UserError(f"--since must be a finite time in s, got {since!r}")
    kinds = None if kind is None else [k.value for k in kind]
    if kinds is None and not samples:
        kinds = [k.value for k in EventKind if k.value != "sample"]
    log = EventLog.open_existing(db)
    try:
        events = log.query(since=since, kinds=kinds, run=run_id)
        if png is not None:
            _replay_png(png, log.query(since=since, run=run_id))
    finally:
        log.close()
    if as_json:
        _json([e.as_dict() for e in events])
        return
    t = Table(title=f"{db}: {len(events)} events" + ("" if samples or kind else " (samples hidden; --samples)"))
    for col in ("id", "run", "t [s]", "mode", "kind", "reason"):
        t.add_column(col)
    for e in events:
        t.add_row(str(e.id), e.run, f"{e.t:.2f}", e.state, e.kind, e.reason)
    out.print(t)
    if png is not None:
        out.print(f"timeline written to {str(png)}")


def _latest_run(events, empty: str) -> tuple[str, list]:
    """The log's latest run with state samples and its events (several runs in one log: the latest is
    replayed, or one chosen with --run); ``empty`` is the error when there is none."""
    samples = [e for e in events if e.kind == "sample"]
    if not samples:
        raise UserError(empty)
    run = samples[-1].run
    return run, [e for e in events if e.run == run]


def _replay_png(png: Path, events) -> None:
    import numpy as np

    from loadarm.eventlog import check_samples
    from loadarm.guidance.controller import MODES
    from loadarm.figures import save
    from loadarm.sim.plots import timeline_figure

    last_run, events = _latest_run(events, "the log has no state samples to replay (was it written by loadarm "
                                           "run?)")
    samples = [e for e in events if e.kind == "sample"]
    check_samples(samples, ("beta", "phi", "distance"), MODES)
    t = np.array([e.t for e in samples])
    mode = np.array([MODES.index(e.state) for e in samples])
    beta = np.array([e.data["beta"] for e in samples], dtype=float)
    phi = np.array([e.data["phi"] for e in samples], dtype=float)
    dist = np.array([e.data["distance"] for e in samples], dtype=float)
    alarms = [(e.t, alarm_label(e.data)) for e in events if e.kind == "alarm"]
    save(timeline_figure(t, mode, beta, phi, dist, MODES, alarms=alarms,
                         title=f"Guidance timeline of {last_run} (replayed from the log)"), png)


@app.command()
def mjcf(
    config: ConfigOpt,
    kinematic: Annotated[bool, typer.Option(help="Add the mocap target and constraints of the forced motion.")] = False,
) -> None:
    """Print the MuJoCo (MJCF) model of the arm, e.g. to open it in MuJoCo's viewer.

    Example: loadarm mjcf --config examples/paper.toml > arm.xml
    """
    from loadarm.arm.dynamics import mass_model
    from loadarm.design.multibody import build_mjcf, load_model

    model = _model(config)
    xml = build_mjcf(model.arm, model.mount, mass_model(model),
                     kinematic=kinematic)
    load_model(xml)  # refuse to print a model MuJoCo would not compile
    sys.stdout.write(xml)


@app.command()
def demo(
    out_dir: Annotated[Path, typer.Option("--out", help="Output directory for report.html, CSV and figures.")] = Path("out"),
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the paper's case).")] = None,
    force: ForceOpt = False,
) -> None:
    """Run an installation end to end (default: the paper's case) and write a self-contained HTML report.

    Example: loadarm demo --config examples/paper.toml --out out
    """
    from loadarm.params.config import packaged_example
    from loadarm.present.report import build_report

    source = config if config is not None else packaged_example("paper.toml")
    inst: Installation = load_config(source)
    from loadarm.files import guard_outputs
    from loadarm.present.report import report_outputs

    outputs, scenario_files = report_outputs(inst, out_dir, source)         # refused before any work or bar
    guard_outputs([("--out", p) for p in outputs], [source, *scenario_files], force=force)
    steps = 13 + len(inst.report.scenarios) + (inst.report.metocean is not None)
    with _progress() as prog:
        task = prog.add_task("starting", total=steps)

        def step(msg: str) -> None:
            prog.update(task, description=msg, advance=1)

        files = build_report(inst, out_dir, title="loadarm: the paper's case end to end" if config is None
                             else f"loadarm report: {config.name}", source=source, progress=step, force=force)
        prog.update(task, description="done", completed=steps)
    out.print(f"report: {files.html}")
    out.print(f"summary: {files.summary}")
    for name, p in files.csv.items():
        out.print(f"samples ({name} timing): {p}")


def _check_endpoint(name: str, value: str) -> None:
    from urllib.parse import urlparse

    url = urlparse(value)
    if url.scheme != "opc.tcp" or not url.hostname or url.port is None:
        raise UserError(f"{name} must be opc.tcp://HOST:PORT, got {value!r}")


def _realtime_scenario(scenario: Optional[Path], config: Optional[Path], speedup: float, command: str,
                       duration: float | None = None):
    """The scenario and its model (``--config``'s if given, checked against it) of a real-time command; without
    a scenario, the default one (``duration`` long, if given) on ``--config``'s installation."""
    from loadarm.params.scenario import Scenario, check_scenario, load_scenario

    if not speedup > 0 or not math.isfinite(speedup):
        raise UserError(f"--speedup must be a positive number, got {speedup!r}")
    if scenario is None:
        if config is None:
            raise UserError(f"{command} without --scenario needs --config (the installation)")
        from loadarm.params.config import in_range, range_text
        from loadarm.params.scenario import ScenarioHead

        if duration is not None and not in_range(ScenarioHead, "duration", duration):
            raise UserError(f"--duration must be in {range_text(ScenarioHead, 'duration')}, got {duration!r}")
        model = _model(config)
        head = {"name": config.stem} if duration is None else {"name": config.stem, "duration": duration}
        sc = Scenario.model_validate({"scenario": head})
        check_scenario(sc, model, source=f"the default scenario on {config}")
        return sc, model
    sc, model = load_scenario(scenario)
    if config is not None:
        model = _model(config)
        check_scenario(sc, model, source=str(scenario))
    return sc, model


@app.command()
def serve(
    scenario: Annotated[Optional[Path], typer.Option(
        "--scenario", "-s", help="Scenario TOML: the simulated plant, ship and sensor the controller runs against "
                                 "(with --plc: only its [guidance] and [sensor] settings and its length).")] = None,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the "
                                                                          "scenario's).")] = None,
    endpoint: Annotated[str, typer.Option("--endpoint", help="OPC UA endpoint to listen on (loopback unless "
                                                             "told otherwise).")] = "opc.tcp://127.0.0.1:4840",
    state_dir: Annotated[Path, typer.Option("--state-dir", help="Certificates, trust list and users (made on "
                                                                "first start).")] = Path("loadarm-state"),
    insecure: Annotated[bool, typer.Option("--insecure", help="Also offer the unsecured endpoint (a lab "
                                                              "only).")] = False,
    scripted: Annotated[bool, typer.Option("--scripted", help="The scenario's operator acts too (a "
                                                              "demonstration).")] = False,
    db: Annotated[Path, typer.Option("--db", help="SQLite event log (operator actions with the user's "
                                                  "name).")] = Path("loadarm-events.db"),
    speedup: Annotated[float, typer.Option("--speedup", help="Run seconds per wall second.")] = 1.0,
    plc: Annotated[Optional[str], typer.Option("--plc", help="A PLC's OPC UA endpoint (loadarm plc-sim, or a "
                                                             "real one): the plant is read from and "
                                                             "commanded through it.")] = None,
    plc_cert: Annotated[Optional[Path], typer.Option("--plc-cert", help="The PLC's certificate (DER or "
                                                                        "PEM), as you trust it.")] = None,
    plc_user: Annotated[str, typer.Option("--plc-user", help="The PLC's user for the controller.")] = "controller",
    plc_password_file: Annotated[Optional[Path], typer.Option(
        "--plc-password-file", help="File whose first line is that user's password.")] = None,
    plc_map: Annotated[Optional[Path], typer.Option("--plc-map", help="Where each tag is on the PLC (TOML; "
                                                                      "default loadarm plc-sim's nodes).")] = None,
    hmi: Annotated[Optional[str], typer.Option("--hmi", help="Serve the operator's web screen on HOST:PORT "
                                                             "(e.g. 127.0.0.1:8080; loopback unless told "
                                                             "otherwise).")] = None,
    replay: Annotated[Optional[Path], typer.Option("--replay", help="Replay a logged run on the screen (an "
                                                                    "event log; needs --hmi) instead of "
                                                                    "running the controller.")] = None,
    run_id: Annotated[Optional[str], typer.Option("--run", help="The run to replay (default the latest).")] = None,
    force: ForceOpt = False,
) -> None:
    """Run the guidance controller in real time against a scenario's simulated plant (or a PLC) and serve it over
    OPC UA (Basic256Sha256 / Aes128 / Aes256, SignAndEncrypt; users and roles from STATE_DIR/users.toml;
    client certificates trusted from STATE_DIR/pki/trusted). With --plc and no --scenario it runs until
    stopped, with the default guidance and sensor settings, on --config's installation. Ctrl-C stops.

    Example: loadarm serve --scenario examples/scenarios/driftoff.toml --state-dir out/state
    """
    from loadarm.eventlog import EventLog
    from loadarm.sim.loop import ClosedLoop
    from loadarm.opcua.security import thumbprint, _load_certificate
    from loadarm.opcua.server import OpcUaServer
    from loadarm.opcua.service import GuidanceService

    _check_endpoint("--endpoint", endpoint)
    hmi_address = None
    if hmi is not None:
        from loadarm.hmi.app import parse_hmi_address

        try:
            hmi_address = parse_hmi_address(hmi)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    if replay is not None:
        return _serve_replay(replay, run_id, scenario, config, state_dir, hmi_address)
    if plc is not None:
        _check_endpoint("--plc", plc)
        if plc_cert is None or plc_password_file is None:
            raise UserError("--plc needs --plc-cert (the PLC's certificate) and --plc-password-file")
    elif scenario is None:
        raise UserError("serve needs --scenario (a simulated plant) or --plc (a PLC's endpoint)")
    if scripted and scenario is None:
        raise UserError("--scripted needs --scenario (its operator is the scenario's)")
    sc, model = _realtime_scenario(scenario, config, speedup, "serve --plc")
    inst_file = None if scenario is None or sc.scenario.installation is None \
        else scenario.parent / sc.scenario.installation
    _outputs({"--db": db}, [scenario, inst_file, config], force, appended=("--db",))
    from datetime import datetime, timezone

    run_id = f"serve:{sc.scenario.name}@{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S.%fZ')}"
    link = None
    interrupted = False
    if plc is not None:
        from loadarm.files import read_input
        from loadarm.opcua.plc import PlcLink, load_tag_map

        tags = load_tag_map(plc_map) if plc_map is not None else None
        lines = read_input(plc_password_file, "password file").splitlines()
        if not lines or not lines[0]:
            raise UserError(f"--plc-password-file {plc_password_file}: its first line is empty")
        link = PlcLink(plc, state_dir, plc_user, lines[0], plc_cert, tags=tags)
        link.start()
    log = EventLog(db, run=run_id)
    try:
        loop = ClosedLoop(sc, model, log=log, scripted=scripted, io=link,
                          continuous=scenario is None)
        service = GuidanceService(loop, speedup=speedup)
        server = OpcUaServer(service, state_dir, endpoint, insecure=insecure, name=sc.scenario.name)
        server.start()
        screen = None
        try:
            if hmi_address is not None:
                from loadarm.hmi.app import HmiServer, create_app

                screen = HmiServer(create_app(service, state_dir, model, name=sc.scenario.name), *hmi_address)
                try:
                    screen.start()
                except OSError as exc:
                    raise UserError(str(exc)) from None
                out.print(f"operator's screen on {screen.url} (users from {server.state.users_file})")
            cert = _load_certificate(server.state.cert)
            out.print(f"OPC UA server on {endpoint} ({'with' if insecure else 'no'} unsecured endpoint); "
                      f"certificate {server.state.cert} (SHA-1 {thumbprint(cert)})")
            users = server.state.users()
            out.print(f"{len(users)} user(s) in {server.state.users_file}; trusted clients in {server.state.trusted}")
            if len(users) == 0:
                out.print(f"no one can log in yet: add a user with loadarm user add NAME --role operator "
                          f"--state-dir {state_dir}", soft_wrap=True)
            out.print(f"events to {db} (run {run_id}); Ctrl-C stops")
            try:
                service.run()
            except KeyboardInterrupt:        # the documented way to stop: say where, then exit 130
                interrupted = True
        finally:
            if screen is not None:
                screen.stop()
            server.stop()
    finally:
        log.close()
        if link is not None:
            link.stop()
    snap = service.snapshot()
    if snap is not None:
        out.print(f"stopped at t = {snap.t:.1f} s in {snap.mode}; {snap.late} late cycles")
    if interrupted:
        raise KeyboardInterrupt


def _serve_replay(db: Path, run_id: Optional[str], scenario: Optional[Path], config: Optional[Path], state_dir: Path,
                  hmi_address) -> None:
    """``serve --replay``: the screen over a logged run (no controller, no OPC UA server), until Ctrl-C."""
    import time as _time

    from loadarm.eventlog import EventLog
    from loadarm.hmi.app import HmiServer, create_app
    from loadarm.hmi.replay import ReplayService
    from loadarm.opcua.security import StateDir

    if hmi_address is None:
        raise UserError("--replay needs --hmi HOST:PORT (the screen it replays on)")
    if scenario is None and config is None:
        raise UserError("--replay needs --config (or --scenario): the installation the run was made on")
    model = _model(config) if config is not None else _realtime_scenario(scenario, None, 1.0, "serve")[1]
    log = EventLog.open_existing(db)
    try:
        events = log.query(run=run_id) if run_id is not None else log.query()
    finally:
        log.close()
    if run_id is None:
        run_id, events = _latest_run(events, f"--replay {db}: no run with state samples in the log")
    if not events:
        raise UserError(f"--run {run_id!r}: no such run in {db}")
    service = ReplayService(events, model)
    users = StateDir(state_dir).users()
    if len(users) == 0:
        raise UserError(f"--state-dir {state_dir}: no users to log in with (add one: loadarm user add NAME "
                        f"--role viewer --state-dir {state_dir})")
    screen = HmiServer(create_app(service, state_dir, model, name=f"replay of {run_id}"), *hmi_address)
    try:
        screen.start()
    except OSError as exc:
        raise UserError(str(exc)) from None
    try:
        out.print(f"replay of run {run_id} ({service.t0:.0f}-{service.t1:.0f} s, {len(service.samples)} samples) "
                  f"on {screen.url}; Ctrl-C stops", soft_wrap=True)
        sys.stdout.flush()
        while True:
            _time.sleep(0.5)
    finally:
        screen.stop()


@app.command("plc-sim")
def plc_sim(
    scenario: Annotated[Optional[Path], typer.Option(
        "--scenario", "-s", help="Scenario TOML: the plant, ship and sensor the PLC simulates (default: a calm "
                                 "ship at the default flange, on --config's installation).")] = None,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the "
                                                                          "scenario's).")] = None,
    endpoint: Annotated[str, typer.Option("--endpoint", help="OPC UA endpoint to listen on.")] =
        "opc.tcp://127.0.0.1:4841",
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The PLC's certificates, trust list and "
                                                                "users.")] = Path("loadarm-plc-state"),
    insecure: Annotated[bool, typer.Option("--insecure", help="Also offer the unsecured endpoint.")] = False,
    speedup: Annotated[float, typer.Option("--speedup", help="PLC seconds per wall second (as serve's).")] = 1.0,
    duration: Annotated[float, typer.Option("--duration", help="Seconds simulated without --scenario.")] = 3600.0,
) -> None:
    """A simulated PLC: the scenario's arm, valve drivers (with a watchdog on the controller's heartbeat), ERS
    valves, flange tracker and hard-wired E-stop in real time, served over OPC UA for `loadarm serve --plc`.
    Ctrl-C stops.

    Example: loadarm plc-sim --scenario examples/scenarios/driftoff.toml --state-dir out/plc
    """
    from loadarm.opcua.plc import PlcServer, PlcSimulator

    _check_endpoint("--endpoint", endpoint)
    sc, model = _realtime_scenario(scenario, config, speedup, "plc-sim", duration)
    sim = PlcSimulator(sc, model, speedup=speedup)
    server = PlcServer(sim, state_dir, endpoint, insecure=insecure)
    server.start()
    try:
        out.print(f"simulated PLC on {endpoint}; certificate {server.state.cert}; "
                  f"{len(server.state.users())} user(s); Ctrl-C stops", soft_wrap=True)
        sys.stdout.flush()
        sim.run()
    finally:
        server.stop()


@app.command()
def trust(
    cert: Annotated[Path, typer.Argument(help="Client certificate (DER or PEM).")],
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The server's state directory.")] = Path("loadarm-state"),
) -> None:
    """Trust an OPC UA client's certificate (copied to STATE_DIR/pki/trusted; a running server reads it at its
    next start).

    Example: loadarm trust client.der --state-dir out/state
    """
    from loadarm.opcua.security import StateDir

    out.print(f"trusted: {StateDir(state_dir).trust(cert)} (effective at the server's next start)")


user_app = typer.Typer(no_args_is_help=True, help="Users of the plant interface (STATE_DIR/users.toml).")
app.add_typer(user_app, name="user")


@user_app.command("add")
def user_add(
    name: Annotated[str, typer.Argument(help="User name (letters, digits, _.@-).")],
    role: Annotated[str, typer.Option("--role", help="viewer, operator or engineer.")],
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The server's state directory.")] = Path("loadarm-state"),
    password_stdin: Annotated[bool, typer.Option("--password-stdin", help="Read the password from the first "
                                                                          "line of stdin.")] = False,
) -> None:
    """Add or replace a user (the password scrypt-hashed; the file mode 0600).

    Example: echo 'secret' | loadarm user add alice --role operator --password-stdin --state-dir out/state
    """
    from loadarm.opcua.security import Role, StateDir

    r = Role.parse(role, "--role")
    if password_stdin:
        password = sys.stdin.readline().rstrip("\n")
    else:
        import getpass

        password = getpass.getpass(f"password for {name}: ")
        if getpass.getpass("again: ") != password:
            raise UserError("the two passwords differ")
    st = StateDir(state_dir)
    st.users().add(name, r, password)
    out.print(f"user {name} ({r.name.lower()}) written to {st.users_file}")


def _fail(message: str) -> None:
    err.print(f"loadarm: error: {' '.join(message.split())}")


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns (and exits with) the process status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 ok, 1 internal error, 2 bad input, 3 a run whose verdict is FAILED (``loadarm run``), 130 interrupted.
    """
    args = sys.argv[1:] if argv is None else argv
    try:
        rv = app(args=args, prog_name="loadarm", standalone_mode=False)
        code = rv if isinstance(rv, int) else 0
    except (LoadarmError, UserError, ValueError) as exc:
        _fail(str(exc))
        code = 2
    except OSError as exc:
        _fail(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
        code = 2
    except Exception as exc:
        # click-style exceptions (typer vendors click in recent releases, so match by shape, not by class)
        name = type(exc).__name__
        if name == "Exit" and hasattr(exc, "exit_code"):
            code = int(exc.exit_code)
        elif name == "NoArgsIsHelpError":  # the help text has already been printed
            code = 2
        elif hasattr(exc, "format_message") and hasattr(exc, "exit_code"):
            _fail(exc.format_message())
            code = 2
        elif name == "Abort":
            _fail("aborted")
            code = 130
        elif os.environ.get("LOADARM_DEBUG"):
            raise
        else:
            err.print(f"loadarm: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (this is a "
                      "bug; LOADARM_DEBUG=1 shows the traceback)")
            code = 1
    except KeyboardInterrupt:
        _fail("interrupted")
        code = 130
    if argv is None:
        sys.exit(code)
    return code


if __name__ == "__main__":  # pragma: no cover
    main()
