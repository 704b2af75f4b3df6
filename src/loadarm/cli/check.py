"""``loadarm check``: the design check before operation."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer

from loadarm.cli.common import (
    ForceOpt,
    JsonOpt,
    Table,
    UserError,
    check_outputs,
    err,
    out,
    print_json,
    read_model,
)
from loadarm.design.check import design_check
from loadarm.figures import save
from loadarm.hydraulics.bank_release import STEPS
from loadarm.params.bank import load_bank
from loadarm.studies.bank_check import check_bank, overload_line

__all__ = ["app"]

app = typer.Typer()


@app.command()
def check(
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML file (see "
                                                                          "examples/paper.toml).")] = None,
    bank: Annotated[Optional[Path], typer.Option("--bank", help="A bank of arms (see "
                                                                "examples/banks/lng150k_bank.toml) instead of one "
                                                                "installation.")] = None,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: distance needed against available, per "
                                                              "direction.")] = None,
    force: ForceOpt = False,
) -> None:
    """Design check before operation: the largest drift each direction absorbs, from the alarm angles, the
    sequence times and the arm's limits; refuses (exit 2) an installation whose alarms cannot absorb its own
    design drift.

    With --bank: the bank's arms along their approaches (clearance), their swivels at the design case, their
    loads on the ship's flanges (connected and free-wheeling, over the design case and the flange box's corners,
    wind and friction) against the allowable, and one emergency release for all on the shared power unit's
    accumulators, the pumps lost; refuses (exit 2) a bank whose power unit cannot release every arm in time, or
    whose arms overload the manifold, naming the shortfall.

    Example: loadarm check --config examples/paper.toml --png out/check.png
    """

    if (config is None) == (bank is None):
        raise UserError("loadarm check takes one of --config FILE or --bank FILE")
    if bank is not None:
        _check_bank(bank, as_json, png, force)
        return
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


def _check_bank(path: Path, as_json: bool, png: Optional[Path], force: bool) -> None:
    """``loadarm check --bank``: clearance along the approaches and their order, the swivels' margins at the design
    case and over the flanging area and the ship's motions, the manifold loads, the release."""
    check_outputs({"--png": png}, [path], force)
    bank = load_bank(path)
    checks = check_bank(bank)       # the one place of the checks and their refusals (the report shows them too)
    quoted = bank.file.manifold_loads.as_quoted()
    note = (f"{', '.join(quoted)} are the defaults, as commonly quoted from OCIMF's loading-arm specification and not "
            "checked against it: confirm them for the flange size before relying on the manifold-load verdict "
            "(and name the document in manifold_loads.confirmed_by)"
            if quoted else None)
    if checks.refusals:              # a manifold-load refusal on unconfirmed figures says so, on its one line
        said = checks.refusals[0]
        on_loads = not checks.loads.ok and said == overload_line(bank, checks.loads.exceeded)
        raise UserError(said + (f"; note: {note}" if note and on_loads else ""))
    over, order, margins, swivels, loads, release = (checks.over, checks.order, checks.swivel_margins,
                                                     checks.swivels, checks.loads, checks.release)
    clearance = order.clearance
    if png is not None:
        save(release.plot(), png)
    names = bank.names
    pairs = clearance.pair_minimum.min(axis=1)
    nearest = [min(float(g) for (a, b), g in zip(clearance.pairs, pairs, strict=True) if i in (a, b))
               for i in range(len(names))]
    if as_json:
        print_json({"bank": str(path), "clearance": clearance.to_dict(), "approach_order": order.to_dict(),
                    "notes": [note] if note else [],
                    "release": release.to_dict(),
                    "manifold_loads": loads.to_dict(),
                    "swivel_margin_deg": {n: float(np.degrees(margins[i].min())) for i, n in enumerate(names)},
                    "swivel_envelope": swivels.to_dict(),
                    "approaches_over_flanging_area": [{"displacement_m": list(d), "waves": [list(w) for w in o.waves],
                                                       "min_clearance_m": o.clearance.min_clearance}
                                                      for d, o in over],
                    "nearest_arm_m": dict(zip(names, nearest, strict=True))})
        return
    out.print(f"{path}: {bank.file.bank.name}: {len(names)} arms, pass")
    out.print(str(clearance.summary()))
    out.print(str(order.summary()))
    d, worst = min(over[1:], key=lambda c: c[1].clearance.min_clearance)
    orders = Counter(" -> ".join(" + ".join(w) for w in o.waves) for _, o in over[1:])
    out.print(f"approaches along the flanging area's edges ({len(over) - 1} points): least clearance "
              f"{worst.clearance.min_clearance:.3f} m (manifold moved by {d[0]:+.2f}, {d[1]:+.2f}, {d[2]:+.2f} m); "
              "orders: " + "; ".join(f"{w} ({n} points)" for w, n in orders.most_common()))
    out.print(str(swivels.summary()))
    out.print(str(loads.summary()))
    out.print(str(release.summary()))
    use = loads.utilisation.max(axis=1)
    t = Table("arm", "nearest arm on approach m", "swivel margin deg rest/ship moving", "flange load / allowable",
              *(f"{s} took s (limit)" for s in STEPS[:2]), "clear at s")
    moving = np.degrees(swivels.by_arm())
    for i, n in enumerate(names):
        st = [s for s in release.steps if s.arm == i]
        t.add_row(n, f"{nearest[i]:.2f}", f"{np.degrees(margins[i].min()):.1f}/{moving[i]:.1f}", f"{use[i]:.2f}",
                  *(f"{release.end[i, j] - release.start[i, j]:.2f} ({st[j].limit:g})" for j in range(2)),
                  f"{release.end[i, 2]:.2f}")
    out.print(t)
    if note:
        err.print(f"loadarm: note: {note}")

