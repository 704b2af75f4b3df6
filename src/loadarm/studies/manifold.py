"""The bank's loads on the ship's manifold over a metocean record: the worst per arm and when (issue 31, item 4).

Every usable hour of the record is one sea state, as the operability study takes it (:mod:`loadarm.studies.operability`:
:func:`~loadarm.studies.operability.record_rows`, :func:`~loadarm.studies.operability.state_environment`, the
hour's place in the record its seed): the berth's design ship moves in that hour's wind, current, waves and tide
(:func:`loadarm.ship.motion.simulate`, its 6-DoF motion at the manifold), the tide lifts the flanges, and
:func:`loadarm.design.manifold.motion_manifold_loads` gives each arm's loads on its flange in that hour's wind. The
study keeps each state's worst load per arm and when; its summary names the worst over the record, its state and
its second, and the hours with a load past its allowable (the alarm ``fault.manifold_load``).

Serial: a state of 600 s costs about 0.15 s (the ship's motion 0.01 s, four arms' loads 0.13 s), two months of
hours about four minutes on one core.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from loadarm.arm.manifold import LOAD_NAMES
from loadarm.design.manifold import (
    LOAD_LABELS,
    MANIFOLD_LOAD_EVENT,
    allowable,
    berth_wind,
    motion_manifold_loads,
)
from loadarm.errors import UnreachableError
from loadarm.params.bank import Bank, load_bank
from loadarm.params.berth import load_berth
from loadarm.results import Metric, Result
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import simulate
from loadarm.studies.operability import record_rows, state_environment
from loadarm.studies.plots import manifold_study_figure

__all__ = ["STATE_DURATION_S", "ManifoldStudy", "manifold_states", "manifold_study"]

#: Seconds of each sea state's motion (the operability study's default state length).
STATE_DURATION_S = 600.0


@dataclass(frozen=True)
class ManifoldStudy(Result):
    """The bank's worst loads on its flanges per sea state of a record.

    Attributes
    ----------
    times : tuple of str
        Each state's hour (ISO 8601).
    names : tuple of str
        The arms.
    worst : ndarray, shape (states, arms, 5)
        The largest magnitude of each load in each state, N and N m (:data:`loadarm.arm.manifold.LOAD_NAMES`).
    when : ndarray, shape (states, arms, 5)
        When in the state, s.
    allowable : ndarray, shape (5,)
    """

    METRICS = (
        Metric("states", "sea states", "", "d"),
        Metric("max_utilisation", "flange load / allowable, largest over the record", "", ".2f"),
        Metric("governing", "which", ""),
        Metric("at", "when", ""),
        Metric("hours_over", "hours with a load over its allowable", "", "d"),
        Metric("out_of_reach", "hours the flange left an arm's reach (no loads)", "", "d"),
        Metric("within_allowable", "within the allowable loads", ""),
    )

    times: tuple[str, ...]
    names: tuple[str, ...]
    worst: np.ndarray
    when: np.ndarray
    allowable: np.ndarray

    @property
    def utilisation(self) -> np.ndarray:
        """``worst / allowable``, shape (states, arms, 5); NaN in a state where the flange left an arm's reach."""
        return self.worst / self.allowable

    @property
    def out_of_reach(self) -> np.ndarray:
        """The states where the flange left an arm's reach (no loads), shape (states,)."""
        return np.isnan(self.worst).any(axis=(1, 2))

    @property
    def exceeded(self) -> list[dict]:
        """Each state, arm and load past its allowable: the alarm's event code, the hour, the second, the arm, the
        load, its value and the allowable."""
        k, i, j = np.nonzero(np.nan_to_num(self.utilisation) > 1.0)
        return [{"code": MANIFOLD_LOAD_EVENT, "time": self.times[a], "at_s": float(self.when[a, b, c]),
                 "arm": self.names[b], "load": LOAD_NAMES[c], "value": float(self.worst[a, b, c]),
                 "allowable": float(self.allowable[c])} for a, b, c in zip(k, i, j, strict=True)]

    def _values(self) -> dict:
        u = np.nan_to_num(self.utilisation, nan=-1.0)
        k, i, j = np.unravel_index(int(np.argmax(u)), u.shape)
        per_arm = u.max(axis=(0, 2))
        worst = np.nan_to_num(self.worst, nan=0.0).max(axis=0)
        return {"states": len(self.times), "max_utilisation": float(u[k, i, j]),
                "governing": f"{self.names[i]} {LOAD_LABELS[j]}",
                "at": f"{self.times[k]} + {float(self.when[k, i, j]):.1f} s",
                "hours_over": int(np.any(u > 1.0, axis=(1, 2)).sum()), "within_allowable": bool(np.all(u <= 1.0)),
                "out_of_reach": int(self.out_of_reach.sum()),
                "arms": {n: {"max_utilisation": float(per_arm[a]),
                             "worst": dict(zip(LOAD_NAMES, (float(v) for v in worst[a]), strict=True))}
                         for a, n in enumerate(self.names)},
                "exceeded": self.exceeded}

    def _figure(self):
        return manifold_study_figure(self.times, self.names, self.utilisation.max(axis=2))


def manifold_states(bank: Bank, ship, base_env, rows: list[dict], *, x_bearing_deg: float = 0.0,
                    duration: float = STATE_DURATION_S, seed: int = 0) -> ManifoldStudy:
    """The bank's worst loads in each sea state of a record.

    Parameters
    ----------
    bank : Bank
    ship : ShipModel
        The berth's ship, compiled.
    base_env : Environment
        The berth file's environment (the record's variables replace its own).
    rows : list of dict
        The record's hours (:func:`loadarm.studies.operability.record_rows`).
    x_bearing_deg : float
        The berth's ``x`` axis as a compass bearing (the record's directions are compass bearings).
    duration : float
        s of each state.
    seed : int
        Added to each hour's place in the record.

    Returns
    -------
    ManifoldStudy
    """
    if not rows:
        raise ValueError("manifold_states: the record has no usable hour")
    worst, when, times = [], [], []
    for row in rows:
        env = state_environment(base_env, row, x_bearing_deg)
        motion = simulate(ship, env, duration, seed=seed + int(row["index"]))
        lift = np.array([0.0, 0.0, float(row["tide_m"])])
        times.append(str(np.datetime64(row["time"], "s")))
        try:
            r = motion_manifold_loads(bank, motion, wind=berth_wind(env), lift=lift)
        except UnreachableError:          # the flange left an arm's reach: no load to give (the monitor's case)
            worst.append(np.full((len(bank.names), len(LOAD_NAMES)), np.nan))
            when.append(np.full((len(bank.names), len(LOAD_NAMES)), np.nan))
            continue
        worst.append(r.worst)
        when.append(r.worst_time)
    return ManifoldStudy(tuple(times), bank.names, np.array(worst), np.array(when), allowable(bank))


def manifold_study(bank: str | Path, berth: str | Path, metocean: str | Path, *, hours: int | None = None,
                   duration: float = STATE_DURATION_S, seed: int = 0) -> ManifoldStudy:
    """:func:`manifold_states` from the files: a bank, the berth its ship comes from, a metocean record.

    Parameters
    ----------
    bank, berth, metocean : path
    hours : int, optional
        Only the record's first ``hours`` usable hours.
    duration : float
        s of each state.
    seed : int

    Returns
    -------
    ManifoldStudy
    """
    b = load_bank(bank)
    bf = load_berth(berth)
    rows, _ = record_rows(metocean, hours)
    return manifold_states(b, compile_ship(bf, source=str(berth)), bf.environment, rows,
                           x_bearing_deg=bf.berth.x_bearing_deg, duration=duration, seed=seed)
