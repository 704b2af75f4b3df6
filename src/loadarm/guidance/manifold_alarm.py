"""The live manifold-load alarm of a bank (issue 31, item 4): each arm's loads on its presentation flange while
connected, against the allowable loads of the bank file, as an ISA-18.2 alarm.

The loads are the design's (:func:`loadarm.design.manifold.record_manifold_loads`: the free-wheeling arm's
weight, product, wind, inertia and the swivels' friction), computed over a short window of the ship's motion at
the manifold so that the joints' rates and accelerations come from the same differences as the record's; the
window's last sample is the one judged. One formula, two users: the check and the records (the design), and this
alarm (the cycle).

An arm's alarm **rises** once any of its five loads has stayed past its allowable for ``alarm_delay`` and
**clears** once every load has stayed below ``(1 - alarm_deadband)`` of its allowable for ``alarm_delay``
(ISA-18.2's on- and off-delays and deadband; the bank file's ``[manifold_loads]``); between the two the alarm
keeps its state. Its annunciation follows :func:`loadarm.arm.alarms.next_alarm_state` (unacknowledged,
acknowledged, returned to normal unacknowledged). The alarm does not stop anything: an overloaded manifold is the
operator's to act on (the emergency sequence is the faces').

Time is the samples' own (``t`` given with each sample): no clock is read. A window whose times are not even
(a missed sample) is started again; until it holds :data:`WINDOW` even samples the alarm keeps its state.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from loadarm.arm.alarms import AlarmState, next_alarm_state
from loadarm.design.manifold import LOAD_LABELS, MANIFOLD_LOAD_EVENT, allowable, record_manifold_loads

__all__ = ["WINDOW", "ManifoldLoadStatus", "ManifoldLoadAlarm"]

#: Samples in the window the rates are differenced over (the judged sample is the last; 3 at the least).
WINDOW = 5


@dataclass(frozen=True)
class ManifoldLoadStatus:
    """The bank's manifold loads at one sample, and each arm's alarm.

    Attributes
    ----------
    t : float
        s.
    utilisation : ndarray, shape (n_arms,)
        Each arm's largest load over its allowable (NaN until the window is full).
    governing : tuple of str
        Each arm's load of that utilisation (:data:`loadarm.design.manifold.LOAD_LABELS`; "" until the window is
        full).
    active : tuple of bool
        Each arm's alarm condition, after the delays and the deadband.
    states : tuple of AlarmState
        Each arm's ISA-18.2 state.
    events : tuple of dict
        The alarms that rose or cleared at this sample: ``code`` (:data:`MANIFOLD_LOAD_EVENT`), ``arm``,
        ``active``, ``load``, ``utilisation``, ``t``.
    """

    t: float
    utilisation: np.ndarray
    governing: tuple
    active: tuple
    states: tuple
    events: tuple


class ManifoldLoadAlarm:
    """Each arm's manifold-load alarm, sample by sample (see the module's text).

    Parameters
    ----------
    bank : Bank
    """

    def __init__(self, bank):
        self.bank = bank
        self.allow = allowable(bank)
        ml = bank.file.manifold_loads
        self.deadband = float(ml.alarm_deadband)
        self.delay = float(ml.alarm_delay)
        n = len(bank.names)
        self._t: deque = deque(maxlen=WINDOW)
        self._d: deque = deque(maxlen=WINDOW)
        self._a: deque = deque(maxlen=WINDOW)
        self.active = [False] * n
        self.states = [AlarmState.NORMAL] * n
        self._since = [math.nan] * n            # when the condition to change state began (NaN: not pending)
        self.utilisation = np.full(n, np.nan)
        self.governing = [""] * n

    def _window(self, t: float, displacement, angles) -> bool:
        """Add a sample; whether the window is full and even."""
        if self._t and not t > self._t[-1]:
            raise ValueError(f"manifold-load alarm: time {t} s does not follow {self._t[-1]} s")
        self._t.append(float(t))
        self._d.append(np.asarray(displacement, dtype=float))
        self._a.append(np.asarray(angles, dtype=float))
        if len(self._t) < WINDOW:
            return False
        dt = np.diff(np.array(self._t))
        if not np.allclose(dt, dt[0], rtol=1e-6):
            for q in (self._t, self._d, self._a):     # a missed sample: start again from this one
                last = q[-1]
                q.clear()
                q.append(last)
            return False
        return True

    def _loads(self, wind) -> None:
        rec = record_manifold_loads(self.bank, np.array(self._t), np.array(self._d), np.array(self._a), wind=wind)
        u = np.abs(rec.loads[:, -1, :]) / self.allow            # (arms, 5) at the judged sample
        k = np.argmax(u, axis=1)
        self.utilisation = u[np.arange(u.shape[0]), k]
        self.governing = [LOAD_LABELS[j] for j in k]

    def _condition(self, i: int, t: float) -> bool:
        """Arm ``i``'s condition after the delays and the deadband; whether it changed."""
        u = self.utilisation[i]
        wants = (u > 1.0) if not self.active[i] else not (u < 1.0 - self.deadband)
        if wants == self.active[i] or math.isnan(u):
            self._since[i] = math.nan
            return False
        if math.isnan(self._since[i]):
            self._since[i] = t
        if t - self._since[i] >= self.delay - 1e-9:
            self.active[i] = wants
            self._since[i] = math.nan
            return True
        return False

    def step(self, t: float, displacement, angles, *, wind=(0.0, 0.0, 0.0), acknowledge=()) -> ManifoldLoadStatus:
        """Judge one sample of the ship's motion at the manifold.

        Parameters
        ----------
        t : float
            The sample's time, s (increasing).
        displacement : array_like, shape (3,)
            The manifold's centre from its design position, bank frame, m.
        angles : array_like, shape (3,)
            The ship's roll, pitch and yaw at the manifold, rad.
        wind : array_like, shape (3,)
            The wind's velocity, bank frame, m/s.
        acknowledge : iterable of str
            The arms whose alarm the operator acknowledged since the last sample.

        Returns
        -------
        ManifoldLoadStatus

        Raises
        ------
        ValueError
            A time that does not follow the last.
        """
        t = float(t)
        if self._window(t, displacement, angles):
            self._loads(wind)
        acked = set(acknowledge)
        events = []
        for i, name in enumerate(self.bank.names):
            if self._condition(i, t):
                events.append({"code": MANIFOLD_LOAD_EVENT, "arm": name, "active": self.active[i],
                               "load": self.governing[i], "utilisation": float(self.utilisation[i]), "t": t})
            self.states[i] = next_alarm_state(self.states[i], self.active[i], name in acked)
        return ManifoldLoadStatus(t, self.utilisation.copy(), tuple(self.governing), tuple(self.active),
                                  tuple(self.states), tuple(events))

