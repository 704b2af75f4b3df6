"""Redundant joint-angle sensors: detect a frozen, drifting or failed channel, vote, and say when no vote is possible.

One encoder per axis feeding the forward kinematics is a single point of failure: a frozen beta encoder hides the
elbow's stretch from every position alarm and from the time-to-limit monitor. The installation's ``[encoder]
redundancy`` gives each axis a second channel (:func:`loadarm.sim.world.AngleSensors`):

* ``dual``: two angle encoders per axis;
* ``cylinder``: the angle encoder against the angle the cylinder-length transducer gives through the pin
  geometry (:func:`loadarm.arm.actuators.joint_angles_from_cylinders`) for alpha and beta, two encoders on the slew.

Each cycle :func:`vote` compares the two channels of each axis:

* a channel that reads NaN or infinity has **failed** (a broken wire, a dead encoder), at once;
* a channel whose value has not changed for ``frozen_time`` while the other moved by more than a tenth of the
  tolerance, the other agreeing with the tracker, is **frozen** (without the tracker a stationary arm whose other
  channel drifts looks the same);
* channels further apart than the tolerance for ``persist`` seconds disagree (a **drifting** channel, or a frozen
  one the other has left behind): the third opinion, the flange tracker's estimate through the inverse kinematics
  (only while the coupler is on the flange), names the channel that is wrong; without it no vote is possible and
  the axis is **lost**;
* the channel left after a rejection stays under watch: no reading, or apart from the tracker, loses the axis.

A lost axis takes the tracker's angle, else the worse of the finite channels (the more stretched beta, the larger
slew), else the last angle used.

A channel found wrong stays rejected (latched) until the operator's reset while the two agree again: a sensor that
failed once is not trusted again without a look. The controller (:mod:`loadarm.guidance.controller`) takes the
voted angles; with an axis lost it fails safe (ESD-1 while attached, no motion otherwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["AXES", "VoteState", "Vote", "vote", "reset_votes"]

#: The axes, in the order of the joint vector.
AXES = ("slew", "alpha", "beta")
#: A channel's channel names, by index.
CHANNELS = ("primary", "second")


@dataclass
class VoteState:
    """What the voter remembers between cycles (mutable, like the controller's state).

    Attributes
    ----------
    rejected : list of (int or None)
        Per axis: the channel found wrong (0 primary, 1 second), latched; None if neither.
    lost : list of bool
        Per axis: the channels disagree and nothing tells which is right.
    odd_since : list of (float or None)
        Per axis: since when the channels disagree, s.
    last : ndarray, shape (2, 3)
        Each channel's last reading, rad.
    changed_at : ndarray, shape (2, 3)
        When each channel's reading last changed, s.
    other_at_change : ndarray, shape (2, 3)
        The other channel's reading at that time, rad.
    why : list of str
        Per axis: why the channel was rejected or the axis lost (for the operator).
    used : list of float
        Per axis: the last angle the vote gave, rad.
    """

    rejected: list = field(default_factory=lambda: [None, None, None])
    lost: list = field(default_factory=lambda: [False, False, False])
    odd_since: list = field(default_factory=lambda: [None, None, None])
    last: np.ndarray = field(default_factory=lambda: np.full((2, 3), np.nan))
    changed_at: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    other_at_change: np.ndarray = field(default_factory=lambda: np.full((2, 3), np.nan))
    why: list = field(default_factory=lambda: ["", "", ""])
    used: list = field(default_factory=lambda: [math.nan, math.nan, math.nan])

    @property
    def status(self) -> str:
        """``"ok"``, ``"degraded"`` (a channel rejected, the other used) or ``"lost"`` (an axis without a vote)."""
        if any(self.lost):
            return "lost"
        return "degraded" if any(r is not None for r in self.rejected) else "ok"


@dataclass(frozen=True, slots=True)
class Vote:
    """One cycle's vote.

    Attributes
    ----------
    q : tuple of float
        The angles to use (slew, alpha, beta), rad.
    found : tuple of (int, str)
        Axes whose channel was rejected or which were lost this cycle, with the reason (for the event log).
    """

    q: tuple
    found: tuple = ()


class _Lazy:
    """A third opinion computed on first use (the inverse kinematics costs more than the whole vote)."""

    def __init__(self, fn):
        self.fn, self.value, self.done = fn, None, False

    def get(self):
        if not self.done:
            self.value, self.done = self.fn(), True
        return self.value


def _track(st: VoteState, now: float, ch: np.ndarray, j: int) -> None:
    """Note when each channel of axis ``j`` last changed, and the other's reading then."""
    for c in (0, 1):
        if ch[c, j] != st.last[c, j]:
            st.last[c, j], st.changed_at[c, j], st.other_at_change[c, j] = ch[c, j], now, ch[1 - c, j]


def _frozen(st: VoteState, now: float, ch: np.ndarray, j: int, tol: float, frozen_time: float) -> int | None:
    """The channel of axis ``j`` unchanged for ``frozen_time`` while the other moved, or None (a candidate only:
    a stationary arm with the other channel drifting looks the same, so the tracker must confirm)."""
    for c in (0, 1):
        moved = abs(ch[1 - c, j] - st.other_at_change[c, j])
        if now - st.changed_at[c, j] >= frozen_time and moved > 0.1 * tol:
            return c
    return None


def _ref(ref):
    return ref.get() if isinstance(ref, _Lazy) else ref


def _judge_axis(st: VoteState, now: float, ch: np.ndarray, j: int, ref, tol: float, persist: float,
                frozen_time: float) -> str:
    """Judge axis ``j``: reject a channel or lose the axis; returns why ("" if nothing new)."""
    a, b = float(ch[0, j]), float(ch[1, j])
    finite = (math.isfinite(a), math.isfinite(b))
    if not all(finite):
        if not any(finite):
            return "both channels failed (no reading)"
        st.rejected[j] = 0 if not finite[0] else 1
        return f"{CHANNELS[st.rejected[j]]} channel failed (no reading)"
    _track(st, now, ch, j)
    frozen = _frozen(st, now, ch, j, tol, frozen_time)
    if frozen is not None:
        r = _ref(ref)
        # found (review): without this, a stationary arm whose primary drifts had its healthy channel "frozen"
        if r is not None and math.isfinite(r[j]) and abs(ch[1 - frozen, j] - r[j]) <= tol:
            st.rejected[j] = frozen
            return (f"{CHANNELS[frozen]} channel frozen (unchanged for {now - st.changed_at[frozen, j]:.1f} s while "
                    f"the other moved {math.degrees(abs(ch[1 - frozen, j] - st.other_at_change[frozen, j])):.2f} deg; "
                    "the flange tracker agrees with the other)")
    if abs(a - b) <= tol:
        st.odd_since[j] = None
        return ""
    if st.odd_since[j] is None:
        st.odd_since[j] = now
    if now - st.odd_since[j] < persist:
        return ""
    gap = f"{math.degrees(abs(a - b)):.2f} deg apart for {now - st.odd_since[j]:.1f} s"
    r = _ref(ref)
    if r is not None and math.isfinite(r[j]):
        da, db = abs(a - r[j]), abs(b - r[j])
        if min(da, db) <= tol:
            c = st.rejected[j] = 0 if da > db else 1
            still = now - st.changed_at[c, j]
            what = f"frozen (unchanged for {still:.1f} s)" if st.changed_at[c, j] <= st.odd_since[j] else "drifted"
            return f"{CHANNELS[c]} channel {what} ({gap}; the flange tracker agrees with the other)"
    return f"channels disagree ({gap}) and nothing tells which is right"


def _judge_survivor(st: VoteState, now: float, ch: np.ndarray, j: int, ref, tol: float, persist: float) -> str:
    """The channel left after a rejection must stay plausible: no reading, or apart from the tracker for
    ``persist``, loses the axis (found (review): a survivor that then failed went unseen)."""
    v = float(ch[1 - st.rejected[j], j])
    if not math.isfinite(v):
        return f"{CHANNELS[1 - st.rejected[j]]} channel failed too (no reading)"
    r = _ref(ref)
    if r is None or not math.isfinite(r[j]) or abs(v - r[j]) <= tol:
        st.odd_since[j] = None
        return ""
    if st.odd_since[j] is None:
        st.odd_since[j] = now
    if now - st.odd_since[j] < persist:
        return ""
    return (f"{CHANNELS[1 - st.rejected[j]]} channel, the one left, {math.degrees(abs(v - r[j])):.2f} deg from the "
            "flange tracker")


def _lost_value(ch: np.ndarray, j: int, ref, last: float) -> float:
    """An axis without a vote: the tracker's angle if it has one, else the worse of the finite channels (the more
    stretched beta, the larger slew), else the last angle used; never NaN while anything is known."""
    r = _ref(ref)
    if r is not None and math.isfinite(r[j]):
        return float(r[j])
    vals = [float(v) for v in ch[:, j] if math.isfinite(v)]
    if not vals:
        return last
    if j == 0:
        return max(vals, key=abs)
    return max(vals) if j == 2 else vals[0]


def vote(st: VoteState, now: float, channels, ref=None, *, tol: float, persist: float,
         frozen_time: float) -> Vote:
    """Vote this cycle's angles from two channels per axis.

    Parameters
    ----------
    st : VoteState
        The voter's memory (updated).
    now : float
        Time, s.
    channels : array_like, shape (2, 3)
        The primary and the second channel's readings (slew, alpha, beta), rad.
    ref : array_like, shape (3,), or callable, optional
        A third opinion: the flange tracker's estimate through the inverse kinematics, rad (while attached); a
        callable returning it (or None) is called only when a disagreement needs it, at most once.
    tol : float
        Largest difference between two healthy channels, rad.
    persist : float
        How long a difference must last before a channel is judged, s (no verdict on one noisy sample).
    frozen_time : float
        How long a channel may read the same value while the other moves, s.

    Returns
    -------
    Vote
    """
    ch = np.asarray(channels, dtype=float)
    found = []
    q = []
    if callable(ref):
        ref = _Lazy(ref)
    for j in range(3):
        if st.lost[j]:                            # the tracker may settle it later
            st.rejected[j] = None                 # a lost axis trusts neither channel until a verdict
            why = _judge_axis(st, now, ch, j, ref, tol, persist, frozen_time)
            if st.rejected[j] is not None:
                st.lost[j] = False
                st.why[j] = why
                found.append((j, why))
        elif st.rejected[j] is None:
            why = _judge_axis(st, now, ch, j, ref, tol, persist, frozen_time)
            if why:
                st.lost[j] = st.rejected[j] is None
                st.why[j] = why
                found.append((j, why))
        else:
            why = _judge_survivor(st, now, ch, j, ref, tol, persist)
            if why:
                st.lost[j], st.why[j] = True, why
                found.append((j, why))
        if st.lost[j]:
            q.append(_lost_value(ch, j, ref, st.used[j]))
        else:
            q.append(float(ch[1 if st.rejected[j] == 0 else 0, j]))
        if math.isfinite(q[-1]):
            st.used[j] = q[-1]
    return Vote(tuple(q), tuple(found))


def reset_votes(st: VoteState, channels, *, tol: float) -> list[int]:
    """The operator's reset: trust again each axis whose two channels agree now.

    Parameters
    ----------
    st : VoteState
    channels : array_like, shape (2, 3)
        The readings now, rad.
    tol : float
        Agreement tolerance, rad.

    Returns
    -------
    list of int
        The axes trusted again.
    """
    ch = np.asarray(channels, dtype=float)
    back = []
    for j in range(3):
        if (st.rejected[j] is not None or st.lost[j]) and np.all(np.isfinite(ch[:, j])) \
                and abs(ch[0, j] - ch[1, j]) <= tol:
            st.rejected[j], st.lost[j], st.odd_since[j], st.why[j] = None, False, None, ""
            st.changed_at[:, j] = np.nan        # restart the frozen test from the next reading
            st.last[:, j] = np.nan
            back.append(j)
    return back
