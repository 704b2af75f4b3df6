"""``loadarm validate FILE``: what kind of input a file is, and whether the command that takes it would accept it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from loadarm.cli.common import JsonOpt, UserError, out, print_json, read_model
from loadarm.errors import ConfigError
from loadarm.params.bank import load_bank
from loadarm.params.berth import load_berth
from loadarm.params.config import Installation, load_sizing_case
from loadarm.params.kinds import KINDS, identify
from loadarm.params.scenario import read_scenario
from loadarm.studies.metocean import read_metocean

__all__ = ["app"]

app = typer.Typer()

#: The tables a full installation must have; with fewer, an installation file is a datasheet for sizing.
REQUIRED_TABLES = frozenset(n for n, f in Installation.model_fields.items() if f.is_required())


def _check(kind: str, path: Path, tables) -> tuple[str, str]:
    """Read ``path`` as its kind's command does (every value, every cross-check): what it holds, in a few words,
    and the command that takes it."""
    command = KINDS[kind].command
    if kind == "installation" and not REQUIRED_TABLES <= set(tables):
        load_sizing_case(path)
        missing = ", ".join(f"[{t}]" for t in sorted(REQUIRED_TABLES - set(tables)))
        return f"a datasheet, for sizing only (an installation also has {missing})", "loadarm size --config"
    if kind == "installation":
        arm = read_model(path).arm
        return f"riser a = {arm.a:g} m, arm b = {arm.b:g} m, c = {arm.c:g} m", command
    if kind == "scenario":
        sc, _, _ = read_scenario(path)
        return f"{sc.scenario.name!r}, {sc.scenario.duration:g} s, {sc.ship.model} ship", command
    if kind == "berth":
        b = load_berth(path)
        return f"{len(b.moorings)} mooring lines, {len(b.fenders)} fenders", command
    if kind == "bank":
        k = load_bank(path)
        return f"{len(k.shapes)} arms ({', '.join(k.names)}), {len(k.file.manifold.flanges)} flanges", command
    _, gaps = read_metocean(path)
    return gaps.summary(), command


@app.command()
def validate(
    file: Annotated[Path, typer.Argument(help="Any input: an installation (or its datasheet), a scenario or a berth "
                                              "(TOML), a metocean record (CSV or NetCDF).")],
    as_json: JsonOpt = False,
) -> None:
    """Name the kind of input FILE is, by what it holds, and check it as the command that takes it would: every
    value against its range, the files it names, the cross-checks. Exit 0 valid; exit 2 not, in one line that
    names the file, the key, the value and its range.

    Example: loadarm validate examples/scenarios/driftoff.toml
    """

    kind, data = identify(file)
    try:
        what, command = _check(kind.name, file, data)
    except ConfigError as exc:
        raise UserError(f"{exc} (read as {kind.noun})") from None
    if as_json:
        print_json({"file": str(file), "kind": kind.name, "command": command, "valid": True, "holds": what})
        return
    out.print(f"{file}: {kind.noun}, valid: {what}; `{command} {file}` takes it")

