"""What the operator's screen shows: the drawing's fixed geometry from the compiled model, one frame per
controller snapshot, and the alarm list (ISA-18.2: priority, time, message, state; shelving with a maximum
time). Pure: the HMI server calls these with the snapshot and its own clock."""

from __future__ import annotations

import math
from dataclasses import dataclass

from loadarm.arm.alarms import AlarmState
from loadarm.vocab import CONDITION_TEXT, FACES, PRIORITIES, Severity, priority

__all__ = ["PRIORITIES", "SHELVE_MAX", "AlarmBook", "AlarmEntry", "geometry", "frame", "priority"]

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
    """

    tag: str
    message: str
    priority: int
    priority_name: str
    state: str
    raised_at: float
    shelved_until: float | None = None

    def to_dict(self) -> dict:
        return {"tag": self.tag, "message": self.message, "priority": self.priority,
                "priority_name": self.priority_name, "state": self.state, "raised_at": self.raised_at,
                "shelved_until": self.shelved_until}


class AlarmBook:
    """The alarm list built from the controller's snapshots: when each alarm was raised, and which are shelved.

    The controller's ISA-18.2 state machine is the one truth for each alarm's state; the book adds what an
    operator's list needs besides: the time it was raised (the first snapshot it left normal) and shelving.
    A shelved alarm leaves the list (it is shown apart) until its time is up or it returns to normal.
    """

    def __init__(self):
        self.raised: dict[str, float] = {}
        self.shelved: dict[str, float] = {}

    def update(self, t: float, alarms: dict, raised: dict | None = None) -> list[AlarmEntry]:
        """The list at run time ``t`` for the controller's alarm states ``alarms`` (tag to state), most urgent
        first, then newest first; ``raised`` gives when each was raised where known (a replay's log)."""
        out = []
        for tag, state in alarms.items():
            if state == AlarmState.NORMAL.value:
                self.raised.pop(tag, None)
                self.shelved.pop(tag, None)
                continue
            if raised and tag in raised:
                self.raised[tag] = raised[tag]
            self.raised.setdefault(tag, t)
            until = self.shelved.get(tag)
            if until is not None and t >= until:
                del self.shelved[tag]
                until = None
            rank, name = priority(tag)
            out.append(AlarmEntry(tag, CONDITION_TEXT.get(tag, tag), rank, name, state, self.raised[tag], until))
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


def geometry(model) -> dict:
    """The drawing's fixed geometry, SI: arm lengths, the alarm angles, the reach of each alarm zone from the
    inboard hinge (bands in the side view), the berth box, the slew limits, and the time the emergency sequence
    needs (ESD-1, ERS valves, release, margin: a time to limit above it is in the normal range).

    Parameters
    ----------
    model : ArmModel

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
    bb, sl, sq = model.berth, model.slew, model.sequence
    return {"a": arm.a, "b": arm.b, "c": arm.c, "zones": zones,
            "sequence_time": sq.esd_time + sq.ers_valve_time + sq.erc_release_time + sq.margin,
            "alarm_beta": {"first": al.first, "second": al.second, "release": al.release},
            "berth": {"jetty_face": bb.jetty_face, "berthing_line": bb.berthing_line, "x_far": bb.x_far,
                      "y_low": bb.y_low, "y_high": bb.y_high},
            "slew": {"limit": sl.limit, "first": sl.first, "second": sl.second, "release": sl.release},
            "limits": {"phi": list(model.joint_limits.phi), "beta": list(model.joint_limits.beta)},
            "faces": list(FACES)}


def _num(v: float) -> float | None:
    """JSON has no NaN or infinity: None."""
    v = float(v)
    return v if math.isfinite(v) else None


def frame(snap, model, alarms: list[AlarmEntry], *, sent_at: float) -> dict:
    """One update of the screen: everything in SI (the page converts for display), non-finite values as
    None.

    Parameters
    ----------
    snap : loadarm.sim.snapshot.Snapshot
    model : ArmModel
    alarms : list of AlarmEntry
        :meth:`AlarmBook.update` for this snapshot.
    sent_at : float
        The HMI server's wall clock, s (the page measures staleness against its own).

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
        "alarms": [a.to_dict() for a in alarms if a.shelved_until is None],
        "shelved": [a.to_dict() for a in alarms if a.shelved_until is not None],
    }
