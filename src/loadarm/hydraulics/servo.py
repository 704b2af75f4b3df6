"""The two hydraulic servo drives as a stateful plant for the live-guidance loop.

:class:`HydraulicArm` keeps the electro-hydraulic state (pressures, spools,
supply, the arm's alpha and beta and their rates, the PID states) between
guidance cycles. Each cycle the guidance controller's joint-rate command is
turned into cylinder references for the next stretch (lengths from Eqs
12-13 along the commanded joint path, speeds through the moment arms, forces
from the static holding torques for the model-based feed-forward) and the
compiled loop of :mod:`loadarm.hydraulics.circuit` runs them at the control
rate. The slew drive is not hydraulic here (kinematic, rate-limited).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.dynamics import G, lagrange_constants, mass_model
from loadarm.hydraulics import circuit as plant
from loadarm.hydraulics.simulate import SimulationError, initial_state, pack_parameters

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["HydraulicArm"]


class HydraulicArm:
    """Stateful two-cylinder electro-hydraulic arm.

    Parameters
    ----------
    model : ArmModel
        The installation (hydraulics, controller, masses).
    alpha, beta : float
        Starting pose, rad (held by its static pressures).
    fill : float, optional
        Product fill of the arm (default ``masses.fill``; 1 after an emergency release, the product trapped
        between the closed ERS valves).
    """

    def __init__(self, model: ArmModel, alpha: float, beta: float, *, fill: float | None = None):
        self.model = model
        self.fill = fill
        self.P = pack_parameters(model, fill=fill)
        self.k = model.lagrange if fill is None else lagrange_constants(mass_model(model, fill=fill))
        self.dt = float(self.P[plant.I_DT])
        self.substeps = int(round(self.P[plant.I_DT] / self.P[plant.I_H]))
        self.reset(alpha, beta)

    def reset(self, alpha: float, beta: float, alpha_rate: float = 0.0, beta_rate: float = 0.0) -> None:
        """Put the arm at a pose, held by the static pressures, moving at the given joint rates (the arm's real
        state when the drives take it over, e.g. at a release); clear the controllers.

        Parameters
        ----------
        alpha, beta : float
            Pose, rad.
        alpha_rate, beta_rate : float
            Joint rates, rad/s.
        """
        y = initial_state(self.model, alpha, beta, fill=self.fill)
        y[2], y[3] = alpha_rate, beta_rate
        self.state = plant.ServoState.at_rest(self.P, y)
        self.q_ref = np.array([alpha, beta], dtype=float)

    @property
    def joints(self) -> tuple[float, float]:
        """Current alpha and beta, rad."""
        return self.state.joints

    def step(self, duration: float, rates: tuple[float, float]) -> tuple[float, float]:
        """Drive the arm for ``duration`` seconds along the commanded joint rates.

        Parameters
        ----------
        duration : float
            Time to simulate, s (a whole number of control periods).
        rates : tuple of float
            Commanded alpha and beta rates, rad/s (zero: hold).

        Returns
        -------
        alpha, beta : float
            Joint angles at the end, rad.

        Raises
        ------
        SimulationError
            If the servo loop trips (following error, chatter, divergence).
        """
        n = max(1, int(round(duration / self.dt)))
        wa, wb = float(rates[0]), float(rates[1])
        a0, b0 = float(self.q_ref[0]), float(self.q_ref[1])
        a1, b1 = a0 + wa * n * self.dt, b0 + wb * n * self.dt
        # references at both ends of the stretch, linear in between (20 ms of slow motion)
        e0 = self._refs(a0, b0, wa, wb)
        e1 = self._refs(a1, b1, wa, wb)
        ref = np.linspace(e0[0:2], e1[0:2], n + 1).T.copy()
        vref = np.linspace(e0[2:4], e1[2:4], n + 1).T.copy()
        fref = np.linspace(e0[4:6], e1[4:6], n + 1).T.copy()
        code = plant.advance(self.P, self.state.y, self.state.c, ref, vref, fref, n, self.substeps)
        if code:
            raise SimulationError(f"hydraulic servo stopped: {plant.fail_reason(code)}")
        self.q_ref = np.array([a1, b1])
        return self.joints

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) the 1 kHz plant now, before a real-time loop starts its clock: one
        hold step on the state, which is then put back as it was. Found (issue 26, CI on a fresh clone): the first
        cycle of ``loadarm serve`` compiled the plant for seconds, late on the clock and deaf to Ctrl-C."""
        y, c, q_ref = self.state.y.copy(), self.state.c.copy(), self.q_ref.copy()
        try:
            self.step(self.dt, (0.0, 0.0))
        finally:
            self.state.y[:], self.state.c[:], self.q_ref = y, c, q_ref

    def _refs(self, a: float, b: float, wa: float, wb: float) -> tuple[float, ...]:
        """Cylinder lengths, speeds and static holding forces at one pose (scalar, fast)."""
        r1, r2, h1, h2 = plant._geometry(self.P, a, b)
        sab = math.sin(a - b)
        ta = -G * (self.k.g_a * math.sin(a) + self.k.g_ab * sab)     # dV/d alpha: the holding torque
        tb = G * self.k.g_ab * sab
        h1s = h1 if abs(h1) > 1e-6 else 1e-6
        h2s = h2 if abs(h2) > 1e-6 else 1e-6
        return (r1, r2, h1 * wa, h2 * wb, ta / h1s, tb / h2s)
