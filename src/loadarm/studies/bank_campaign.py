"""The bank's drift-off over many seeds (issue 31, item 5): every arm connected to one moored ship, the bank's
emergency sequence, and what it must never do: overstretch an arm, open a coupler before its ERS valves confirm,
let two arms clash.

**The route, and what it does not simulate.** The single arm's closed loop costs about 11 s a 600 s run; this is
the operability kernel's route (:mod:`loadarm.studies.kernel`), for a bank:

* the ship: the scenario's moored ship (:func:`loadarm.ship.flange.flange_motion`: its 10 Hz motion with waves,
  slow drift and the lines parting, as ``loadarm run`` sees it), seeded per run; the manifold's centre follows the
  scenario's flange, every presentation flange the manifold at its offset, turned with the ship's roll, pitch and
  yaw (:meth:`loadarm.guidance.bank.BankMonitor.flanges`, as :class:`loadarm.sim.bank.BankWorld`);
* each arm: connected from the record's start, its coupler on its flange (the inverse kinematics, exact: the
  closed loop's attached arm is carried by the flange the same way), sampled at the monitor's 5 Hz;
* the alarms: each arm's customer angles (beta and slew), its design-drift floor, the time a break-out at the
  berth's design drift takes to reach a face (the kernel's :func:`~loadarm.studies.kernel.floor_table`, looked up;
  beyond it the rays cast), its own monitor's forecast with the measured routes (:func:`measured_times`: the
  drift fit, the velocity-step and break-out tests on its true flange, every second once the floor is within
  130 s), and the bank's faces, the swivels' stops and the clash of neighbours, by the bank's
  monitor's design-drift forecast (:class:`loadarm.guidance.bank.BankMonitor` without history, every 2 s, its
  time held down by the time elapsed);
* the sequence, compiled from :func:`loadarm.arm.sequence.lead_values` and :func:`~loadarm.arm.sequence.stage_of`:
  ESD-1 for every arm at the first sample any arm's stage reaches it, each arm's ERS valves confirmed
  ``ers_valve_time`` after their command (intact valves), ERS-2 for every arm at the first sample any arm's stage
  reaches RELEASE, each coupler opening as soon as its own valves confirm, free ``erc_release_time`` later;
* the retraction (PERC): from its coupler free, each arm's coupler leaves its flange straight towards its stored
  position, :data:`~loadarm.design.check.MANIFOLD_CLEARANCE` in the time the shared power unit's accumulators
  take to drive it there with every arm releasing at once (:func:`retraction_times`, from
  :func:`loadarm.hydraulics.bank_release.require_release`: a bank whose power unit cannot release every arm is
  refused before any run), then held; the clash of neighbours is counted over the whole run, connected,
  retracting or retracted (:func:`couplers`).

Not simulated: the flange sensor and its estimator (the monitor sees the true flange, at 1 Hz rather than the
controller's 5 Hz), the predictor of issue 30, the pre-alarm, the drives before the release, valve faults, and
the hydraulics' timing of the valves and couplers (they take the sequence's times, the longest the sequence
allows, where the power unit's simulation is quicker). The coupler opening before its valves confirm is the
scan's interlock: its count checks the bank's sequence, not a plant. A slow test holds this route to the single
arm's closed loop on the same seeds.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from loadarm._numba import njit
from loadarm.arm.alarms import beta_severity, slew_severity
from loadarm.arm.faces import face_margins
from loadarm.arm.sequence import esd_lead, lead_values, stage_of, valve_worst_time
from loadarm.arm.slew import inverse3d
from loadarm.design.check import MANIFOLD_CLEARANCE
from loadarm.errors import ConfigError
from loadarm.hydraulics.bank_release import require_release
from loadarm.figures import subplots
from loadarm.guidance.bank import BankMonitor, neighbours
from loadarm.guidance.monitor import EnvelopeMonitor, stage_leads
from loadarm.params.bank import Bank, load_bank
from loadarm.params.config import read_toml
from loadarm.params.scenario import parse_scenario, resolve_berth
from loadarm.results import Metric, Result
from loadarm.ship.flange import flange_motion
from loadarm.ship.model import moored_ship
from loadarm.vocab import Severity
from loadarm.studies.kernel import breakout_time, floor_table, ray_distances
from loadarm.studies.runs_file import RUNS_FILE_BATCH, RunsFile, Tally

__all__ = ["BankRun", "BankCampaignResult", "bank_run", "run_bank_campaign", "check_bank_campaign",
           "bank_sequence", "sequence_table", "arm_record", "single_arm_run", "retraction_times", "couplers", "BANK_PERIOD"]

#: The monitor's sampling period, s (its 5 Hz forecast).
BANK_PERIOD = 0.2
#: How often the bank's faces are forecast, s (their time held down by the time elapsed between; the forecast's
#: own scan steps 2 s).
BANK_FACE_PERIOD = 2.0
#: How often each arm's own forecast (the monitor's, measured routes included) is made, s.
MEASURED_PERIOD = 1.0
#: The design floor's time to limit under which an arm's own forecast is made, s: a drift the measured routes
#: would call ESD-1 for (35 s) at up to 0.5 m/s lies within 17.5 m, 124 s away at the floor's design drift.
MEASURED_GATE = 130.0
#: Seconds judged past the scenario's end, for where each flange would have crossed its face after the release.
LOOKAHEAD = 300.0

_lead_values = njit(cache=True, nogil=True, inline="always")(lead_values)
_stage_of = njit(cache=True, nogil=True, inline="always")(stage_of)


@njit(cache=True, nogil=True)
def _arm_stage(a, i, t, level, ttl, seq, i_cmd, i_open):
    """Arm ``a``'s stage at sample ``i``: its position level and its time to limit against its leads as its
    sequence stands (valves at their worst until confirmed; the release's own time once opening)."""
    if i_cmd[a] >= 0:
        confirmed = t >= i_cmd[a] * seq[a, 6] + seq[a, 0] - 1e-9
        valves_left = 0.0 if confirmed else max(i_cmd[a] * seq[a, 6] + seq[a, 4] - t, 0.0)
    else:
        valves_left = seq[a, 4]
    release_left = seq[a, 1] if i_open[a] < 0 else max(i_open[a] * seq[a, 6] + seq[a, 1] - t, 0.0)
    rel, sec, esd, pre = _lead_values(valves_left, release_left, seq[a, 2], seq[a, 3], 0.0)
    return max(level[a, i], _stage_of(ttl[a, i], np.inf, rel, sec, esd, pre))


@njit(cache=True, nogil=True)
def bank_sequence(level, ttl, seq, i_cmd, i_conf, i_open):
    """The bank's emergency sequence over a record, compiled: ESD-1 and ERS-2 act on every arm.

    Parameters
    ----------
    level : ndarray of int, shape (arms, n)
        Each arm's position alarm level per sample.
    ttl : ndarray, shape (arms, n)
        Each arm's time to its nearest face (its own and the bank's) per sample, s.
    seq : ndarray, shape (arms, 7)
        Per arm: ``ers_valve_time``, ``erc_release_time``, ``margin``, the ESD-1 lead, the valves' worst time,
        1 if its ERS valves close at ERS-2 (else at ESD-1), and the sample period.
    i_cmd, i_conf, i_open : ndarray of int, shape (arms,)
        Written: the samples of each arm's valve command, their confirmation and its coupler opening (-1: never).

    Returns
    -------
    stage : int
        The most severe stage the bank reached.
    i_esd, i_req : int
        The samples of the bank's ESD-1 and of its ERS-2 request (-1: never).
    first : int
        The arm whose stage raised ESD-1 first (-1: none).
    """
    n_arms, n = level.shape
    raised, i_esd, i_req, first = 0, -1, -1, -1
    for a in range(n_arms):
        i_cmd[a], i_conf[a], i_open[a] = -1, -1, -1
    for i in range(n):
        t = i * seq[0, 6]
        stage, top = 0, -1
        for a in range(n_arms):
            s = _arm_stage(a, i, t, level, ttl, seq, i_cmd, i_open)
            if s > stage:
                stage, top = s, a
        raised = max(raised, stage)
        if raised >= 2 and i_esd < 0:
            i_esd, first = i, top
        if raised >= 4 and i_req < 0:
            i_req = i
        for a in range(n_arms):
            if i_cmd[a] < 0 and ((raised >= 2 and seq[a, 5] == 0.0) or raised >= 4):
                i_cmd[a] = i
            if i_cmd[a] >= 0 and i_conf[a] < 0 and t >= i_cmd[a] * seq[a, 6] + seq[a, 0] - 1e-9:
                i_conf[a] = i
            if i_req >= 0 and i_open[a] < 0 and i_conf[a] >= 0:       # the interlock: only once confirmed
                i_open[a] = i
    return raised, i_esd, i_req, first


@dataclass(frozen=True)
class BankRun:
    """One seed of the bank's drift-off.

    Attributes
    ----------
    seed : int
    esd1_s, release_request_s : float
        The bank's ESD-1 and ERS-2 (NaN: never).
    esd1_by : str
        The arm whose stage raised ESD-1 (``""``: none).
    confirmed_s, opened_s, free_s, retracted_s : tuple of float
        Per arm: its ERS valves confirmed, its coupler opening, free, and retracted clear of the manifold (NaN:
        never).
    face_s : tuple of float
        Per arm: when its flange first passes a face (its own or a swivel's stop), connected or not (NaN: not
        within the record).
    overstretched : tuple of bool
        Per arm: past a face while connected.
    before_isolation : tuple of bool
        Per arm: past a face before its ERS valves confirmed.
    opened_early : tuple of bool
        Per arm: its coupler began to open before its valves confirmed.
    clash : bool
        Two neighbours closer than the bank's clearance during the run (connected, retracting or retracted).
    min_clearance : float
        The smallest clearance of neighbours during the run, m.
    min_swivel_margin_deg : float
        The smallest swivel margin while connected, deg.
    seconds : float
        Its computing time, s (the process's CPU time: the machine's other load apart).
    """

    seed: int
    esd1_s: float
    release_request_s: float
    esd1_by: str
    confirmed_s: tuple
    opened_s: tuple
    free_s: tuple
    face_s: tuple
    overstretched: tuple
    before_isolation: tuple
    opened_early: tuple
    clash: bool
    min_clearance: float
    min_swivel_margin_deg: float
    retracted_s: tuple = ()
    seconds: float = math.nan

    @property
    def margins(self) -> list[float]:
        """Per arm released: from its coupler free to its flange's face, s (inf: no face in the record)."""
        return [(f if f == f else math.inf) - r for f, r in zip(self.face_s, self.free_s, strict=True) if r == r]


def sequence_table(models) -> np.ndarray:
    """The sequence's figures per arm, as :func:`bank_sequence` reads them.

    Parameters
    ----------
    models : sequence of ArmModel
        The arms' compiled installations.

    Returns
    -------
    ndarray, shape (arms, 7)
        Per arm: the ERS valves' time, the coupler's release time, the margin, ESD-1's lead, the valves' worst
        time, whether the valves close at ERS-2 (1.0) or ESD-1 (0.0), and the bank's period, s.
    """
    return np.array([[m.sequence.ers_valve_time, m.sequence.erc_release_time, m.sequence.margin,
                      esd_lead(m.sequence), valve_worst_time(m.sequence),
                      1.0 if m.sequence.ers_valves_close_at == "ers2" else 0.0, BANK_PERIOD] for m in models])


def arm_record(model, table, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One arm on a record of its flange: the kernel's route.

    Parameters
    ----------
    model : ArmModel
    table : FloorTable
        Its design-drift table (:func:`loadarm.studies.kernel.floor_table`).
    p : ndarray, shape (n, 3)
        Flange positions, its own frame, m.

    Returns
    -------
    q : ndarray, shape (n, 3)
        Slew, inboard, elbow angles, rad (NaN out of reach).
    level : ndarray of int, shape (n,)
        Its position alarm level (out of reach: release).
    ttl : ndarray, shape (n,)
        The design drift's time to a face, s.
    past : ndarray of bool, shape (n,)
        Past a face.
    """
    q = inverse3d(model.arm, p[:, 0], p[:, 1], p[:, 2], check=False)
    level = np.maximum(beta_severity(q.beta, model.alarms), slew_severity(q.phi, model.slew))
    level = np.where(np.isnan(q.beta), 4, level)
    past = face_margins(model, p[:, 0], p[:, 1], p[:, 2]).min(axis=-1) < 0.0
    h, v, inside = table.lookup(p)
    if not inside.all():                           # beyond the table: the rays cast there
        d = ray_distances(model, p[~inside], table.cap, table.cap_v)
        h[~inside], v[~inside] = d[:, :8].min(axis=1), d[:, 8:].min(axis=1)
    dd = model.design_drift
    th = np.where(h >= table.cap - 1e-9, np.inf, breakout_time(h, dd.speed, dd.acceleration))
    tv = np.where(v >= table.cap_v - 1e-9, np.inf, v / dd.vertical_speed)
    return np.stack([q.phi, q.alpha, q.beta], axis=-1), level.astype(np.int64), np.minimum(th, tv), past


def measured_times(model, p: np.ndarray, floor: np.ndarray, horizon: float) -> np.ndarray:
    """An arm's time to its faces by its own monitor (:class:`loadarm.guidance.monitor.EnvelopeMonitor`, called:
    the drift fit, the velocity-step and break-out tests, the design drift), fed the true flange at 5 Hz and
    forecast every :data:`MEASURED_PERIOD` s where the design floor's time is under :data:`MEASURED_GATE`, held
    down by the time elapsed between (``inf`` elsewhere).

    Parameters
    ----------
    model : ArmModel
    p : ndarray, shape (n, 3)
        Its flange, its own frame, every :data:`BANK_PERIOD` s from the connection, m.
    floor : ndarray, shape (n,)
        The design floor's time to limit there, s.
    horizon : float
        s.

    Returns
    -------
    ndarray, shape (n,)
        s.
    """
    monitor = EnvelopeMonitor(model, window=60.0)
    every = int(round(MEASURED_PERIOD / BANK_PERIOD))
    out = np.full(p.shape[0], np.inf)
    for i in range(p.shape[0]):
        t = i * BANK_PERIOD
        monitor.observe(t, p[i])
        if i % every == 0 and floor[i] < MEASURED_GATE:
            monitor.refit()
            k = min(every, p.shape[0] - i)
            out[i:i + k] = monitor.time_to_limit(p[i], horizon, now=t).time - np.arange(k) * BANK_PERIOD
    return out


def _bank_face_times(monitor: BankMonitor, centre: np.ndarray, angles: np.ndarray, horizon: float,
                     every: int) -> np.ndarray:
    """Each arm's time to its nearest bank face per sample (arms, n): the design-drift forecast every ``every``
    samples, held down by the time elapsed between (early, never late, for a face the forecast saw)."""
    n = centre.shape[0]
    out = np.empty((len(monitor.bank.names), n))
    for k in range(0, n, every):
        f = monitor.time_to_limit(centre[k], angles[k], horizon)
        span = np.arange(min(every, n - k)) * BANK_PERIOD
        out[:, k:k + span.size] = np.asarray(f.by_arm)[:, None] - span[None, :]
    return out


def retraction_times(bank: Bank) -> np.ndarray:
    """Each arm's retraction clear of the manifold (PERC), from its coupler free, s: the shared power unit's
    release of every arm at once, pumps lost (:func:`loadarm.hydraulics.bank_release.require_release`).

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    ndarray, shape (arms,)

    Raises
    ------
    ReleaseError
        The power unit cannot release every arm (one line naming the shortfall).
    """
    release = require_release(bank)
    return np.asarray(release.end[:, 2] - release.start[:, 2], dtype=float)


def couplers(bank: Bank, flanges: np.ndarray, t: np.ndarray, free, retract) -> np.ndarray:
    """Each arm's coupler over a record: on its flange until it is free, then retracted
    :data:`~loadarm.design.check.MANIFOLD_CLEARANCE` straight towards its stored position at a steady speed in
    its retraction time, then held there (the ship goes on moving).

    Parameters
    ----------
    bank : Bank
    flanges : ndarray, shape (n, arms, 3)
        Each arm's flange, its own frame, m.
    t : ndarray, shape (n,)
        s.
    free : sequence of float
        Per arm, when its coupler is free, s (NaN: never).
    retract : sequence of float
        Per arm, its retraction time, s (:func:`retraction_times`).

    Returns
    -------
    ndarray, shape (n, arms, 3)
        m. The retraction starts from the flange at the first sample at or after the coupler is free.
    """
    out = np.array(flanges, dtype=float, copy=True)
    for a, model in enumerate(bank.models):
        if not free[a] == free[a] or free[a] > t[-1]:
            continue
        i0 = int(np.searchsorted(t, free[a] - 1e-9))
        sx, sz = model.approach.stored
        p0 = out[i0, a].copy()
        d = np.array([sx, 0.0, sz]) - p0
        d /= max(float(np.linalg.norm(d)), 1e-9)
        share = np.clip((t[i0:] - free[a]) / max(float(retract[a]), 1e-9), 0.0, 1.0)
        out[i0:, a] = p0 + (MANIFOLD_CLEARANCE * share)[:, None] * d
    return out


def bank_run(bank: Bank, motion, reference, tables: list, seed: int, duration: float,
             retract=None) -> BankRun:
    """One run: the bank on its ship's record, its sequence and what it came to.

    Parameters
    ----------
    bank : Bank
    motion : MooredFlangeMotion
        The ship's motion for this seed (:func:`loadarm.ship.flange.flange_motion`; its record must cover
        ``duration + LOOKAHEAD``): ``position(t)`` of the manifold's centre and ``orientation(t)``.
    reference : array_like, shape (3,)
        The motion's mean position (the scenario's ``[ship] flange``): the manifold's centre is the bank's
        ``manifold.position`` moved by ``position(t) - reference``.
    tables : list of FloorTable
        Each arm's design-drift table.
    seed : int
    duration : float
        The scenario's length, s: the sequence runs over it; the faces are looked for until ``LOOKAHEAD`` after.
    retract : sequence of float, optional
        Each arm's retraction time, s (default: :func:`retraction_times`, which refuses a bank whose power unit
        cannot release every arm).

    Returns
    -------
    BankRun
    """
    retract = retraction_times(bank) if retract is None else np.asarray(retract, dtype=float)
    t = np.arange(0.0, duration + LOOKAHEAD, BANK_PERIOD)
    n_run = int(round(duration / BANK_PERIOD))
    centre = np.asarray(bank.file.manifold.position, dtype=float) + motion.position(t) - np.asarray(reference)
    angles = np.asarray(motion.orientation(t), dtype=float)
    monitor = BankMonitor(bank, own_faces=False)       # each arm's own faces: the kernel's route, below
    flanges = monitor.flanges(centre, angles)                                  # (n, arms, 3), each arm's frame
    per = [arm_record(bank.models[i], tables[i], np.ascontiguousarray(flanges[:, i])) for i in range(len(bank.names))]
    margins, _ = monitor._margins(centre[:n_run], angles[:n_run])
    n_sw = 6 * len(bank.names)
    swivel = margins[:, :n_sw].reshape(n_run, len(bank.names), 6)
    # the longest lead this route's stages use (no pre-alarm: no measured route), and one forecast period more
    horizon = max(stage_leads(m.sequence)[Severity.ESD1] for m in bank.models) + BANK_FACE_PERIOD
    every = int(round(BANK_FACE_PERIOD / BANK_PERIOD))
    own = np.stack([np.minimum(p[2][:n_run], measured_times(m, flanges[:n_run, i], p[2][:n_run], horizon))
                    for i, (m, p) in enumerate(zip(bank.models, per, strict=True))])
    ttl = np.minimum(own, _bank_face_times(monitor, centre[:n_run], angles[:n_run], horizon, every))
    level = np.ascontiguousarray(np.stack([p[1][:n_run] for p in per]))
    seq = sequence_table(bank.models)
    idx = [np.full(len(bank.names), -1, dtype=np.int64) for _ in range(3)]
    _, i_esd, i_req, first = bank_sequence(level, np.ascontiguousarray(ttl), seq, *idx)
    past = np.stack([p[3] for p in per])                                     # (arms, n) whole record
    past[:, :n_run] |= (swivel < 0.0).any(axis=-1).T
    return _judge(bank, seed, t, n_run, idx, (i_esd, i_req, first), past, swivel,
                  (monitor, flanges[:n_run], retract))


def single_arm_run(model, table, motion, duration: float) -> dict:
    """The kernel's route for one arm on a scenario's flange (what :func:`bank_run` does per arm, alone): to hold
    it to the single arm's closed loop on the same seed.

    Parameters
    ----------
    model : ArmModel
    table : FloorTable
    motion : MooredFlangeMotion or FlangeMotion
        The scenario's flange (its installation frame).
    duration : float
        s.

    Returns
    -------
    dict
        ``alarm1_s``, ``release_s`` (the coupler opening), ``release_complete_s``, ``face_s`` (the flange first
        past a face: NaN none within ``LOOKAHEAD`` after the end), ``overstretched`` (past a face before the
        coupler was free).
    """
    t = np.arange(0.0, duration + LOOKAHEAD, BANK_PERIOD)
    n_run = int(round(duration / BANK_PERIOD))
    p = np.ascontiguousarray(motion.position(t))
    _, level, ttl, past = arm_record(model, table, p)
    horizon = stage_leads(model.sequence)[Severity.ESD1] + MEASURED_PERIOD
    ttl = np.minimum(ttl, np.concatenate([measured_times(model, p[:n_run], ttl[:n_run], horizon),
                                          np.full(t.size - n_run, np.inf)]))
    idx = [np.full(1, -1, dtype=np.int64) for _ in range(3)]
    _, i_esd, _, _ = bank_sequence(level[None, :n_run].copy(), ttl[None, :n_run].copy(), sequence_table([model]),
                                   *idx)
    opened = _when(t, int(idx[2][0]))
    free = opened + model.sequence.erc_release_time
    face = _when(t, int(np.argmax(past))) if past.any() else math.nan
    return {"alarm1_s": _when(t, i_esd), "release_s": opened, "release_complete_s": free, "face_s": face,
            "overstretched": bool(face == face and (free != free or face <= free + 1e-9))}


def _when(t, i) -> float:
    return float(t[i]) if i >= 0 else math.nan


def _judge(bank, seed, t, n_run, idx, bank_idx, past, swivel, retraction) -> BankRun:
    i_cmd, i_conf, i_open = idx
    i_esd, i_req, first = bank_idx
    names = bank.names
    conf = [_when(t, i) for i in i_conf]
    opened = [_when(t, i) for i in i_open]
    free = [o + m.sequence.erc_release_time for o, m in zip(opened, bank.models, strict=True)]
    face = [_when(t, int(np.argmax(p))) if p.any() else math.nan for p in past]
    connected = np.array([[ti < f if f == f else True for ti in t[:n_run]] for f in free])      # (arms, n_run)
    # the face's time is the first sample past it: the crossing lies in the period before, so a face at the
    # sample the coupler is free was crossed before it (an overstretch of up to one period)
    over = [bool(f == f and (fr != fr or f <= fr + 1e-9)) for f, fr in zip(face, free, strict=True)]
    before = [bool(f == f and (c != c or f <= c + 1e-9)) for f, c in zip(face, conf, strict=True)]
    early = [bool(o == o and (c != c or o < c - 1e-9)) for o, c in zip(opened, conf, strict=True)]
    monitor, flanges, retract = retraction
    held = couplers(bank, flanges, t[:n_run], free, retract)          # on the flanges, retracting, retracted
    poses = []
    for a, m in enumerate(bank.models):
        q = inverse3d(m.arm, held[:, a, 0], held[:, a, 1], held[:, a, 2], check=False)
        poses.append(np.stack([q.phi, q.alpha, q.beta], axis=-1))
    gaps = monitor.clearances(poses)[0] if neighbours(bank) else np.full((n_run, 1), np.inf)
    retracted = [float(f + r) if f == f else math.nan for f, r in zip(free, retract, strict=True)]
    sw = np.where(connected.T[:, :, None], swivel, np.inf)
    # an arm carried past its reach has no pose (NaN): that is its overstretch, counted above; the clearance is the
    # least of the poses there are (found by review: np.min gave NaN and the campaign's least became order-dependent)
    least = math.nan if np.isnan(gaps).all() else float(np.nanmin(gaps))
    return BankRun(seed, _when(t, i_esd), _when(t, i_req), names[first] if first >= 0 else "", tuple(conf),
                   tuple(opened), tuple(free), tuple(face), tuple(over), tuple(before), tuple(early),
                   bool((gaps < bank.file.clearance.min_clearance).any()), least,
                   float(np.degrees(np.nanmin(sw))), tuple(retracted))


class _Context:
    """A worker's bank, scenario and compiled ship, read once; the design-drift tables built once."""

    def __init__(self, bank_file: str, scenario: str):
        self.bank = load_bank(bank_file)
        self.retract = retraction_times(self.bank)
        self.scenario = scenario
        self.raw = read_toml(Path(scenario), "scenario")
        sc = self.build(0)
        if sc.ship.model != "moored":
            raise ConfigError(f"{scenario}: a bank's campaign needs a moored ship ([ship] model = \"moored\"): "
                              f"the flanges follow the manifold turned with the ship", source=scenario)
        self.ship = moored_ship(sc)
        self.duration = float(sc.scenario.duration)
        self.tables = _tables(self.bank)

    def build(self, seed: int):
        """The scenario with this seed."""
        data = copy.deepcopy(self.raw)
        data.setdefault("scenario", {})["seed"] = int(seed)
        return resolve_berth(parse_scenario(data, source=self.scenario), self.scenario)

    def run(self, seed: int) -> BankRun:
        """One seed."""
        t0 = time.process_time()
        sc = self.build(seed)
        run = bank_run(self.bank, flange_motion(sc, self.ship), sc.ship.flange, self.tables, seed, self.duration,
                       self.retract)
        return dataclasses.replace(run, seconds=time.process_time() - t0)


def _tables(bank: Bank) -> list:
    """Each arm's design-drift table over the region its flange can reach, one per installation file."""
    out, done = [], {}
    for i, model in enumerate(bank.models):
        key = str(bank.paths[i])
        if key not in done:
            p = np.array([bank.flange_position(j) for j in range(len(bank.names)) if str(bank.paths[j]) == key])
            lo, hi = p.min(axis=0) - (6.0, 6.0, 3.0), p.max(axis=0) + (6.0, 6.0, 3.0)
            done[key] = floor_table(model, lo, hi, spacing=0.25)
        out.append(done[key])
    return out


_CONTEXT: dict = {}


def _run_batch(bank_file: str, scenario: str, seeds: list[int]) -> list[BankRun]:
    """Worker: a batch of seeds (the context built once per process)."""
    key = (bank_file, scenario)
    if key not in _CONTEXT:
        _CONTEXT[key] = _Context(bank_file, scenario)
    ctx = _CONTEXT[key]
    return [ctx.run(s) for s in seeds]


#: The campaign's headline numbers.
BANK_CAMPAIGN_METRICS = (
    Metric("runs", "runs", "", "d"),
    Metric("arms", "arms", "", "d"),
    Metric("overstretches", "runs with an arm overstretched", "", "d"),
    Metric("overstretches_before_isolation", "of which before its ERS valves confirmed", "", "d"),
    Metric("opened_early", "couplers opened before their ERS valves confirmed", "", "d"),
    Metric("clashes", "runs with two arms closer than the clearance", "", "d"),
    Metric("stopped", "runs the bank stopped (ESD-1 by any arm)", "", "d"),
    Metric("esd1_by", "ESD-1 raised by"),
    Metric("releases", "arms released", "", "d"),
    Metric("margin_min_s", "release margin, min", "s", ".2f", none="-"),
    Metric("margin_p5_s", "release margin, 5th percentile", "s", ".2f", none="-"),
    Metric("margin_median_s", "release margin, median", "s", ".2f", none="-"),
    Metric("min_clearance_m", "smallest clearance of neighbours (connected, retracting, retracted)", "m", ".3f"),
    Metric("min_swivel_margin_deg", "smallest swivel margin, connected", "deg", ".1f"),
    Metric("seconds_per_run", "CPU time per run (a worker's set-up apart)", "s", ".2f", none="-"),
)


@dataclass(frozen=True)
class BankCampaignResult(Result):
    """The bank's drift-off over seeds.

    Attributes
    ----------
    bank : str
    scenario : str
    names : tuple of str
    runs : tuple of BankRun
    seconds_per_run : float
        Mean CPU time of a run in its process, s (the ship's motion, the arms, the sequence; a worker's one-off
        set-up apart).
    codes : dict
        With a runs file: how many of the runs each version of loadarm's code ran (its digest's first 16 hex
        digits, :func:`loadarm.studies.runs_file.code_digest`); empty otherwise.
    """

    METRICS = BANK_CAMPAIGN_METRICS

    bank: str
    scenario: str
    names: tuple[str, ...]
    runs: tuple
    seconds_per_run: float = math.nan
    codes: dict = dataclasses.field(default_factory=dict)

    def _values(self) -> dict:
        margins = np.array([m for r in self.runs for m in r.margins])
        finite = margins[np.isfinite(margins)]

        def q(p):
            return float(np.percentile(finite, p)) if finite.size else None

        by = {n: sum(r.esd1_by == n for r in self.runs) for n in self.names}
        return {"bank": self.bank, "scenario": self.scenario, "runs": len(self.runs), "arms": len(self.names),
                "overstretches": sum(any(r.overstretched) for r in self.runs),
                "overstretches_before_isolation": sum(any(r.before_isolation) for r in self.runs),
                "opened_early": sum(sum(r.opened_early) for r in self.runs),
                "clashes": sum(r.clash for r in self.runs),
                "stopped": sum(r.esd1_s == r.esd1_s for r in self.runs),
                "esd1_by": ", ".join(f"{n} {k}" for n, k in by.items() if k) or "none",
                "releases": int(margins.size), "margin_min_s": q(0), "margin_p5_s": q(5), "margin_median_s": q(50),
                "min_clearance_m": float(np.nanmin([r.min_clearance for r in self.runs])),
                "min_swivel_margin_deg": min(r.min_swivel_margin_deg for r in self.runs),
                "seconds_per_run": None if self.seconds_per_run != self.seconds_per_run else self.seconds_per_run,
                "codes": dict(self.codes),
                "seeds": [r.seed for r in self.runs],
                "margins_s": sorted(round(float(m), 3) for m in margins),
                "esd1_s": [r.esd1_s for r in self.runs]}

    def _figure(self):
        fig, ax = subplots(figsize=(7, 3.5))
        fig.set_layout_engine("constrained")
        margins = np.array([m for r in self.runs for m in r.margins])
        ax.hist(margins[np.isfinite(margins)], bins=30, color="0.4")
        ax.set_xlabel("release margin: coupler free to the flange's face [s]")
        ax.set_ylabel("arms released")
        ax.set_title(f"{self.bank}: {len(self.runs)} runs of {self.scenario}", fontsize=9)
        return fig


def check_bank_campaign(bank_file: str | Path, scenario: str | Path, seeds: int, first_seed: int = 0,
                        runs_file: str | Path | None = None) -> None:
    """Refuse, in one line, a bank campaign that cannot run (before any worker starts).

    Parameters
    ----------
    bank_file, scenario : str or Path
    seeds, first_seed : int
    runs_file : str or Path, optional
        Refused if it is not this campaign's runs file.

    Raises
    ------
    ConfigError
        Bad seeds, a scenario without a moored ship, a bad bank file.
    ReleaseError
        The bank's power unit cannot release every arm (:func:`retraction_times`).
    """
    if not 1 <= seeds <= 1_000_000 or first_seed < 0:
        raise ConfigError(f"--seeds must be in [1, 1000000] and --first-seed >= 0, got {seeds} and {first_seed}")
    raw = read_toml(Path(scenario), "scenario")
    sc = resolve_berth(parse_scenario(raw, source=str(scenario)), str(scenario))
    if sc.ship.model != "moored":
        raise ConfigError(f"{scenario}: a bank's campaign needs a moored ship ([ship] model = \"moored\"): the "
                          f"flanges follow the manifold turned with the ship", source=str(scenario))
    bank = load_bank(bank_file)
    retraction_times(bank)                          # a power unit that cannot release every arm: refused
    if runs_file is not None:
        _runs_file(runs_file, bank_file, scenario, bank)


def _runs_file(runs_file, bank_file, scenario, bank: Bank) -> RunsFile:
    """The bank campaign's runs file: its header names the bank, its digest the bank's installations too."""
    return RunsFile(runs_file, str(scenario), None, [], bank=bank_file, also=sorted({str(p) for p in bank.paths}))


def _stored(store: RunsFile | None, wanted) -> tuple[list[BankRun], Counter]:
    """The runs a runs file already holds of the wanted seeds, and how many each code ran."""
    if store is None:
        return [], Counter()
    stored = store.runs(wanted)
    runs = [BankRun(**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})
            for fields, _ in stored]
    return runs, Counter(code for _, code in stored)


def run_bank_campaign(bank_file: str | Path, scenario: str | Path, seeds: int, *, first_seed: int = 0,
                      workers: int | None = None, batch: int = 5,
                      progress: Callable[[int, int], None] | None = None,
                      runs_file: str | Path | None = None) -> BankCampaignResult:
    """The bank's drift-off over seeds ``first_seed .. first_seed + seeds - 1``, on a process pool.

    Parameters
    ----------
    bank_file : str or Path
    scenario : str or Path
        A moored scenario (its ship, sea, lines parting and length; its installation is not read: the bank's
        arms are).
    seeds, first_seed : int
    workers : int, optional
        Processes (default: every core; 1: in this process).
    batch : int
        Seeds per task.
    progress : callable, optional
        ``progress(done, total)``.
    runs_file : str or Path, optional
        A JSON-lines file of the runs (:mod:`loadarm.studies.runs_file`, its header naming the bank and the digest
        of the bank, its installations and the scenario): each batch's runs (at most
        :data:`~loadarm.studies.runs_file.RUNS_FILE_BATCH`) appended as it ends, the seeds it holds not run again,
        the result over every seed of the range.

    Returns
    -------
    BankCampaignResult
    """
    check_bank_campaign(bank_file, scenario, seeds, first_seed)
    bank_file, scenario = str(bank_file), str(scenario)
    bank = load_bank(bank_file)
    store = None if runs_file is None else _runs_file(runs_file, bank_file, scenario, bank)
    wanted = range(first_seed, first_seed + seeds)
    runs, codes = _stored(store, wanted)
    held = {r.seed for r in runs}
    if store is not None:
        batch = min(batch, RUNS_FILE_BATCH)
    todo = [s for s in wanted if s not in held]
    chunks = [todo[k:k + batch] for k in range(0, len(todo), batch)]
    workers = workers or os.cpu_count() or 1
    report = Tally(runs, store, codes, seeds, progress)

    if workers == 1 or len(chunks) <= 1:
        for c in chunks:
            report(_run_batch(bank_file, scenario, c))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for part in pool.map(_run_batch, [bank_file] * len(chunks), [scenario] * len(chunks), chunks):
                report(part)
    per_run = float(np.mean([r.seconds for r in runs])) if runs else math.nan
    return BankCampaignResult(bank_file, scenario, bank.names, tuple(sorted(runs, key=lambda r: r.seed)), per_run,
                              codes=dict(codes))
