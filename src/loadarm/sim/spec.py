"""A run specification, compiled once (as MuJoCo compiles its XML into an ``MjModel``): the scenario's frozen
sections, the compiled arm, the compiled ``[guidance]`` record and, for a moored scenario, its berth read once and
its ship compiled once. The command line builds one with :func:`load_run` and the closed loop takes its parts; no
stage reads a file again.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from loadarm.params.berth import Berth
from loadarm.params.scenario import GuidanceSettings, Scenario, read_scenario
from loadarm.ship.model import ShipModel, compile_ship, moored_ship

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["RunSpec", "compile_run", "load_run"]


@dataclass(frozen=True)
class RunSpec:
    """Everything a closed-loop run needs, compiled.

    Attributes
    ----------
    scenario : Scenario
        The scenario's sections (frozen, validated at the edge).
    model : ArmModel
        The installation, compiled.
    guidance : GuidanceSettings
        The ``[guidance]`` section as the controller takes it.
    berth : Berth or None
        The moored scenario's berth file, read once (None: the simple ship).
    ship : ShipModel or None
        Its ship, compiled once (None: the simple ship).
    """

    scenario: Scenario
    model: ArmModel
    guidance: GuidanceSettings
    berth: Berth | None
    ship: ShipModel | None


def compile_run(sc: Scenario, model: ArmModel, *, berth: Berth | None = None,
                ship: ShipModel | None = None) -> RunSpec:
    """Compile a run from its parts: the guidance record, and the ship of a moored scenario (from ``berth`` when
    it was read already, else from the scenario's berth file; ``ship`` when it was compiled already).

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    berth : Berth, optional
    ship : ShipModel, optional

    Returns
    -------
    RunSpec
    """
    if ship is None and sc.ship.model == "moored":
        ship = moored_ship(sc) if berth is None else compile_ship(berth, source=str(sc.ship.berth))
    return RunSpec(sc, model, sc.guidance.compile(), berth, ship)


def load_run(path: str | Path) -> RunSpec:
    """Read a scenario file, the installation and the berth it names (each once) and compile the run.

    Parameters
    ----------
    path : str or Path
        Scenario TOML.

    Returns
    -------
    RunSpec

    Raises
    ------
    ConfigError
        Missing or invalid file.
    """
    sc, model, berth = read_scenario(path)
    return compile_run(sc, model, berth=berth)
