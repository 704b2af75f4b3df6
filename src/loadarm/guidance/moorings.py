"""The berth's mooring load monitoring, as the guidance reads it: the second witness the predictive alarms need.

A terminal's quick-release hooks carry load cells (OCIMF MEG4 recommends mooring load monitoring; the judgement
below, its 1 %, 2 s and a third of the lines, is this project's, measured on the shipped berth); the monitoring reports
each line's load, here as a share of the line's minimum breaking load (MBL, the ship's line's: entered per ship),
about once a second. The flange predictor (:mod:`loadarm.guidance.predict`) learned the ship on its moorings;
when the lines part, the ship is no longer the one it learned, and its track stays inside the prediction's
intervals for seconds after the drift fit's break-out test has seen the drift (found: the 1000-seed break-out
campaign, docs/guidance.md section 13). So the predictive rule holds a change detector's call only while this
watch says the moorings hold.

The judgement: a line is *slack* when its load stays below :data:`SLACK_SHARE` of its MBL for :data:`SLACK_TIME` (a
load cell cannot tell a parted line from a slack one); the moorings are *lost* when more than :data:`LOST_SHARE` of
the lines (a third: 6 of 16) are slack at once. Latched for the rest of the run (a departure while connected is,
for the connection). Measured
on the shipped berth (``lng150k.toml``, 16 lines) from its moored-ship records alone, the watch's own judgement,
every stored run (seeds 100-1099 a band, 100-819 at Hs 0.5-1.0 m, each with its drawn Hs;
:mod:`loadarm.studies.watch_basis`): no line slack at Hs 0.5-1.0 m, at most 2 lines slack at once at Hs 1.0-1.5 m, at
most 4 at Hs 1.5-2.0 m, so the watch never fires below Hs 2.0 m; 6 or more in 167 of
the 1000 runs at Hs 2.0-2.5 m (more than half in 20); in the break-out (every line parts at 400 s, 1000 seeds) all 16
were slack, the moorings lost by 401.9 s on the record's 10 Hz (the 402 s reading at 1 Hz); when half the lines part
(the partial break-out, 8 of 16) they are lost at the same reading. Until 2026-12-06 the share was a half: half the
lines parting was not seen, and in a 25 m/s squall the prediction held the break-out test's call for up to 24 s
(docs/guidance.md section 13, ``partial_breakout_squall_tracked``).

The watch is a witness only while it is fresh: a reading it cannot use (not finite, not one number per line),
no reading for :data:`STALE_TIME`, or the same values for that long (a frozen feed: live load cells are never
that still) make it *silent*, and a silent watch holds nothing. It never raises in the guidance cycle.
What it does not see: a third of the lines or fewer parting at once (the four breast lines alone: 4 of 16; the
waves already slacken 4 below Hs 2.0 m and 5 at 2.0-2.5 m, so a count cannot go lower), lines parting one by one
while a third or fewer are slack, and brakes rendering (the lines stay loaded while the ship moves); there the hold
rests on the track's departure test, as before it (docs/guidance.md section 13 measures the breast lines).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LOST_SHARE", "READING_PERIOD", "SLACK_SHARE", "SLACK_TIME", "STALE_TIME", "MooringWatch"]

#: How often the simulated monitoring reports, s (hook load monitoring systems update about once a second).
READING_PERIOD = 1.0

#: A line's load below this share of its MBL counts toward its slack time (1 %: 10 kN on the shipped berth's
#: 1000 kN lines, whose tension after tending is 3-9 % of MBL; a load cell's zero reads within it, and a
#: zero drifted below 0 reads as slack).
SLACK_SHARE = 0.01
#: How long a line's load must stay below :data:`SLACK_SHARE` before the line counts as slack, s (three readings
#: of a 1 Hz monitoring: one or two low readings are a snatch or a dropped sample).
SLACK_TIME = 2.0
#: The moorings are lost when more than this share of the lines are slack at once (6 of the shipped berth's 16:
#: the waves slacken at most 4 of 16 below Hs 2.0 m over 2720 stored runs (the basis does not record which); half the
#: lines parting, 8; a break-out, every line). Lower, the prediction stands down on a wave's slack lines more
#: often (toward the rule without it: never later than that rule, but the prediction's own warnings go with it:
#: at Hs 2.0-2.5 m, 3 of the 167 runs it touched had ESD-1 later than at a half, none reaching a face); higher,
#: a partial break-out goes unseen.
LOST_SHARE = 1.0 / 3.0
#: The watch goes silent (no witness) after this long without a usable reading, or with the same values, s
#: (three missed readings of a 1 Hz monitoring).
STALE_TIME = 3.0


class MooringWatch:
    """Mutable state: the lines' slack timers, the feed's freshness and whether the moorings were lost (one per
    controller, for one ship).

    Attributes
    ----------
    lost_at : float or None
        When more than :data:`LOST_SHARE` of the lines were first slack at once, s (None: the moorings hold).
    fault : str
        Why the last reading could not be used (``""``: it could).
    """

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        """Forget the lines (a new ship)."""
        self.low_since: np.ndarray | None = None
        self.lost_at: float | None = None
        self.fault = ""
        self.read_at = -math.inf                          # the last usable reading's time, s
        self.changed_at = -math.inf                       # when its values last changed, s
        self._last: tuple | None = None                   # the last reading evaluated (a tuple: immutable)
        self._due = math.inf                              # the soonest a low line's slack time is up, s

    def fresh(self, now: float) -> bool:
        """A usable reading within :data:`STALE_TIME`, its values changing within it."""
        return not self.fault and now - self.read_at <= STALE_TIME and now - self.changed_at <= STALE_TIME

    def holding(self, now: float) -> bool:
        """The watch is a witness that the moorings hold: fresh, and the moorings not lost."""
        return self.lost_at is None and self.fresh(now)

    def state(self, now: float) -> str:
        """``"lost"``, ``"holding"``, ``"silent"`` (read before, not fresh now) or ``"none"`` (never read)
        (:data:`loadarm.vocab.MOORINGS_TEXT`)."""
        if self.lost_at is not None:
            return "lost"
        if self.fresh(now):
            return "holding"
        return "none" if self.read_at == -math.inf and not self.fault else "silent"

    def update(self, now: float, loads) -> bool:
        """Read the lines' loads (never raises: a reading it cannot use makes the watch silent, :attr:`fault`).

        Parameters
        ----------
        now : float
            Time of the reading, s.
        loads : sequence of float or None
            Each line's load as a share of its MBL (None or empty: no reading this cycle).

        Returns
        -------
        bool
            True at the reading that finds the moorings lost (once).
        """
        if loads is None or len(loads) == 0:
            return False
        seen = isinstance(loads, tuple) and loads == self._last      # the last one again (a tuple, or None)
        if seen:
            self.read_at = now
            if self.lost_at is not None or now < self._due:
                return False                     # the same reading, no line's slack time up: nothing changes
        try:
            a = np.asarray(loads, dtype=float)
        except (TypeError, ValueError):
            a = np.full(1, math.nan)
        if a.ndim != 1 or not np.all(np.isfinite(a)):
            self.fault, self._last = "a reading not one finite share of MBL per line", None
            return False
        if self.low_since is None or self.low_since.size != a.size:
            self.low_since = np.full(a.size, math.nan)        # the first reading, or another ship's lines
        self.fault = ""
        self.read_at = now
        if not seen:
            self.changed_at = now
        low = a < SLACK_SHARE
        self.low_since = np.where(low, np.where(np.isnan(self.low_since), now, self.low_since), math.nan)
        self._last = loads if isinstance(loads, tuple) else None
        slack = low & (now - self.low_since >= SLACK_TIME - 1e-9)
        pending = low & ~slack                  # low, not yet for long enough: the next change a repeat can bring
        self._due = float(np.min(self.low_since[pending])) + SLACK_TIME - 1e-9 if pending.any() else math.inf
        if self.lost_at is not None:
            return False
        if np.count_nonzero(slack) > LOST_SHARE * a.size:
            self.lost_at = now
            return True
        return False
