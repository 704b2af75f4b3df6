"""Installation configuration: one TOML file describes one arm at one berth.

Every physical parameter is declared exactly once, in :mod:`loadarm.params.sections`,
with its unit, its valid range, a default (or, for customer data that must be given,
the paper's example value) and the source of that value; here the sections make the
:class:`Installation`, and :func:`parameter_table` turns the declarations into the
table printed in ``docs/configuration.md``.

Lengths are metres, speeds m/s, accelerations m/s^2, voltages V. Angles are
degrees in the file only, in keys ending ``_deg``; the rest of loadarm works in
radians (see :attr:`Alarms.first`).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field, ValidationError, create_model, model_validator

from loadarm.errors import ConfigError
from loadarm.files import read_toml  # noqa: F401 (re-exported: config.read_toml, its home before files)
from loadarm.params.declare import Section, choices_text, format_validation_error, param, toml_values, valid_range_text
from loadarm.params.sections import (
    Accumulator,
    ActuatorSection,
    Alarms,
    Approach,
    ArmSection,
    Controller,
    Cylinders,
    Datasheet,
    DesignDrift,
    Encoder,
    Masses,
    Operability,
    Pump,
    Report,
    Sequence,
    SizingBounds,
    Slew,
    Transfer,
    Valve,
)

__all__ = ["Installation", "packaged_example", "SizingArm", "sizing_case_model", "read_toml", "toml_values",
           "load_config", "load_sizing_case", "parse_config", "paper_installation", "parameter_table",
           "parameter_markdown", "example_toml"]


class Installation(Section):
    """One marine loading arm at one berth: everything loadarm needs to plan."""

    datasheet: Datasheet
    arm: ArmSection
    actuators: ActuatorSection
    alarms: Alarms = Field(default_factory=Alarms)
    slew: Slew = Field(default_factory=Slew)
    approach: Approach
    sizing: SizingBounds = Field(default_factory=SizingBounds)
    masses: Masses = Field(default_factory=Masses)
    cylinders: Cylinders = Field(default_factory=Cylinders)
    pump: Pump = Field(default_factory=Pump)
    valve: Valve = Field(default_factory=Valve)
    encoder: Encoder = Field(default_factory=Encoder)
    controller: Controller = Field(default_factory=Controller)
    sequence: Sequence = Field(default_factory=Sequence)
    design_drift: DesignDrift = Field(default_factory=DesignDrift)
    accumulator: Accumulator = Field(default_factory=Accumulator)
    transfer: Transfer = Field(default_factory=Transfer)
    operability: Operability = Field(default_factory=Operability)
    report: Report = Field(default_factory=Report)


def parse_config(data: dict[str, Any], *, source: str = "<config>") -> Installation:
    """Validate a configuration mapping (as read from TOML).

    Parameters
    ----------
    data : dict
        Nested mapping with the sections ``datasheet``, ``arm``, ``actuators``,
        ``approach`` and optionally ``alarms`` and ``sizing``.
    source : str, optional
        Name used in error messages (usually the file name).

    Returns
    -------
    Installation
        The validated, immutable installation.

    Raises
    ------
    ConfigError
        One line naming the key, the value given and the valid range.
    """
    try:
        return Installation.model_validate(toml_values(data))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source, Installation), source=source,
                          expected="installation") from None


def load_config(path: str | Path) -> Installation:
    """Read and validate a TOML installation file.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    Installation
        The validated installation.

    Raises
    ------
    ConfigError
        If the file is missing, is not valid TOML, or fails validation.
    """
    return parse_config(read_toml(path), source=str(path))


class SizingArm(Section):
    """The ``[arm]`` section as sizing reads it: the riser is required, the arm lengths are what sizing finds
    (given, they are checked at the berth's corners as the configured arm)."""

    riser: float = ArmSection.model_fields["riser"]
    inboard: float | None = param(None, unit="m", gt=0, le=100, source="optional for sizing",
                                  description="configured inboard arm length b, checked against the berth")
    outboard: float | None = param(None, unit="m", gt=0, le=100, source="optional for sizing",
                                   description="configured outboard arm length c, checked against the berth")

    @model_validator(mode="after")
    def _both_or_none(self) -> "SizingArm":
        if (self.inboard is None) != (self.outboard is None):
            given, missing = ("inboard", "outboard") if self.outboard is None else ("outboard", "inboard")
            raise ValueError(f"arm.{given} is given without arm.{missing}: give both arm lengths to check a "
                             "configured arm, or neither to size from the datasheet alone")
        return self


def _sizing_fields() -> dict[str, Any]:
    fields: dict[str, Any] = {"datasheet": (Datasheet, ...), "arm": (SizingArm, ...)}
    for name, info in Installation.model_fields.items():
        if name not in fields:  # required elsewhere (actuators, approach) -> optional here; defaults kept
            fields[name] = (info.annotation | None, None) if info.is_required() else (info.annotation, info)
    return fields


@functools.cache
def sizing_case_model() -> type[BaseModel]:
    """The ``SizingCase`` model: what ``loadarm size`` reads.

    ``[datasheet]`` and ``[arm] riser`` are required, ``[alarms]`` and ``[sizing]`` have defaults; every other
    section of an installation may be present and is then validated as usual. Built on first use (it is
    needed by one command only, and building a pydantic model costs start-up time).

    Returns
    -------
    type
        A pydantic model class.
    """
    model = create_model("SizingCase", __base__=Section, **_sizing_fields())
    model.__doc__ = ("What sizing needs from an installation file: the datasheet, the riser, the alarm angles "
                     "and the bounds; every other section is optional and validated when present.")
    return model


def load_sizing_case(path: str | Path) -> Any:
    """Read a file for sizing: ``[datasheet]`` and ``[arm] riser`` are enough.

    Parameters
    ----------
    path : str or Path
        A TOML file: a full installation, or a datasheet with the riser (plus optional ``[alarms]`` and
        ``[sizing]``).

    Returns
    -------
    SizingCase
        The validated sections.

    Raises
    ------
    ConfigError
        One line naming the file, the key, the value and the valid range.
    """
    try:
        return sizing_case_model().model_validate(toml_values(read_toml(path)))
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, str(path), sizing_case_model()), source=str(path),
                          expected="installation") from None


def packaged_example(name: str) -> Path:
    """Path of an example file shipped inside the package (``paper.toml``, ``scenarios/calm.toml``...).

    Parameters
    ----------
    name : str
        Path relative to the package's ``examples`` folder.

    Returns
    -------
    Path
        A file on disk (the package is installed unzipped).
    """
    from importlib.resources import files

    return Path(str(files("loadarm") / "examples" / name))


def _paper_values(model: type[BaseModel]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, info in model.model_fields.items():
        extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
        if "paper" in extra:
            out[name] = extra["paper"]
    return out


def paper_installation() -> Installation:
    """The paper's case (Table 1, Sections 2-5) built from the parameter declarations.

    Returns
    -------
    Installation
        Identical to ``examples/paper.toml``.
    """
    data = {
        "datasheet": _paper_values(Datasheet),
        "arm": _paper_values(ArmSection),
        "actuators": _paper_values(ActuatorSection),
        "approach": _paper_values(Approach),
    }
    return parse_config(data, source="paper case")


_VALIDATOR_RANGES = {
    "approach.stored": "finite, each in [-1000, 1000] m; must be reachable",
    "approach.flange": "finite, each in [-1000, 1000] m; must be reachable",
    "sizing.inboard": "0 < low <= high <= 100 m",
    "sizing.outboard": "0 < low <= high <= 100 m",
    "masses.balance_fills": "each in [0, 1]",
    "cylinders.length_range_1": "0 < retracted < extended <= 50 m",
    "cylinders.length_range_2": "0 < retracted < extended <= 50 m",
    "controller.feedforward": "none, nominal or model",
    "report.scenarios": "up to 50 scenario files",
    "controller.substeps": "auto, or an integer in [1, 100]",
}


def _installation_sections() -> list[tuple[str, type[BaseModel]]]:
    out = []
    for section, info in Installation.model_fields.items():
        model = info.annotation
        assert isinstance(model, type) and issubclass(model, BaseModel)
        out.append((section, model))
    return out


def parameter_table(sections: list[tuple[str, type[BaseModel]]] | None = None) -> list[dict[str, str]]:
    """Every declared parameter, for the configuration docs.

    Parameters
    ----------
    sections : list of (str, model), optional
        Key prefix and section model of each section (default: the installation's; the berth file passes its
        own, :func:`loadarm.params.berth.berth_parameter_markdown`).

    Returns
    -------
    list of dict
        One row per parameter with keys ``key``, ``unit``, ``default``,
        ``range``, ``description`` and ``source``.
    """
    rows = []
    for section, model in (_installation_sections() if sections is None else sections):
        for name, f in model.model_fields.items():
            extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else {}
            if f.is_required():
                default = f"required (paper: {extra['paper']})" if "paper" in extra else "required"
            else:
                default = repr(f.default)
            rows.append({
                "key": f"{section}.{name}",
                "unit": str(extra.get("unit", "")),
                "default": default,
                "range": valid_range_text(model, name).removeprefix("valid range ") or _VALIDATOR_RANGES.get(
                    f"{section}.{name}", choices_text(f) or "see validator"),
                "description": f.description or "",
                "source": str(extra.get("source", "")),
            })
    return rows


def parameter_markdown(sections: list[tuple[str, type[BaseModel]]] | None = None) -> str:
    """The parameter table as Markdown (the body of ``docs/configuration.md``).

    Parameters
    ----------
    sections : list of (str, model), optional
        As for :func:`parameter_table`.

    Returns
    -------
    str
        A Markdown table, one row per parameter.
    """
    def esc(text: str) -> str:
        return text.replace("|", "\\|")

    lines = ["| key | unit | default | valid range | description | source |", "|---|---|---|---|---|---|"]
    for r in parameter_table(sections):
        lines.append("| `{}` | {} | {} | {} | {} | {} |".format(
            r["key"], esc(r["unit"]), esc(r["default"]), esc(r["range"]), esc(r["description"]), esc(r["source"])))
    return "\n".join(lines) + "\n"


def example_toml() -> str:
    """``examples/full.toml``: every key with the paper's case and the defaults, commented.

    Returns
    -------
    str
        TOML text that loads back to :func:`paper_installation`.
    """
    inst = paper_installation()
    rows = {r["key"]: r for r in parameter_table()}

    def fmt(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, (tuple, list)):
            return "[" + ", ".join(fmt(x) for x in v) + "]"
        return repr(float(v)) if isinstance(v, float) else repr(v)

    lines = ["# Every key loadarm reads, with the paper's case and the documented defaults.",
             "# Generated from the parameter declarations (python -m loadarm.params.config --example); SI units.",
             "# examples/paper.toml is the short form: anything left out takes these defaults.", ""]
    for section in Installation.model_fields:
        sec = getattr(inst, section)
        lines.append(f"[{section}]")
        for key in type(sec).model_fields:
            r = rows[f"{section}.{key}"]
            value = getattr(sec, key)
            if value is None:                     # TOML has no null: an optional key left out, shown commented
                lines.append(f"# {key} = (not set)  # {r['unit']}: {r['description']}")
            else:
                lines.append(f"{key} = {fmt(value)}  # {r['unit']}: {r['description']}")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover - regenerates docs/configuration.md's table and examples/full.toml
    import sys

    print(example_toml() if "--example" in sys.argv else parameter_markdown(), end="")
