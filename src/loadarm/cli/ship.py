"""``loadarm hydro`` and ``loadarm alarms``: the moored ship, and the alarm design from its drift."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import (
    BerthOpt,
    ForceOpt,
    JsonOpt,
    Table,
    UserError,
    check_outputs,
    err,
    out,
    print_json,
    print_wide,
    progress_bar,
    read_model,
)
from loadarm.design.alarm_design import DesignSettings, design_alarms
from loadarm.design.bank_alarms import design_bank_alarms
from loadarm.figures import save
from loadarm.params.bank import load_bank
from loadarm.params.berth import load_berth
from loadarm.ship.model import compile_ship
from loadarm.ship.summary import ship_summary

__all__ = ["app"]

app = typer.Typer()


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

    check_outputs({"--png": png}, [berth], force)
    b = load_berth(berth)
    ship = compile_ship(b, solve=True, progress=not as_json, source=str(berth))
    res = ship_summary(ship, b.environment)
    if png is not None:

        save(res.plot(), png)
    if as_json:
        print_json(res.to_dict())
    else:
        out.print(str(res.summary()))


@app.command()
def alarms(
    berth: BerthOpt,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML file (see "
                                                                          "examples/paper.toml).")] = None,
    bank: Annotated[Optional[Path], typer.Option("--bank", help="A bank of arms (see "
                                                                "examples/banks/lng150k_bank.toml) instead of one "
                                                                "installation: every arm's alarms from one mooring "
                                                                "analysis, the settings each installation file "
                                                                "shares.")] = None,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Figure: the alarm zones and the break-out "
                                                              "stages.")] = None,
    seeds: Annotated[int, typer.Option("--seeds", help="Realisations of the design sea state per case (at least 20 "
                                                     "for the extreme-value fit of the allowance).")] = 20,
    exceedance: Annotated[float, typer.Option("--exceedance", help="Probability per hour, in the design weather "
                                                                    "with the lines intact, that the flange passes "
                                                                    "ESD-1's allowance.")] = 1e-4,
    force: ForceOpt = False,
) -> None:
    """Design the alarm settings of this arm at this berth from a mooring analysis of its design ship (intact
    and break-out, Choi et al. 2018; Lanquetin): per face, the drift allowance, the break-out drift per stage
    and the recommended beta, slew and design-drift settings as blocks to paste into the installation. Refuses
    (exit 2), naming the face and the shortfall, when the arm cannot absorb the design drift.

    With --bank: one mooring analysis, each arm's flange on the ship (its offset and height), each arm's stages
    on its own flange's drift, and the settings to paste into each installation file that suit every arm built
    from it; refuses (exit 2) naming the arm.

    Example: loadarm alarms --config examples/paper.toml --berth examples/berths/lng150k.toml --png out/alarms.png
    """

    check_outputs({"--png": png}, [config, berth, bank], force)
    if (config is None) == (bank is None):
        raise UserError("loadarm alarms takes one of --config FILE or --bank FILE")
    if not 1 <= seeds <= 100:
        raise UserError(f"--seeds must be in [1, 100], got {seeds}")
    if not 1e-8 <= exceedance <= 1e-2:                    # NaN fails too
        raise UserError(f"--exceedance must be in [1e-08, 0.01] per hour, got {exceedance:g}")
    settings = DesignSettings(seeds=seeds, exceedance_per_hour=exceedance)
    if bank is not None:
        _bank_alarms(bank, berth, settings, as_json, png)
        return
    model = read_model(config)
    res = _analysed(berth, png, "mooring analysis",
                    lambda ship, env, progress: design_alarms(model, ship, env, settings=settings, progress=progress))
    if as_json:
        print_json(res.to_dict())
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
        print_wide(t, 100)
        out.print("Paste into the installation:")
        out.print(res.toml().rstrip("\n"))
        for w in res.warnings:
            err.print(f"loadarm: note: {w}")
    if not res.ok:
        raise UserError(f"{berth}: refused: " + "; ".join(res.problems))


def _analysed(berth: Path, png: Optional[Path], label: str, design):
    """The berth's ship compiled, ``design(ship, environment, progress)`` run under a progress bar, its figure
    saved to ``png`` if asked: the one arm's alarm design and the bank's."""
    b = load_berth(berth)
    ship = compile_ship(b, source=str(berth))
    with progress_bar() as prog:
        task = prog.add_task(label, total=1.0)
        res = design(ship, b.environment, lambda f: prog.update(task, completed=f))
    if png is not None:

        save(res.plot(), png)
    return res


def _bank_alarms(path: Path, berth: Path, settings: DesignSettings, as_json: bool, png: Optional[Path]) -> None:
    """``loadarm alarms --bank``: every arm's alarm design from one mooring analysis."""
    from rich import box

    bank = load_bank(path)
    res = _analysed(berth, png, "mooring analysis (every flange)",
                    lambda ship, env, progress: design_bank_alarms(bank, ship, env, settings=settings,
                                                                   progress=progress))
    if as_json:
        print_json(res.to_dict())
    else:
        out.print(str(res.summary()))
        t = Table("arm", "allow m", "ESD-1 beta", "ERS-2 beta", "ESD-1 slew", "ERS-2 slew", "margin m",
                  "verdict", box=box.SIMPLE_HEAD, pad_edge=False)
        for r in res.arm_rows():
            t.add_row(r["arm"], f"{r['allowance_m']:.2f}",
                      *("-" if r[k] is None else f"{r[k]:.1f}" for k in ("first_beta_deg", "release_beta_deg",
                                                                        "first_slew_deg", "release_slew_deg")),
                      "-" if r["shared_margin_m"] is None else f"{r['shared_margin_m']:+.2f}",
                      r["verdict"])
        print_wide(t, 110)
        if any(r["verdict"] == "holds by the floor" for r in res.arm_rows()):
            out.print("margin: the least of the shared settings on the arm. holds by the floor: a shared angle "
                      "alone is late for the break-out, or fires inside the intact drift allowance, by the negative "
                      "margin; the design-drift floor of the connected-mode monitor raises ESD-1 by the time to the "
                      "face whatever the angles")
        for f in res.shared:
            out.print(f"Paste into {f}:")
            out.print(res.toml(f).rstrip("\n"))
        for c in res.costs:
            err.print(f"loadarm: note: {c}")
    if not res.ok:
        raise UserError(f"{path}: refused: " + "; ".join(res.problems))
