"""Alarm settings designed from the moored ship (issue 12, item 6): where to set the alarms on this berth, for
this ship.

The method stacks, along each direction towards a face of the attached arm's envelope (:mod:`loadarm.arm.faces`),
what the industry stacks (Lanquetin's combined method; Choi et al. 2018 stack the mooring analysis's drift per
stage):

1. **Flanging area**: every flange position at which the arm may connect (the datasheet's box: berthing-line
   distances C to D, heights H to I above the low tide, :func:`loadarm.arm.envelope.berth_box`; along the berth
   the berth file's ``manifold_tolerance`` either side of the arm's centre line), corner by corner, and the
   installation's nominal flange. Corners outside the attached envelope are reported and left out.
2. **Drift allowance** (intact moorings): the flange's excursion towards the face in the design environment
   (``[environment]`` of the berth file), from the calm equilibrium, that is exceeded with a stated probability
   per hour (:attr:`DesignSettings.exceedance_per_hour`, 1e-4), by statistics: the 3-hour maxima of at least 20
   seeds (:func:`loadarm.ship.motion.simulate`: slow drift, gusts, first-order waves, static offset, the lines'
   brakes) fitted by a Gumbel distribution (maximum likelihood), the level whose per-hour exceedance is the
   stated one, and its confidence bounds by a parametric bootstrap (:func:`extreme_level`). The allowance is
   the upper bound (95 % one-sided): the ESD-1 threshold at its edge is reached intact, in the design weather,
   less often than the stated probability with 95 % confidence. A pre-alarm band starts where the excursion is
   exceeded once in 100 hours. No alarm may fire inside the allowance.
3. **Break-out** (every line parted at once, the ship from rest at the edge of the allowance): the distance
   ``s(tau)`` it drifts in time ``tau`` under the same loads, the envelope over the seeds. The first alarm
   (ESD-1) is set at the allowance's edge; the release (ERS-2) where the ship is ``ers_valve_time +
   ers_valve_timeout`` later (the coupler never opens before the ERS valves are confirmed closed, which may be
   as late as their timeout allows); the second alarm half-way in time. The design holds when the ship is still
   inside the face ``erc_release_time + margin`` after the release, and ``esd_lead`` (``max(esd_time,
   ers_valve_time + ers_valve_timeout) + erc_release_time + margin``) after ESD-1.

Thresholds are the arm's own coordinates: beta (off the berth), slew (along it, the worse side). Vertical faces
(alpha) have no angle alarms in the installation: their allowance and the tide over the sequence
(``[design_drift] vertical_speed``) are checked and reported. Each threshold is the largest over the flanging
area's corners of the angle at the stage's distance (the alarm must not fire early at any corner); each corner
is then checked with those thresholds. A face the arm cannot protect is refused with its shortfall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.stats import gumbel_r

from loadarm.arm.envelope import berth_box, flanging_x_far
from loadarm.arm.faces import (
    FACE_LABELS,
    FACES,
    breakout_distance,
    face_margins,
    first_face,
    past_a_face_at,
    ray_crossing,
)
from loadarm.arm.sequence import esd_lead, valve_worst_time
from loadarm.arm.slew import inverse3d
from loadarm.design.plots import alarm_design_figure
from loadarm.errors import ConfigError
from loadarm.results import Metric, Result
from loadarm.ship.motion import flange_kinematics, simulate

__all__ = ["FaceDesign", "AlarmDesign", "MooringAnalysis", "design_from_analysis", "flanging_corners",
           "mooring_analysis", "recommended_settings", "StageFit", "Verdict", "alarm_verdict", "STAGES", "design_alarms", "DesignSettings", "breakout_curve", "extreme_level",
           "ExtremeLevel"]


@dataclass(frozen=True)
class DesignSettings:
    """How the mooring analysis behind the design is run.

    Attributes
    ----------
    seeds : int
        Realisations of the design sea state: their intact 3-hour maxima are fitted (at least
        :data:`MIN_FIT_SEEDS` for a fit; fewer take the largest), the break-out's envelope is used.
    intact_duration : float
        Duration of each intact realisation, s (3 hours: the usual short-term sea state).
    breakout_window : float
        How long the break-out is followed, s.
    part_time : float
        When the lines part in the break-out realisations, s (after the start-up transient).
    exceedance_per_hour : float
        Probability per hour, in the design weather with the lines intact, that the flange passes ESD-1's
        allowance (a false ESD-1).
    pre_alarm_per_hour : float
        The same for the start of the pre-alarm band.
    confidence : float
        One-sided confidence of the allowance (its bootstrap upper bound).
    """

    seeds: int = 20
    intact_duration: float = 10800.0
    breakout_window: float = 180.0
    part_time: float = 120.0
    exceedance_per_hour: float = 1e-4
    pre_alarm_per_hour: float = 1e-2
    confidence: float = 0.95


#: Fewest 3-hour maxima fitted; with fewer the allowance is the largest excursion (and says so).
MIN_FIT_SEEDS = 20
#: Monte Carlo samples of the Gumbel fit's pivot (the upper bound's coverage measured 92.5 % of 200 for a 95 %
#: bound at 20 maxima, within the binomial spread; fixed seed: the same design every time).
BOOTSTRAP = 1000


@dataclass(frozen=True)
class ExtremeLevel:
    """The excursion exceeded with a given probability per hour, from 3-hour maxima.

    Attributes
    ----------
    level : float
        Point estimate, m.
    lower, upper : float
        Confidence bounds (two-sided interval of ``2 confidence - 1``), m.
    pre_alarm : float
        The level of the pre-alarm's probability (point estimate), m.
    sample_max : float
        The largest of the maxima, m.
    location, scale : float
        The Gumbel fit of the maxima, m.
    n : int
        Maxima fitted (0: too few, the level is the largest).
    """

    level: float
    lower: float
    upper: float
    pre_alarm: float
    sample_max: float
    location: float
    scale: float
    n: int


def _gumbel_z(p_nonexceed: float) -> float:
    """The standard Gumbel's quantile: ``-ln(-ln p)``."""
    return -math.log(-math.log(p_nonexceed))


@lru_cache(maxsize=8)
def _standard_fits(n: int, resamples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood fits of ``resamples`` samples of ``n`` standard Gumbel variates: the pivot's
    distribution (for a location-scale family it does not depend on the true parameters), once per size."""
    rng = np.random.default_rng(seed)
    fits = np.array([gumbel_r.fit(gumbel_r.rvs(size=n, random_state=rng)) for _ in range(resamples)])
    fits.setflags(write=False)
    return fits[:, 0], fits[:, 1]


def extreme_level(maxima, hours: float, per_hour: float, pre_per_hour: float, confidence: float, *,
                  resamples: int = BOOTSTRAP, seed: int = 0) -> ExtremeLevel:
    """The level exceeded with probability ``per_hour`` per hour, from maxima over records of ``hours`` each:
    a Gumbel fit by maximum likelihood (SciPy's ``gumbel_r.fit``); hours taken as independent, so the record's
    maximum stays below ``x`` with ``(1 - per_hour) ** hours``. The bounds from the fit's pivot ``(x_hat - x) /
    scale_hat``, whose distribution for a location-scale family is that of standard Gumbel samples of the same
    size, fitted (:func:`_standard_fits`: exact up to the Monte Carlo; found, the percentile bootstrap covered
    the true level 80 times in 100 for a stated 95, the maximum-likelihood scale of 20 maxima being biased
    low).

    Parameters
    ----------
    maxima : array_like
        One maximum per record, m.
    hours : float
        Record length, h.
    per_hour, pre_per_hour : float
        Exceedance probabilities per hour: the level's and the pre-alarm's.
    confidence : float
        One-sided confidence of ``upper`` (and of ``lower``).
    resamples : int
    seed : int

    Returns
    -------
    ExtremeLevel
    """
    x = np.asarray(maxima, dtype=float)
    top = float(np.max(x))
    if x.size < MIN_FIT_SEEDS or float(np.std(x)) < 1e-9:
        return ExtremeLevel(top, top, top, top, top, top, 0.0, 0)
    z = _gumbel_z((1.0 - per_hour) ** hours)
    loc, scale = gumbel_r.fit(x)
    level = loc + scale * z
    l_b, s_b = _standard_fits(int(x.size), int(resamples), int(seed))
    pivot = (l_b + s_b * z - z) / s_b
    t_lo, t_hi = np.quantile(pivot, [1.0 - confidence, confidence])
    return ExtremeLevel(float(level), float(level - scale * t_hi), float(level - scale * t_lo),
                        float(loc + scale * _gumbel_z((1.0 - pre_per_hour) ** hours)), top, float(loc),
                        float(scale), int(x.size))


@dataclass(frozen=True)
class FaceDesign:
    """The design along one direction (distances from the flanging area's worst corner, m)."""

    direction: str
    vector: tuple[float, float, float]
    face: str
    available_m: float
    allowance_m: float
    intact_speed_ms: float
    second_m: float
    release_m: float
    free_m: float
    lead_m: float
    breakout_speed_at_release_ms: float
    coordinate: str
    first: float | None
    second: float | None
    release: float | None
    limit: float | None
    ok: bool
    shortfall_m: float
    corner: tuple[float, float, float]
    case: str = ""
    position_shortfall_m: float = 0.0
    floor: float | None = None
    extreme: ExtremeLevel | None = None
    pre_alarm: float | None = None

    @property
    def esd_m(self) -> float:
        """Where ESD-1 fires in the stacking: at the drift allowance's edge, m."""
        return self.allowance_m

    @property
    def short_case(self) -> str:
        """The design case in a word (for tables): break-out, fenders or tide."""
        return self.case.split(":")[0].split(" ")[0] if self.case.startswith("break") else \
            ("tide" if self.case.startswith("tide") else "fenders")

    def to_dict(self) -> dict:
        """Row as JSON (angles in degrees, keys with units).

        Returns
        -------
        dict
        """
        deg = (lambda v: None if v is None else math.degrees(v))
        return {"direction": self.direction, "face": self.face, "design_case": self.case,
                "worst_corner_m": list(self.corner),
                "available_m": self.available_m, "drift_allowance_m": self.allowance_m,
                "intact_speed_max_ms": self.intact_speed_ms, "esd1_at_m": self.esd_m,
                "second_at_m": self.second_m, "release_at_m": self.release_m, "coupler_free_at_m": self.free_m,
                "esd_lead_reach_m": self.lead_m, "breakout_speed_at_release_ms": self.breakout_speed_at_release_ms,
                "coordinate": self.coordinate, "first_deg": deg(self.first), "second_deg": deg(self.second),
                "release_deg": deg(self.release), "limit_deg": deg(self.limit), "ok": self.ok,
                "shortfall_m": self.shortfall_m, "position_alarms_shortfall_m": self.position_shortfall_m,
                "pre_alarm_deg": deg(self.pre_alarm),
                "allowance_statistics": None if self.extreme is None else {
                    "maxima_fitted": self.extreme.n, "level_m": self.extreme.level, "lower_m": self.extreme.lower,
                    "upper_m": self.extreme.upper, "pre_alarm_level_m": self.extreme.pre_alarm,
                    "largest_maximum_m": self.extreme.sample_max, "gumbel_location_m": self.extreme.location,
                    "gumbel_scale_m": self.extreme.scale}}


#: The stages of the position alarms, in order: their name in the tables, the threshold's key.
STAGES = (("ESD-1", "first"), ("second alarm", "second"), ("ERS-2 release", "release"))


@dataclass(frozen=True)
class StageFit:
    """One stage of one face under one set of thresholds (the installation's, or the recommended), judged against
    both design cases over the flanging area's corners (the least margin of any corner).

    Attributes
    ----------
    direction, face : str
        The drift direction and the face it nears.
    stage : str
        ``ESD-1``, ``second alarm`` or ``ERS-2 release`` (:data:`STAGES`).
    settings : str
        ``configured`` or ``recommended``.
    angle_deg : float
        The threshold, deg (beta, or the slew).
    fires_at_m : float or None
        Where it fires at the corner of the least margin, m from that corner towards the face (None: not before
        the face).
    intact_margin_m : float
        How far beyond the intact drift allowance it fires, m (negative: it fires in the design weather with the
        lines intact more often than the stated probability: false alarms).
    breakout_margin_m : float or None
        How far short of the face the break-out is when this stage's part of the sequence is done, m (ESD-1: its
        whole lead; the release: the coupler free with the margin); negative: too late. None for the second alarm
        (no deadline of its own).
    """

    direction: str
    face: str
    stage: str
    settings: str
    angle_deg: float
    fires_at_m: float | None
    intact_margin_m: float
    breakout_margin_m: float | None

    @property
    def margin_m(self) -> float:
        """The smaller of the two margins, m."""
        return min(self.intact_margin_m, math.inf if self.breakout_margin_m is None else self.breakout_margin_m)

    @property
    def governs(self) -> str:
        """The design case that sets the margin: ``intact drift`` or ``break-out``."""
        return "break-out" if self.breakout_margin_m is not None and self.breakout_margin_m < self.intact_margin_m \
            else "intact drift"

    @property
    def ok(self) -> bool:
        """Both margins at least zero."""
        return self.margin_m >= 0

    def to_dict(self) -> dict:
        """As JSON.

        Returns
        -------
        dict
        """
        return {"direction": self.direction, "face": self.face, "stage": self.stage, "settings": self.settings,
                "angle_deg": self.angle_deg, "fires_at_m": self.fires_at_m, "intact_margin_m": self.intact_margin_m,
                "breakout_margin_m": self.breakout_margin_m, "margin_m": self.margin_m, "governs": self.governs,
                "ok": self.ok}


@dataclass(frozen=True)
class Verdict:
    """The one verdict on an installation's alarms at a berth (:func:`alarm_verdict`).

    Attributes
    ----------
    status : str
        ``pass``, ``conditional`` (holds only by the design-drift floor: the configured angles alone are late, or
        fire in the intact drift) or ``refused``.
    reason : str
        Why, in one paragraph.
    """

    status: str
    reason: str


def alarm_verdict(check, design: "AlarmDesign | None") -> Verdict:
    """One verdict from the design check (the installation's design drift against its faces) and, at a berth, the
    alarm design (the mooring analysis) with the configured thresholds judged stage by stage.

    Parameters
    ----------
    check : loadarm.design.check.CheckResult
    design : AlarmDesign or None
        None without a berth.

    Returns
    -------
    Verdict
    """
    problems = list(check.problems) + (list(design.problems) if design is not None else [])
    if problems:
        return Verdict("refused", "; ".join(problems))
    late = [r for r in check.rows if r.angle_alarm is not None and r.angle_alarm > r.alarm_at]
    bad = [f for f in (design.stages if design is not None else ()) if f.settings == "configured" and not f.ok]
    if not late and not bad:
        return Verdict("pass", "the configured angles fire in time in every direction, and never inside the "
                               "intact drift allowance" if design is not None else
                               "the configured angles fire before the design drift's latest point in every direction")
    why = [f"{r.direction}: the configured first alarm fires {r.angle_alarm:.2f} m out, past the {r.alarm_at:.2f} m "
           "where the design drift needs ESD-1 at the latest" for r in late]
    why += [f"{f.direction}, {f.stage} at {f.angle_deg:.1f} deg: {f.governs} margin {f.margin_m:+.2f} m" for f in bad]
    rec_bad = sorted({f"{f.direction} ({f.stage})" for f in (design.stages if design is not None else ())
                      if f.settings == "recommended" and not f.ok})
    advice = "" if design is None else (
        ". Adopt the recommended settings, which hold on their own" if not rec_bad else
        ". The recommended angles alone are short too at " + ", ".join(rec_bad) + " (one angle cannot serve the "
        "whole flanging area there): adopt them with the recommended design drift, whose floor covers the rest")
    return Verdict("conditional", "holds only by the design-drift floor of the connected-mode monitor (it fires "
                                  "ESD-1 by the time to the face whatever the angles); the configured angles alone "
                                  "do not: " + "; ".join(why) + advice)


@dataclass(frozen=True)
class AlarmDesign(Result):
    """The alarm design of an arm at a berth (``loadarm alarms``)."""

    rows: tuple[FaceDesign, ...]
    recommended: dict
    sequence: dict
    natural_periods: dict
    mean_offset: tuple[float, float, float]
    breakout_t: np.ndarray
    breakout_s: np.ndarray
    flanging_area: tuple[float, float, float, float]
    problems: tuple[str, ...]
    warnings: tuple[str, ...]
    nominal_flange: tuple[float, float]
    arm: object = field(repr=False)
    joint_limits: object = field(repr=False)
    exceedance_per_hour: float = 1e-4
    stages: tuple[StageFit, ...] = ()

    METRICS = (
        Metric("ok", "design holds"),
        Metric("first_beta_deg", "ESD-1 (first alarm) beta", "deg", ".1f"),
        Metric("second_beta_deg", "second alarm beta", "deg", ".1f"),
        Metric("release_beta_deg", "ERS-2 (release) beta", "deg", ".1f"),
        Metric("first_slew_deg", "ESD-1 slew", "deg", ".1f"),
        Metric("second_slew_deg", "second alarm slew", "deg", ".1f"),
        Metric("release_slew_deg", "ERS-2 slew", "deg", ".1f"),
        Metric("pre_alarm_beta_deg", "pre-alarm band from beta", "deg", ".1f"),
        Metric("pre_alarm_slew_deg", "pre-alarm band from slew", "deg", ".1f"),
        Metric("drift_allowance_off_berth_m", "drift allowance off the berth (intact)", "m", ".2f"),
        Metric("allowance_interval_m", "its 90 % confidence interval", "m", ".2f"),
        Metric("esd1_exceedance_per_hour", "ESD-1 passed intact in design weather, per hour", "", ".0e"),
        Metric("maxima_fitted", "3-hour maxima fitted (Gumbel)", "", "d"),
        Metric("breakout_speed_at_release_ms", "break-out speed at the release", "m/s", ".3f"),
        Metric("esd_lead_s", "ESD-1 lead (sequence)", "s", ".1f"),
    )

    @property
    def ok(self) -> bool:
        """No face refused."""
        return not self.problems

    def _values(self) -> dict:
        off = self.rows[0]
        ext = off.extreme
        stats = {} if ext is None else {
            "allowance_interval_m": [ext.lower, ext.upper], "maxima_fitted": ext.n,
            "esd1_exceedance_per_hour": self.exceedance_per_hour if ext.n else None}
        return {"ok": self.ok, **self.recommended, **stats, "drift_allowance_off_berth_m": off.allowance_m,
                "breakout_speed_at_release_ms": off.breakout_speed_at_release_ms,
                "esd_lead_s": self.sequence["esd_lead_s"]}

    def to_dict(self) -> dict:
        """Everything the JSON output carries.

        Returns
        -------
        dict
        """
        return {"ok": self.ok, "recommended": dict(self.recommended), "sequence": dict(self.sequence),
                "natural_periods_s": {k.removesuffix("_s"): v for k, v in self.natural_periods.items()},
                "mean_offset_m": list(self.mean_offset),
                "design_drift": {"drift_allowance_off_berth_m": self.rows[0].allowance_m,
                                 "intact_speed_max_ms": max(r.intact_speed_ms for r in self.rows),
                                 "breakout_speed_at_release_ms": self.rows[0].breakout_speed_at_release_ms,
                                 "breakout_distance_in_esd_lead_m": self.rows[0].lead_m - self.rows[0].allowance_m},
                "faces": [r.to_dict() for r in self.rows], "stages": [f.to_dict() for f in self.stages],
                "alarms_toml": self.toml(), "problems": list(self.problems),
                "warnings": list(self.warnings)}

    def toml(self) -> str:
        """The recommended settings as ``[alarms]`` and ``[slew]`` blocks to paste into the installation.

        Returns
        -------
        str
        """
        r = self.recommended
        lines = ["[alarms]"]
        for k in ("first", "second", "release"):
            v = r.get(f"{k}_beta_deg")
            if v is not None:
                lines.append(f"{k}_deg = {v:.1f}")
        lines.append("")
        lines.append("[slew]")
        for k in ("first", "second", "release"):
            v = r.get(f"{k}_slew_deg")
            if v is not None:
                lines.append(f"{k}_deg = {v:.1f}")
        lines += ["", "[design_drift]", f"speed = {r['design_drift_speed_ms']:.2f}",
                  f"acceleration = {r['design_drift_acceleration_ms2']:.3f}"]
        return "\n".join(lines) + "\n"

    def _figure(self):

        return alarm_design_figure(self)


def breakout_curve(flange: np.ndarray, t: np.ndarray, part_time: float, d: np.ndarray, window: float):
    """Distance drifted towards ``d`` since the lines parted, as a non-decreasing envelope.

    Parameters
    ----------
    flange : ndarray (seeds, n, 3)
        Flange positions of the break-out realisations.
    t : ndarray (n,)
    part_time, window : float
    d : ndarray (3,)
        Unit direction.

    Returns
    -------
    tau, s : ndarray
        Time since the parting (s) and the envelope over the seeds of the distance (m, from 0).
    """
    k0 = int(np.searchsorted(t, part_time))
    k1 = min(t.size, k0 + int(round(window / (t[1] - t[0]))) + 1)
    proj = (flange[:, k0:k1] - flange[:, k0:k0 + 1]) @ d
    s = np.maximum.accumulate(np.maximum(np.max(proj, axis=0), 0.0))
    return t[k0:k1] - t[k0], s


#: Start of the break-out fit, s after the lines part.
FIT_FROM = 2.0


def design_drift_fit(curves, horizon: float) -> tuple[float, float]:
    """The owner's design drift (speed, break-out acceleration) that covers the break-out curves: the distance
    of :func:`loadarm.arm.faces.breakout_distance` is at least each curve's over ``[0, horizon]``. The acceleration
    covers the start (``max 2 s / t^2`` from :data:`FIT_FROM` s: the ship's slow motion when the lines part makes
    the first second linear, not quadratic), then the speed is the least that covers the rest within 1 cm
    (bisection), both rounded up (to 0.001 m/s^2, 0.01 m/s).

    Parameters
    ----------
    curves : list of (tau, s)
    horizon : float
        s.

    Returns
    -------
    speed, acceleration : float
        m/s, m/s^2.
    """
    acc = 1e-4
    for tau, s in curves:
        k = (tau >= FIT_FROM) & (tau <= horizon)
        if np.any(k):
            acc = max(acc, float(np.max(2 * s[k] / tau[k] ** 2)))
    acc = math.ceil(acc * 1000 - 1e-9) / 1000
    lo, hi = 0.0, 5.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if all(np.all(breakout_distance(tau[k], mid, acc) >= s[k] - 0.01)
               for tau, s in curves for k in [(tau >= FIT_FROM) & (tau <= horizon)]):
            hi = mid
        else:
            lo = mid
    return max(math.ceil(hi * 100 - 1e-9) / 100, 0.01), acc


def _tau_at(tau: np.ndarray, s: np.ndarray, dist: float) -> float:
    """First time the envelope reaches ``dist`` (inf if never within the window)."""
    i = np.flatnonzero(s >= dist)
    if i.size == 0:
        return math.inf
    j = int(i[0])
    if j == 0:
        return 0.0
    return float(np.interp(dist, s[j - 1:j + 1], tau[j - 1:j + 1]))


def _s_at(tau: np.ndarray, s: np.ndarray, time: float) -> float:
    if not math.isfinite(time):
        return math.inf
    if time > tau[-1]:
        # past the window: extrapolate at the last speed (the drift keeps going)
        v = (s[-1] - s[-11]) / (tau[-1] - tau[-11]) if s.size > 11 else 0.0
        return float(s[-1] + v * (time - tau[-1]))
    return float(np.interp(time, tau, s))


#: Directions towards the faces: name, unit vector (installation frame), the arm coordinate whose alarms guard
#: it, and how the ship gets there ("breakout": the lines part with the design environment turned towards it;
#: "fenders": the fenders stop it, intact motion only; "vertical": tide and loading at the design vertical speed).
_DIRECTIONS = (
    ("off the berth (+x)", (1.0, 0.0, 0.0), "beta", "breakout"),
    ("along the berth (+y)", (0.0, 1.0, 0.0), "slew", "breakout"),
    ("along the berth (-y)", (0.0, -1.0, 0.0), "slew", "breakout"),
    ("towards the jetty (-x)", (-1.0, 0.0, 0.0), None, "fenders"),
    ("up (+z)", (0.0, 0.0, 1.0), None, "vertical"),
    ("down (-z)", (0.0, 0.0, -1.0), None, "vertical"),
)


def _towards(env, vec):
    """The environment with wind, current and waves all turned towards a horizontal direction."""
    ang = math.degrees(math.atan2(vec[1], vec[0]))
    return env.model_copy(update={"wind_direction_deg": ang, "current_direction_deg": ang,
                                  "wave_direction_deg": ang})


def _round_thresholds(first: float, second: float, release: float, floor: float) -> tuple[float, float, float]:
    """To 0.1 deg (radians in and out): ESD-1 and the release rounded down (earlier), unless that puts ESD-1
    inside the drift allowance (then up); the second alarm to the nearest."""
    def down(v):
        return math.radians(math.floor(10 * math.degrees(v) + 1e-9) / 10)

    def up(v):
        return math.radians(math.ceil(10 * math.degrees(v) - 1e-9) / 10)

    f = down(first)
    if f < floor:
        f = up(floor)
    r = max(down(release), f)
    return f, min(max(math.radians(round(10 * math.degrees(second)) / 10), f), r), r


def design_alarms(model, ship, env, *, settings: DesignSettings = DesignSettings(), progress=None) -> AlarmDesign:
    """Design the alarm thresholds of an installation at a berth.

    Parameters
    ----------
    model : ArmModel
        The compiled installation (arm, limits, datasheet, sequence, design drift).
    ship : ShipModel
        The berth's ship, compiled.
    env : Environment
        The design environment (the berth file's ``[environment]``); for each face the lines part with its wind,
        current and waves turned towards that face (the worst direction for it).
    settings : DesignSettings
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    AlarmDesign

    Raises
    ------
    ConfigError
        No corner of the flanging area lies inside the attached envelope.
    """

    fx, fz = model.approach.flange
    corners, warnings = flanging_corners(model, ship, (fx, 0.0, fz))        # refused before the analysis
    analysis = mooring_analysis((ship,), env, settings, progress)[0]
    return design_from_analysis(model, analysis, settings, (fx, 0.0, fz), corners, warnings)


@dataclass(frozen=True)
class MooringAnalysis:
    """The mooring analysis at one flange of the ship: what :func:`design_from_analysis` stacks.

    Attributes
    ----------
    intact : dict
        Per environment (``berth`` and each break-out face's name): a list of (flange from the calm equilibrium
        (n, 3) m, flange velocity (n, 3) m/s), one per seed.
    broken : dict
        Per break-out face's name: a list of flange tracks (n, 3), one per seed (every line parted).
    breakout_t : ndarray
        The break-out runs' times, s.
    mean_offset : tuple of float
        The flange's static offset under the design environment's mean loads, from calm, m.
    natural_periods : dict
        The moored ship's natural periods.
    """

    intact: dict
    broken: dict
    breakout_t: np.ndarray
    mean_offset: tuple
    natural_periods: dict


def design_from_analysis(model, analysis: MooringAnalysis, settings: DesignSettings, flange, corners,
                         warnings, judged: tuple = ()) -> AlarmDesign:
    """Stack the alarm stages of one arm on the mooring analysis at its flange (the second half of
    :func:`design_alarms`; a bank's arms share one analysis, each at its own flange).

    Parameters
    ----------
    model : ArmModel
    analysis : MooringAnalysis
    settings : DesignSettings
    flange : tuple of float
        The nominal flange in the arm's frame (x, y, z), m.
    corners, warnings : list
        :func:`flanging_corners` of the arm at that flange.
    judged : tuple of (str, dict)
        Other settings to judge beside the installation's and the recommended (a label and settings as
        :attr:`AlarmDesign.recommended`, degrees): their stage fits carry the label.

    Returns
    -------
    AlarmDesign
    """
    seq = model.sequence
    lead1 = esd_lead(seq)
    t_rel = valve_worst_time(seq)
    t_free = t_rel + seq.erc_release_time + seq.margin
    box, x_conn_far = berth_box(model.datasheet), flanging_x_far(model.datasheet)
    fx, _, fz = flange
    intact, broken, bt, mean_offset = analysis.intact, analysis.broken, analysis.breakout_t, analysis.mean_offset
    warnings = list(warnings)
    st = _Stack(model, corners, lead1, t_rel, t_free)
    rows, problems, curves, contexts = [], [], [], []
    tau_main = s_main = None
    for name, vec, kind, how in _DIRECTIONS:
        d = np.array(vec)
        runs = intact["berth"] + (intact[name] if how == "breakout" else [])
        ext = _allowance(intact, name, how, d, settings)
        allow = max(0.0, ext.upper)
        v_int = max(0.0, max(float(np.max(v @ d)) for _, v in runs))
        tau, s, case = _drift(model, how, broken.get(name), bt, d, settings)
        if tau_main is None:
            tau_main, s_main = tau, s
        rows.append(st.face_row(name, vec, kind, d, tau, s, allow, v_int, case, problems, warnings, ext))
        if how == "breakout":
            curves.append((tau, s))
        if kind is not None:
            contexts.append((rows[-1], kind, d, tau, s, allow))
    rec = recommended_settings(rows)
    sets = (("recommended", rec),) + tuple(judged)
    stages = tuple(fit for row, kind, d, tau, s, allow in contexts
                   for label, thr in (("configured", _configured(model, kind)),) + tuple(
                       (label, tuple(math.radians(given[f"{k}_{kind}_deg"]) for _, k in STAGES))
                       for label, given in sets)
                   for fit in st.stage_fits(row, kind, d, tau, s, allow, label, thr))
    speed, accel = design_drift_fit(curves, lead1 + t_free)
    rec["design_drift_speed_ms"] = speed
    rec["design_drift_acceleration_ms2"] = accel
    sequence = {"esd_time_s": seq.esd_time, "ers_valve_time_s": seq.ers_valve_time,
                "ers_valve_timeout_s": seq.ers_valve_timeout, "valves_worst_s": t_rel,
                "erc_release_time_s": seq.erc_release_time, "margin_s": seq.margin, "esd_lead_s": lead1}
    return AlarmDesign(tuple(rows), rec, sequence, analysis.natural_periods, mean_offset, tau_main, s_main,
                       (box.x_near, x_conn_far, box.y_low, box.y_high), tuple(problems), tuple(warnings), (fx, fz),
                       model.arm, model.joint_limits, settings.exceedance_per_hour, stages)


def flanging_corners(model, ship, flange) -> tuple[list, list]:
    """The flanging area's corners (and the nominal flange) inside the attached envelope, and a warning for each
    outside it; refuses when none is inside. Along the berth the area is the berth's manifold tolerance either
    side of the flange.

    Parameters
    ----------
    model : ArmModel
    ship : ShipModel
        Its ``manifold_tolerance``.
    flange : tuple of float
        The nominal flange in the arm's frame (x, y, z), m.

    Returns
    -------
    corners : list of ndarray
    warnings : list of str

    Raises
    ------
    ConfigError
        No corner nor the nominal flange lies inside the attached envelope.
    """
    box, x_conn_far = berth_box(model.datasheet), flanging_x_far(model.datasheet)
    fx, fy, fz = flange
    tol = ship.manifold_tolerance
    candidates = [np.array([x, fy + y, z]) for x in (box.x_near, x_conn_far) for z in (box.y_low, box.y_high)
                  for y in sorted({-tol, tol})]
    candidates.append(np.array([fx, fy, fz]))
    corners, warnings = [], []
    for c in candidates:
        mg = face_margins(model, c[0], c[1], c[2])
        if np.min(mg) < 0:
            f = FACES[int(np.argmin(mg))]
            warnings.append(f"the flanging area's corner x = {c[0]:.2f}, y = {c[1]:.2f}, z = {c[2]:.2f} m is outside "
                            f"the attached envelope ({FACE_LABELS[f]}, by {abs(math.degrees(float(np.min(mg)))):.1f} "
                            "deg): the arm cannot connect there; the design uses the other corners")
        else:
            corners.append(c)
    if not corners:
        raise ConfigError("no corner of the flanging area (datasheet C-D, H-I, the berth's manifold tolerance) nor "
                          "the nominal flange lies inside the attached envelope: " + "; ".join(warnings))
    return corners, warnings


def mooring_analysis(ships, env, settings: DesignSettings, progress=None) -> list[MooringAnalysis]:
    """The mooring analysis: intact (the berth's environment, and turned towards each horizontal face) and
    break-out (every line parted, the environment turned towards the face), several seeds each; one simulation
    per run, its flange at each ship's manifold (the same ship with its manifold moved: a bank's flanges).

    Parameters
    ----------
    ships : sequence of ShipModel
        The first is simulated; the others are it with another ``manifold`` (their flanges follow its motion).
    env : Environment
    settings : DesignSettings
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    list of MooringAnalysis
        One per ship.
    """
    envs = {"berth": env}
    for name, vec, _, how in _DIRECTIONS:
        if how == "breakout":
            envs[name] = _towards(env, vec)
    jobs = [(key, e, broken) for key, e in envs.items() for broken in ((False, True) if key != "berth" else (False,))]
    ship = ships[0]
    zero3, zero6 = np.zeros((1, 3)), np.zeros((1, 6))
    calm = [flange_kinematics(s, ship.eq0[None], zero3, zero6, zero6)[0] for s in ships]
    intact: list[dict] = [{k: [] for k in envs} for _ in ships]
    broken: list[dict] = [{k: [] for k in envs} for _ in ships]
    n = settings.seeds
    done, total = 0, len(jobs) * n
    mean_offset = [(0.0, 0.0, 0.0)] * len(ships)
    bt = None
    for key, e, part in jobs:
        for i in range(n):
            if part:
                # the drift without the first-order wave motion (that is inside the allowance already)
                b = simulate(ship, e, settings.part_time + settings.breakout_window, seed=2000 + i,
                             parted=ship.names, part_time=settings.part_time, waves=False)
                for j, s in enumerate(ships):
                    broken[j][key].append(_at(j, s, b)[0])
                bt = b.t
            else:
                m = simulate(ship, e, settings.intact_duration, seed=1000 + i)
                for j, s in enumerate(ships):
                    flange, velocity = _at(j, s, m)
                    intact[j][key].append((flange - calm[j][0], velocity))
                    if key == "berth" and i == 0:
                        ref = flange_kinematics(s, m.mean_pose[None], zero3, zero6, zero6)[0][0]
                        mean_offset[j] = tuple(float(v) for v in ref - calm[j][0])
            done += 1
            if progress:
                progress(done / total)
    periods = ship.natural_periods()
    return [MooringAnalysis(intact[j], broken[j], bt, mean_offset[j], periods) for j in range(len(ships))]


def _at(j: int, ship, motion):
    """A run's flange track and velocity at the ``j``-th ship's manifold (the run's own for the first: the run's
    ship)."""
    if j == 0:
        return motion.flange, motion.flange_velocity
    p, v, _ = flange_kinematics(ship, motion.pose, motion.pose_velocity, motion.wave, motion.wave_velocity)
    return p, v


def _allowance(intact, name: str, how: str, d, settings: DesignSettings) -> ExtremeLevel:
    """The drift allowance towards one face: the extreme level of the 3-hour maxima of each intact environment
    (the berth's, and turned towards the face for a break-out face), the one whose upper bound is the larger."""
    groups = [intact["berth"]] + ([intact[name]] if how == "breakout" else [])
    hours = settings.intact_duration / 3600.0
    levels = [extreme_level([float(np.max(p @ d)) for p, _ in runs], hours, settings.exceedance_per_hour,
                            settings.pre_alarm_per_hour, settings.confidence) for runs in groups]
    return max(levels, key=lambda e: e.upper)


def _drift(model, how: str, broken, bt, d, settings: DesignSettings):
    """The design drift towards one face from the allowance's edge: ``(tau, s, case)``."""
    if how == "breakout":
        tau, s = breakout_curve(np.stack(broken), bt, settings.part_time, d, settings.breakout_window)
        return tau, s, "break-out: every line parted, the design environment towards this face"
    tau = np.linspace(0.0, settings.breakout_window, 1801)
    if how == "vertical":
        return tau, model.design_drift.vertical_speed * tau, "tide and loading at the design vertical speed"
    return tau, np.zeros_like(tau), "the fenders stop the ship: intact motion only"


def _configured(model, kind: str) -> tuple[float, float, float]:
    """The installation's first, second and release thresholds of one coordinate, rad."""
    src = model.alarms if kind == "beta" else model.slew
    return src.first, src.second, src.release


def recommended_settings(rows) -> dict:
    """The recommended ``[alarms]`` and ``[slew]`` settings in degrees (None where no face guards them): per
    coordinate, the earliest stages of its faces' rows, ESD-1 never inside any row's drift allowance (rows of
    several arms of one installation give the one setting that suits them all).

    Parameters
    ----------
    rows : sequence of FaceDesign

    Returns
    -------
    dict
    """
    rec = {}
    for kind in ("beta", "slew"):
        rs = [r for r in rows if r.coordinate == kind]
        if not rs:
            rec.update({f"{stage}_{kind}_deg": None for stage in ("pre_alarm", "first", "second", "release")})
            continue
        # the slew alarms are one setting for both sides: the earlier side's stages, but the first alarm never
        # inside either side's allowance
        floor = max(r.floor for r in rs)
        first = max(min(r.first for r in rs), floor)
        release = max(min(r.release for r in rs), first)
        second = min(max(min(r.second for r in rs), first), release)
        first, second, release = _round_thresholds(first, second, release, floor)
        for stage, v in (("first", first), ("second", second), ("release", release)):
            rec[f"{stage}_{kind}_deg"] = round(math.degrees(v), 1)
        pres = [r.pre_alarm for r in rs if r.pre_alarm is not None]
        rec[f"pre_alarm_{kind}_deg"] = round(math.degrees(min(min(pres), first)), 1) if pres else None
    return rec


@dataclass(frozen=True)
class _Stack:
    """The stages stacked back from each face (Choi et al. 2018), over the corners of the flanging area."""

    model: object
    corners: list
    lead1: float
    t_rel: float
    t_free: float

    def past_face(self, pts):
        return past_a_face_at(self.model, pts[:, 0], pts[:, 1], pts[:, 2])

    def guard(self, kind: str, sign: float):
        """The guarding coordinate at points: beta, or the slew signed towards this face."""
        arm = self.model.arm

        def ang(pts):
            q = inverse3d(arm, pts[..., 0], pts[..., 1], pts[..., 2], check=False)
            return np.asarray(q.beta if kind == "beta" else sign * q.phi, dtype=float)

        return ang

    def thresholds(self, kind, vec, d, tau, s, allow, avail):
        """First, second and release thresholds of one face, the face's limit, the allowance floor, and how
        short of the face the worst corner's release comes (``short``, at corner ``worst``)."""
        seq, lim, corners = self.model.sequence, self.model.joint_limits, self.corners
        sign = float(np.sign(vec[0] + vec[1]))
        limit = lim.beta[1] if kind == "beta" else (lim.phi[1] if sign > 0 else -lim.phi[0])
        ang = self.guard(kind, sign)
        # stacked back from the face, corner by corner (Choi et al. 2018): the coupler free (plus the margin)
        # at the face, the release that long before, ESD-1 the valves' closing time before the release and at
        # least the whole ESD-1 lead before the face; the break-out from the allowance's edge, so that the
        # speed at each stage is the largest it can be there
        ideal_first, ideal_release = [], []
        for ci, c in enumerate(corners):
            t_face = _tau_at(tau, s, avail[ci] - allow)
            if not math.isfinite(t_face):
                continue                      # the drift never reaches this corner's face in the window
            t_r = max(t_face - seq.erc_release_time - seq.margin, 0.0)
            t_1 = max(min(t_r - self.t_rel, t_face - self.lead1), 0.0)
            ideal_release.append(float(ang(c + (allow + _s_at(tau, s, t_r)) * d)))
            ideal_first.append(float(ang(c + (allow + _s_at(tau, s, t_1)) * d)))
        floor = max(float(ang(c + allow * d)) for c in corners)
        if ideal_first:
            # one threshold for every corner: the earliest any corner needs, never inside any allowance
            f0, r0 = min(ideal_first), min(ideal_release)
        else:
            f0, r0 = floor, 0.5 * (floor + limit)
        first, second, release = _round_thresholds(max(f0, floor), 0.5 * (max(f0, floor) + max(r0, f0, floor)),
                                                   max(r0, f0, floor), floor)
        short, worst = self.shortfall(ang, first, release, d, tau, s, allow, avail)
        return first, second, release, limit, floor, short, worst

    def shortfall(self, ang, first, release, d, tau, s, allow, avail):
        """Each corner with these thresholds: where they fire, and whether the coupler is free in time."""
        seq = self.model.sequence
        short, worst = -math.inf, 0
        for ci, c in enumerate(self.corners):
            s1 = ray_crossing(c, d, lambda p: ang(p) >= first) or 0.0
            sr = ray_crossing(c, d, lambda p: ang(p) >= release)
            if sr is None or sr >= avail[ci]:
                if short < math.inf:
                    short, worst = math.inf, ci
                continue
            # a stage the drift never reaches within the window: it stays short of it (the window's end
            # stands for it) and must stay short of the face
            tau1 = min(_tau_at(tau, s, max(s1 - allow, 0.0)), float(tau[-1]))
            taur = min(max(_tau_at(tau, s, max(sr - allow, 0.0)), tau1 + self.t_rel), float(tau[-1]))
            need = allow + max(_s_at(tau, s, taur + seq.erc_release_time + seq.margin),
                               _s_at(tau, s, tau1 + self.lead1))
            if need - avail[ci] > short:
                short, worst = need - avail[ci], ci
        return short, worst

    def stage_fits(self, row, kind, d, tau, s, allow, label, thresholds) -> list[StageFit]:
        """Each stage of ``thresholds`` (first, second, release, rad) on one face, judged over the corners: where it
        fires, its margin beyond the intact allowance, and for ESD-1 and the release how far short of the face the
        break-out is when its part of the sequence is done (the least over the corners)."""
        seq = self.model.sequence
        ang = self.guard(kind, float(np.sign(row.vector[0] + row.vector[1])))
        out = []
        for (stage, _), thr in zip(STAGES, thresholds):
            worst = None
            for c in self.corners:
                a = ray_crossing(c, d, self.past_face)
                avail = 40.0 if a is None else a
                s_fire = ray_crossing(c, d, lambda p, t=thr: ang(p) >= t)
                s_fire = None if s_fire is None or s_fire >= avail else s_fire
                intact = (avail if s_fire is None else s_fire) - allow
                breakout = None
                if stage != "second alarm":
                    s1 = ray_crossing(c, d, lambda p: ang(p) >= thresholds[0])
                    tau1 = min(_tau_at(tau, s, max((avail if s1 is None else s1) - allow, 0.0)), float(tau[-1]))
                    if stage == "ESD-1":
                        breakout = avail - allow - _s_at(tau, s, tau1 + self.lead1)
                    else:                         # a release that never fires before the face: as if at the face
                        at = avail if s_fire is None else s_fire
                        taur = min(max(_tau_at(tau, s, max(at - allow, 0.0)), tau1 + self.t_rel), float(tau[-1]))
                        breakout = avail - allow - _s_at(tau, s, taur + seq.erc_release_time + seq.margin)
                fit = StageFit(row.direction, row.face, stage, label, math.degrees(thr), s_fire, intact, breakout)
                if worst is None or fit.margin_m < worst.margin_m:
                    worst = fit
            out.append(worst)
        return out

    def face_row(self, name, vec, kind, d, tau, s, allow, v_int, case, problems, warnings,
                 extreme: ExtremeLevel | None = None) -> FaceDesign:
        """One face's design; a refusal goes to ``problems``, a late position alarm to ``warnings``."""
        corners = self.corners
        avail = {}
        for ci, c in enumerate(corners):
            a = ray_crossing(c, d, self.past_face)
            avail[ci] = 40.0 if a is None else a
        s_rel, s_sec, s_free, s_lead = (_s_at(tau, s, t) for t in (self.t_rel, 0.5 * self.t_rel, self.t_free,
                                                                   self.lead1))
        v_rel = float(np.interp(min(self.t_rel, tau[-1]), tau[1:], np.diff(s) / np.diff(tau)))
        first = second = release = limit = floor = None
        pre = None
        if kind is not None:
            first, second, release, limit, floor, short, worst = self.thresholds(kind, vec, d, tau, s, allow, avail)
            if extreme is not None:
                ang = self.guard(kind, float(np.sign(vec[0] + vec[1])))
                pre = min(max(float(ang(c + max(extreme.pre_alarm, 0.0) * d)) for c in corners), first)
        # the refusal: even an alarm at the allowance's edge (loadarm's design-drift floor fires there at the
        # latest, whatever the corner) leaves less than the ESD-1 lead's drift before the face
        worst_f = max(avail, key=lambda ci: allow + s_lead - avail[ci])
        short_floor = allow + s_lead - avail[worst_f]
        if kind is None:
            short, worst = short_floor, worst_f
        c = corners[worst]
        face = ""
        hit = ray_crossing(c, d, self.past_face)
        if hit is not None:
            face = FACES[int(first_face(face_margins(self.model, *(c + (hit + 1e-6) * d)))[1])]
        ok = bool(short_floor <= 0)
        what = FACE_LABELS.get(face, face or "the reach")
        where = f"x = {c[0]:.2f}, y = {c[1]:.2f}, z = {c[2]:.2f} m"
        if not ok:
            cf = corners[worst_f]
            problems.append(f"{name}: the arm cannot absorb the design drift before the face ({what}): short by "
                            f"{short_floor:.2f} m at the flanging-area corner x = {cf[0]:.2f}, y = {cf[1]:.2f}, "
                            f"z = {cf[2]:.2f} m")
        elif kind is not None and short > 0:
            warnings.append(f"{name}: the {kind} alarms alone fire too late at the corner {where} (short by "
                            + (f"{short:.2f} m" if math.isfinite(short) else "the whole release")
                            + "): one angle cannot serve the whole flanging area there; the design-drift floor "
                              "(recommended [design_drift]) covers it")
        return FaceDesign(name, tuple(vec), face, avail[worst_f], allow, v_int, allow + s_sec,
                          allow + s_rel, allow + s_free, allow + s_lead, v_rel, kind or "", first, second,
                          release, limit, ok, float(short_floor),
                          tuple(float(v) for v in corners[worst_f]), case,
                          float(short) if math.isfinite(short) else float("inf"), floor, extreme, pre)
