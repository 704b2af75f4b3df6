"""The berth's design ship at a glance: natural periods, mooring stiffness, static offset, RAOs (``loadarm hydro``
and the report's berth section)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from loadarm.figures import subplots
from loadarm.params.berth import Environment
from loadarm.results import Metric, Result
from loadarm.ship.hydro import DOFS
from loadarm.ship.model import ShipModel
from loadarm.ship.mooring import equilibrium, line_tensions
from loadarm.ship.motion import mean_load

__all__ = ["ShipSummary", "ship_summary"]


@dataclass(frozen=True)
class ShipSummary(Result):
    """Natural periods, stiffness and static offset of a moored ship (the RAOs for the figure)."""

    periods: dict
    stiffness: np.ndarray
    mean_load: np.ndarray
    offset: np.ndarray
    tension_max: float
    tension_line: str
    mbl: float
    key: str
    panels: int
    ship: ShipModel = field(repr=False)

    METRICS = (
        Metric("hydro_key", "hydrodynamic coefficients (cache key)"),
        Metric("panels", "hull panels (capytaine)", "", "d"),
        Metric("surge_sway_yaw_periods_s", "moored natural periods (3 modes)", "s", ".1f"),
        Metric("heave_period_s", "heave natural period", "s", ".1f"),
        Metric("roll_period_s", "roll natural period", "s", ".1f"),
        Metric("pitch_period_s", "pitch natural period", "s", ".1f"),
        Metric("stiffness_x_kn_per_m", "lines' stiffness off the berth", "kN/m", ".0f"),
        Metric("stiffness_y_kn_per_m", "lines' stiffness along the berth", "kN/m", ".0f"),
        Metric("stiffness_yaw_mnm_per_deg", "lines' stiffness in yaw", "MN m/deg", ".1f"),
        Metric("mean_load_kn", "design mean load (x, y)", "kN", ".0f"),
        Metric("static_offset_m", "static offset under it (x, y)", "m", ".3f"),
        Metric("tension_max_kn", "largest line tension there", "kN", ".0f"),
        Metric("tension_line", "in line"),
    )

    def _values(self) -> dict:
        p = self.periods
        k = self.stiffness
        return {"hydro_key": self.key, "panels": self.panels,
                "surge_sway_yaw_periods_s": [p[f"lf_mode_{i}_s"] for i in (1, 2, 3)],
                "heave_period_s": p["heave_s"], "roll_period_s": p["roll_s"], "pitch_period_s": p["pitch_s"],
                "stiffness_x_kn_per_m": k[0, 0] / 1e3, "stiffness_y_kn_per_m": k[1, 1] / 1e3,
                "stiffness_yaw_mnm_per_deg": k[2, 2] * math.pi / 180 / 1e6,
                "mean_load_kn": [float(v) / 1e3 for v in self.mean_load[:2]],
                "static_offset_m": [float(v) for v in self.offset[:2]],
                "tension_max_kn": self.tension_max / 1e3, "tension_line": self.tension_line,
                "tension_max_fraction_mbl": self.tension_max / self.mbl}

    def to_dict(self) -> dict:
        """Headline numbers plus the 3 x 3 stiffness (N/m, N/rad, N m/m, N m/rad).

        Returns
        -------
        dict
        """
        return dict(self._values(), stiffness_matrix=self.stiffness.tolist())

    def _figure(self):
        return rao_figure(self.ship)


def rao_figure(ship: ShipModel):
    """RAO amplitudes of the six motions against the wave period, beam and quartering seas.

    Parameters
    ----------
    ship : ShipModel

    Returns
    -------
    matplotlib.figure.Figure
    """

    h = ship.hydro
    fig, axes = subplots(2, 3, figsize=(11, 6), sharex=True)
    period = 2 * math.pi / h.omega
    for j, ax in enumerate(axes.ravel()):
        for deg, style in ((90, "-"), (135, "--"), (180, ":")):
            k = int(np.argmin(np.abs(np.degrees(h.heading) - deg)))
            amp = np.abs(ship.rao[:, k, j]) * (1.0 if j < 3 else 180 / math.pi)
            ax.plot(period, amp, style, color="0.2", label=f"{deg} deg")
        ax.set_title(DOFS[j], fontsize=9)
        ax.set_ylabel("m/m" if j < 3 else "deg/m", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("wave period [s]")
    axes[0, 0].legend(fontsize=7, title="heading (0 = following)", title_fontsize=7)
    fig.suptitle("Motion RAOs at the centre of gravity (capytaine, moored, viscous roll damping)", fontsize=10)
    fig.tight_layout()
    return fig


def ship_summary(ship: ShipModel, env: Environment) -> ShipSummary:
    """Summarise a compiled ship under its design environment.

    Parameters
    ----------
    ship : ShipModel
    env : Environment

    Returns
    -------
    ShipSummary
    """
    load = mean_load(ship, env)
    eq = equilibrium(ship.moorings, load, eta0=ship.eq0)
    ten = line_tensions(ship.moorings, eq)
    j = int(np.argmax(ten / ship.moorings.mbl))
    return ShipSummary(ship.natural_periods(), ship.k_lines, load, eq - ship.eq0,
                       float(ten[j]), ship.names[j], float(ship.moorings.mbl[j]), ship.hydro.key, ship.hydro.panels,
                       ship)
