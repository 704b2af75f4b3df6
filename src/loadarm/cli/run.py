"""``loadarm run`` and ``loadarm log``: a closed-loop guidance run, and the event log."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from loadarm.cli.common import (
    SAFETY_FAILED,
    EventKind,
    ForceOpt,
    JsonOpt,
    PlantKind,
    Table,
    UserError,
    check_outputs,
    latest_run,
    out,
    print_json,
    progress_bar,
)
from loadarm.eventlog import EventLog, LogWriter, check_samples
from loadarm.figures import save
from loadarm.guidance.modes import MODES
from loadarm.sim.loop import run_scenario, wall_clock_pacer
from loadarm.sim.plots import timeline_figure
from loadarm.sim.spec import load_run
from loadarm.vocab import alarm_label

__all__ = ["app"]

app = typer.Typer()


@app.command()
def run(
    scenario: Annotated[Path, typer.Option("--scenario", "-s", help="Scenario TOML (see examples/scenarios/).")],
    db: Annotated[Path, typer.Option("--db", help="SQLite event log to append to.")] = Path("loadarm-events.db"),
    no_db: Annotated[bool, typer.Option("--no-db", help="Do not log events.")] = False,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Timeline figure.")] = None,
    realtime: Annotated[bool, typer.Option("--realtime", help="Pace the run with the wall clock.")] = False,
    plant: Annotated[Optional[PlantKind], typer.Option(help="Arm plant (default: the scenario's).")] = None,
    log_wait: Annotated[float, typer.Option("--log-wait", help="At the end, wait this long for an event log "
                                                                "that is unavailable (locked, disk full), s.")] = 30.0,
    force: ForceOpt = False,
) -> None:
    """Run a scenario in closed loop: ship, sensor, estimator, guidance controller, arm; log every event.

    Example: loadarm run --scenario examples/scenarios/driftoff.toml --db out/events.db --png out/timeline.png
    """

    if not no_db and str(db) == ":memory:":
        raise UserError("--db :memory: would throw the events away; name a file, or give --no-db to run without a log")
    spec = load_run(scenario)                 # the scenario, installation and berth read once, compiled once
    sc, model = spec.scenario, spec.model
    inst_file = None if sc.scenario.installation is None else scenario.parent / sc.scenario.installation
    check_outputs({"--png": png, "--db": None if no_db else db}, [scenario, inst_file], force, appended=("--db",))
    from datetime import datetime, timezone

    run_id = f"{sc.scenario.name}@{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S.%fZ')}"
    if not (0 <= log_wait <= 86400):
        raise UserError(f"--log-wait must be in [0, 86400] s, got {log_wait!r}")
    # the log off the run's path: a log locked by another process, or a full disk, holds the events in memory
    log = None if no_db else LogWriter(EventLog(db, run=run_id))
    unwritten = 0
    try:
        with progress_bar() as prog:
            task = prog.add_task(f"scenario {sc.scenario.name}", total=1.0)
            res = run_scenario(sc, model, log=log, progress=lambda f: prog.update(task, completed=f), ship=spec.ship,
                               plant=None if plant is None else plant.value,
                               pace=wall_clock_pacer() if realtime else None)
    finally:
        if log is not None:
            unwritten = log.close(timeout=log_wait)
    if unwritten:
        raise UserError(f"--db {db}: {log.status().unwritten(unwritten, log_wait)}; the run's result is not "
                        "logged whole")
    if png is not None:
        save(res.plot(), png)
    s = res.summary()
    if as_json:
        print_json(s)
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

    check_outputs({"--png": png}, [db], force)
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
        print_json([e.as_dict() for e in events])
        return
    _print_events(db, events, "" if samples or kind else " (samples hidden; --samples)")
    if png is not None:
        out.print(f"timeline written to {str(png)}")


def _print_events(db: Path, events, note: str) -> None:
    """The events as one table per run, under a line with the run's id whole: the id is what ``--run`` takes, so it
    is never cut (found: a run column at 80 columns showed "drift-off@20261…"). The table's other cells wrap."""
    by_run: dict[str, list] = {}
    for e in events:
        by_run.setdefault(e.run, []).append(e)
    out.print(f"{db}: {len(events)} event{'' if len(events) == 1 else 's'} in {len(by_run)} "
              f"run{'' if len(by_run) == 1 else 's'}{note}")
    for run_id, evs in by_run.items():
        out.print(f"run {run_id}: {len(evs)} event{'' if len(evs) == 1 else 's'}")
        t = Table()
        for col in ("id", "t [s]", "mode", "kind"):
            t.add_column(col, no_wrap=True)
        t.add_column("reason", overflow="fold")
        for e in evs:
            t.add_row(str(e.id), f"{e.t:.2f}", e.state, e.kind, e.reason)
        out.print(t)


def _replay_png(png: Path, events) -> None:

    last_run, events = latest_run(events, "the log has no state samples to replay (was it written by loadarm "
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
