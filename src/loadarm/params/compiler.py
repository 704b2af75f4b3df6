"""Compile a validated installation into the :class:`~loadarm.arm.model.ArmModel` (the edge between files and maths).

Only the edges (CLI, report, scenario loading, docs) call :func:`compile_model`; everything downstream takes
the model. The parameter records are generated from the declarations in :mod:`loadarm.params.sections` (same section
and key names, their declared types), so each parameter is still declared exactly once, with its unit, range and
source, there.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import make_dataclass
from typing import Any

from pydantic import BaseModel

from loadarm.arm.actuators import joint_angles_from_cylinders, length_limits
from loadarm.arm.alarms import AlarmAngles
from loadarm.arm.dynamics import cylinder_areas, lagrange_constants, mass_model
from loadarm.arm.envelope import berth_box
from loadarm.arm.geometry import Arm, Mounting
from loadarm.arm.model import ArmModel, JointLimits, ParamRecord, SlewLimits
from loadarm.errors import ConfigError
from loadarm.params.config import Installation

__all__ = ["compile_model", "RECORD_SECTIONS", "MIN_STROKE"]

#: Configuration sections carried into the model as plain records (the others become typed objects:
#: ``arm`` -> :class:`~loadarm.arm.geometry.Arm`, ``alarms`` -> :class:`~loadarm.arm.alarms.AlarmAngles`,
#: ``slew`` -> :class:`~loadarm.arm.model.SlewLimits`; ``sizing`` and ``report`` are read at the edge only).
RECORD_SECTIONS = ("datasheet", "actuators", "approach", "masses", "cylinders", "pump", "valve", "encoder",
                   "controller", "sequence", "design_drift", "accumulator", "transfer")


def _record_type(key: str, section: type[BaseModel]) -> type:
    """A frozen, slotted dataclass with the section's keys and their declared types (the declarations stay in the
    config model)."""
    rec = make_dataclass(f"{section.__name__}Params",
                         [(name, f.annotation) for name, f in section.model_fields.items()],
                         bases=(ParamRecord,), frozen=True, slots=True)
    rec.__doc__ = (f"The ``[{key}]`` parameters as plain values, SI units "
                   f"(declared in :class:`loadarm.params.sections.{section.__name__}`).")
    return rec


_RECORD_TYPES = {name: _record_type(name, Installation.model_fields[name].annotation) for name in RECORD_SECTIONS}


def _plain(value: Any) -> Any:
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    return value


def _record(name: str, section: BaseModel) -> Any:
    return _RECORD_TYPES[name](**{k: _plain(getattr(section, k)) for k in type(section).model_fields})


#: Smallest usable cylinder stroke, m: less cannot swing a loading arm through its envelope (found: a pin at
#: ``actuators.a1 = 1e-12`` m made a zero-stroke cylinder that compiled without a word).
MIN_STROKE = 0.05


def _joint_limits(mount: Mounting, cylinders, slew: SlewLimits, v_max: tuple[float, float]) -> JointLimits:
    geo = length_limits(mount)
    # Eq. 12: r_ac1 shrinks as alpha grows; Eq. 13: r_ac2 grows with beta. A cylinder cannot be shorter or
    # longer than its pin triangle allows (flat), so its length range is cut to that.
    r1 = [min(max(v, geo["r_ac1"][0]), geo["r_ac1"][1]) for v in cylinders.length_range_1]
    r2 = [min(max(v, geo["r_ac2"][0]), geo["r_ac2"][1]) for v in cylinders.length_range_2]
    for i, r, pins in ((1, r1, "a1 = {0.a1:g} m, b1 = {0.b1:g} m"), (2, r2, "b2 = {0.b2:g} m, c2 = {0.c2:g} m")):
        if r[1] - r[0] < MIN_STROKE:
            given = getattr(cylinders, f"length_range_{i}")
            lo, hi = geo[f"r_ac{i}"]
            raise ConfigError(
                f"cylinder {i} has a usable stroke of {max(r[1] - r[0], 0.0):.3g} m: cylinders.length_range_{i} = "
                f"[{given[0]:g}, {given[1]:g}] m within the [{lo:.3g}, {hi:.3g}] m its pins allow (actuators."
                f"{pins.format(mount)}); at least {MIN_STROKE:g} m is needed")
    a_hi, b_lo = joint_angles_from_cylinders(mount, r1[0], r2[0])
    a_lo, b_hi = joint_angles_from_cylinders(mount, r1[1], r2[1])
    # joint rate bound from the cylinder speed over the largest moment arm (a1 b1 / r etc. <= min(a1, b1))
    rate_a = v_max[0] / max(min(mount.a1, mount.b1), 1e-6)
    rate_b = v_max[1] / max(min(mount.b2, mount.c2), 1e-6)
    return JointLimits((-slew.limit, slew.limit), (float(a_lo), float(a_hi)), (float(b_lo), float(b_hi)),
                       (slew.max_rate, rate_a, rate_b))


def compile_model(inst: Installation, *, source: str | None = None) -> ArmModel:
    """Compile a validated installation into the model every stage takes.

    Parameters
    ----------
    inst : Installation
        A validated installation (:func:`loadarm.params.config.load_config`).
    source : str, optional
        The file it came from, to name in the messages of the cross-checks.

    Returns
    -------
    ArmModel
        The immutable model.

    Raises
    ------
    ConfigError
        A cross-check between sections fails (a cylinder without a usable stroke, a release angle beyond the
        stroke end); one line, starting with ``source``.
    """
    try:
        return _compile(inst)
    except ConfigError as exc:
        if source is None:
            raise
        raise ConfigError(f"{source}: {exc}") from None


def _compile(inst: Installation) -> ArmModel:
    arm = Arm(inst.arm.riser, inst.arm.inboard, inst.arm.outboard)
    a = inst.actuators
    mount = Mounting(a.a1, a.b1, a.b2, a.c2)
    al = inst.alarms
    sl = inst.slew
    slew = SlewLimits(math.radians(sl.limit_deg), math.radians(sl.first_deg), math.radians(sl.second_deg),
                      math.radians(sl.release_deg), math.radians(sl.max_rate_deg))
    area = cylinder_areas(inst.cylinders.bore, inst.cylinders.rod)
    v = min(inst.valve.nominal_flow, inst.pump.max_flow / 2.0) / area[0]
    joint_limits = _joint_limits(mount, inst.cylinders, slew, (v, v))
    if al.release > joint_limits.beta[1]:
        raise ConfigError(
            f"alarms.release_deg = {al.release_deg:g} deg lies beyond the arm's limit: cylinder 2's stroke ends at "
            f"beta = {math.degrees(joint_limits.beta[1]):.1f} deg, so the release could never fire; set it below "
            "that (with room for the release sequence)")
    records = {name: _record(name, getattr(inst, name)) for name in RECORD_SECTIONS}
    base = ArmModel(arm=arm, mount=mount, alarms=AlarmAngles(al.first, al.second, al.release), slew=slew,
                    berth=berth_box(inst.datasheet), joint_limits=joint_limits,
                    cylinder_area=(float(area[0]), float(area[1])), cylinder_speed_limit=(v, v), **records)
    # the mass model at the configured fill, derived once from the model itself (the hydraulic parameter vector
    # is packed by hydraulics.simulate.pack_parameters, so that compiling never imports numba: cold start)
    mass = mass_model(base)
    return dataclasses.replace(base, mass=mass, lagrange=lagrange_constants(mass))
