"""``loadarm warmup``: compile every numba kernel into the cache once, in parallel, before anything needs it.

loadarm's compiled kernels (the 1 kHz hydraulic circuit, the moored ship's integrators and set-down pairs, the
bank's clearance and sequence, the operability monitor) are compiled on their first call and kept in numba's
cache, stamped with every source file of the package (:mod:`loadarm._numba`). A cold first call costs about a
second per kernel: a real-time run pays it before its clock starts (``warm_up``), a study pays it in every worker
process, and a test run in every worker.

This command pays it once: a few short workloads, one per family of kernels, each in a process of its own, run side
by side on the machine's cores. It is what to run after installing or updating loadarm on a controller, and what
``make test`` runs before the suite (the suite's workers then load the machine code instead of compiling it
twice). On a warm cache it only runs the workloads (a few seconds).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from loadarm.arm.clearance import pair_clearance_compiled
from loadarm.cli.common import out
from loadarm.design.trajectory import plan_approach
from loadarm.guidance.predict import ar_forecast, fit_ar
from loadarm.hydraulics.reference import cylinder_rig, reference_simulation
from loadarm.hydraulics.simulate import simulate_approach
from loadarm.params.bank import load_bank
from loadarm.params.berth import load_berth
from loadarm.params.compiler import compile_model
from loadarm.params.config import load_config, packaged_example
from loadarm.params.scenario import read_scenario
from loadarm.ship.model import compile_ship
from loadarm.ship.mooring import restoring_force
from loadarm.sim.loop import run_scenario
from loadarm.studies.bank_campaign import bank_sequence, sequence_table
from loadarm.studies.kernel import floor_table, monitor_record, relative_record

__all__ = ["FAMILIES", "app", "warm_family"]

app = typer.Typer()


def _examples() -> Path:
    return packaged_example("paper.toml").parent


def _run(name: str, plant: str | None = None) -> None:
    sc, model, _ = read_scenario(_examples() / "scenarios" / name)
    short = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": 5.0})})
    run_scenario(short, model, plant=plant)


def _closed_loop() -> None:
    """The guidance controller, its monitor and the hydraulic plant: a short drift-off."""
    _run("driftoff.toml", "hydraulic")


def _hydraulics() -> None:
    """The hydraulic circuit on its own (the approach simulator, its ``solve_ivp`` reference and the cylinder
    rig), then the operability monitor."""
    model = compile_model(load_config(_examples() / "paper.toml"))
    plan = plan_approach(model, samples=201)
    simulate_approach(model, plan)
    reference_simulation(model, plan, 0.02)
    cylinder_rig(model, mass=1000.0, duration=0.02, x0=0.3, spool=0.2)
    _operability()


def _moored_ship() -> None:
    """The moored ship: its equilibrium and stiffness, the set-down pairs, the low-frequency integrator and the
    flange's record, the lines' parting: short moored runs in waves and of the break-out."""
    _run("hs15_moored.toml")
    _run("breakout.toml")
    ship = compile_ship(load_berth(_examples() / "berths" / "lng150k.toml"))
    restoring_force(ship.moorings, [0.1, 0.2, 0.001])


def _bank() -> None:
    """The bank's compiled clearance and emergency sequence, on a few poses and samples with the types its
    campaign and monitor pass (a seed of the bank's campaign compiled them too, but spent 6 s of a warm cache on its
    design-drift tables and release simulation, measured 2026-12-07)."""
    bank = load_bank(_examples() / "banks" / "lng150k_bank.toml")
    q = np.asarray(bank.connected[1], dtype=float)
    pair_clearance_compiled(bank.shapes[0], bank.shapes[1], np.stack([q, q]), bank.connected[1])
    arms, n = len(bank.names), 4
    bank_sequence(np.zeros((arms, n), dtype=np.int64), np.full((arms, n), np.inf), sequence_table(bank.models),
                  *[np.full(arms, -1, dtype=np.int64) for _ in range(3)])


def _operability() -> None:
    """The operability monitor (the floor table's lookup, the per-sample pass, the scan of a record, including
    samples beyond the table) and the flange predictor's refit and forecast."""
    model = compile_model(load_config(_examples() / "full.toml"))
    fx, fz = model.approach.flange
    table = floor_table(model, [fx - 1.0, -1.0, fz - 1.0], [fx + 1.0, 1.0, fz + 1.0], spacing=0.5)
    t = np.linspace(0.0, 60.0, 601)
    p = np.column_stack([fx + 0.05 * t, np.zeros_like(t), np.full_like(t, fz)])
    monitor_record(model, table, p, 0.1)
    relative_record(p, p[0].copy(), np.zeros(3), np.empty((3, len(p))))
    table.lookup(np.array([[fx, 0.0, fz]]))
    track = np.random.default_rng(0).normal(size=(200, 3))
    ar_forecast(fit_ar(track, order=10), track, 20)                    # the flange predictor's refit and forecast


#: Each family of kernels and the workload that compiles it (one process each).
FAMILIES = {"closed loop": _closed_loop, "moored ship": _moored_ship, "hydraulics and operability": _hydraulics,
            "bank": _bank}


def warm_family(name: str) -> tuple[str, float]:
    """Run one family's workload (in a worker process) and time it.

    Parameters
    ----------
    name : str
        A key of :data:`FAMILIES`.

    Returns
    -------
    tuple of (str, float)
        The name and the seconds it took.
    """
    t0 = time.perf_counter()
    FAMILIES[name]()
    return name, time.perf_counter() - t0


@app.command()
def warmup(
    jobs: Annotated[Optional[int], typer.Option("--jobs", "-j", min=1, max=64,
                                               help="Processes side by side (default: one per core).")] = None,
) -> None:
    """Compile every numba kernel into the cache once, the families side by side (run after installing).

    Example: loadarm warmup
    """
    n = jobs or max(1, min(len(FAMILIES), os.cpu_count() or 1))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=n) as pool:
        for name, seconds in pool.map(warm_family, sorted(FAMILIES, key=_ORDER.index)):
            out.print(f"compiled: {name} ({seconds:.1f} s)")
    out.print(f"warm: {len(FAMILIES)} families in {time.perf_counter() - t0:.1f} s on {n} processes")


#: Longest first, so that the processes finish together (measured cold on 2 cores).
_ORDER = ["moored ship", "hydraulics and operability", "closed loop", "bank"]
