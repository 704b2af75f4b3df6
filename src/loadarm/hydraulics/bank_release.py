"""One emergency release for all the bank's arms on the shared power unit's accumulators (issue 31, item 5).

With the pumps lost, the power unit's accumulator bottles alone close every arm's ERS valves, open every
coupler (ERC) once its valves confirm, and retract every arm clear of the manifold (PERC). All arms act at once
(the worst draw); each arm's steps run in the sequence's order: ERS valves from t = 0, the coupler from the
valves' confirmation, the retraction from the coupler free.

**Gas.** The bottles are charged slowly to ``max_pressure`` (isothermal: ``V1 = N V0 p0 / p_max``) and discharged
in seconds (polytropic ``p V^n = const``, ``n`` the power unit's declared ``polytropic_index``, 1.4 for an
adiabatic diatomic ideal gas): the ideal gas's polytropic process (e.g. Cengel & Boles, *Thermodynamics: An
Engineering Approach*, section on polytropic processes); the same law as the single arm's check
(:func:`loadarm.design.check.accumulator_usable_volume`). Real nitrogen at 200 bar departs from the ideal gas by
a few per cent; the index's source is the bank file's.

**Oil.** Each arm's steps draw the oil the single arm's check counts (one formula, one place): its installation's
``[accumulator] required_volume`` (the ERS valve actuators and the PERC's release stroke, split by the power
unit's ``ers_valve_share``) and :func:`loadarm.design.check.retraction_oil`.

**Flow.** Each step fills through an orifice from the common supply to tank (gauge 0; the actuators' load is
not modelled, the power unit's ``min_pressure`` stands for the pressure they need to move):
:func:`loadarm.hydraulics.components.orifice_flow` with the arm's ``[valve] laminar_pressure``. The ERS valve
actuators' and the coupler's orifices are sized so that at ``max_pressure`` they stroke in their rated time
(the power unit's ``ers_valve_stroke_time``, ``erc_stroke_time``); the retraction runs through the arm's two
proportional valves fully open (``[valve] nominal_flow`` at ``nominal_pressure_drop`` over both lands,
:func:`~loadarm.hydraulics.components.valve_coefficient`), the arm balanced by its counterweights.

The release fails when the pressure falls below ``min_pressure`` before every step is done, or a step ends
later than its sequence time (``[sequence] ers_valve_time`` from the command, ``erc_release_time`` from the
coupler's command). :func:`require_release` refuses such a bank in one line naming the shortfall
(:class:`loadarm.errors.ReleaseError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from loadarm.design.check import accumulator_usable_volume, retraction_oil
from loadarm.errors import ReleaseError
from loadarm.hydraulics.components import orifice_flow, valve_coefficient
from loadarm.hydraulics.plots import release_figure
from loadarm.results import Metric, Result

__all__ = ["STEPS", "DT", "ReleaseStep", "BankRelease", "release_steps", "gas_pressure", "simulate_release",
           "require_release", "release_shortfall"]

#: The steps of each arm's release, in order.
STEPS = ("ERS valves", "coupler", "retraction")
#: Largest time step of the integration, s: 1 ms, 1/5000 of the ERS valves' 5 s stroke.
DT = 1e-3


@dataclass(frozen=True, slots=True)
class ReleaseStep:
    """One step of one arm's release.

    Attributes
    ----------
    arm : int
    step : int
        Index in :data:`STEPS`.
    volume : float
        Oil it draws, m^3.
    k : float
        Its orifice coefficient, m^3/(s Pa^0.5).
    p_lam : float
        The laminar transition, Pa.
    limit : float
        Its sequence time (from its own start), s; ``inf`` for the retraction.
    """

    arm: int
    step: int
    volume: float
    k: float
    p_lam: float
    limit: float


def gas_pressure(oil_out, gas0: float, p_max: float, n: float):
    """The bottles' pressure once ``oil_out`` has left them: ``p_max (V1 / (V1 + oil_out))^n``, Pa.

    Parameters
    ----------
    oil_out : float or ndarray
        Oil delivered since the release began, m^3.
    gas0 : float
        Gas volume charged, ``N V0 p0 / p_max``, m^3.
    p_max : float
        Charged pressure, Pa.
    n : float
        Polytropic index.

    Returns
    -------
    float or ndarray
    """
    return p_max * (gas0 / (gas0 + np.asarray(oil_out, dtype=float))) ** n


def release_steps(bank) -> tuple[ReleaseStep, ...]:
    """Every arm's three steps: oil, orifice and sequence time, from each arm's installation.

    Parameters
    ----------
    bank : loadarm.params.bank.Bank

    Returns
    -------
    tuple of ReleaseStep
        Arm by arm, in the order of :data:`STEPS`.
    """
    pu = bank.file.power_unit
    p_max = pu.max_pressure
    out = []
    for i, (model, inst) in enumerate(zip(bank.models, bank.installations, strict=True)):
        p_lam = inst.valve.laminar_pressure
        req, seq = model.accumulator.required_volume, model.sequence
        ers, erc = req * pu.ers_valve_share, req * (1.0 - pu.ers_valve_share)
        unit = orifice_flow(1.0, p_max, p_lam)
        valves = 2.0 * valve_coefficient(inst.valve.nominal_flow, inst.valve.nominal_pressure_drop) / math.sqrt(2.0)
        out += [ReleaseStep(i, 0, ers, ers / (pu.ers_valve_stroke_time * unit), p_lam, seq.ers_valve_time),
                ReleaseStep(i, 1, erc, erc / (pu.erc_stroke_time * unit), p_lam, seq.erc_release_time),
                ReleaseStep(i, 2, retraction_oil(model), valves, p_lam, math.inf)]
    return tuple(out)


@dataclass(frozen=True)
class BankRelease(Result):
    """The release of every arm at once on the power unit's accumulators.

    Attributes
    ----------
    names : tuple of str
        The arms.
    t, pressure, oil : ndarray, shape (n,)
        Time (s), the bottles' pressure (Pa) and the oil delivered (m^3).
    start, end : ndarray, shape (n_arms, 3)
        Each step's start and end, s (NaN: not reached).
    steps : tuple of ReleaseStep
    usable, needed : float
        Oil the bottles deliver from ``max_pressure`` to ``min_pressure`` (closed form), and what every step draws,
        m^3.
    max_pressure, min_pressure : float
        Pa.
    problems : tuple of str
    """

    METRICS = (
        Metric("verdict", "verdict"),
        Metric("usable_m3", "accumulators, usable oil", "L", ".2f", scale=1e3),
        Metric("needed_m3", "every arm's release needs", "L", ".2f", scale=1e3),
        Metric("end_pressure_pa", "accumulators' end pressure", "bar", ".1f", scale=1e-5),
        Metric("min_pressure_pa", "minimum working pressure", "bar", ".1f", scale=1e-5),
        Metric("last_clear_s", "last arm retracted clear", "s", ".2f", none="never"),
    )

    names: tuple[str, ...]
    t: np.ndarray
    pressure: np.ndarray
    oil: np.ndarray
    start: np.ndarray
    end: np.ndarray
    steps: tuple[ReleaseStep, ...]
    usable: float
    needed: float
    max_pressure: float
    min_pressure: float
    problems: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """Every step done in its time above the minimum pressure."""
        return not self.problems

    def _values(self) -> dict:
        done = bool(np.all(np.isfinite(self.end)))
        return {"verdict": "pass" if self.ok else "refused", "usable_m3": self.usable, "needed_m3": self.needed,
                "end_pressure_pa": float(self.pressure[-1]), "min_pressure_pa": self.min_pressure,
                "last_clear_s": float(np.max(self.end[:, 2])) if done else None,
                "arms": [{"arm": n, **{f"{s.replace(' ', '_')}_start_s": _num(self.start[i, j])
                                       for j, s in enumerate(STEPS)},
                          **{f"{s.replace(' ', '_')}_end_s": _num(self.end[i, j]) for j, s in enumerate(STEPS)}}
                         for i, n in enumerate(self.names)],
                "problems": list(self.problems)}

    def _figure(self):
        return release_figure(self)


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _flows(steps, active, p: float) -> np.ndarray:
    return np.array([orifice_flow(s.k, p, s.p_lam) if a else 0.0 for s, a in zip(steps, active, strict=True)])


def _integrate(steps, n_arms: int, gas0: float, pu, dt: float):
    """Fixed-step midpoint integration with each step's end hit exactly (the step size cut to it)."""
    vol = np.array([s.volume for s in steps])
    fill = np.zeros(len(steps))
    cur = np.zeros(n_arms, dtype=int)            # each arm's current step (3: done)
    start = np.full((n_arms, 3), np.nan)
    end = np.full((n_arms, 3), np.nan)
    start[:, 0] = 0.0
    t, oil = 0.0, 0.0
    ts, ps, oils = [0.0], [pu.max_pressure], [0.0]
    low = math.nan
    while np.any(cur < 3):
        active = np.array([cur[s.arm] == s.step for s in steps])
        p = float(gas_pressure(oil, gas0, pu.max_pressure, pu.polytropic_index))
        if p < pu.min_pressure:
            low = t
            break
        q0 = _flows(steps, active, p)
        h = min(dt, float(np.min((vol - fill)[active] / q0[active])))
        pm = float(gas_pressure(oil + 0.5 * h * q0.sum(), gas0, pu.max_pressure, pu.polytropic_index))
        qm = _flows(steps, active, pm)
        h = min(dt, float(np.min((vol - fill)[active] / qm[active])))
        fill = np.where(active, np.minimum(fill + h * qm, vol), fill)
        oil, t = float(fill.sum()), t + h
        for k in np.flatnonzero(active & (fill >= vol * (1.0 - 1e-12))):
            s = steps[k]
            fill[k] = vol[k]
            end[s.arm, s.step] = t
            cur[s.arm] += 1
            if s.step < 2:
                start[s.arm, s.step + 1] = t
        ts.append(t)
        ps.append(float(gas_pressure(oil, gas0, pu.max_pressure, pu.polytropic_index)))
        oils.append(oil)
    return np.array(ts), np.array(ps), np.array(oils), start, end, low


def release_shortfall(bank, usable: float, needed: float) -> str:
    """The power unit's shortfall in one line (the file, its bottles, what every arm's release needs).

    Parameters
    ----------
    bank : loadarm.params.bank.Bank
    usable, needed : float
        m^3.

    Returns
    -------
    str
    """
    pu, n = bank.file.power_unit, len(bank.names)
    return (f"{bank.source}: power_unit: the accumulators deliver {usable * 1e3:.2f} L from "
            f"{pu.max_pressure / 1e5:g} to {pu.min_pressure / 1e5:g} bar; closing {n} arms' ERS valves, opening "
            f"{n} couplers and retracting {n} arms needs {needed * 1e3:.2f} L: short by "
            f"{(needed - usable) * 1e3:.2f} L (accumulator_volume {pu.accumulator_volume * 1e3:g} L x "
            f"{pu.accumulators})")


def _problems(bank, steps, start, end, low, usable, needed) -> list[str]:
    pu, names = bank.file.power_unit, bank.names
    problems = []
    if not math.isnan(low):
        undone = sorted({names[s.arm] for s in steps if not np.isfinite(end[s.arm, s.step])})
        problems.append(release_shortfall(bank, usable, needed) if needed > usable else
                        f"{bank.source}: power_unit: the accumulators fell to {pu.min_pressure / 1e5:g} bar at "
                        f"{low:.2f} s with {', '.join(undone)} not done")
    for s in steps:
        took = end[s.arm, s.step] - start[s.arm, s.step]
        if np.isfinite(took) and took > s.limit:
            key = "ers_valve_time" if s.step == 0 else "erc_release_time"
            problems.append(f"{bank.source}: power_unit: arm {names[s.arm]!r}: its {STEPS[s.step]} took {took:.2f} s, "
                            f"past its [sequence] {key} = {s.limit:g} s")
    return problems


def simulate_release(bank, *, dt: float = DT) -> BankRelease:
    """Every arm's release at once on the power unit's accumulators, the pumps lost.

    Parameters
    ----------
    bank : loadarm.params.bank.Bank
    dt : float
        Largest time step, s.

    Returns
    -------
    BankRelease
    """
    pu = bank.file.power_unit
    gas0 = pu.accumulators * pu.accumulator_volume * pu.precharge_pressure / pu.max_pressure
    usable = pu.accumulators * accumulator_usable_volume(pu.accumulator_volume, pu.precharge_pressure,
                                                         pu.max_pressure, pu.min_pressure, pu.polytropic_index)
    steps = release_steps(bank)
    needed = float(sum(s.volume for s in steps))
    t, p, oil, start, end, low = _integrate(steps, len(bank.names), gas0, pu, dt)
    problems = _problems(bank, steps, start, end, low, usable, needed)
    return BankRelease(bank.names, t, p, oil, start, end, steps, usable, needed, pu.max_pressure, pu.min_pressure,
                       tuple(problems))


def require_release(bank, *, dt: float = DT) -> BankRelease:
    """:func:`simulate_release`, refusing a bank whose power unit cannot release every arm.

    Parameters
    ----------
    bank : loadarm.params.bank.Bank
    dt : float

    Returns
    -------
    BankRelease

    Raises
    ------
    ReleaseError
        One line naming the shortfall.
    """
    res = simulate_release(bank, dt=dt)
    if not res.ok:
        raise ReleaseError(res.problems[0], result=res)
    return res
