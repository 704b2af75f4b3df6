"""The verdict of a closed-loop run: :class:`RunResult` (signals, events, the metrics declared once in
:data:`RUN_METRICS`, :meth:`RunResult.failures`, the one verdict) and the failures it names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from loadarm.design.check import MANIFOLD_CLEARANCE
from loadarm.guidance.modes import MODES
from loadarm.results import Metric, Result
from loadarm.sim.plots import run_timeline_figure

if TYPE_CHECKING:  # the model is only ever received, never built, here
    pass

__all__ = ["FAILURES", "RUN_METRICS", "RunResult"]


#: The ways a run fails the safety chain, declared once (codes; the words are for people): the run's verdict, the
#: campaign's counters and ``loadarm run``'s exit status all read these.
FAILURES = {
    "overstretch_before_isolation": "the arm overstretched before the ERS valves were confirmed closed (live product)",
    "overstretch": "the arm overstretched",
    "opened_on_live_product": "the coupler began to open before the ERS valves were confirmed closed",
    "missed_alarm": "the flange reached a face before the release completed",
}


#: The headline numbers of a guidance run, declared once.
RUN_METRICS = (
    Metric("scenario", "scenario"),
    Metric("verdict", "verdict"),
    Metric("duration_s", "simulated", "s", ".1f"),
    Metric("final_mode", "final mode"),
    Metric("alarm1_s", "first alarm (ESD-1)", "s", ".2f", none="-"),
    Metric("alarm2_s", "second alarm", "s", ".2f", none="-"),
    Metric("release_s", "release (ERS-2)", "s", ".2f", none="-"),
    Metric("release_complete_s", "release complete", "s", ".2f", none="-"),
    Metric("overstretched_s", "overstretched", "s", ".2f", none="no"),
    Metric("release_margin_s", "release margin to the limit", "s", ".2f", none="-"),
    Metric("cleared_s", "coupler clear of the manifold", "s", ".2f", none="-"),
    Metric("retracted_s", "arm retracted clear of its release point", "s", ".2f", none="-"),
    Metric("connected_s", "time connected", "s", ".1f"),
    Metric("max_beta_deg", "max beta", "deg", ".1f"),
    Metric("max_abs_slew_deg", "max |slew|", "deg", ".1f"),
    Metric("events", "events", "", "d"),
)


@dataclass(frozen=True)
class RunResult(Result):
    """Signals and events of one run.

    Attributes
    ----------
    name : str
        Scenario name.
    signals : dict of str to ndarray
        ``t, mode (index into MODES), phi, alpha, beta, x, y, z, fx, fy, fz, ex, ey, ez, healthy, distance,
        severity`` (:class:`loadarm.vocab.Severity` of the connected mode), ``level`` (connected-mode alarm
        level), ``ttl`` (forecast time to the nearest face, s; NaN when none in sight), ``connected`` at every
        guidance cycle.
    events : list of tuple
        ``(t, mode, kind, reason, data)`` in order.
    overstretched_at : float or None
        First time the attached arm could not reach the flange, s.
    cycle_us : ndarray
        Wall time of each controller cycle (estimate + decide), microseconds.
    beta_thresholds_deg : tuple of float
        The run's first, second and release angles (for the timeline figure).
    limit_at : float or None
        First time after the connection the true flange lies past a face of the arm's envelope (where an
        arm still attached would be overstretched), s: in the run or on the flange's trajectory up to
        ``LIMIT_LOOKAHEAD`` s after it.
    limit_face : str
        That face (:data:`loadarm.vocab.FACES`).
    """

    name: str
    signals: dict
    events: list
    overstretched_at: float | None
    cycle_us: np.ndarray = field(repr=False)
    beta_thresholds_deg: tuple = ()
    limit_at: float | None = None
    limit_face: str = ""

    METRICS = RUN_METRICS

    def first(self, kind: str, contains: str = "") -> float | None:
        """Time of the first event of a kind whose reason contains a text, s (None if none); for reading a run
        by eye. Metrics read codes (:meth:`first_code`)."""
        for t, _, k, reason, _ in self.events:
            if k == kind and contains in reason:
                return t
        return None

    def measured_alarm1(self) -> float | None:
        """When the rule without the prediction would have raised the ESD-1 that came: the onset of its call in
        progress at the ESD-1 (the stage event's ``measured_since``), else its first call after it; with no
        ESD-1, its first call; None: it never called, s.

        Returns
        -------
        float or None
        """
        esd = next((e for e in self.events if e[4] and e[4].get("code") == "stage.esd1"), None)
        calls = [e[0] for e in self.events if e[4] and e[4].get("code") == "info.measured_esd1"]
        if esd is None:
            return calls[0] if calls else None
        if esd[4].get("measured_since") is not None:
            return float(esd[4]["measured_since"])
        return next((t for t in calls if t >= esd[0]), None)

    def held_calls(self) -> list[list[float]]:
        """The calls for ESD-1 of the rule without the prediction made before the run's ESD-1 (or in a run
        without one): the prediction held them. Each as ``[onset, end]``, s: the end is when the call ended
        (``info.measured_esd1_end``), the ESD-1 when it still stood then, or the run's end. What a hold limit
        ``H`` would have changed follows from them alone: ESD-1 at the first ``onset + H`` before its ``end``
        (:func:`loadarm.studies.campaign.capped_alarm1`).

        Returns
        -------
        list of [float, float]
        """
        esd = self.first_code("stage.esd1")
        stop = esd if esd is not None else float(self.signals["t"][-1])
        calls, onset = [], None
        for t, _, _, _, d in self.events:
            code = d.get("code") if d else None
            if code == "info.measured_esd1" and t < stop:
                onset = t
            elif code == "info.measured_esd1_end" and onset is not None:
                calls.append([round(onset, 6), round(t, 6)])
                onset = None
        if onset is not None:
            calls.append([round(onset, 6), round(stop, 6)])
        return calls

    def first_code(self, code: str) -> float | None:
        """Time of the first event with an event code (:data:`loadarm.vocab.EVENT_TABLE`), s (None if none).

        Parameters
        ----------
        code : str
            E.g. ``"stage.esd1"``, ``"command.release_complete"``.

        Returns
        -------
        float or None
        """
        for t, _, _, _, data in self.events:
            if data and data.get("code") == code:
                return t
        return None

    def first_data(self, code: str) -> dict | None:
        """The data of the first event with an event code (None if none): e.g. a stage's ``face``.

        Parameters
        ----------
        code : str
            E.g. ``"stage.esd1"``.

        Returns
        -------
        dict or None
        """
        for _, _, _, _, data in self.events:
            if data and data.get("code") == code:
                return data
        return None

    def release_margin(self) -> float | None:
        """Time from the release complete to the flange's first crossing of a face, s (None without a
        release, or when the flange reaches no face in the run nor in the look-ahead after it).

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None or self.limit_at is None:
            return None
        return self.limit_at - t_rel

    def failures(self) -> tuple[str, ...]:
        """How the run failed the safety chain: codes of :data:`FAILURES` (empty: it held).

        An overstretch is ``overstretch_before_isolation`` when it came before the ERS valves' confirmation (or
        with none), product still live in the arm; ``missed_alarm`` is a face reached within the run before the
        release completed (the attached arm overstretched, or would have).

        Returns
        -------
        tuple of str
        """
        out = []
        confirmed = self.first_code("interlock.valves_confirmed")
        if self.overstretched_at is not None:
            live = confirmed is None or self.overstretched_at < confirmed
            out.append("overstretch_before_isolation" if live else "overstretch")
        opened = self.first_code("command.coupler_opening")
        if opened is not None and (confirmed is None or opened < confirmed):
            out.append("opened_on_live_product")
        done, limit = self.first_code("command.release_complete"), self.limit_at
        if limit is not None and limit <= float(self.signals["t"][-1]) and (done is None or done > limit) \
                and (done is not None or self._attached_at(limit)):
            # found (review): a face the flange passed after a controlled disconnection failed the run
            out.append("missed_alarm")
        return tuple(out)

    def _attached_at(self, t: float) -> bool:
        """Whether the coupler was on the flange at time ``t`` (the last cycle at or before it)."""
        s = self.signals
        k = int(np.searchsorted(s["t"], t, side="right")) - 1
        return bool(k >= 0 and s["connected"][k] > 0)

    def verdict(self) -> str:
        """``"pass"``, or ``"FAILED: "`` and what failed, in words (:data:`FAILURES`), with its times.

        Returns
        -------
        str
        """
        fails = self.failures()
        if not fails:
            return "pass"
        words = []
        for code in fails:
            text = FAILURES[code]
            if code.startswith("overstretch"):
                confirmed = self.first_code("interlock.valves_confirmed")
                text += f" at {self.overstretched_at:.2f} s" + (
                    "" if confirmed is None or code == "overstretch"
                    else f", {confirmed - self.overstretched_at:.2f} s before the confirmation")
            words.append(text)
        return "FAILED: " + "; ".join(words)

    def cleared_at(self) -> float | None:
        """First time after the release the coupler is :data:`MANIFOLD_CLEARANCE` from the flange, s.

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None:
            return None
        s = self.signals
        ok = np.flatnonzero((s["t"] >= t_rel) & (s["distance"] >= MANIFOLD_CLEARANCE))
        return float(s["t"][ok[0]]) if ok.size else None

    def retracted_at(self) -> float | None:
        """First time after the release the coupler is :data:`~loadarm.design.check.MANIFOLD_CLEARANCE` from where it was
        released, s: the arm itself moved clear (the flange may also have left on its own, :meth:`cleared_at`).

        Returns
        -------
        float or None
        """
        t_rel = self.first_code("command.release_complete")
        if t_rel is None:
            return None
        s = self.signals
        k0 = int(np.searchsorted(s["t"], t_rel))
        p = np.stack([s["x"][k0:], s["y"][k0:], s["z"][k0:]], axis=1)
        ok = np.flatnonzero(np.linalg.norm(p - p[0], axis=1) >= MANIFOLD_CLEARANCE)
        return float(s["t"][k0 + ok[0]]) if ok.size else None

    def _figure(self):

        return run_timeline_figure(self)

    def _values(self) -> dict:
        """Headline numbers, JSON-friendly."""
        s = self.signals
        modes = [MODES[int(i)] for i in s["mode"]]
        seq = [modes[0]] + [m for a, m in zip(modes, modes[1:]) if m != a]
        return {
            "scenario": self.name,
            "verdict": self.verdict(),
            "failures": list(self.failures()),
            "duration_s": float(s["t"][-1]),
            "mode_sequence": seq,
            "final_mode": modes[-1],
            "alarm1_s": self.first_code("stage.esd1"),
            "alarm1_measured_s": self.measured_alarm1(),
            "alarm1_measured_first_s": self.first_code("info.measured_esd1"),
            "held_calls": self.held_calls(),
            "departed_s": self.first_code("info.prediction_departed"),
            "alarm1_rule": next((d.get("rule", "") for _, _, _, _, d in self.events
                                 if d and d.get("code") == "stage.esd1"), ""),
            "alarm2_s": self.first_code("stage.second"),
            "release_s": self.first_code("stage.release"),
            "release_complete_s": self.first_code("command.release_complete"),
            "overstretched_s": self.overstretched_at,
            "limit_s": self.limit_at,
            "limit_face": self.limit_face,
            "release_margin_s": self.release_margin(),
            "valves_confirmed_s": self.first_code("interlock.valves_confirmed"),
            "coupler_opening_s": self.first_code("command.coupler_opening"),
            "cleared_s": self.cleared_at(),
            "retracted_s": self.retracted_at(),
            "connected_s": float(np.sum(np.diff(s["t"]) * (s["connected"][:-1] > 0))),
            "max_beta_deg": float(np.degrees(np.nanmax(s["beta"]))),
            "max_abs_slew_deg": float(np.degrees(np.nanmax(np.abs(s["phi"])))),
            "events": len(self.events),
            "cycle_us_median": float(np.median(self.cycle_us)) if self.cycle_us.size else None,
            "cycle_us_p99": float(np.percentile(self.cycle_us, 99)) if self.cycle_us.size else None,
        }
