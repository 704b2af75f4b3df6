"""The state of one cycle of the closed loop as the operator sees it, built one way for the live run and its replay.

A cycle's state is first a *sample* (:func:`state_sample`: a JSON-ready dict of what the controller decided and
what the plant and the estimator report); :func:`snapshot` turns a sample into the :class:`Snapshot` the OPC UA
server and the screen show, computing the coupler, the cylinders and the margins from the joints. The live
service (:class:`loadarm.opcua.service.GuidanceService`) samples every cycle; the run's log keeps a sample once a
second ("sample" events) and the replay (:class:`loadarm.hmi.replay.ReplayService`) builds its snapshots from
those with the same function, so a replay shows what the live screen showed at the logged times
(``tests/test_replay_matches_live.py``).
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field

import numpy as np

from loadarm.arm.actuators import cylinder_lengths
from loadarm.arm.faces import FACES, face_margins
from loadarm.arm.slew import forward3d
from loadarm.vocab import ANNUNCIATED

__all__ = ["MODE_TAIL", "TREND_WINDOW", "TREND_EVERY", "Snapshot", "TrendLog", "state_sample", "snapshot",
           "trend_point", "held_times"]

#: Mode changes carried on each snapshot (:attr:`Snapshot.modes`): more than a sequence's modes from the
#: connection to the return, so a screen a few frames behind still shows each one.
MODE_TAIL = 12
#: The screen's trends span this much run time, s (the last 10 minutes).
TREND_WINDOW = 600.0
#: One trend point per this much run time, s: the event log's sample period, so that a replay's trends, built
#: from the logged samples, are the live ones.
TREND_EVERY = 1.0


def _finite_or_none(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _nan_if_none(v) -> float:
    return math.nan if v is None else float(v)


def state_sample(cmd, q, estimate, distance: float, ers_valves_closed: bool, alarms: dict) -> dict:
    """What the log keeps of one cycle, JSON-ready (non-finite values as None; only the alarms out of normal).

    Parameters
    ----------
    cmd : loadarm.guidance.modes.Command
        The cycle's command.
    q : sequence of float
        Slew, alpha, beta at the cycle, rad.
    estimate : loadarm.guidance.estimator.Estimate
        The flange estimate the controller used.
    distance : float
        Coupler to the (simulated plant's) flange, m.
    ers_valves_closed : bool
        The plant's confirmation of the ERS valves.
    alarms : dict
        The controller's ISA-18.2 state of each annunciated alarm (:class:`loadarm.arm.alarms.AlarmState`).

    Returns
    -------
    dict
    """
    ttl = float(cmd.time_to_limit)
    return {"phi": float(q[0]), "alpha": float(q[1]), "beta": float(q[2]), "distance": float(distance),
            "healthy": bool(estimate.healthy), "connected": bool(cmd.connected),
            "flange": [_finite_or_none(v) for v in np.asarray(estimate.position, dtype=float)],
            "flange_velocity": [_finite_or_none(v) for v in np.asarray(estimate.velocity, dtype=float)],
            "level": int(cmd.level), "ttl": ttl if math.isfinite(ttl) else None, "esd": bool(cmd.esd),
            "release": bool(cmd.release), "coupler_open": bool(cmd.coupler_open),
            "ers_valves_closed": bool(ers_valves_closed),
            "alarms": {tag: st.value for tag, st in alarms.items() if st.value != "normal"},
            "time_to_faces": {f: float(t) for f, t in cmd.time_to_faces},
            "horizon": _finite_or_none(cmd.horizon), "route": str(cmd.route),
            "drift": [_finite_or_none(v) for v in cmd.drift] or None,
            "prediction": prediction_sample(cmd.prediction, cmd.predicted, cmd.trusted, cmd.unused),
            "rule": str(cmd.rule),
            "moorings": str(cmd.moorings), "held": [float(v) for v in cmd.held] or None}


#: Seconds between the predicted track's points kept in a sample (and drawn on the screen).
PREDICTION_EVERY = 5


def prediction_sample(forecast, predicted, trusted: bool = False, unused: str = "") -> dict | None:
    """The prediction as a sample keeps it, JSON-ready: ``claimed`` (s), ``t`` (when it was made, s), ``h`` (the
    horizons kept, every :data:`PREDICTION_EVERY` s up to the claim), ``mean``, ``lo``, ``hi`` (m, per kept
    horizon, x y z; the band holds the mean, as the rule's box does, not widened as that box is by the motion
    within a second), ``ttl`` (the time to the nearest face by the calibrated bound and by the mean, s; None:
    none within the claim), ``trusted`` (it stands in for the measured routes), ``unused`` (why not:
    :data:`loadarm.vocab.PREDICTION_UNUSED`, ``""``). None: no prediction.

    Parameters
    ----------
    forecast : Forecast or None
        :class:`loadarm.guidance.predict.Forecast`.
    predicted : tuple of float
        ``(bound, mean)`` s, or ``()``.
    trusted : bool
    unused : str

    Returns
    -------
    dict or None
    """
    if forecast is None:
        return None
    n = int(round(forecast.claimed / forecast.horizon[0]))
    keep = np.arange(PREDICTION_EVERY - 1, n, PREDICTION_EVERY)

    def rows(a):
        return [[round(float(v), 4) for v in r] for r in a[keep]]

    ttl = [_finite_or_none(v) for v in predicted] if predicted else [None, None]
    # the band holds the mean, as the rule's box does (an edge can be calibrated inside the mean when nearly all of
    # a window's errors share a sign; found by review: the screen's band could then lie to one side of its track)
    lo, hi = np.minimum(forecast.lo, forecast.mean), np.maximum(forecast.hi, forecast.mean)
    return {"claimed": float(forecast.claimed), "t": float(forecast.time),
            "h": [float(v) for v in forecast.horizon[keep]], "mean": rows(forecast.mean), "lo": rows(lo),
            "hi": rows(hi), "ttl": ttl, "trusted": bool(trusted), "unused": str(unused)}


def snapshot(model, seq: int, t: float, mode: str, sample: dict, **live) -> "Snapshot":
    """The :class:`Snapshot` of one cycle from its sample (:func:`state_sample`; a replay's logged one).

    Parameters
    ----------
    model : ArmModel
        The installation (the coupler, the cylinders and the margins from the joints).
    seq : int
        Cycle number (a replay: the sample's index).
    t : float
        Run time, s.
    mode : str
        The guidance mode.
    sample : dict
        The cycle's state (a log written before the flange velocity and the faces' times were logged replays
        them as zero and none).
    **live
        What only a live cycle knows (``cycle_us``, ``late``, ``plant_ok``, ``pressures``, ``wall``).

    Returns
    -------
    Snapshot
    """
    q = tuple(_nan_if_none(sample.get(k)) for k in ("phi", "alpha", "beta"))
    x, y, z = (float(v) for v in forward3d(model.arm, *q))
    c1, c2 = cylinder_lengths(model.mount, q[1], q[2])
    m = face_margins(model, x, y, z)
    alarms = {tag: "normal" for tag in ANNUNCIATED}
    alarms.update(sample.get("alarms", {}))
    return Snapshot(seq=seq, t=float(t), mode=mode, q=q, coupler=(x, y, z),
                    flange_estimate=tuple(_nan_if_none(v) for v in sample.get("flange", (None,) * 3)),
                    estimate_healthy=bool(sample.get("healthy", False)),
                    distance=_nan_if_none(sample.get("distance")), level=int(sample.get("level", 0)),
                    time_to_limit=math.inf if sample.get("ttl") is None else float(sample["ttl"]),
                    connected=bool(sample.get("connected", False)), esd=bool(sample.get("esd", False)),
                    release=bool(sample.get("release", False)), coupler_open=bool(sample.get("coupler_open", False)),
                    ers_valves_closed=bool(sample.get("ers_valves_closed", False)), alarms=alarms,
                    cylinders=(float(c1), float(c2)), margins={f: float(m[..., k]) for k, f in enumerate(FACES)},
                    flange_velocity=tuple(_nan_if_none(v) for v in sample.get("flange_velocity", (0.0,) * 3)),
                    time_to_faces={f: float(v) for f, v in sample.get("time_to_faces", {}).items()},
                    horizon=_nan_if_none(sample.get("horizon")), route=str(sample.get("route", "")),
                    drift=tuple(_nan_if_none(v) for v in (sample.get("drift") or ())),
                    prediction=sample.get("prediction"), rule=str(sample.get("rule", "")),
                    moorings=str(sample.get("moorings", "none")),
                    held=tuple(float(v) for v in (sample.get("held") or ())), **live)


@dataclass(frozen=True)
class Snapshot:
    """The controller's state after one cycle (what the plant interface and the HMI show).

    Attributes
    ----------
    seq : int
        Cycle number.
    t : float
        Run time, s.
    mode : str
    q : tuple of float
        Slew, alpha, beta, rad.
    coupler, flange_estimate : tuple of float
        m, installation frame.
    estimate_healthy : bool
    distance : float
        Coupler to the flange, m (the simulated plant's flange, as the run records it).
    level : int
        Connected-mode alarm level (:class:`loadarm.vocab.Severity`).
    time_to_limit : float
        s (inf: none in sight).
    connected, esd, release, coupler_open, ers_valves_closed : bool
    alarms : dict of str to str
        ISA-18.2 state of each annunciated alarm.
    cycle_us : float
        The cycle's computing time, microseconds.
    late : int
        Cycles that started after their deadline so far.
    plant_ok : bool
        The plant's values are good (False: the PLC link is dead, they are the last ones read).
    cylinders : tuple of float
        Both cylinders' pin-to-pin lengths, m.
    margins : dict of str to float
        Margin to each face of the envelope (:data:`loadarm.vocab.FACES`), rad (NaN: out of reach).
    flange_velocity : tuple of float
        The estimate's velocity, m/s.
    pressures : tuple of float
        Chamber pressures ``pA1, pB1, pA2, pB2`` and the supply pressure, Pa (NaN: a plant without them, the
        kinematic one or a PLC that does not report them).
    wall : float
        Wall-clock time the cycle was published, s since the epoch (for the screen's end-to-end latency).
    time_to_faces : dict of str to float
        The forecast's time to each face it crossed within its horizon, s (absent: none in sight).
    modes : tuple of (int, str)
        The last :data:`MODE_TAIL` mode changes up to this cycle, ``(cycle, mode)`` (a screen that samples the
        snapshots shows a mode held for less than its frame; empty: not kept, a replay).
    horizon : float
        How far ahead the forecast looked, s (NaN: no forecast, not attached or a log without it): a
        ``time_to_limit`` of inf is beyond it.
    route : str
        The forecast's route to the nearest face (``"design drift"``, ``"measured drift"``, ...; ``""``: none).
    drift : tuple of float
        The measured drift velocity the forecast extrapolated, m/s (``()``: no drift fit).
    prediction : dict or None
        The flange prediction (:func:`prediction_sample`; None: no prediction, or a log without it).
    rule : str
        The rule behind the connected-mode level (:data:`loadarm.vocab.ALARM_RULES`; ``""``: none).
    moorings : str
        The mooring load monitoring's state (:data:`loadarm.vocab.MOORINGS_TEXT`).
    held : tuple of float
        ``(since, until)`` of the call for ESD-1 the prediction holds, s (:attr:`loadarm.guidance.modes.Command.held`;
        ``()``: none, or a log without it).
    """

    seq: int
    t: float
    mode: str
    q: tuple[float, float, float]
    coupler: tuple[float, float, float]
    flange_estimate: tuple[float, float, float]
    estimate_healthy: bool
    distance: float
    level: int
    time_to_limit: float
    connected: bool
    esd: bool
    release: bool
    coupler_open: bool
    ers_valves_closed: bool
    alarms: dict = field(default_factory=dict)
    cycle_us: float = 0.0
    late: int = 0
    plant_ok: bool = True
    cylinders: tuple[float, float] = (math.nan, math.nan)
    margins: dict = field(default_factory=dict)
    flange_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pressures: tuple[float, float, float, float, float] = (math.nan,) * 5
    wall: float = math.nan
    time_to_faces: dict = field(default_factory=dict)
    modes: tuple = ()
    horizon: float = math.nan
    route: str = ""
    drift: tuple = ()
    prediction: dict | None = None
    rule: str = ""
    moorings: str = "none"
    held: tuple = ()


def held_times(snap: Snapshot) -> tuple[float, float] | None:
    """How long the prediction has held a call for ESD-1 and how much longer it may at most, s, at the snapshot
    (None: connected with no call held, or not connected): what the screen and OPC UA say of :attr:`Snapshot.held`.

    Parameters
    ----------
    snap : Snapshot

    Returns
    -------
    tuple of float or None
    """
    if not (snap.connected and snap.held):
        return None
    since, until = snap.held
    return max(snap.t - since, 0.0), max(until - snap.t, 0.0)


def trend_point(snap: Snapshot) -> dict:
    """What the screen's trends keep of one snapshot, JSON-ready (SI; None where there is no value): ``t``,
    ``beta`` (rad), ``margin`` (the nearest face's margin, rad) and ``face``, ``ttl`` (the time to limit, s; None
    beyond the forecast's horizon or not attached), ``drift`` (the horizontal speed of the drift the forecast
    extrapolated, m/s; None without a drift fit) and ``speed`` (the flange estimate's horizontal speed, m/s: the
    waves' motion included, so not the drift: found in review, the trend called it the drift and it crossed the
    berth's design drift at every wave while the forecast's drift was nil).

    Parameters
    ----------
    snap : Snapshot

    Returns
    -------
    dict
    """
    margins = {f: v for f, v in snap.margins.items() if math.isfinite(v)}
    face = min(margins, key=margins.get) if margins else ""
    vx, vy = snap.flange_velocity[0], snap.flange_velocity[1]
    drift = _finite_or_none(math.hypot(snap.drift[0], snap.drift[1])) if len(snap.drift) >= 2 else None
    return {"t": snap.t, "beta": _finite_or_none(snap.q[2]), "margin": margins[face] if face else None,
            "face": face, "ttl": _finite_or_none(snap.time_to_limit), "drift": drift,
            "speed": _finite_or_none(math.hypot(vx, vy))}


class TrendLog:
    """The last :data:`TREND_WINDOW` s of trend points, one at the first snapshot at or after each
    :data:`TREND_EVERY` s (the rule of the event log's samples): the live service feeds it every cycle, the
    replay every logged sample, and both give the same points."""

    def __init__(self, window: float = TREND_WINDOW, every: float = TREND_EVERY):
        self.window, self.every = window, every
        self.points: collections.deque = collections.deque(maxlen=int(window / every) + 2)
        self.next = 0.0

    def add(self, snap: Snapshot) -> None:
        """Keep ``snap``'s point if it is due (any thread; a point is appended whole)."""
        if snap.t >= self.next:
            self.points.append(trend_point(snap))
            self.next += self.every                 # as sim.loop's recorder steps its samples

    def window_at(self, t: float) -> list[dict]:
        """The points of ``(t - window, t]``, oldest first."""
        return [p for p in list(self.points) if t - self.window < p["t"] <= t]
