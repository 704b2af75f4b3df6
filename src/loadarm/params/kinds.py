"""The kinds of input loadarm reads, told apart by what is in the file (issue 29, item 16): an installation (or
its datasheet, enough for sizing), a scenario, a berth, a bank of arms (TOML, each by its tables) and a metocean record (CSV or
NetCDF). A file given to the wrong command is named for what it is, with the command that takes it
(``loadarm plan --config`` a scenario file: "this is a scenario file; loadarm run --scenario takes it"), and
``loadarm validate`` checks any input as its own command would.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from loadarm.errors import ConfigError
from loadarm.files import read_toml
from loadarm.params.bank import BankFile
from loadarm.params.berth import Berth
from loadarm.params.config import Installation
from loadarm.params.scenario import Scenario

__all__ = ["Kind", "KINDS", "METOCEAN_SUFFIXES", "identify", "kind_of_tables", "wrong_kind"]


@dataclass(frozen=True)
class Kind:
    """One kind of input.

    Attributes
    ----------
    name : str
        ``installation``, ``scenario``, ``berth`` or ``metocean``.
    command : str
        The command (and option) that takes it.
    tables : frozenset of str
        Its top-level tables (a TOML kind; none for a metocean record).
    """

    name: str
    command: str
    tables: frozenset[str]

    @property
    def noun(self) -> str:
        """``an installation file``, ``a metocean record``..."""
        return f"{'an' if self.name[0] in 'aeiou' else 'a'} {self.name} {'file' if self.tables else 'record'}"


#: Every kind, each with the command that takes it.
KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("installation", "loadarm plan --config", frozenset(Installation.model_fields)),
    Kind("scenario", "loadarm run --scenario", frozenset(Scenario.model_fields)),
    Kind("berth", "loadarm hydro --berth", frozenset(Berth.model_fields)),
    Kind("bank", "loadarm check --bank", frozenset(BankFile.model_fields)),
    Kind("metocean", "loadarm operability --metocean", frozenset()),
)}
#: A metocean record's file suffixes (``studies.metocean.read_metocean`` reads them).
METOCEAN_SUFFIXES = (".csv", ".nc")


def _own(kind: Kind) -> frozenset[str]:
    """The tables only this kind has (``[ship]`` and ``[environment]`` are a scenario's and a berth's)."""
    others = frozenset().union(*(k.tables for k in KINDS.values() if k is not kind))
    return kind.tables - others


def kind_of_tables(tables) -> Kind | None:
    """The TOML kind whose own tables the file has most of (None: none of any kind's, or as many of two).

    Parameters
    ----------
    tables : iterable of str
        The file's top-level keys.

    Returns
    -------
    Kind or None
    """
    keys = set(tables)
    score = {k: len(keys & _own(k)) for k in KINDS.values() if k.tables}
    best = max(score.values())
    winners = [k for k, s in score.items() if s == best]
    return winners[0] if best > 0 and len(winners) == 1 else None


def identify(path: str | Path) -> tuple[Kind, dict]:
    """The kind of an input file, and its TOML (empty for a metocean record, which is not read here).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    kind : Kind
    data : dict

    Raises
    ------
    ConfigError
        The file cannot be read, is not TOML (nor a metocean record's CSV or NetCDF), or has none of any kind's
        tables: one line naming the file and the kinds.
    """
    p = Path(path)
    if p.suffix.lower() in METOCEAN_SUFFIXES:
        return KINDS["metocean"], {}
    try:
        data = read_toml(p, "input")
    except ConfigError as exc:
        if "not valid TOML" not in str(exc):
            raise
        raise ConfigError(f"{exc}: not an installation, a scenario, a berth or a bank (TOML), nor a metocean record "
                          "(.csv or .nc)") from None
    kind = kind_of_tables(data)
    if kind is None:
        found = ", ".join(f"[{k}]" for k in sorted(data)) or "no tables"
        raise ConfigError(f"{p}: {found}: not an installation ([datasheet], [arm], ...), a scenario ([scenario], "
                          "[drift], ...), a berth ([berth], [[moorings]], ...) or a bank ([bank], [[arms]], ...), "
                          "nor a metocean record (.csv or .nc)")
    return kind, data


def wrong_kind(source: str | None, expected: str | None) -> str | None:
    """The one line that says a refused file is another kind of input, and which command takes it; None when it is
    the kind expected, or no kind at all (its own error is the better one).

    Parameters
    ----------
    source : str or None
        The file refused.
    expected : str or None
        The kind the command wanted (a name of :data:`KINDS`).

    Returns
    -------
    str or None
    """
    if not source or expected not in KINDS:
        return None
    try:
        kind, _ = identify(source)
    except (ConfigError, OSError):
        return None
    if kind.name == expected:
        return None
    return f"{source}: this is {kind.noun}, not {KINDS[expected].noun}; `{kind.command} {source}` takes it"
