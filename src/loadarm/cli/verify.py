"""``loadarm verify`` and ``loadarm mjcf``: the closed forms against MuJoCo, and the arm as MJCF."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.arm.dynamics import mass_model
from loadarm.cli.common import ConfigOpt, ForceOpt, JsonOpt, Timing, check_outputs, err, out, print_json, read_model
from loadarm.design.multibody import VERIFY_SAMPLES, build_mjcf, load_model, verify_kinematics
from loadarm.design.plots import verification_figure
from loadarm.design.trajectory import plan_approach
from loadarm.figures import save

__all__ = ["app"]

app = typer.Typer()


@app.command()
def verify(
    config: ConfigOpt,
    timing: Annotated[Timing, typer.Option(help="Timing law of the approach to verify.")] = Timing.paper,
    samples: Annotated[int, typer.Option(help="Number of samples along the approach.")] = VERIFY_SAMPLES,
    as_json: JsonOpt = False,
    png: Annotated[Optional[Path], typer.Option("--png", help="Draw closed form and MuJoCo over each other.")] = None,
    force: ForceOpt = False,
) -> None:
    """Verify the closed-form kinematics in MuJoCo (paper Section 4, Fig. 8).

    Example: loadarm verify --config examples/paper.toml --png out/verification.png
    """

    timing = timing.value
    check_outputs({"--png": png}, [config], force)
    model = read_model(config)
    p = plan_approach(model, timing=timing, samples=samples)
    with err.status("stepping the MuJoCo arm along the line"):
        res = verify_kinematics(model, p)
    if png is not None:

        save(verification_figure(res), png)
    s = res.summary()
    if as_json:
        print_json(s)
        return
    out.print(f"MuJoCo against the closed form, {s['samples']} samples ({timing} timing):")
    out.print(f"  max |alpha| difference {s['max_alpha_diff_deg']:.3e} deg, max |beta| difference "
              f"{s['max_beta_diff_deg']:.3e} deg")
    out.print(f"  max |r_ac1| difference {s['max_r_ac1_diff_mm']:.3e} mm, max |r_ac2| difference "
              f"{s['max_r_ac2_diff_mm']:.3e} mm")
    if png is not None:
        out.print(f"figure written to {png}")


@app.command()
def mjcf(
    config: ConfigOpt,
    kinematic: Annotated[bool, typer.Option(help="Add the mocap target and constraints of the forced motion.")] = False,
) -> None:
    """Print the MuJoCo (MJCF) model of the arm, e.g. to open it in MuJoCo's viewer.

    Example: loadarm mjcf --config examples/paper.toml > arm.xml
    """

    model = read_model(config)
    xml = build_mjcf(model.arm, model.mount, mass_model(model),
                     kinematic=kinematic)
    load_model(xml)  # refuse to print a model MuJoCo would not compile
    sys.stdout.write(xml)
