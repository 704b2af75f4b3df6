"""The compiled arm model: the immutable object every stage takes (built by :mod:`loadarm.params.compiler`).

As MuJoCo compiles its XML into an ``MjModel`` once and every function then takes that model (and a separate,
mutable ``MjData``), :func:`loadarm.params.compiler.compile_model` turns a validated installation into an
:class:`ArmModel`: the arm and its cylinder mounting, the alarm angles and slew limits in radians, the
datasheet's flange box, the joint and cylinder-speed limits, the cylinder areas, and every physical parameter
group as a plain frozen record in SI units. This module holds only the data types; it imports no
configuration, so the maths modules may use it.
"""

from __future__ import annotations

from dataclasses import dataclass

from loadarm.arm.alarms import AlarmAngles
from loadarm.arm.dynamics import LagrangeConstants, MassModel
from loadarm.arm.envelope import BerthBox
from loadarm.arm.geometry import Arm, Mounting

__all__ = ["ArmModel", "SlewLimits", "JointLimits", "ParamRecord"]


class ParamRecord:
    """A parameter group compiled: a frozen, slotted record whose fields carry the types their declaration gives
    (SI units). The compiler makes one record type per configuration section (``DatasheetParams``,
    ``SequenceParams``, ...) from that section's declaration, so a key is declared once, in
    :mod:`loadarm.params.sections`."""

    __slots__ = ()


@dataclass(frozen=True, slots=True)
class SlewLimits:
    """Slew joint limit and alarm angles (rad, +/- from the arm's centre line) and rate limit (rad/s)."""

    limit: float
    first: float
    second: float
    release: float
    max_rate: float


@dataclass(frozen=True, slots=True)
class JointLimits:
    """Joint ranges (rad) from the slew limit and the cylinder strokes, and joint rate limits (rad/s)."""

    phi: tuple[float, float]
    alpha: tuple[float, float]
    beta: tuple[float, float]
    rate: tuple[float, float, float]

    def contains(self, q, tol: float = 0.0) -> bool:
        """Whether joint angles ``(phi, alpha, beta)`` lie within every range, to ``tol`` rad.

        Parameters
        ----------
        q : sequence of float
            Slew, alpha, beta, rad.
        tol : float
            Slack, rad (for positions computed exactly on a limit).

        Returns
        -------
        bool
        """
        return all(lo - tol <= float(v) <= hi + tol for v, (lo, hi) in zip(q, (self.phi, self.alpha, self.beta)))


@dataclass(frozen=True, slots=True)
class ArmModel:
    """One loading arm at one berth, compiled (immutable, hashable).

    Attributes
    ----------
    arm : Arm
        Riser, inboard and outboard lengths, m.
    mount : Mounting
        Cylinder pin distances, m.
    alarms : AlarmAngles
        Elbow-angle alarm thresholds, rad.
    slew : SlewLimits
        Slew limits and alarms, rad.
    berth : BerthBox
        The datasheet's flange box, m.
    joint_limits : JointLimits
        Joint ranges from the slew limit and the cylinder strokes, joint rate limits.
    cylinder_area : tuple of float
        Piston and annulus areas, m^2.
    cylinder_speed_limit : tuple of float
        Largest extension speed of each cylinder, m/s (valve or half the pump, over the piston area).
    datasheet, actuators, approach, masses, cylinders, pump, valve, encoder, controller, sequence, design_drift, \
accumulator, transfer : ParamRecord
        The parameter groups as frozen records, SI units, keys and types as declared in the configuration.
    mass : MassModel
        The arm's lumps at the configured product fill.
    lagrange : LagrangeConstants
        Its Lagrangian constants.
    """

    arm: Arm
    mount: Mounting
    alarms: AlarmAngles
    slew: SlewLimits
    berth: BerthBox
    joint_limits: JointLimits
    cylinder_area: tuple[float, float]
    cylinder_speed_limit: tuple[float, float]
    datasheet: ParamRecord
    actuators: ParamRecord
    approach: ParamRecord
    masses: ParamRecord
    cylinders: ParamRecord
    pump: ParamRecord
    valve: ParamRecord
    encoder: ParamRecord
    controller: ParamRecord
    sequence: ParamRecord
    design_drift: ParamRecord
    accumulator: ParamRecord
    transfer: ParamRecord | None = None
    mass: MassModel | None = None
    lagrange: LagrangeConstants | None = None
