"""Operability of a bank of arms over a metocean record (issue 31, item 6): **the downtime of a bank is any arm's**.

Every usable hour of the record is one sea state, as for one arm (:mod:`loadarm.studies.operability`: the same
rows, environment, seed and terminal's criteria). Per state the berth's ship is simulated once
(:func:`loadarm.ship.motion.moored_state`, its roll, pitch and yaw at the manifold with it); the manifold's centre
is the bank's ``[manifold] position`` moved by the ship's flange record and lifted by the tide; each arm's
presentation flange is that centre plus the flange's offset and height turned with the ship, in the arm's own
frame (:meth:`loadarm.guidance.bank.BankMonitor.flanges`, the bank campaign's and the bank's world's route). Each
arm then gets its own connected-mode monitoring (:func:`loadarm.studies.kernel.monitor_record`) with its own
compiled model and design-drift floor table (about its own flange), and its own connect criterion (the
significant motion of its own flange). The terminal's criteria (lines, wind, fenders, motion) are the ship's,
judged once; the arm criterion is down when ANY arm cannot connect or reaches ESD-1.

Each row carries the single arm's columns (:data:`loadarm.studies.operability.COLUMNS`: the stage is the worst
arm's, ESD-1 and the release the first arm's, the largest beta and slew the largest of any arm, the flange
motion the largest, ``connectable`` all arms'), ``arm_governing`` (the arm that took the arm criterion down: the
most severe stage, then the earliest ESD-1, then the largest flange motion, then the bank's order; ``""`` when
the arm criterion is up) and, per arm ``N``, ``stage_N``, ``esd1_s_N``, ``flange_motion_m_N``,
``connectable_N`` and ``down_arm_N``.

The terminal's criteria and the state's length come from the installations' ``[operability]``, which must be
the same for every arm (a bank has one ship, one berth, one terminal).

**The manifold's loads** (``manifold_loads=True``, ``loadarm operability --bank ... --manifold-loads``): each
state's record of the ship (the same flange, reference and angles the monitoring reads, the tide's lift and the
hour's mean wind) also goes through the bank's loads on its flanges
(:func:`loadarm.design.manifold.record_manifold_loads`, the one route of ``check --bank``, the live alarm and
:mod:`loadarm.studies.manifold`): ``manifold_utilisation`` (the largest load over its allowable of any arm in the
state; NaN: not computed, or a flange out of an arm's reach), ``manifold_governing`` (the arm and the load),
``manifold_at_s`` (when), each arm's ``manifold_utilisation_N``, and the criterion ``down_manifold``: any arm's
load past its allowable in the state (a terminal does not stay connected with its ship's manifold overloaded).
It costs about five times the monitoring (74 ms of CPU a 600 s state for four arms), so it is asked for.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from loadarm.design.manifold import LOAD_LABELS, allowable, berth_wind, record_manifold_loads
from loadarm.errors import ConfigError, UnreachableError
from loadarm.guidance.bank import BankMonitor
from loadarm.params.bank import Bank, load_bank
from loadarm.params.berth import load_berth
from loadarm.ship.motion import DT, moored_state
from loadarm.studies.cluster import check_workers
from loadarm.studies.kernel import monitor_record, relative_record
from loadarm.studies.operability import (
    COLUMNS,
    CRITERIA,
    OperabilityResult,
    OperabilitySettings,
    headline_rows,
    judge_state,
    monitor_table_at,
    record_rows,
    run_chunked,
    state_environment,
    state_ship,
    write_parquet,
)
from loadarm.vocab import Severity

__all__ = ["ARM_COLUMNS", "BankOperabilityResult", "bank_columns", "bank_headline_rows", "bank_states",
           "bank_tables", "run_bank_operability"]

#: Per-arm columns, ``<column>_<arm name>`` each.
ARM_COLUMNS = ("stage", "esd1_s", "flange_motion_m", "connectable", "down_arm", "manifold_utilisation")
#: The bank's columns after the single arm's: the governing arm, the manifold's loads and their criterion.
BANK_COLUMNS = ("arm_governing", "manifold_utilisation", "manifold_governing", "manifold_at_s", "down_manifold")


def bank_columns(names) -> tuple[str, ...]:
    """A bank's rows' columns: the single arm's, :data:`BANK_COLUMNS`, then each arm's own.

    Parameters
    ----------
    names : sequence of str

    Returns
    -------
    tuple of str
    """
    return (*COLUMNS, *BANK_COLUMNS, *(f"{c}_{n}" for n in names for c in ARM_COLUMNS))


def bank_tables(bank: Bank, rows: list[dict]) -> list:
    """Each arm's design-drift floor table about its own presentation flange, over these hours' tides (one per
    installation file and flange position).

    Parameters
    ----------
    bank : Bank
    rows : list of dict

    Returns
    -------
    list of FloorTable
    """
    done: dict = {}
    out = []
    for i, model in enumerate(bank.models):
        p = bank.flange_position(i)
        key = (str(bank.paths[i]), *(float(v) for v in p))
        if key not in done:
            done[key] = monitor_table_at(model, p, rows)
        out.append(done[key])
    return out


def _first(values) -> float:
    """The least of the values that are numbers (NaN: none)."""
    real = [v for v in values if v == v]
    return min(real) if real else math.nan


def _governing(names, arms: list[dict]) -> str:
    """The arm that took the arm criterion down (``""``: none did)."""
    down = [k for k, a in enumerate(arms) if a["down_arm"]]
    if not down:
        return ""
    esd = [a["esd1_s"] if a["esd1_s"] == a["esd1_s"] else math.inf for a in arms]
    k = min(down, key=lambda k: (-arms[k]["stage"], esd[k], -arms[k]["flange_motion_m"], k))
    return names[k]


def _combined(arms: list[dict], rec: list) -> dict:
    """The bank's monitoring columns from its arms' (the worst stage, the first ESD-1 and release, the largest)."""
    return {"stage": max(a["stage"] for a in arms), "esd1_s": _first([r.esd1_s for r in rec]),
            "release_s": _first([r.release_s for r in rec]), "max_beta_deg": max(r.max_beta_deg for r in rec),
            "max_slew_deg": max(r.max_slew_deg for r in rec), "z_range_m": max(r.z_range_m for r in rec),
            "min_time_to_limit_s": min(r.min_time_to_limit_s for r in rec),
            "flange_motion_m": max(a["flange_motion_m"] for a in arms),
            "connectable": all(a["connectable"] for a in arms), "outside": any(r.outside for r in rec)}


def _manifold(bank: Bank, limits: np.ndarray, rel: np.ndarray, centre: np.ndarray, angles: np.ndarray,
              env) -> dict:
    """One state's loads on the manifold: the columns of :data:`BANK_COLUMNS` but the governing arm, and each
    arm's utilisation (``manifold_utilisation_<n>``)."""
    names = bank.names
    t = np.arange(rel.shape[1]) * DT
    try:
        rec = record_manifold_loads(bank, t, rel.T - centre, angles, wind=berth_wind(env))
    except UnreachableError:                 # a flange out of an arm's reach: no loads (the monitoring's case)
        return _no_manifold(names)
    u = rec.worst / limits
    i, j = np.unravel_index(int(np.argmax(u)), u.shape)
    return {"manifold_utilisation": float(u[i, j]), "manifold_governing": f"{names[i]} {LOAD_LABELS[j]}",
            "manifold_at_s": float(rec.worst_time[i, j]), "down_manifold": bool(u[i, j] > 1.0),
            **{f"manifold_utilisation_{n}": float(u[a].max()) for a, n in enumerate(names)}}


def _no_manifold(names) -> dict:
    """The manifold's columns where no loads are judged (not asked for, or a flange out of an arm's reach)."""
    return {"manifold_utilisation": math.nan, "manifold_governing": "", "manifold_at_s": math.nan,
            "down_manifold": False, **{f"manifold_utilisation_{n}": math.nan for n in names}}


def bank_states(bank: Bank, ship, tables: list, rows: list[dict], settings: OperabilitySettings,
                x_bearing_deg: float, base_env, manifold_loads: bool = False) -> list[dict]:
    """Simulate the ship once per state and monitor every arm of the bank on it (one Dask task).

    Parameters
    ----------
    bank : Bank
    ship : ShipModel
    tables : list of FloorTable
        Each arm's (:func:`bank_tables`).
    rows : list of dict
        Hours of the record (:func:`loadarm.studies.operability.record_rows`).
    settings : OperabilitySettings
        Resolved.
    x_bearing_deg : float
    base_env : Environment
    manifold_loads : bool
        Judge the manifold's loads too (the module's text).

    Returns
    -------
    list of dict
        One row per state (:func:`bank_columns`).
    """
    if settings.duration_per_state is None or settings.connect_motion_limit is None:
        raise ValueError("bank_states needs resolved settings (OperabilitySettings.resolved)")
    crit = settings.criteria
    ship = state_ship(ship, crit)
    monitor = BankMonitor(bank)
    names = bank.names
    centre = np.asarray(bank.file.manifold.position, dtype=float)
    limits = allowable(bank)[None, :]
    zero = np.zeros(3)
    rel = scratch = np.empty((3, 0))
    out = []
    for row in rows:
        env = state_environment(base_env, row, x_bearing_deg)
        flange, reference, loads, angles = moored_state(ship, env, settings.duration_per_state,
                                                        seed=settings.seed + int(row["index"]), angles=True)
        if rel.shape[1] != flange.shape[0]:
            rel, scratch = np.empty((3, flange.shape[0])), np.empty((3, flange.shape[0]))
        relative_record(flange, reference, centre + np.array([0.0, 0.0, float(row["tide_m"])]), rel)
        flanges = monitor.flanges(rel.T, angles)                  # (n, arms, 3): each arm's flange, its own frame
        loads_on = _manifold(bank, limits, rel, centre, angles, env) if manifold_loads else _no_manifold(names)
        arms, rec = [], []
        for i, model in enumerate(bank.models):
            p = flanges[:, i]
            motion = 4.0 * float(np.max(relative_record(p, zero, zero, scratch)))
            r = monitor_record(model, tables[i], p, DT)
            ok = motion <= settings.connect_motion_limit
            arms.append({"stage": r.stage, "esd1_s": r.esd1_s, "flange_motion_m": motion, "connectable": ok,
                         "down_arm": bool((not ok) or r.stage >= Severity.ESD1),
                         "manifold_utilisation": loads_on.pop(f"manifold_utilisation_{names[i]}")})
            rec.append(r)
        c = _combined(arms, rec)
        verdict = judge_state(crit, ship.moorings, loads, env, c["connectable"], c["stage"])
        verdict["down"] = bool(verdict["down"] or loads_on["down_manifold"])
        out.append({"time": row["time"], "hs_m": row["hs_m"], "tp_s": row["tp_s"],
                    "wind_speed_ms": row["wind_speed_ms"], "current_speed_ms": row["current_speed_ms"],
                    "tide_m": row["tide_m"], **c, **verdict, "arm_governing": _governing(names, arms), **loads_on,
                    **{f"{k}_{n}": a[k] for n, a in zip(names, arms, strict=True) for k in ARM_COLUMNS}})
    return out


def _bank_chunk_task(compiled: tuple, rows: list[dict], settings: OperabilitySettings, path: str):
    """A Dask task: the chunk's states of the bank, written to ``path`` and returned.

    ``compiled`` is ``(bank, ship, tables, x_bearing_deg, base_env, manifold_loads)``.
    """
    import pandas as pd

    bank, ship, tables, x_bearing_deg, base_env, manifold_loads = compiled
    res = pd.DataFrame(bank_states(bank, ship, tables, rows, settings, x_bearing_deg, base_env, manifold_loads),
                       columns=list(bank_columns(bank.names)))
    write_parquet(res, path)
    return res


def _criteria(bank: Bank, source: str):
    """The terminal's ``[operability]``: the same in every arm's installation (one ship, one berth)."""
    first = bank.installations[0].operability
    for inst, path in zip(bank.installations[1:], bank.paths[1:], strict=True):
        other = inst.operability
        if other != first:
            a, b = first.model_dump(), other.model_dump()
            key = next(k for k in a if a[k] != b[k])
            raise ConfigError(f"{source}: every arm's [operability] must be the same (one ship, one terminal): "
                              f"operability.{key} = {b[key]!r} in {path}, {a[key]!r} in {bank.paths[0]}",
                              source=source)
    return first


def run_bank_operability(bank: str | Path, berth: str | Path, metocean: str | Path, out: str | Path, *,
                         hours: int | None = None, settings: OperabilitySettings = OperabilitySettings(),
                         scheduler: str | None = None, workers: int | None = None,
                         progress: Callable[[int, int], None] | None = None, fresh: bool = False,
                         ship=None, manifold_loads: bool = False) -> BankOperabilityResult:
    """The operability of a bank over a record on Dask (chunks in ``<out>.chunks/``, resumed as for one arm).

    Parameters
    ----------
    bank, berth, metocean : path
        The bank file (its arms' installations beside it), the berth file, the metocean record.
    out : path
        Parquet of the per-state rows (:func:`bank_columns`).
    hours, settings, scheduler, workers, progress, fresh, ship
        As :func:`loadarm.studies.operability.run_operability`.
    manifold_loads : bool
        Judge the manifold's loads too: the criterion ``down_manifold`` (the module's text).

    Returns
    -------
    BankOperabilityResult

    Raises
    ------
    ConfigError
        A bad bank, record or setting; arms whose ``[operability]`` differ; chunks of another run.
    """
    check_workers("--workers", workers)
    rows, gaps = record_rows(metocean, hours)
    b = load_bank(bank)
    settings = settings.resolved(_criteria(b, str(bank)))
    bf = load_berth(berth)
    if settings.criteria.passing_ship and bf.passing_ship is None:
        raise ConfigError(f"{b.paths[0]}: operability.passing_ship = true needs a [passing_ship] table in the berth "
                          f"file {berth}")

    def compiled(ship):
        return (b, ship, bank_tables(b, rows), bf.berth.x_bearing_deg, bf.environment, manifold_loads)

    installations = tuple(dict.fromkeys(str(p) for p in b.paths))
    table, wall, n_workers = run_chunked(rows, out, (bank, berth, metocean, hours, settings), compiled,
                                         _bank_chunk_task, bank_columns(b.names), settings=settings,
                                         scheduler=scheduler, workers=workers, progress=progress, fresh=fresh,
                                         ship=ship, berth_file=bf, berth=berth, extra=installations,
                                         variant="manifold loads" if manifold_loads else "")
    return BankOperabilityResult(table, gaps.to_dict(), wall, n_workers, settings.criteria, names=b.names)


@dataclass(frozen=True)
class BankOperabilityResult(OperabilityResult):
    """The operability of a bank: the single arm's result of the bank's rows, with each arm's downtime and the
    governing arm."""

    JUDGED = (*CRITERIA, "manifold")

    names: tuple = field(default=())

    def by_arm(self) -> dict:
        """Each arm's share of the downtime: the hours the state would have been down with that arm alone (the
        ship's criteria or that arm's), and the hours it governed the bank's arm criterion.

        Returns
        -------
        dict
            ``downtime_by_arm_h``, ``downtime_by_arm_fraction``, ``governing_h`` (per arm), ``governing_arm``
            (the arm that governed most hours; ``"none"``). An arm alone is down when its own load on its flange is
            past its allowable too (with the manifold's loads judged).
        """
        df = self.table
        n = len(df)
        ship = np.zeros(n, dtype=bool)
        for name in CRITERIA[:-1]:
            ship |= df[f"down_{name}"].to_numpy(dtype=bool)
        alone = {a: int((ship | df[f"down_arm_{a}"].to_numpy(dtype=bool)
                         | (df[f"manifold_utilisation_{a}"].to_numpy(dtype=float) > 1.0)).sum()) for a in self.names}
        gov = {a: int((df["arm_governing"] == a).sum()) for a in self.names}
        top = max(self.names, key=lambda a: (gov[a], alone[a])) if self.names else None
        return {"downtime_by_arm_h": alone,
                "downtime_by_arm_fraction": {a: h / n if n else math.nan for a, h in alone.items()},
                "governing_h": gov, "governing_arm": top if top is not None and gov[top] > 0 else "none"}

    def manifold(self) -> dict | None:
        """The manifold's loads over the record (None: not judged): the hours down by them, the largest load over
        its allowable, which and when, each arm's largest, and the hours with a flange out of an arm's reach.

        Returns
        -------
        dict or None
        """
        df = self.table
        u = df["manifold_utilisation"].to_numpy(dtype=float)
        if not np.isfinite(u).any():
            return None
        k = int(np.nanargmax(u))
        over = int(df["down_manifold"].to_numpy(dtype=bool).sum())
        when = str(np.datetime64(df["time"].iloc[k], "s"))
        return {"hours_over": over, "downtime_fraction": over / len(df), "max_utilisation": float(u[k]),
                "governing": str(df["manifold_governing"].iloc[k]),
                "at": f"{when} + {float(df['manifold_at_s'].iloc[k]):.1f} s",
                "hours_out_of_reach": int(np.isnan(u).sum()),
                "max_utilisation_by_arm": {a: float(np.nanmax(df[f"manifold_utilisation_{a}"].to_numpy(dtype=float)))
                                           for a in self.names}}

    def to_dict(self) -> dict:
        """:meth:`OperabilityResult.to_dict`, the arms' (:meth:`by_arm`) and the manifold's loads
        (:meth:`manifold`; ``None``: not judged).

        Returns
        -------
        dict
        """
        return {**super().to_dict(), "arms": list(self.names), **self.by_arm(), "manifold_loads": self.manifold()}

    def headline(self) -> list[tuple[str, str]]:
        """:func:`bank_headline_rows` of :meth:`to_dict`.

        Returns
        -------
        list of tuple of str
        """
        return bank_headline_rows(self.to_dict())


def bank_headline_rows(d: dict) -> list[tuple[str, str]]:
    """The single arm's headline (:func:`loadarm.studies.operability.headline_rows`) and the bank's: the downtime
    by arm and the governing arm, after the criteria's rows.

    Parameters
    ----------
    d : dict
        :meth:`BankOperabilityResult.to_dict`.

    Returns
    -------
    list of tuple of str
    """
    rows = headline_rows(d)
    alone, frac, gov = d["downtime_by_arm_h"], d["downtime_by_arm_fraction"], d["governing_h"]
    bank = [("downtime by arm (that arm alone, the ship's criteria too)",
             ", ".join(f"{a} {alone[a]} h ({100 * frac[a]:.1f} %)" for a in d["arms"])),
            ("governing arm (hours it took the arm criterion down)",
             f"{d['governing_arm']}: " + ", ".join(f"{a} {gov[a]} h" for a in d["arms"]))]
    m = d.get("manifold_loads")
    if m is not None:
        bank = [("  manifold loads above their allowable (any arm)", f"{100 * m['downtime_fraction']:.1f} %"),
                *bank, ("largest manifold load / allowable", f"{m['max_utilisation']:.2f} ({m['governing']}, "
                                                             f"{m['at']})"),
                ("largest manifold load / allowable, by arm",
                 ", ".join(f"{a} {v:.2f}" for a, v in m["max_utilisation_by_arm"].items()))]
    at = next((k + 1 for k, (label, _) in enumerate(rows) if label.strip().startswith("the arm (")), len(rows))
    return rows[:at] + bank + rows[at:]
