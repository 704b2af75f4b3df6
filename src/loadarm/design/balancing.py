"""Counterweight balancing over the whole operating envelope.

A double-counterweighted arm is built to be nearly balanced in every pose, so
that the cylinders only fight inertia and the residual imbalance. With the
counterweight *positions* fixed, the static joint torques are affine in the
two counterweight *masses* (only the moment ``m d`` matters for a point mass on
a line through its hinge, so the result can be read as a required moment and
traded between mass and lever length):

    tau_j(pose, fill; m1, m2) = tau_j0(pose, fill) + m1 k_j1(pose) + m2 k_j2(pose)

Minimising the largest ``|tau_j|`` over every pose of the envelope, every fill
case and both joints is therefore a linear programme (minimise ``t`` subject
to ``-t <= tau <= t``), solved exactly and globally by SciPy's HiGHS.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import linprog

from loadarm.arm.dynamics import MassModel, mass_model, static_torques
from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import inverse, reach_mask
from loadarm.design.plots import residual_torque_figure
from loadarm.results import Result

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["EnvelopeGrid", "envelope_grid", "BalanceResult", "balance_counterweights", "max_static_torque"]


@dataclass(frozen=True)
class EnvelopeGrid:
    """Coupler positions covering the operating envelope, with their joint angles.

    Attributes
    ----------
    x, y : ndarray, shape (n,)
        Positions, m.
    alpha, beta : ndarray, shape (n,)
        Joint angles, rad.
    """

    x: np.ndarray
    y: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray


def envelope_grid(model: ArmModel, *, arm: Arm | None = None, spacing: float = 0.25) -> EnvelopeGrid:
    """Grid over every coupler position the arm must serve.

    The rectangle spanning the stored position, the configured flange and the
    datasheet's flange box, kept where reachable with ``beta`` below the
    release angle (beyond it the coupler has let go).

    Parameters
    ----------
    model : ArmModel
        The installation.
    arm : Arm, optional
        Geometry (default the configured arm).
    spacing : float
        Grid step, m (> 0).

    Returns
    -------
    EnvelopeGrid
    """
    if not spacing > 0:
        raise ValueError(f"spacing must be > 0 m, got {spacing!r}")
    arm = arm or model.arm
    box = model.berth
    pts = np.array([model.approach.stored, model.approach.flange, (box.x_near, box.y_low), (box.x_far, box.y_high)])
    x0, y0 = pts.min(axis=0)
    x1, y1 = pts.max(axis=0)
    xs = np.arange(x0, x1 + spacing / 2, spacing)
    ys = np.arange(y0, y1 + spacing / 2, spacing)
    X, Y = (v.ravel() for v in np.meshgrid(xs, ys))
    ok = reach_mask(arm, X, Y)
    X, Y = X[ok], Y[ok]
    q = inverse(arm, X, Y)
    keep = q.beta < model.alarms.release
    if not keep.any():
        raise ValueError("no reachable pose below the release angle in the operating envelope")
    return EnvelopeGrid(X[keep], Y[keep], q.alpha[keep], q.beta[keep])


def max_static_torque(model: MassModel, grid: EnvelopeGrid) -> tuple[float, float]:
    """Largest holding torque of each joint over a grid, N m.

    Parameters
    ----------
    model : MassModel
        Mass model.
    grid : EnvelopeGrid
        Poses.

    Returns
    -------
    tau_alpha_max, tau_beta_max : float
        ``max |tau|`` per joint.
    """
    ta, tb = static_torques(model, grid.alpha, grid.beta)
    return float(np.max(np.abs(ta))), float(np.max(np.abs(tb)))


@dataclass(frozen=True)
class BalanceResult(Result):
    """Minimax counterweights and the residual torque they leave.

    Attributes
    ----------
    counterweight_inboard_kg, counterweight_outboard_kg : float
        Optimal masses at the configured positions, kg.
    moment_inboard_kgm, moment_outboard_kgm : float
        The same as moments ``m d``, kg m (any mass/position pair with this
        product balances equally well).
    max_torque : float
        Largest residual static torque over grid, fills and joints, N m.
    max_torque_per_joint : tuple of float
        ``(alpha, beta)`` maxima, N m.
    configured_max_torque_per_joint : tuple of float
        The same for the configured counterweights, N m.
    fills : tuple of float
        Fill cases balanced over.
    grid : EnvelopeGrid
        The poses.
    residual_alpha, residual_beta : ndarray, shape (n_fills, n)
        Residual torques at each pose and fill, N m.
    """

    counterweight_inboard_kg: float
    counterweight_outboard_kg: float
    moment_inboard_kgm: float
    moment_outboard_kgm: float
    max_torque: float
    max_torque_per_joint: tuple[float, float]
    configured_max_torque_per_joint: tuple[float, float]
    fills: tuple[float, ...]
    grid: EnvelopeGrid
    residual_alpha: np.ndarray
    residual_beta: np.ndarray

    def _values(self) -> dict:
        """Headline numbers, JSON-friendly."""
        return {
            "counterweight_inboard_kg": self.counterweight_inboard_kg,
            "counterweight_outboard_kg": self.counterweight_outboard_kg,
            "moment_inboard_kgm": self.moment_inboard_kgm,
            "moment_outboard_kgm": self.moment_outboard_kgm,
            "max_residual_torque_Nm": self.max_torque,
            "max_residual_torque_alpha_Nm": self.max_torque_per_joint[0],
            "max_residual_torque_beta_Nm": self.max_torque_per_joint[1],
            "configured_max_torque_alpha_Nm": self.configured_max_torque_per_joint[0],
            "configured_max_torque_beta_Nm": self.configured_max_torque_per_joint[1],
            "fills": list(self.fills),
            "poses": int(self.grid.x.size),
        }

    def _figure(self):

        return residual_torque_figure(self)


def balance_counterweights(model: ArmModel, *, fills: tuple[float, ...] | None = None, spacing: float = 0.25,
                           max_counterweight_kg: float = 1e6) -> BalanceResult:
    """Counterweight masses that minimise the largest static joint torque over the envelope.

    Parameters
    ----------
    model : ArmModel
        The installation (arm, masses, counterweight positions).
    fills : tuple of float, optional
        Fill fractions to balance over; default ``masses.balance_fills``.
    spacing : float
        Envelope grid step, m.
    max_counterweight_kg : float
        Upper bound of each counterweight mass, kg.

    Returns
    -------
    BalanceResult

    Raises
    ------
    RuntimeError
        If the linear programme fails (it cannot for valid input).
    """
    fills = tuple(model.masses.balance_fills if fills is None else fills)
    grid = envelope_grid(model, spacing=spacing)
    base_models = [mass_model(model, fill=f) for f in fills]
    d1 = model.masses.counterweight_inboard_distance
    d2 = model.masses.counterweight_outboard_distance
    rows, rhs = [], []
    tau0 = []
    # per-kg torque columns (independent of fill); subtract the zero-counterweight torques
    m0 = base_models[0].with_counterweights(0.0, 0.0)
    z_a, z_b = static_torques(m0, grid.alpha, grid.beta)
    k1a, k1b = (t - z for t, z in zip(static_torques(base_models[0].with_counterweights(1.0, 0.0), grid.alpha,
                                                     grid.beta), (z_a, z_b)))
    k2a, k2b = (t - z for t, z in zip(static_torques(base_models[0].with_counterweights(0.0, 1.0), grid.alpha,
                                                     grid.beta), (z_a, z_b)))
    for model in base_models:
        ta, tb = static_torques(model.with_counterweights(0.0, 0.0), grid.alpha, grid.beta)
        tau0.append((ta, tb))
        for t0, k1, k2 in ((ta, k1a, k2a), (tb, k1b, k2b)):
            # t0 + m1 k1 + m2 k2 <= t   and   -(t0 + m1 k1 + m2 k2) <= t
            rows.append(np.column_stack([k1, k2, -np.ones_like(k1)]))
            rhs.append(-t0)
            rows.append(np.column_stack([-k1, -k2, -np.ones_like(k1)]))
            rhs.append(t0)
    A = np.vstack(rows)
    bvec = np.concatenate(rhs)
    bounds_m = [(0.0, max_counterweight_kg), (0.0, max_counterweight_kg)]
    # stage 1: the smallest achievable largest torque t* (over poses, fills and both joints)
    res = linprog(c=[0.0, 0.0, 1.0], A_ub=A, b_ub=bvec, bounds=bounds_m + [(0.0, None)], method="highs")
    if not res.success:  # pragma: no cover
        raise RuntimeError(f"balancing linear programme failed: {res.message}")
    t_star = float(res.x[2])
    # stage 2: the minimax optimum is not unique (the joint with the smaller maximum leaves slack), so among
    # the optimal designs take the one with the smallest sum of the two joints' maxima
    A2 = np.zeros((A.shape[0], 4))
    A2[:, :2] = A[:, :2]
    # the row blocks go (alpha +, alpha -, beta +, beta -) per fill: mark which joint each row bounds
    joint_of_row = np.concatenate([np.full(rows[k].shape[0], (k // 2) % 2) for k in range(len(rows))])
    A2[joint_of_row == 0, 2] = -1.0
    A2[joint_of_row == 1, 3] = -1.0
    cap = t_star * (1 + 1e-9) + 1e-9
    res2 = linprog(c=[0.0, 0.0, 1.0, 1.0], A_ub=A2, b_ub=bvec, bounds=bounds_m + [(0.0, cap), (0.0, cap)],
                   method="highs")
    if not res2.success:  # pragma: no cover
        raise RuntimeError(f"balancing linear programme (stage 2) failed: {res2.message}")
    m1, m2 = float(res2.x[0]), float(res2.x[1])
    t = t_star
    ra = np.array([t0a + m1 * k1a + m2 * k2a for t0a, _ in tau0])
    rb = np.array([t0b + m1 * k1b + m2 * k2b for _, t0b in tau0])
    conf = [max_static_torque(m, grid) for m in base_models]
    return BalanceResult(
        counterweight_inboard_kg=m1, counterweight_outboard_kg=m2, moment_inboard_kgm=m1 * d1,
        moment_outboard_kgm=m2 * d2, max_torque=t,
        max_torque_per_joint=(float(np.abs(ra).max()), float(np.abs(rb).max())),
        configured_max_torque_per_joint=(max(c[0] for c in conf), max(c[1] for c in conf)),
        fills=fills, grid=grid, residual_alpha=ra, residual_beta=rb)
