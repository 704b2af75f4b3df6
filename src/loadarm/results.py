"""Results as data: every computation returns a typed result with ``summary()``, ``to_dict()`` and ``plot()``.

Modelled on python-control's response objects: the numbers live on the result, the command line and the
report both print them from the same :class:`Metric` declarations (key with its unit, label, format), and
``plot()`` draws the same figure everywhere. A metric's name is defined once, on its result type.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = ["Metric", "Summary", "Result", "round_floats", "JSON_DIGITS"]

#: Significant digits of every float loadarm writes as JSON (``--json``, ``summary.json``): far finer than any
#: quantity here is known (0.1 um on 100 m), and 233.14000000000001 prints as 233.14.
JSON_DIGITS = 12


def round_floats(obj: Any, digits: int = JSON_DIGITS) -> Any:
    """Floats to ``digits`` significant digits, through dicts, lists and tuples (tuples become lists): the one
    rounding of every JSON output (``--json`` and the report's ``summary.json``). NaN and infinity stay as they are.

    Parameters
    ----------
    obj : Any
        A JSON-friendly value.
    digits : int
        Significant digits.

    Returns
    -------
    Any
    """
    if isinstance(obj, float):
        return float(f"{obj:.{digits}g}") if math.isfinite(obj) else obj
    if isinstance(obj, dict):
        return {k: round_floats(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [round_floats(v, digits) for v in obj]
    return obj


@dataclass(frozen=True, slots=True)
class Metric:
    """One headline number of a result type.

    Attributes
    ----------
    key : str
        JSON key, ending in its unit (``max_deviation_mm``).
    label : str
        Human label for tables.
    unit : str
        Display unit (``mm``, ``bar``...); empty for counts and text.
    fmt : str
        Format of one value (``.1f``).
    short : str
        Column header for compact tables (default: the label).
    none : str
        Text shown for a missing value (``never``, ``n/a``).
    sep : str
        Separator of a pair of values (``" / "``; ``" .. "`` for a range).
    scale : float
        Display factor from the stored SI value to ``unit`` (1e-3 to show newtons as kN).
    """

    key: str
    label: str
    unit: str = ""
    fmt: str = ".3g"
    short: str = ""
    none: str = "n/a"
    sep: str = " / "
    scale: float = 1.0

    @property
    def header(self) -> str:
        """Compact column header with the unit, ``dev max [mm]``."""
        name = self.short or self.label
        return f"{name} [{self.unit}]" if self.unit else name

    def _scaled(self, value):
        # counts keep their type (an int times 1.0 would be a float that the "d" format refuses)
        return value if self.scale == 1 else value * self.scale

    def format(self, value: Any, *, unit: bool = True) -> str:
        """The value as text, with its unit.

        Parameters
        ----------
        value : float, sequence of float, str or None
            A value of this metric (a pair prints as ``a / b``).
        unit : bool
            Append the unit.

        Returns
        -------
        str
        """
        if value is None:
            return self.none
        if isinstance(value, (list, tuple)):
            text = self.sep.join(format(self._scaled(v), self.fmt) for v in value)
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            text = format(self._scaled(value), self.fmt)
        else:
            text = str(value)
        return f"{text} {self.unit}" if unit and self.unit and value is not None else text


class Summary(dict):
    """Headline numbers of a result: a JSON-friendly dict (keys carry their units) that knows its metrics.

    Parameters
    ----------
    values : dict
        Key to value.
    metrics : tuple of Metric
        The declared metrics, in display order.
    """

    def __init__(self, values: dict, metrics: tuple[Metric, ...]):
        super().__init__(values)
        self.metrics = metrics

    def rows(self) -> list[tuple[str, str]]:
        """``(label, value with unit)`` for every declared metric present, in order.

        Returns
        -------
        list of tuple of str
        """
        return [(m.label, m.format(self.get(m.key))) for m in self.metrics if m.key in self]

    def __str__(self) -> str:
        return format_rows(self.rows())


def format_rows(rows: list[tuple[str, str]]) -> str:
    """``(label, text)`` rows as the console prints them: labels left-aligned in one column.

    Parameters
    ----------
    rows : list of tuple of str

    Returns
    -------
    str
    """
    width = max((len(label) for label, _ in rows), default=0)
    return "\n".join(f"{label:<{width}}  {text}" for label, text in rows)


class Result:
    """Mixin of the result types: ``summary()``, ``to_dict()``, ``plot()``.

    A subclass declares ``METRICS`` and implements ``_values()`` (the headline numbers) and ``_figure()``.
    """

    METRICS: tuple[Metric, ...] = ()

    def _values(self) -> dict:  # pragma: no cover - every result implements it
        raise NotImplementedError

    def summary(self) -> Summary:
        """Headline numbers with their units and labels (a dict, JSON-friendly).

        Returns
        -------
        Summary
        """
        return Summary(self._values(), self.METRICS)

    def to_dict(self) -> dict:
        """Everything JSON needs: the headline numbers as a plain dict.

        Returns
        -------
        dict
        """
        return dict(self._values())

    def plot(self):
        """The result's figure (the one the report and the command line draw).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return self._figure()

    def _figure(self):  # pragma: no cover - every result implements it
        raise NotImplementedError
