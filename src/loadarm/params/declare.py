"""How a parameter is declared, once: its unit, range, default and source (:func:`param`), the strict frozen
section it belongs to (:class:`Section`), and the one-line error that names the file, the key, the value and the
allowed range (:func:`format_validation_error`). The installation, the berth and the scenario files all declare
their parameters with these."""

from __future__ import annotations

import difflib
import types
import typing
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

__all__ = ["REQUIRED", "Section", "param", "toml_values", "param_range", "range_text", "in_range",
           "format_validation_error"]

#: The default of a parameter the file must give (customer data with no sensible default).
REQUIRED = object()


def param(default: Any, *, unit: str, description: str, source: str, gt: float | None = None,
          ge: float | None = None, lt: float | None = None, le: float | None = None,
          paper: Any = None) -> Any:
    """Declare one parameter: unit, range, default and where the default comes from.

    Parameters
    ----------
    default : Any
        The default, or :data:`REQUIRED`.
    unit : str
        SI unit (``deg`` only for keys ending ``_deg``).
    description : str
        What it is.
    source : str
        Where the default comes from (a standard, the paper, an engineering choice).
    gt, ge, lt, le : float, optional
        The allowed range.
    paper : Any, optional
        The paper's value, where it differs from the default.

    Returns
    -------
    pydantic.fields.FieldInfo
        For a :class:`Section`'s field.
    """
    extra = {"unit": unit, "source": source}
    if paper is not None:
        extra["paper"] = paper
    kwargs: dict[str, Any] = dict(description=description, json_schema_extra=extra)
    for key, val in (("gt", gt), ("ge", ge), ("lt", lt), ("le", le)):
        if val is not None:
            kwargs[key] = val
    if default is REQUIRED:
        return Field(**kwargs)
    return Field(default, **kwargs)


class Section(BaseModel):
    """A section of a parameter file: strict (no coercion), frozen, no unknown key, no NaN or infinity."""

    # strict: no coercion ("12" or true is not a length; an integer is accepted where a float is declared),
    # no NaN or infinity (TOML has both literals)
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True, strict=True, allow_inf_nan=False)


def toml_values(data: Any) -> Any:
    """TOML arrays as tuples (the parameters' declared type), everything else as it is, so that the strict
    models accept them. The depth is bounded by :func:`loadarm.files.check_depth`.

    Parameters
    ----------
    data : Any
        Parsed TOML.

    Returns
    -------
    Any
    """
    if isinstance(data, dict):
        return {k: toml_values(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return tuple(toml_values(v) for v in data)
    return data


def param_range(model: type[BaseModel], field: str) -> tuple[float | None, bool, float | None, bool, str]:
    """A declared parameter's range and unit, from its declaration (:func:`param`).

    Parameters
    ----------
    model : pydantic model class
        A section (``Operability``, ...).
    field : str

    Returns
    -------
    lo : float or None
    lo_inclusive : bool
    hi : float or None
    hi_inclusive : bool
    unit : str
    """
    info = model.model_fields[field]
    unit = (info.json_schema_extra or {}).get("unit", "") if isinstance(info.json_schema_extra, dict) else ""
    lo = hi = None
    lo_incl = hi_incl = True
    for meta in info.metadata:
        for attr, incl, is_lo in (("gt", False, True), ("ge", True, True), ("lt", False, False), ("le", True, False)):
            v = getattr(meta, attr, None)
            if v is not None:
                if is_lo:
                    lo, lo_incl = v, incl
                else:
                    hi, hi_incl = v, incl
    return lo, lo_incl, hi, hi_incl, unit


def range_text(model: type[BaseModel], field: str, display: tuple[str, Any] | None = None) -> str:
    """A declared parameter's range as ``[lo, hi] unit`` (brackets open where the bound is), or "" if none.

    Parameters
    ----------
    model : pydantic model class
        A section.
    field : str
        One of its parameters.
    display : (str, callable), optional
        Show the bounds in another unit: its name and the conversion of a bound from the declared unit (the
        report's bar, kN and L/min, converted by pint).

    Returns
    -------
    str
    """
    lo, lo_incl, hi, hi_incl, unit = param_range(model, field)
    if lo is None and hi is None:
        return ""
    if display is not None:
        unit, convert = display
        lo, hi = (None if v is None else convert(v) for v in (lo, hi))
    left = ("[" if lo_incl else "(") + ("-inf" if lo is None else f"{lo:g}")
    right = ("inf" if hi is None else f"{hi:g}") + ("]" if hi_incl else ")")
    return f"{left}, {right} {unit}".rstrip()


def in_range(model: type[BaseModel], field: str, value: float) -> bool:
    """Whether ``value`` lies in the declared range of ``model.field`` (NaN never does).

    Parameters
    ----------
    model : pydantic model class
        A section.
    field : str
        One of its parameters.
    value : float
        The value to test.

    Returns
    -------
    bool
    """
    lo, lo_incl, hi, hi_incl, _ = param_range(model, field)
    if value != value:
        return False
    above = lo is None or (value >= lo if lo_incl else value > lo)
    below = hi is None or (value <= hi if hi_incl else value < hi)
    return above and below


def valid_range_text(model: type[BaseModel], field: str) -> str:
    text = range_text(model, field)
    return f"valid range {text}" if text else ""


def _section_type(ann: Any) -> type[BaseModel] | None:
    """The model class behind a field annotation (``Section`` or ``Section | None``), else None."""
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    if isinstance(ann, types.UnionType) or typing.get_origin(ann) is typing.Union:
        found = [a for a in typing.get_args(ann) if isinstance(a, type) and issubclass(a, BaseModel)]
        return found[0] if len(found) == 1 else None
    return None


def _model_at(loc: tuple[Any, ...], root: type[BaseModel]) -> tuple[type[BaseModel] | None, str | None]:
    model: type[BaseModel] = root
    for i, part in enumerate(loc):
        if not isinstance(part, str) or part not in model.model_fields:
            return (model, None) if i == len(loc) - 1 else (None, None)
        ann = _section_type(model.model_fields[part].annotation)
        if i == len(loc) - 1:
            return model, part
        if ann is not None:
            model = ann
        else:
            return model, part
    return None, None


def format_validation_error(err: ValidationError, source: str, root: type[BaseModel]) -> str:
    """One line for a file's first error: the file, the key, the value and the allowed range.

    Parameters
    ----------
    err : pydantic.ValidationError
        What pydantic found.
    source : str
        The file.
    root : type
        The file's model (``Installation``, ``Berth``, ``Scenario``).

    Returns
    -------
    str
    """
    errors = err.errors()
    # An unknown key is reported first: a typo ('inbord') also makes the intended key missing, and the
    # typo is what the user must see. A wrong value comes next, a missing key last.
    e = min(errors, key=lambda x: {"extra_forbidden": 0, "missing": 2}.get(x.get("type", ""), 1))
    loc = tuple(e.get("loc", ()))
    key = ".".join(str(p) for p in loc) or "(top level)"
    etype = e.get("type", "")
    model, field = _model_at(loc, root)
    rng = valid_range_text(model, field) if model is not None and field is not None else ""
    if etype != "extra_forbidden" and field is None:
        model = None
    if etype == "missing":
        what = f"missing required key '{key}'"
        if model is not None and field is not None:
            info = model.model_fields[field]
            extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
            unit = extra.get("unit", "")
            what += f" ({info.description}, {unit})" if info.description else ""
            if rng:
                what += f"; {rng}"
    elif etype == "extra_forbidden":
        what = f"unknown key '{key}'"
        if model is not None:
            close = difflib.get_close_matches(str(loc[-1]), list(model.model_fields), n=1, cutoff=0.6)
            if close:
                what += f" (did you mean '{close[0]}'?)"
            what += f"; allowed keys: {', '.join(model.model_fields)}"
    elif etype == "value_error":
        msg = str(e.get("ctx", {}).get("error", e.get("msg", "")))
        what = msg if not loc or msg.startswith(key) else f"{key}: {msg}"
    else:
        what = f"{key} = {e.get('input')!r}: {e.get('msg', 'invalid')}"
        if rng:
            what += f"; {rng}"
    extra_count = len(errors) - 1
    more = f" (and {extra_count} more problem{'s' if extra_count > 1 else ''})" if extra_count else ""
    return f"{source}: {what}{more}"


def choices_text(f: Any) -> str:
    """``one of a, b`` for a Literal field, ``text of 1-40 characters`` for a text field, else ``""``."""
    args = typing.get_args(f.annotation) if typing.get_origin(f.annotation) is Literal else ()
    if args:
        return "one of " + ", ".join(str(a) for a in args)
    if f.annotation is str:
        lo = next((m.min_length for m in f.metadata if getattr(m, "min_length", None) is not None), 0)
        hi = next((m.max_length for m in f.metadata if getattr(m, "max_length", None) is not None), None)
        pattern = next((m.pattern for m in f.metadata if getattr(m, "pattern", None) is not None), None)
        return ("text" if hi is None else f"text of {lo}-{hi} characters") + (
            f" matching `{pattern}`" if pattern else "")
    return ""
