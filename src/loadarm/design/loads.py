"""Actuator loads along a planned approach: forces, pressures, speeds, flows.

Joint torques come from :func:`loadarm.arm.dynamics.joint_torques` (gravity,
counterweights, inertia) along the plan's joint trajectory; the cylinder
forces from the exact moment arms of Eqs 12-13; pressures from the force
balance of a single-rod cylinder with the other chamber at return pressure;
flows from the extension speed times the piston area (extending) or the
annulus area (retracting).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.dynamics import chamber_pressures, cylinder_forces, joint_torques, mass_model
from loadarm.design.plots import loads_figure
from loadarm.design.trajectory import Plan
from loadarm.results import Metric, Result

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["CYLINDER_LOAD_METRICS", "ActuatorLoads", "actuator_loads"]


#: Per-cylinder load metrics, declared once (the CLI and the report print each cylinder's row from them).
CYLINDER_LOAD_METRICS = (
    Metric("peak_force_N", "peak force", "kN", ".1f", scale=1e-3),
    Metric("rms_force_N", "RMS force", "kN", ".1f", scale=1e-3),
    Metric("peak_pressure_bar", "peak pressure", "bar", ".1f"),
    Metric("peak_speed_m_s", "peak speed", "mm/s", ".2f", scale=1e3),
    Metric("peak_flow_L_min", "peak flow", "L/min", ".2f"),
)


@dataclass(frozen=True)
class ActuatorLoads(Result):
    """Loads of both cylinders along a plan; arrays have shape ``(n,)``.

    Attributes
    ----------
    t : ndarray
        Time, s.
    tau_alpha, tau_beta : ndarray
        Joint torques, N m.
    force1, force2 : ndarray
        Cylinder forces, N (positive = pushing).
    pressure1, pressure2 : ndarray
        Pressure of the working chamber, Pa.
    speed1, speed2 : ndarray
        Extension speeds, m/s.
    flow1, flow2 : ndarray
        Oil flow into the working chamber, m^3/s.
    max_pressure : float
        Rating the pressures are compared with, Pa.
    """

    t: np.ndarray
    tau_alpha: np.ndarray
    tau_beta: np.ndarray
    force1: np.ndarray
    force2: np.ndarray
    pressure1: np.ndarray
    pressure2: np.ndarray
    speed1: np.ndarray
    speed2: np.ndarray
    flow1: np.ndarray
    flow2: np.ndarray
    max_pressure: float

    def _values(self) -> dict:
        """Peak and RMS values per cylinder, JSON-friendly (bar and L/min at the edge too)."""
        out = {}
        for i, (F, p, v, q) in enumerate(((self.force1, self.pressure1, self.speed1, self.flow1),
                                          (self.force2, self.pressure2, self.speed2, self.flow2)), start=1):
            peak_p = float(np.max(p))
            out[f"cylinder{i}"] = {
                "peak_force_N": float(np.max(np.abs(F))),
                "rms_force_N": float(np.sqrt(np.mean(F ** 2))),
                "peak_pressure_Pa": peak_p,
                "peak_pressure_bar": peak_p / 1e5,
                "peak_speed_m_s": float(np.max(np.abs(v))),
                "peak_flow_m3_s": float(np.max(q)),
                "peak_flow_L_min": float(np.max(q)) * 60e3,
                "pressure_ok": bool(peak_p <= self.max_pressure),
            }
        out["peak_torque_alpha_Nm"] = float(np.max(np.abs(self.tau_alpha)))
        out["peak_torque_beta_Nm"] = float(np.max(np.abs(self.tau_beta)))
        out["max_pressure_bar"] = self.max_pressure / 1e5
        return out

    def _figure(self):

        return loads_figure({"approach": self})


def actuator_loads(model: ArmModel, plan: Plan, *, fill: float | None = None) -> ActuatorLoads:
    """Forces, pressures, speeds and flows of both cylinders along a plan.

    Parameters
    ----------
    model : ArmModel
        Mass model (``[masses]``), mounting and cylinder sizes (``[cylinders]``).
    plan : Plan
        The approach (with joint rates and accelerations).
    fill : float, optional
        Product fill fraction; default ``masses.fill``.

    Returns
    -------
    ActuatorLoads
    """
    mm = mass_model(model, fill=fill)
    mount = model.mount
    cyl = model.cylinders
    ta, tb = joint_torques(mm, plan.alpha, plan.beta, plan.alpha_dot, plan.beta_dot, plan.alpha_ddot,
                           plan.beta_ddot)
    F1, F2 = cylinder_forces(mount, plan.alpha, plan.beta, ta, tb)
    Ap, Aa = model.cylinder_area
    pressures = []
    for F in (F1, F2):
        pA, pB = chamber_pressures(F, cyl.bore, cyl.rod, cyl.return_pressure)
        pressures.append(np.maximum(pA, pB))
    flows = [np.where(v >= 0, Ap * v, -Aa * v) for v in (plan.v_ac1, plan.v_ac2)]
    return ActuatorLoads(plan.t, ta, tb, F1, F2, pressures[0], pressures[1], plan.v_ac1, plan.v_ac2, flows[0],
                         flows[1], cyl.max_pressure)
