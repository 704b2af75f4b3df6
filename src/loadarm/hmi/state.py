"""What the operator's screen shows: the drawing's fixed geometry from the compiled model, one frame per
controller snapshot, and the alarm list (ISA-18.2: priority, time, message, state; shelving with a maximum
time; times of day from the injected wall clock), the trends of the last 10 minutes, the forecast's state and the
alarm journal. Pure: the HMI server calls these with the snapshot and its own clocks."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime

import numpy as np

from loadarm.arm.alarms import AlarmState
from loadarm.guidance.monitor import stage_leads
from loadarm.params.berth import RHO_SEA, BerthSection, ShipSection
from loadarm.ship.hull import hull_mesh
from loadarm.sim.snapshot import held_times
from loadarm.vocab import (ALARM_RULES, CONDITION_TEXT, EVENTS, FACE_WORDS, FACES, MEASURED_ROUTES, MOORINGS_TEXT,
                           PREDICTION_UNUSED, PREDICTION_UNUSED_ABNORMAL, PRIORITIES, Severity, event_label, priority)

__all__ = ["PRIORITIES", "SHELVE_MAX", "JOURNAL_KINDS", "AlarmBook", "AlarmEntry", "clock_text", "drift_words",
           "forecast_state", "prediction_state", "geometry", "frame", "in_words", "journal_entry", "priority",
           "ship_outline"]

#: The longest an operator may shelve an alarm, s (ISA-18.2: shelving is time-limited; the alarm comes back).
SHELVE_MAX = 600.0


@dataclass(frozen=True)
class AlarmEntry:
    """One line of the alarm list.

    Attributes
    ----------
    tag, message : str
    priority : int
        1 (critical) to 4 (low).
    priority_name : str
    state : str
        :class:`loadarm.arm.alarms.AlarmState` value: unacknowledged, acknowledged, returned-to-normal unacknowledged.
    raised_at : float
        Run time it became active, s.
    shelved_until : float or None
        Run time the shelving ends, s (None: not shelved).
    raised_wall : float or None
        Wall-clock time it became active, s since the epoch (None: not known).
    """

    tag: str
    message: str
    priority: int
    priority_name: str
    state: str
    raised_at: float
    shelved_until: float | None = None
    raised_wall: float | None = None

    def to_dict(self) -> dict:
        return {"tag": self.tag, "message": self.message, "priority": self.priority,
                "priority_name": self.priority_name, "state": self.state, "raised_at": self.raised_at,
                "shelved_until": self.shelved_until, "raised_wall": self.raised_wall}


class AlarmBook:
    """The alarm list built from the controller's snapshots: when each alarm was raised, and which are shelved.

    The controller's ISA-18.2 state machine is the one truth for each alarm's state; the book adds what an
    operator's list needs besides: the time it was raised (the first snapshot it left normal) and shelving.
    A shelved alarm leaves the list (it is shown apart) until its time is up or it returns to normal.
    """

    def __init__(self):
        self.raised: dict[str, float] = {}
        self.raised_wall: dict[str, float | None] = {}
        self.shelved: dict[str, float] = {}

    def update(self, t: float, alarms: dict, raised: dict | None = None, *, wall: float | None = None,
               raised_wall: dict | None = None) -> list[AlarmEntry]:
        """The list at run time ``t`` for the controller's alarm states ``alarms`` (tag to state), most urgent
        first, then newest first; ``raised`` gives when each was raised where known (a replay's log), run time,
        and ``raised_wall`` the same on the wall clock; else an alarm was raised now: at ``t`` and ``wall`` (the
        snapshot's wall-clock time, s since the epoch)."""
        out = []
        for tag, state in alarms.items():
            if state == AlarmState.NORMAL.value:
                for book in (self.raised, self.raised_wall, self.shelved):
                    book.pop(tag, None)
                continue
            if raised and tag in raised:
                self.raised[tag] = raised[tag]
            if raised_wall and tag in raised_wall:
                self.raised_wall[tag] = raised_wall[tag]
            self.raised.setdefault(tag, t)
            self.raised_wall.setdefault(tag, _num(wall) if wall is not None else None)
            until = self.shelved.get(tag)
            if until is not None and t >= until:
                del self.shelved[tag]
                until = None
            rank, name = priority(tag)
            out.append(AlarmEntry(tag, CONDITION_TEXT.get(tag, tag), rank, name, state, self.raised[tag], until,
                                  self.raised_wall[tag]))
        out.sort(key=lambda e: (e.priority, -e.raised_at, e.tag))
        return out

    def shelve(self, tag: str, t: float, seconds: float, alarms: dict) -> str:
        """Shelve an active alarm for ``seconds`` (0 < seconds <= :data:`SHELVE_MAX`) from run time ``t``;
        returns "" or why not."""
        if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and 0 < seconds <= SHELVE_MAX):
            return f"shelving lasts 0 < seconds <= {SHELVE_MAX:g}, got {seconds!r}"
        if alarms.get(tag, AlarmState.NORMAL.value) == AlarmState.NORMAL.value:
            return f"{tag} is not active"
        self.shelved[tag] = t + float(seconds)
        return ""

    def unshelve(self, tag: str) -> str:
        """Return a shelved alarm to the list; "" or why not."""
        if self.shelved.pop(tag, None) is None:
            return f"{tag} is not shelved"
        return ""


def geometry(model, berth=None) -> dict:
    """The drawing's fixed geometry, SI: arm lengths, the alarm angles, the reach of each alarm zone from the
    inboard hinge (bands in the side view), the berth box, the slew limits, and the time the emergency sequence
    needs (ESD-1, ERS valves, release, margin: a time to limit above it is in the normal range).

    Parameters
    ----------
    model : ArmModel
    berth : loadarm.params.berth.Berth, optional
        The ship drawn in the top view (:func:`ship_outline`).

    Returns
    -------
    dict
        JSON-ready.
    """
    arm, al = model.arm, model.alarms

    def reach(beta: float) -> float:          # hinge to coupler at elbow angle beta (law of cosines)
        return math.sqrt(arm.b ** 2 + arm.c ** 2 - 2 * arm.b * arm.c * math.cos(beta))

    beta_max = float(model.joint_limits.beta[1])
    zones = [{"name": name, "from_beta": lo, "to_beta": hi, "from_r": reach(lo), "to_r": reach(hi)}
             for name, lo, hi in (("ESD-1", al.first, al.second), ("second alarm", al.second, al.release),
                                  ("release", al.release, beta_max))]
    bb, sl, sq, dd = model.berth, model.slew, model.sequence, model.design_drift
    return {"a": arm.a, "b": arm.b, "c": arm.c, "zones": zones,
            "sequence_time": sq.esd_time + sq.ers_valve_time + sq.erc_release_time + sq.margin,
            "horizon": max(stage_leads(sq).values()),
            "design_drift": {"speed": dd.speed, "acceleration": dd.acceleration, "vertical": dd.vertical_speed},
            "alarm_beta": {"first": al.first, "second": al.second, "release": al.release},
            "berth": {"jetty_face": bb.jetty_face, "berthing_line": bb.berthing_line, "x_far": bb.x_far,
                      "y_low": bb.y_low, "y_high": bb.y_high},
            "slew": {"limit": sl.limit, "first": sl.first, "second": sl.second, "release": sl.release},
            "limits": {"phi": list(model.joint_limits.phi), "beta": list(model.joint_limits.beta)},
            "faces": list(FACES), "face_words": dict(FACE_WORDS),
            "ship": ship_outline(model, berth)}


def ship_outline(model, berth=None) -> dict:
    """The ship in the top view: its deck edge from the berth's hull (:func:`loadarm.ship.hull.hull_mesh`, the
    same parametric hull the hydrodynamics mesh), lying at its moored position: the side given by ``[berth]
    side`` against the berthing line, midships at ``[berth] ship_y``.

    Parameters
    ----------
    model : ArmModel
        Its berth box (the berthing line).
    berth : loadarm.params.berth.Berth, optional
        The berth file's ship and berth (default: the design ship of :mod:`loadarm.params.berth`, for a scenario
        without a berth file).

    Returns
    -------
    dict
        ``outline``: the deck edge, ``[x, y]`` in the jetty frame (x off the berth, y along it), m; ``length``,
        ``beam``: m; ``side``.
    """
    ship = berth.ship if berth is not None else ShipSection()
    place = berth.berth if berth is not None else BerthSection()
    cb = ship.displacement / (RHO_SEA * ship.length_pp * ship.beam * ship.draft)
    mesh = hull_mesh(ship.length_pp, ship.beam, ship.draft, ship.depth, cb, nx=48, nz=3)
    v = mesh.vertices
    deck = v[np.isclose(v[:, 2], ship.depth) & (v[:, 1] >= 0)]
    deck = deck[np.argsort(deck[:, 0])]
    ring = np.concatenate([deck[:, :2], deck[::-1, :2] * [1.0, -1.0]])       # port edge forward, starboard aft
    sign = 1.0 if place.side == "port" else -1.0       # the side against the fenders faces the jetty (-x)
    x0 = model.berth.berthing_line + ship.beam / 2
    pts = [[round(float(x0 - sign * ys), 3), round(float(place.ship_y + sign * xs), 3)] for xs, ys in ring]
    return {"outline": pts, "length": ship.length_pp, "beam": ship.beam, "side": place.side}


def _num(v: float) -> float | None:
    """JSON has no NaN or infinity: None."""
    v = float(v)
    return v if math.isfinite(v) else None


def clock_text(wall: float | None, now: float) -> str:
    """A wall-clock time as the alarm list shows it: the local time of day, with the date before it when that
    day is not ``now``'s ("" when not known).

    Parameters
    ----------
    wall, now : float
        s since the epoch (``now``: the server's injected wall clock).

    Returns
    -------
    str
        ``"14:03:27"`` or ``"2026-12-04 14:03:27"``.
    """
    if wall is None or not math.isfinite(wall):
        return ""
    at = datetime.fromtimestamp(wall)
    day = "" if at.date() == datetime.fromtimestamp(now).date() else f"{at:%Y-%m-%d} "
    return f"{day}{at:%H:%M:%S}"


def drift_words(v) -> dict | None:
    """A horizontal drift velocity as the operator reads it: speed, the direction in degrees from "off the berth"
    (+x) towards +y along it, and the words of that direction.

    Parameters
    ----------
    v : sequence of float
        m/s, jetty frame (x off the berth, y along it); empty or non-finite: None.

    Returns
    -------
    dict or None
        ``speed`` (m/s), ``direction_deg``, ``words``.
    """
    if len(v) < 2 or not all(math.isfinite(float(c)) for c in v[:2]):
        return None
    vx, vy = float(v[0]), float(v[1])
    deg = math.degrees(math.atan2(vy, vx))
    sector = int(round(deg / 45.0)) % 8
    words = ("off the berth", "off the berth and along it, +y", "along the berth, +y",
             "onto the berth and along it, +y", "onto the berth", "onto the berth and along it, -y",
             "along the berth, -y", "off the berth and along it, -y")[sector]
    return {"speed": math.hypot(vx, vy), "direction_deg": deg, "words": words}


def forecast_state(snap, model) -> dict:
    """What the screen says of the time to limit: ``state`` is ``"time"`` (a face within the forecast's
    horizon), ``"beyond"`` (none within it: "> H s", H the horizon the forecast used), ``"none"`` (attached but
    no forecast: no healthy estimate or the plant's values bad) or ``"off"`` (not attached: nothing to forecast);
    ``text``, the nearest ``face`` and its words, the ``route`` and the ``drift`` the forecast used.

    Parameters
    ----------
    snap : loadarm.sim.snapshot.Snapshot
    model : ArmModel

    Returns
    -------
    dict
    """
    times = {f: t for f, t in snap.time_to_faces.items() if math.isfinite(t)}
    face = min(times, key=times.get) if times else ""
    drift = drift_words(snap.drift)
    out = {"face": face, "face_words": FACE_WORDS.get(face, ""), "route": snap.route,
           "horizon": _num(snap.horizon), "drift": drift, "design_speed": model.design_drift.speed,
           "basis": _basis(snap.route, drift, model.design_drift.speed) if snap.connected else "",
           "rule": snap.rule, "rule_words": ALARM_RULES.get(snap.rule, ""),
           "prediction": prediction_state(snap.prediction, snap.connected, snap.moorings),
           "held": held_state(snap)}
    if not snap.connected:
        return {**out, "state": "off", "text": "not connected"}
    if not (snap.plant_ok and snap.estimate_healthy and math.isfinite(snap.horizon)):
        why = "plant values bad" if not snap.plant_ok else "no healthy estimate"
        return {**out, "state": "none", "text": f"NO FORECAST: {why}"}
    if math.isfinite(snap.time_to_limit):
        return {**out, "state": "time", "text": f"{snap.time_to_limit:.1f} s"}
    return {**out, "state": "beyond", "text": f"> {snap.horizon:.0f} s"}


def held_state(snap) -> dict:
    """What the screen says of a call for ESD-1 the prediction holds (ISA-18.2's suppressed by design: shown,
    never hidden): ``text`` ("" when none is held), ``for_s`` (held so far) and ``left_s`` (at most this much
    longer), s, None when none.

    Parameters
    ----------
    snap : loadarm.sim.snapshot.Snapshot

    Returns
    -------
    dict
    """
    times = held_times(snap)
    if times is None:
        return {"text": "", "for_s": None, "left_s": None}
    held, left = times
    return {"text": f"MEASURED DRIFT CALLS ESD-1, held by the prediction for {held:.0f} s: ESD-1 in at most "
                    f"{left:.0f} s if the call stands", "for_s": held, "left_s": left}


def prediction_state(p: dict | None, connected: bool, moorings: str = "none") -> dict:
    """What the screen says and draws of the flange prediction: ``state`` ``"trusted"`` (it stands in for the
    measured drift), ``"shown"`` (claimed, not trusted: the track left its intervals, or ESD-1 is raised),
    ``"none"`` (no prediction: the track is too short or not yet calibrated); ``text``; while connected and not
    used, ``why`` in words (:data:`loadarm.vocab.PREDICTION_UNUSED`; ``""`` otherwise) and ``why_abnormal``
    (the track left its intervals or the moorings are lost: the screen marks it); the time to limit with
    its interval (``bound``: the calibrated bound's, what the alarms use; ``mean``: the mean track's; s, None:
    no face within the claim); the top view's ``track`` (x, y of the mean, m) and ``band`` (x0, y0, x1, y1 of the
    interval at each kept horizon, m).

    Parameters
    ----------
    p : dict or None
        The snapshot's :attr:`~loadarm.sim.snapshot.Snapshot.prediction`.
    connected : bool
    moorings : str
        The mooring load monitoring's state (:data:`loadarm.vocab.MOORINGS_TEXT`): while connected, the
        result's ``moorings`` says it in words ("" otherwise) and ``moorings_abnormal`` is true when the
        moorings are lost or their monitoring silent (the screen marks it as abnormal, after ``text``).

    Returns
    -------
    dict
    """
    watch = {"moorings": MOORINGS_TEXT.get(moorings, moorings) if connected else "",
             "moorings_abnormal": connected and moorings in ("lost", "silent")}
    if p is None:
        return {"state": "none", "text": "no prediction (track too short or calibrating)", "track": [], "band": [],
                "bound": None, "mean": None, "claimed": 0.0, "why": "", "why_abnormal": False, **watch}
    bound, mean = p["ttl"]
    claimed = float(p["claimed"])
    if bound is None:
        when = f"no face within {claimed:.0f} s"
    elif mean is None:
        when = f"face in {bound:.0f} s at the earliest (mean track: none within {claimed:.0f} s)"
    else:
        when = f"face in {bound:.0f} s at the earliest, {mean:.0f} s on the mean track"   # not an interval
    trusted = bool(p.get("trusted")) and connected
    text = f"prediction{'' if trusted else ' (not used)'}: {when}"
    unused = str(p.get("unused", "")) if connected and not trusted else ""
    return {**watch, "state": "trusted" if trusted else "shown", "text": text, "bound": bound, "mean": mean,
            "why": PREDICTION_UNUSED.get(unused, unused), "why_abnormal": unused in PREDICTION_UNUSED_ABNORMAL,
            "claimed": claimed, "track": [[m[0], m[1]] for m in p["mean"]],
            "band": [[lo[0], lo[1], hi[0], hi[1]] for lo, hi in zip(p["lo"], p["hi"])]}


def _basis(route: str, drift: dict | None, design: float) -> str:
    """The drift a forecast used, in words: the measured one when a measured route found the nearest face,
    else the berth's design drift (in any horizontal direction), with the measured drift beside it."""
    measured = None if drift is None else (f"{drift['speed']:.2f} m/s {drift['words']} "
                                           f"({drift['direction_deg']:.0f} deg)")
    if route in MEASURED_ROUTES and measured:
        return f"{route}: {measured}"
    text = f"design drift {design:.2f} m/s, any direction"
    return f"{text}; measured {measured}" if measured else text


#: The journal's filters: each a set of event kinds (:data:`loadarm.eventlog.KINDS`; the samples are never in it).
JOURNAL_KINDS = {"all": ("alarm", "alarm_state", "operator", "security", "mode", "command", "interlock", "info",
                         "sensor"),
                 "alarms": ("alarm", "alarm_state"), "operator": ("operator", "security"),
                 "modes": ("mode", "command", "interlock")}


#: A face's code in an event's message, with the word "face" after it when there is one.
_FACE_CODE = re.compile(r"\b(" + "|".join(FACES) + r")\b( face\b)?")


def in_words(text: str) -> str:
    """A message with every face's code replaced by the face's words in quotes: an event without codes of its own
    (an ESD-1 command's message: "velocity step: beta_max face in 27.9 s") still reads in the operator's words
    ('velocity step: "the face's words" in 27.9 s').

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return _FACE_CODE.sub(lambda m: f'"{FACE_WORDS[m[1]]}"', text)


def _journal_text(kind: str, data: dict, reason: str) -> str:
    """An event's line in the journal, from its codes (the face's and the alarm's words); an event without codes
    has its message, its faces in words (:func:`in_words`)."""
    code, tag = data.get("code"), data.get("tag")
    if kind == "alarm_state" and tag in CONDITION_TEXT:
        return f"{CONDITION_TEXT[tag]}: {data.get('alarm_state', '')}"
    if kind == "mode" and "mode" in data:
        return f"{data.get('previous', '?')} -> {data['mode']}"
    if kind == "operator" and "action" in data:
        return f"{data.get('user', '?')}: {data['action']}" + (f" {tag}" if tag else "")
    if code in EVENTS:
        face = FACE_WORDS.get(data.get("face", ""), "")
        held = " (held by the prediction)" if code == "info.measured_esd1" and data.get("held") else ""
        return event_label(code) + (f": {face}" if face else "") + held
    return in_words(reason)


def journal_entry(t: float, wall: float | None, mode: str, kind: str, reason: str, data: dict, now: float) -> dict:
    """One line of the alarm journal: run time, wall-clock time and its text (:func:`clock_text`), the kind, the
    alarm's tag and priority (an alarm's state change), and what happened in the operator's words.

    Parameters
    ----------
    t : float
        Run time, s.
    wall : float or None
        Wall-clock time, s since the epoch.
    mode, kind, reason : str
        The event's.
    data : dict
        The event's data (its codes).
    now : float
        The server's wall clock (the date is shown when the day differs).

    Returns
    -------
    dict
    """
    tag = data.get("tag") if kind == "alarm_state" else None
    prio = priority(tag) if tag in CONDITION_TEXT else (None, None)
    return {"t": t, "wall": _num(wall) if wall is not None else None, "clock": clock_text(wall, now),
            "mode": mode, "kind": kind, "tag": tag, "priority": prio[0], "priority_name": prio[1],
            "text": _journal_text(kind, data, reason)}


def frame(snap, model, alarms: list[AlarmEntry], *, sent_at: float, anchor=None) -> dict:
    """One update of the screen: everything in SI (the page converts for display), non-finite values as
    None.

    Parameters
    ----------
    snap : loadarm.sim.snapshot.Snapshot
    model : ArmModel
    alarms : list of AlarmEntry
        :meth:`AlarmBook.update` for this snapshot.
    sent_at : float
        The HMI server's wall clock, s (the page measures staleness against its own; the alarms' times of day are
        dated against it).
    anchor : sequence of float, optional
        Where the flange was first seen healthy, m: the ship is drawn moved by the estimate's displacement
        from it (``ship_offset``).

    Returns
    -------
    dict
        JSON-ready (``type`` "state", ``seq`` the controller's cycle).
    """
    arm = model.arm
    phi, alpha, beta = snap.q
    elbow = (arm.b * math.sin(alpha), arm.a + arm.b * math.cos(alpha))
    return {
        "type": "state", "seq": snap.seq, "t": snap.t, "sent_at": sent_at, "published_at": _num(snap.wall),
        "mode": snap.mode, "modes": [[int(k), m] for k, m in snap.modes],
        "q": [_num(v) for v in snap.q], "elbow": [_num(v) for v in elbow],
        "coupler": [_num(v) for v in snap.coupler], "flange": [_num(v) for v in snap.flange_estimate],
        "flange_velocity": [_num(v) for v in snap.flange_velocity], "estimate_healthy": snap.estimate_healthy,
        "distance": _num(snap.distance), "level": snap.level, "level_name": Severity(snap.level).label,
        "time_to_limit": _num(snap.time_to_limit), "connected": snap.connected, "esd": snap.esd,
        "release": snap.release, "coupler_open": snap.coupler_open, "ers_valves_closed": snap.ers_valves_closed,
        "plant_ok": snap.plant_ok, "late": snap.late, "cycle_us": _num(snap.cycle_us),
        "cylinders": [_num(v) for v in snap.cylinders],
        "margins": {f: _num(v) for f, v in snap.margins.items()},
        "time_to_faces": {f: _num(v) for f, v in snap.time_to_faces.items()},
        "pressures": [_num(v) for v in snap.pressures],
        "alarms": [{**a.to_dict(), "clock": clock_text(a.raised_wall, sent_at)} for a in alarms
                   if a.shelved_until is None],
        "shelved": [{**a.to_dict(), "until_clock": clock_text(_until_wall(snap, a.shelved_until, sent_at), sent_at)}
                    for a in alarms if a.shelved_until is not None],
        "wall": _num(snap.wall), "forecast": forecast_state(snap, model),
        "ship_offset": _offset(snap, anchor),
    }


def _until_wall(snap, until: float, sent_at: float) -> float:
    """When a shelving ends on the wall clock: the snapshot's wall-clock time (else the frame's) plus the run time
    left, s since the epoch."""
    base = snap.wall if math.isfinite(snap.wall) else sent_at
    return base + (until - snap.t)


def _offset(snap, anchor) -> list[float]:
    """The flange estimate's horizontal displacement from ``anchor``, m (zero without both)."""
    f = snap.flange_estimate
    if anchor is None or not (math.isfinite(f[0]) and math.isfinite(f[1])):
        return [0.0, 0.0]
    return [float(f[0] - anchor[0]), float(f[1] - anchor[1])]
