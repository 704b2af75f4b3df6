"""The bank file: a bank of loading arms on one jetty, the ship's manifold they connect to, the hydraulic power
unit they share (issue 31, item 1).

One TOML file per bank (``examples/banks/``), read and validated at the edge like the installation and the berth
(:mod:`loadarm.params.declare`): every parameter declared once with its unit, range, default and source; strict
types; one-line errors naming the file, the key, the value and the range. Each arm refers to its own
installation file (relative paths resolved against the bank file), so the arms' sizes may differ.

Frame of the bank (SI units; degrees only in keys ending ``_deg``): ``x`` from the line of the risers towards the
ship (each installation's ``x``), ``y`` along the jetty, ``z`` up from the jetty deck. Each arm's riser stands at
its ``(x, y, 0)``; its own frame (:mod:`loadarm.arm.slew`) is the bank's shifted there.

A bank is refused (one line) when an arm cannot reach its flange at the manifold's design position, or when two
arms come closer than ``clearance.min_clearance`` connected to their flanges or stowed
(:mod:`loadarm.arm.clearance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, Field, ValidationError, model_validator

from loadarm.arm.clearance import PARTS, ArmShape, pair_clearance
from loadarm.arm.model import ArmModel
from loadarm.arm.slew import inverse3d
from loadarm.arm.swivel import ship_rotation, swivel_angles, swivel_margins
from loadarm.errors import ConfigError, UnreachableError
from loadarm.files import read_toml
from loadarm.params.compiler import compile_model
from loadarm.params.config import Installation, load_config, parameter_markdown
from loadarm.params.declare import REQUIRED, Section, format_validation_error, param, toml_values

__all__ = ["BankSection", "BankArm", "Flange", "Manifold", "PowerUnit", "ManifoldLoads", "Clearance", "Swivels",
           "BankFile", "Bank", "parse_bank", "load_bank", "bank_parameter_markdown", "OCIMF_MLA"]

#: The loading-arm specification the allowable manifold loads default to.
OCIMF_MLA = ("OCIMF, Design and Construction Specification for Marine Loading Arms, 3rd ed., 1999 (allowable "
             "forces and moments on the ship's manifold flange)")
_AS_QUOTED = ("as commonly quoted from " + OCIMF_MLA + "; NOT checked against the document here: confirm the "
              "figure for the flange size before relying on it")
_EXAMPLE = "example: a 150 000 m^3 LNG carrier's berth (engineering choice)"


class BankSection(Section):
    """The bank as a whole."""

    name: str = Field("bank", min_length=1, max_length=80, description="the bank's name",
                      json_schema_extra={"unit": "", "source": "the terminal's"})


class BankArm(Section):
    """One arm of the bank (``[[arms]]``)."""

    name: str = Field(..., min_length=1, max_length=40, description="the arm's name (tag)",
                      json_schema_extra={"unit": "", "source": "the terminal's"})
    installation: str = Field(..., min_length=1, max_length=400,
                              description="its installation file, relative to the bank file",
                              json_schema_extra={"unit": "", "source": "the arm's datasheet"})
    y: float = param(REQUIRED, unit="m", ge=-200, le=200, source="the jetty's layout (OCIMF datasheet K: riser to riser)",
                     description="the riser's position along the jetty")
    x: float = param(0.0, unit="m", ge=-20, le=20, source="risers in one line (usual)",
                     description="the riser's offset towards the ship from the bank's line of risers")


class Flange(Section):
    """One presentation flange of the ship's manifold (``[[manifold.flanges]]``)."""

    name: str = Field(..., min_length=1, max_length=40, description="the flange's name",
                      json_schema_extra={"unit": "", "source": "the ship's manifold drawing"})
    arm: str = Field(..., min_length=1, max_length=40, description="the arm that takes it",
                     json_schema_extra={"unit": "", "source": "the terminal's"})
    product: Literal["liquid", "vapour"] = Field(..., description="what flows through it",
                                                 json_schema_extra={"unit": "", "source": "the ship's manifold"})
    offset: float = param(REQUIRED, unit="m", ge=-50, le=50,
                          source="the ship's manifold drawing (OCIMF datasheet M, N: flange to flange)",
                          description="along the manifold from its centre, +y")
    height: float = param(0.0, unit="m", ge=-5, le=5, source="flanges at one height (usual)",
                          description="above the manifold's centre line")
    @model_validator(mode="after")
    def _vapour_runs_empty(self) -> "Flange":
        if self.product == "vapour" and self.density is not None:
            raise ValueError(f"manifold.flanges: {self.name}: density = {self.density:g} kg/m^3 on a vapour flange: "
                             "the vapour return runs empty (give density on liquid flanges only)")
        return self

    density: float | None = param(None, unit="kg/m^3", gt=0, le=2000,
                                  source="the cargo's (LNG about 430-470 kg/m^3 by its composition; crude oil "
                                         "800-950); none: the arm's installation's [masses] product_density",
                                  description="the product's density in the arm's pipes on this flange (a liquid "
                                              "flange's arm runs full)")


class Manifold(Section):
    """The ship's manifold: where its centre is presented at the design case, and its flanges."""

    position: tuple[float, float, float] = param(
        (14.0, 0.0, 1.0), unit="m", source="the paper's design flange (the installation's [approach] flange) "
                                           "at y = 0", description="the manifold's centre at the design case, bank "
                                                                   "frame")
    heading_deg: float = param(90.0, unit="deg", ge=-180, le=180,
                               source="ship alongside, bow along +y, port side to the jetty (example)",
                               description="the ship's bow direction, from +x towards +y")
    tolerance: float = param(1.5, unit="m", ge=0, le=20,
                             source="as the berth file's [ship] manifold_tolerance: the mooring master places the "
                                    "manifold within about 1-2 m of its mark (terminal procedure; example)",
                             description="how far along the berth from its design position the manifold may lie "
                                         "when the arms connect (the flanging area's width)")
    flanges: tuple[Flange, ...] = Field(..., min_length=1, max_length=8,
                                        description="the presentation flanges ([[manifold.flanges]])")


class PowerUnit(Section):
    """The hydraulic power unit the bank shares: pumps and accumulators. With the pumps lost, the accumulators
    alone must close every ERS valve and open every coupler (issue 31, item 5)."""

    pumps: int = param(2, unit="1", ge=1, le=8, source="duty and standby (usual for a bank's HPU)",
                       description="number of pumps")
    standby_pumps: int | None = param(None, unit="1", ge=0, le=7,
                                      source="duty and standby: one kept in reserve when there are two or more "
                                             "(usual for a bank's HPU); none of a single pump",
                                      description="pumps kept in reserve: the approaches run on the others' flow "
                                                  "(default: one, if there is more than one pump)")
    pump_flow: float = param(6.67e-4, unit="m^3/s", gt=0, le=0.1,
                             source="40 L/min each, a 15 kW pump (as the installation's [pump], engineering estimate)",
                             description="flow of one pump at full displacement")
    accumulators: int = param(4, unit="1", ge=1, le=64,
                              source="one 50 L bottle per arm (example; sized by the release simulation)",
                              description="number of accumulator bottles")
    accumulator_volume: float = param(50.0e-3, unit="m^3", gt=0, le=1,
                                      source="50 L bladder accumulator (a supplier's size)",
                                      description="gas volume of one bottle at precharge (nominal size)")
    precharge_pressure: float = param(90.0e5, unit="Pa", gt=0, le=500e5,
                                      source="about 0.9 x the minimum working pressure (usual bladder practice)",
                                      description="gas precharge pressure")
    max_pressure: float = param(200.0e5, unit="Pa", gt=0, le=500e5,
                                source="HPU working pressure that charges the bottles (as the installation's "
                                       "[accumulator])", description="pressure when charged")
    min_pressure: float = param(100.0e5, unit="Pa", gt=0, le=500e5,
                                source="lowest pressure at which the ERS valve actuators and the PERC still work "
                                       "(as the installation's [accumulator])",
                                description="minimum working pressure")
    polytropic_index: float = param(1.4, unit="1", ge=1, le=1.67, source="adiabatic nitrogen (a fast discharge)",
                                    description="gas expansion exponent during the release")
    ers_valve_share: float = param(1.0 / 1.5, unit="1", gt=0, lt=1,
                                   source="about 1 L of each installation's 1.5 L [accumulator] required_volume "
                                          "(its source: supplier's figures; the rest the PERC's release stroke)",
                                   description="the ERS valve actuators' share of each arm's [accumulator] "
                                               "required_volume in the release (loadarm check --bank)")
    ers_valve_stroke_time: float = param(5.0, unit="s", gt=0, le=60,
                                         source="suppliers quote about 5 s for the ERS double-block valves (as the "
                                                "installation's [sequence] ers_valve_time)",
                                         description="the ERS valve actuators' stroke at max_pressure (sizes their "
                                                     "orifice in the release)")
    erc_stroke_time: float = param(1.5, unit="s", gt=0, le=30,
                                   source="suppliers quote 1-2 s for the PERC (as the installation's [sequence] "
                                          "erc_release_time)",
                                   description="the coupler's release stroke at max_pressure (sizes its orifice in "
                                               "the release)")

    @property
    def standby(self) -> int:
        """The pumps kept in reserve: ``standby_pumps``, or one if there is more than one pump (found by review: a
        default of one refused a single-pump bank that had loaded before)."""
        return self.standby_pumps if self.standby_pumps is not None else min(1, self.pumps - 1)

    @property
    def duty_flow(self) -> float:
        """The flow the duty pumps deliver (all but the standby), m^3/s."""
        return (self.pumps - self.standby) * self.pump_flow

    @model_validator(mode="after")
    def _pressures(self) -> "PowerUnit":
        if self.standby_pumps is not None and self.standby_pumps >= self.pumps:
            raise ValueError(f"power_unit.standby_pumps = {self.standby_pumps} must be below pumps = {self.pumps}: "
                             "valid range [0, pumps - 1]")
        if not (self.precharge_pressure < self.min_pressure < self.max_pressure):
            raise ValueError(
                f"power_unit pressures must satisfy precharge_pressure ({self.precharge_pressure:g}) < min_pressure "
                f"({self.min_pressure:g}) < max_pressure ({self.max_pressure:g}) Pa")
        return self


class ManifoldLoads(Section):
    """The allowable loads at each presentation flange, in the flange's axes (axial: along its normal)."""

    axial_force: float = param(20.0e3, unit="N", gt=0, le=1e6, source=_AS_QUOTED,
                               description="allowable force along the flange's normal")
    lateral_force: float = param(20.0e3, unit="N", gt=0, le=1e6, source=_AS_QUOTED,
                                 description="allowable horizontal force across the flange's normal")
    vertical_force: float = param(20.0e3, unit="N", gt=0, le=1e6, source=_AS_QUOTED,
                                  description="allowable vertical force")
    bending_moment: float = param(30.0e3, unit="N m", gt=0, le=1e7, source=_AS_QUOTED,
                                  description="allowable bending moment (resultant, about the flange's face)")
    torsion_moment: float = param(10.0e3, unit="N m", gt=0, le=1e7, source=_AS_QUOTED,
                                  description="allowable moment about the flange's normal")
    coupler_length: float = param(1.0, unit="m", ge=0, le=5,
                                  source="the QCDC and the ERS's lower half between the triple swivel and the flange "
                                         "(example; the supplier's drawing gives it)",
                                  description="the flange's face ahead of the triple swivel's centre (the arm's tip) "
                                              "along the flange's normal: the lever of the bending moment")
    swivel_friction_torque: float = param(1.0e3, unit="N m", ge=0, le=1e5,
                                          source="engineering estimate for a 16 in cryogenic product swivel (the "
                                                 "supplier's breakaway torque to be given)",
                                          description="Coulomb friction torque of each of the chain's six swivel "
                                                      "joints (slew, inboard, outboard and the triple swivel's three), "
                                                      "against its motion")
    wind_speed: float = param(20.0, unit="m/s", ge=0, le=60,
                              source="connected-operation limit of the order of 40 kn (terminal rules; as the berth's "
                                     "[environment] wind_speed, example)",
                              description="wind on the connected arm for the design check (loadarm check --bank)")
    alarm_deadband: float = param(0.05, unit="1", ge=0, le=0.5,
                                  source="ISA-TR18.2.3's suggested starting deadbands for analog alarms (flow and "
                                         "level 5 %); a load's signal is as noisy as a flow's",
                                  description="the live manifold-load alarm clears only once every load is below "
                                              "(1 - alarm_deadband) of its allowable")
    alarm_delay: float = param(2.0, unit="s", ge=0, le=60,
                               source="ISA-TR18.2.3's suggested starting on- and off-delays for analog alarms (flow "
                                      "and pressure 2 s)",
                               description="the live manifold-load alarm rises once a load has been past its "
                                           "allowable this long, and clears once below the deadband this long")
    drag_coefficient: float = param(1.0, unit="1", gt=0, le=3,
                                    source="engineering choice: an insulated (rough) circular cylinder at "
                                           "supercritical Reynolds number is of the order of 1",
                                    description="drag coefficient of the arm's pipes, on clearance.pipe_radius x 2 "
                                                "across the flow normal to the pipe")

    confirmed_by: str = Field("", max_length=200,
                              description="the document that confirms the five allowable loads for this manifold "
                                          "(the ship's or terminal's, with its revision); empty: unconfirmed",
                              json_schema_extra={"unit": "", "source": "the terminal's"})

    def as_quoted(self) -> tuple[str, ...]:
        """The allowable loads left at their defaults, the figures as commonly quoted from OCIMF's specification and
        not checked against it here (:data:`OCIMF_MLA`): each a verdict that rests on an unconfirmed figure. None
        once :attr:`confirmed_by` names the document that confirms them (a terminal's own figure may equal the
        default).

        Returns
        -------
        tuple of str
            Their keys, ``manifold_loads.<key>``.
        """
        keys = ("axial_force", "lateral_force", "vertical_force", "bending_moment", "torsion_moment")
        if self.confirmed_by.strip():
            return ()
        return tuple(f"manifold_loads.{k}" for k in keys
                     if getattr(self, k) == type(self).model_fields[k].default)


class Clearance(Section):
    """The arms as capsules (:mod:`loadarm.arm.clearance`) and the clearance they must keep."""

    min_clearance: float = param(0.5, unit="m", ge=0.0, le=10,
                                 source="engineering choice (example): the OCIMF datasheet asks for the clearance "
                                        "between adjacent arms, it sets no figure here",
                                 description="smallest allowed distance between two arms' surfaces")
    riser_radius: float = param(0.4, unit="m", gt=0, le=3, source="a 16 in arm's riser with its base (example)",
                                description="the riser's capsule radius")
    pipe_radius: float = param(0.3, unit="m", gt=0, le=3,
                               source="16 in pipe, OD 406 mm, with cryogenic insulation (example)",
                               description="the inboard and outboard pipes' capsule radius")
    swivel_radius: float = param(0.6, unit="m", gt=0, le=3,
                                 source="style-80 triple swivel, ERS and QCDC around the coupler (example)",
                                 description="the triple swivel's sphere radius, at the coupler")
    counterweight_radius: float = param(0.7, unit="m", gt=0, le=5,
                                        source="a 20 t steel counterweight block, about 1.4 m across (example)",
                                        description="the counterweights' capsule radius (their arms included)")


class Swivels(Section):
    """The style-80 triple swivel's travel, each swivel's lower and upper stop."""

    swivel1_deg: tuple[float, float] = param((-100.0, 100.0), unit="deg",
                                             source="supplier's figure to be given; example wide enough for the "
                                                    "outboard arm's angle over the envelope plus the roll",
                                             description="swivel 1 (about the hinge axis) travel")
    swivel2_deg: tuple[float, float] = param((-75.0, 75.0), unit="deg",
                                             source="example: the slew's 40 deg plus the ship's yaw",
                                             description="swivel 2 (about the coupler's drop) travel")
    swivel3_deg: tuple[float, float] = param((-30.0, 30.0), unit="deg",
                                             source="example: a moored ship's pitch is a few degrees",
                                             description="swivel 3 (about the flange's normal) travel")
    design_yaw_rate_deg: float = param(0.1, unit="deg/s", ge=0.0, le=5.0,
                                       source="the shipped berth's break-out (breakout.toml, seeds 0-11): the "
                                              "ship's yaw at the manifold, smoothed over 10 s, turned at up to "
                                              "0.06 deg/s; rounded up. Roll and pitch are restored by the "
                                              "hull: no design rate",
                                       description="the swivels' design floor: the ship's yaw turning either way at "
                                                   "this rate from the angles now, until and beside the fit of the "
                                                   "measured rotation")

    @model_validator(mode="after")
    def _ordered(self) -> "Swivels":
        for key in ("swivel1_deg", "swivel2_deg", "swivel3_deg"):
            lo, hi = getattr(self, key)
            if not -180.0 <= lo < 0.0 < hi <= 180.0:
                raise ValueError(f"swivels.{key} = [{lo:g}, {hi:g}] deg: need -180 <= lower < 0 < upper <= 180 deg")
        return self

    def limits(self) -> tuple[tuple[float, float], ...]:
        """The three swivels' stops, rad.

        Returns
        -------
        tuple of (float, float)
        """
        return tuple((math.radians(lo), math.radians(hi))
                     for lo, hi in (self.swivel1_deg, self.swivel2_deg, self.swivel3_deg))


class BankFile(BaseModel):
    """A bank file, validated (its own parts; the installations are read by :func:`load_bank`)."""

    model_config = Section.model_config

    bank: BankSection = Field(default_factory=BankSection)
    arms: tuple[BankArm, ...] = Field(..., min_length=2, max_length=8, description="the arms ([[arms]] tables)")
    manifold: Manifold
    power_unit: PowerUnit = Field(default_factory=PowerUnit)
    manifold_loads: ManifoldLoads = Field(default_factory=ManifoldLoads)
    clearance: Clearance = Field(default_factory=Clearance)
    swivels: Swivels = Field(default_factory=Swivels)

    @model_validator(mode="after")
    def _consistent(self) -> "BankFile":
        for kind, names in (("arms", [a.name for a in self.arms]),
                            ("manifold.flanges", [f.name for f in self.manifold.flanges])):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"{kind}: names must be unique, {', '.join(dup)} repeated")
        arms = [a.name for a in self.arms]
        taken = [f.arm for f in self.manifold.flanges]
        for f in self.manifold.flanges:
            if f.arm not in arms:
                raise ValueError(f"manifold.flanges {f.name!r}: arm = {f.arm!r} is not an arm of the bank "
                                 f"({', '.join(arms)})")
        for a in arms:
            if taken.count(a) != 1:
                raise ValueError(f"arms {a!r} takes {taken.count(a)} flanges of the manifold: each arm takes one")
        offsets = sorted(f.offset for f in self.manifold.flanges)
        for lo, hi in zip(offsets, offsets[1:], strict=False):
            if hi - lo <= 0.0:
                raise ValueError(f"manifold.flanges: two flanges at offset = {lo:g} m")
        ys = sorted((a.y, a.name) for a in self.arms)
        for (y0, n0), (y1, n1) in zip(ys, ys[1:], strict=False):
            if y1 == y0:
                raise ValueError(f"arms {n0!r} and {n1!r}: both risers at y = {y0:g} m")
        return self


@dataclass(frozen=True)
class Bank:
    """A bank, read: its file, and each arm's installation, model and capsules (in the order of ``file.arms``).

    Attributes
    ----------
    file : BankFile
    source : str
        The bank file.
    installations : tuple of Installation
        Each arm's, as its file gives it but for ``[masses] product_density``: its flange's ``density`` where
        the bank gives one.
    paths : tuple of Path
        Each arm's installation file, resolved.
    models : tuple of ArmModel
    shapes : tuple of ArmShape
    flanges : tuple of Flange
        Each arm's flange.
    connected : ndarray, shape (n_arms, 3)
        Each arm's (slew, inboard, elbow) angles on its flange at the manifold's design position, rad.
    stowed : ndarray, shape (n_arms, 3)
        Each arm's angles stowed (its installation's ``[approach] stored``, no slew), rad.
    """

    file: BankFile
    source: str
    installations: tuple[Installation, ...]
    paths: tuple[Path, ...]
    models: tuple[ArmModel, ...]
    shapes: tuple[ArmShape, ...]
    flanges: tuple[Flange, ...]
    connected: np.ndarray
    stowed: np.ndarray

    @property
    def names(self) -> tuple[str, ...]:
        """The arms' names."""
        return tuple(a.name for a in self.file.arms)

    def flanges_at(self, centre, angles, rotation=None) -> np.ndarray:
        """Each arm's flange in its own frame at manifold poses: the centre, plus the flange's offset and height
        turned with the ship (:func:`loadarm.arm.swivel.ship_rotation`, the ship's heading), less the arm's
        riser. The one place of this formula (the bank's monitor, world, campaign and checks call it).

        Parameters
        ----------
        centre : array_like, shape (..., 3)
            The manifold's centre, bank frame, m.
        angles : array_like, shape (..., 3)
            Roll, pitch, yaw, rad.
        rotation : ndarray, shape (..., 3, 3), optional
            Their rotation, if already computed.

        Returns
        -------
        ndarray, shape (..., n_arms, 3)
            m.
        """
        centre, angles = np.asarray(centre, dtype=float), np.asarray(angles, dtype=float)
        if rotation is None:
            rotation = ship_rotation(angles[..., 0], angles[..., 1], angles[..., 2],
                                     math.radians(self.file.manifold.heading_deg))
        offsets = np.array([[0.0, f.offset, f.height] for f in self.flanges])
        risers = np.array([[a.x, a.y, 0.0] for a in self.file.arms])
        return centre[..., None, :] + np.einsum("...ij,aj->...ai", rotation, offsets) - risers

    def on_flanges(self, centre, angles, rotation=None) -> tuple[np.ndarray, list, list, np.ndarray]:
        """Every arm on its flange at manifold poses: its joints (inverse kinematics, NaN out of reach) and its
        swivels' margins to their stops. The one place of this computation (the bank's monitor and its swivel
        envelope call it).

        Parameters
        ----------
        centre : array_like, shape (..., 3)
            The manifold's centre, bank frame, m.
        angles : array_like, shape (..., 3)
            Roll, pitch, yaw, rad.
        rotation : ndarray, shape (..., 3, 3), optional
            Their rotation, if already computed.

        Returns
        -------
        flanges : ndarray, shape (..., n_arms, 3)
            Each arm's flange in its own frame (:meth:`flanges_at`), m.
        iks : list
            Each arm's :func:`loadarm.arm.slew.inverse3d` result.
        poses : list of ndarray, shape (..., 3)
            Each arm's slew, inboard and elbow angles, rad.
        swivels : ndarray, shape (..., n_arms, 6)
            Each arm's swivel margins, rad, in the order of :data:`loadarm.vocab.SWIVEL_FACE_TABLE` (NaN out of
            reach).
        """
        angles = np.asarray(angles, dtype=float)
        heading = math.radians(self.file.manifold.heading_deg)
        if rotation is None:
            rotation = ship_rotation(angles[..., 0], angles[..., 1], angles[..., 2], heading)
        flanges = self.flanges_at(centre, angles, rotation)
        limits = self.file.swivels.limits()
        iks, poses, swivels = [], [], []
        for i, model in enumerate(self.models):
            f = flanges[..., i, :]
            q = inverse3d(model.arm, f[..., 0], f[..., 1], f[..., 2], check=False)
            iks.append(q)
            poses.append(np.stack([q.phi, q.alpha, q.beta], axis=-1))
            swivels.append(swivel_margins(swivel_angles(q.phi, q.alpha, q.beta, heading=heading, rotation=rotation),
                                          limits))
        return flanges, iks, poses, np.stack(swivels, axis=-2)

    def flange_position(self, i: int) -> np.ndarray:
        """Arm ``i``'s flange at the manifold's design position, in the arm's own frame, m.

        Parameters
        ----------
        i : int

        Returns
        -------
        ndarray, shape (3,)
        """
        f, arm = self.flanges[i], self.file.arms[i]
        cx, cy, cz = self.file.manifold.position
        return np.array([cx - arm.x, cy + f.offset - arm.y, cz + f.height])


def parse_bank(data: dict[str, Any], *, source: str = "<bank>") -> BankFile:
    """Validate a bank mapping (as read from TOML), without its installations.

    Parameters
    ----------
    data : dict
    source : str
        Name for messages.

    Returns
    -------
    BankFile

    Raises
    ------
    ConfigError
        One line naming the file, the key, the value and the valid range.
    """
    try:
        return BankFile.model_validate(toml_values(data))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, BankFile), source=source, expected="bank") from None


def _shape(arm: BankArm, inst: Installation, model: ArmModel, c: Clearance) -> ArmShape:
    radii = (c.riser_radius, c.pipe_radius, c.pipe_radius, c.swivel_radius, c.counterweight_radius,
             c.counterweight_radius)
    return ArmShape(arm.name, model.arm, (arm.x, arm.y, 0.0),
                    (inst.masses.counterweight_inboard_distance, inst.masses.counterweight_outboard_distance), radii)


def _refuse_close(bank: Bank, q: np.ndarray, where: str) -> None:
    """One line if two arms, at poses ``q`` (n_arms, 3), come closer than the bank's minimum clearance."""
    need = bank.file.clearance.min_clearance
    shapes, names = bank.shapes, bank.names
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            gap, parts = pair_clearance(shapes[i], shapes[j], q[i], q[j])
            if float(gap) < need:
                pa, pb = (PARTS[int(k)] for k in parts)
                apart = f"overlap by {-float(gap):.3f} m" if gap < 0 else f"come {float(gap):.3f} m apart"
                raise ConfigError(
                    f"{bank.source}: arms {names[i]!r} (y = {bank.file.arms[i].y:g} m) and {names[j]!r} (y = "
                    f"{bank.file.arms[j].y:g} m) {where} {apart} ({pa} to {pb}); "
                    f"clearance.min_clearance = {need:g} m: valid range [{need:g}, inf) m",
                    source=bank.source, expected="bank")


def _poses(file: BankFile, source: str, models, insts, flanges) -> tuple[np.ndarray, np.ndarray]:
    cx, cy, cz = file.manifold.position
    connected, stowed = [], []
    for arm, model, inst, f in zip(file.arms, models, insts, flanges, strict=True):
        p = (cx - arm.x, cy + f.offset - arm.y, cz + f.height)
        try:
            q = inverse3d(model.arm, *p)
        except UnreachableError as exc:
            raise ConfigError(f"{source}: arms {arm.name!r} cannot reach its flange {f.name!r} at ({p[0]:.3f}, "
                              f"{p[1]:.3f}, {p[2]:.3f}) m from its riser: {exc}", source=source,
                              expected="bank") from None
        connected.append([float(v) for v in q])
        x0, z0 = inst.approach.stored
        s = inverse3d(model.arm, x0, 0.0, z0)
        stowed.append([float(v) for v in s])
    return np.array(connected), np.array(stowed)


def load_bank(path: str | Path) -> Bank:
    """Read and validate a bank file and each arm's installation; refuse arms that cannot reach their flanges or
    come too close, connected or stowed.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Bank

    Raises
    ------
    ConfigError
        One line naming the file, the key, the value and the range.
    """
    source = str(path)
    file = parse_bank(read_toml(path, "bank"), source=source)
    here = Path(path).resolve().parent
    paths = tuple((here / a.installation).resolve() for a in file.arms)
    insts = []
    for i, (arm, p) in enumerate(zip(file.arms, paths, strict=True)):
        try:
            insts.append(load_config(p))
        except ConfigError as exc:
            raise ConfigError(f"{source}: arms.{i}.installation = {arm.installation!r} ({arm.name}): {exc}",
                              source=source, expected="bank") from None
    by_arm = {f.arm: f for f in file.manifold.flanges}
    flanges = tuple(by_arm[a.name] for a in file.arms)
    insts = [inst if f.density is None else            # the flange's product, where the bank names its density
             inst.model_copy(update={"masses": inst.masses.model_copy(update={"product_density": f.density})})
             for inst, f in zip(insts, flanges, strict=True)]
    models = tuple(compile_model(inst, source=str(p)) for inst, p in zip(insts, paths, strict=True))
    shapes = tuple(_shape(a, inst, m, file.clearance) for a, inst, m in zip(file.arms, insts, models, strict=True))
    connected, stowed = _poses(file, source, models, insts, flanges)
    bank = Bank(file, source, tuple(insts), paths, models, shapes, flanges, connected, stowed)
    _refuse_close(bank, connected, "connected to their flanges")
    _refuse_close(bank, stowed, "stowed")
    return bank


def bank_parameter_markdown() -> str:
    """The bank file's parameters as a markdown table (key, unit, default, range, description, source), for
    docs/bank.md.

    Returns
    -------
    str
    """
    return parameter_markdown([("bank", BankSection), ("arms[]", BankArm), ("manifold", Manifold),
                               ("manifold.flanges[]", Flange), ("power_unit", PowerUnit),
                               ("manifold_loads", ManifoldLoads), ("clearance", Clearance), ("swivels", Swivels)])
