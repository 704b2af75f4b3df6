"""The berth's mooring load monitoring, as the guidance reads it: the second witness the predictive alarms need.

A terminal's quick-release hooks carry load cells (OCIMF MEG4's mooring load monitoring); the monitoring reports
each line's load, here as a share of the line's minimum breaking load (MBL), about once a second. The flange
predictor (:mod:`loadarm.guidance.predict`) learned the ship on its moorings; when the lines part, the ship is no
longer the one it learned, and its track stays inside the prediction's intervals for seconds after the drift
fit's break-out test has seen the drift (found: the 1000-seed break-out campaign, docs/guidance.md section 13).
So the predictive rule holds a change detector's call only while this watch says the moorings hold.

The judgement: a line is *slack* when its load stays below :data:`SLACK_SHARE` of its MBL for :data:`SLACK_TIME`
(a load cell cannot tell a parted line from a slack one); the moorings are *lost* when more than
:data:`LOST_SHARE` of the lines are slack at once. Latched for the rest of the connection, as the departure test
is. Measured on the shipped berth (``lng150k.toml``, 16 lines) from its moored-ship records alone: at Hs 1.5-2.0 m
(150 seeds) at most 4 lines were slack at once; in the break-out (every line parts at 400 s, 1000 seeds) all 16
were slack 1.9 s after the parting, before any break-out test's call.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LOST_SHARE", "READING_PERIOD", "SLACK_SHARE", "SLACK_TIME", "MooringWatch"]

#: How often the simulated monitoring reports, s (hook load monitoring systems update about once a second).
READING_PERIOD = 1.0

#: A line's load below this share of its MBL counts toward its slack time (1 %: 10 kN on the shipped berth's
#: 1000 kN lines, whose tension after tending is 3-9 % of MBL; a load cell's zero reads within it).
SLACK_SHARE = 0.01
#: How long a line's load must stay below :data:`SLACK_SHARE` before the line counts as slack, s (two samples of
#: a 1 Hz monitoring: one low reading is a snatch or a dropped sample).
SLACK_TIME = 2.0
#: The moorings are lost when more than this share of the lines are slack at once (the waves slacken the breast
#: lines of one end, 2-4 of 16 at Hs 1.5-2.0 m; a break-out, every line).
LOST_SHARE = 0.5


class MooringWatch:
    """Mutable state: the lines' slack timers and whether the moorings were lost (one per controller).

    Attributes
    ----------
    lost_at : float or None
        When more than :data:`LOST_SHARE` of the lines were first slack at once, s (None: the moorings hold).
    reading : bool
        Whether the monitoring has reported at all (False: no witness; the predictive rule then never holds a
        change detector's call).
    """

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        """Forget the lines (a new connection)."""
        self.low_since: np.ndarray | None = None
        self.lost_at: float | None = None
        self.reading = False
        self._last: tuple | None = None                   # the last reading evaluated (a tuple: immutable)
        self._due = math.inf                              # the soonest a low line's slack time is up, s

    @property
    def state(self) -> str:
        """``"none"`` (no reading yet), ``"holding"`` or ``"lost"`` (:data:`loadarm.vocab.MOORINGS_TEXT`)."""
        return "lost" if self.lost_at is not None else "holding" if self.reading else "none"

    @property
    def holding(self) -> bool:
        """The monitoring reports and the moorings were not lost."""
        return self.reading and self.lost_at is None

    def update(self, now: float, loads) -> bool:
        """Read the lines' loads.

        Parameters
        ----------
        now : float
            Time of the reading, s.
        loads : sequence of float or None
            Each line's load as a share of its MBL (None: no reading this cycle; the watch keeps its state).

        Returns
        -------
        bool
            True at the reading that finds the moorings lost (once).

        Raises
        ------
        ValueError
            A load that is negative or not finite, or a number of lines that changed.
        """
        if loads is None:
            return False
        seen = loads is self._last or (self._last is not None and loads == self._last)
        if seen and (self.lost_at is not None or now < self._due):
            return False                         # the same reading, no line's slack time up: nothing changes
        a = np.asarray(loads, dtype=float)
        if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ValueError(f"line loads {loads!r}: one finite share of MBL >= 0 per line expected")
        if self.low_since is None:
            self.low_since = np.full(a.size, math.nan)
        elif self.low_since.size != a.size:
            raise ValueError(f"line loads: {a.size} lines reported, {self.low_since.size} before")
        self.reading = True
        low = a < SLACK_SHARE
        self.low_since = np.where(low, np.where(np.isnan(self.low_since), now, self.low_since), math.nan)
        self._last = loads if isinstance(loads, tuple) else None
        self._due = float(np.min(self.low_since[low])) + SLACK_TIME - 1e-9 if low.any() else math.inf
        if self.lost_at is not None:
            return False
        slack = low & (now - self.low_since >= SLACK_TIME - 1e-9)
        if np.count_nonzero(slack) > LOST_SHARE * a.size:
            self.lost_at = now
            return True
        return False
