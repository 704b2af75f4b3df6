"""The batched operability kernel (issue 13, item 3): the connected-mode monitoring of many sea states, without
the closed loop.

For one sea state the moored ship's flange moves (:func:`loadarm.ship.motion.simulate`, the same motion a
``loadarm run`` of that state sees); while connected the coupler follows it, so the arm's joints are the inverse
kinematics of the flange, vectorised over the whole record. The monitor's two alarm criteria are evaluated on
every sample at once:

* **position**: the customer's beta and slew angles (:func:`loadarm.arm.alarms.beta_severity`, ``slew_severity``);
* **design drift** (the floor of :class:`loadarm.guidance.monitor.EnvelopeMonitor`): the time a break-out from
  the flange's position at the design acceleration up to the design speed, along the monitor's eight horizontal
  directions, or the design vertical speed up and down, takes to reach a face. It depends on the position only,
  so it is tabulated once per installation over the region the flange can reach (:class:`FloorTable`: the ray
  distance to the first face along each direction, bisected to 1 mm, on a 0.2 m grid) and interpolated.

A compiled scan (numba) then runs the alarm sequence over the record: ESD-1 at the first sample whose stage is at
least ESD-1, the ERS valves closed ``ers_valve_time`` later, the leads of the later stages shrinking as the
sequence runs (:func:`loadarm.guidance.monitor.stage_leads`), the release at the first sample after the valves
closed whose stage is RELEASE. The monitor's measured-drift route (the 60 s drift fit and its velocity-step test)
is not evaluated here: in a sea state with intact moorings the design-drift floor and the angles are what raise
the alarms (the 100-seed Hs 1.5 m campaign measured no alarm at all); a break-out is the safety campaigns'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from loadarm._numba import njit
from loadarm.arm.alarms import BETA_TOL_RAD, LEVEL_RELEASE, AlarmThresholds, zone_level
from loadarm.arm.faces import breakout_distance, past_a_face, past_a_face_at
from loadarm.arm.kinematics import ik_cosine, ik_elbow
from loadarm.arm.sequence import esd_lead, lead_values, stage_of, valve_worst_time
from loadarm.arm.slew import JointAngles3D
from loadarm.guidance.monitor import EnvelopeMonitor, stage_leads
from loadarm.vocab import UNREACHABLE, Severity

__all__ = ["FloorTable", "floor_table", "ray_distances", "monitor_record", "RecordMonitor", "breakout_time", "N_DIRECTIONS",
           "relative_record", "record_ik"]

#: The monitor's horizontal directions (every 45 deg) and the vertical two.
N_DIRECTIONS = 10
_ANG = np.arange(8) * (math.pi / 4)
_DIRS = np.concatenate([np.stack([np.cos(_ANG), np.sin(_ANG), np.zeros(8)], axis=1),
                        np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])])


def breakout_time(distance, speed: float, accel: float) -> np.ndarray:
    """Time a break-out from rest at ``accel`` up to ``speed`` takes to cover ``distance`` (the inverse of
    :func:`loadarm.arm.faces.breakout_distance`).

    Parameters
    ----------
    distance : array_like
        m (>= 0; ``inf`` gives ``inf``).
    speed, accel : float
        m/s, m/s^2 (> 0).

    Returns
    -------
    ndarray
        s.
    """
    d = np.asarray(distance, dtype=float)
    knee = speed * speed / (2 * accel)
    return np.where(d <= knee, np.sqrt(2 * np.maximum(d, 0.0) / accel), d / speed + speed / (2 * accel))


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _breakout_time(d, speed, accel):
    """:func:`breakout_time` of one distance (a test holds it to the vectorised rule, bit for bit)."""
    if d <= speed * speed / (2 * accel):
        return math.sqrt(2 * max(d, 0.0) / accel)
    return d / speed + speed / (2 * accel)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _time_to_limit(h, v, drift):
    """The design-drift time to a face from the least horizontal and vertical ray distances ``h`` and ``v``;
    ``drift`` is ``(cap, cap_v, speed, acceleration, vertical_speed)``; a distance at its cap is beyond every
    lead (inf)."""
    cap, cap_v, speed, accel, vspeed = drift
    th = math.inf if h >= cap - 1e-9 else _breakout_time(h, speed, accel)
    tv = math.inf if v >= cap_v - 1e-9 else v / vspeed
    return min(th, tv)


@dataclass(frozen=True)
class FloorTable:
    """Ray distances from grid points to the first face along each of :data:`N_DIRECTIONS` directions, m.

    Attributes
    ----------
    origin : ndarray (3,)
    spacing : float
    dist : ndarray (nx, ny, nz, 10)
        Capped at ``cap`` (horizontal) and ``cap_v`` (vertical); 0 at a point outside the envelope.
    cap, cap_v : float
    """

    origin: np.ndarray
    spacing: float
    dist: np.ndarray
    cap: float
    cap_v: float

    def inside(self, p: np.ndarray) -> np.ndarray:
        """Which points lie inside the tabulated region.

        Parameters
        ----------
        p : ndarray (n, 3)

        Returns
        -------
        ndarray (n,) bool
        """
        return self.lookup(p)[2]

    def lookup(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The least horizontal and vertical ray distances at points (trilinear; the nearest edge value beyond
        the table) and which points lie inside it (to 1e-9 m), in one compiled pass (found: two
        ``scipy.ndimage.map_coordinates`` passes and the box test were 40 % of a state's monitoring).

        Parameters
        ----------
        p : ndarray (n, 3)

        Returns
        -------
        horizontal, vertical : ndarray (n,)
        inside : ndarray (n,) bool
        """
        p = np.ascontiguousarray(p, dtype=float)
        n = p.shape[0]
        h, v, ins = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
        _trilinear(self._hv, self.origin, self.spacing, p, h, v, ins)
        return h, v, ins

    @cached_property
    def _hv(self):                  # the least horizontal and vertical ray distances per grid point (once)
        return np.ascontiguousarray(np.stack([self.dist[..., :8].min(axis=-1), self.dist[..., 8:].min(axis=-1)],
                                             axis=-1))


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _cell(x, lo, spacing, m):
    """Grid cell and fraction of a coordinate (clamped to the grid's ``m`` nodes), and whether it is on it."""
    u = min(max((x - lo) / spacing, 0.0), m - 1.0)
    j = min(int(math.floor(u)), m - 2)
    return j, u - j, lo - 1e-9 <= x <= lo + spacing * (m - 1) + 1e-9


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _point(hv, origin, spacing, x, y, z):
    """Trilinear interpolation of ``hv[(nx, ny, nz, 2)]`` at one point, coordinates clamped to the grid (the
    nearest edge value beyond it, as ``map_coordinates(mode="nearest")``): (horizontal, vertical, inside to
    1e-9 m)."""
    x0, fx, okx = _cell(x, origin[0], spacing, hv.shape[0])
    y0, fy, oky = _cell(y, origin[1], spacing, hv.shape[1])
    z0, fz, okz = _cell(z, origin[2], spacing, hv.shape[2])
    out0 = out1 = 0.0
    for c in range(2):
        c00 = hv[x0, y0, z0, c] * (1 - fx) + hv[x0 + 1, y0, z0, c] * fx
        c10 = hv[x0, y0 + 1, z0, c] * (1 - fx) + hv[x0 + 1, y0 + 1, z0, c] * fx
        c01 = hv[x0, y0, z0 + 1, c] * (1 - fx) + hv[x0 + 1, y0, z0 + 1, c] * fx
        c11 = hv[x0, y0 + 1, z0 + 1, c] * (1 - fx) + hv[x0 + 1, y0 + 1, z0 + 1, c] * fx
        val = (c00 * (1 - fy) + c10 * fy) * (1 - fz) + (c01 * (1 - fy) + c11 * fy) * fz
        if c == 0:
            out0 = val
        else:
            out1 = val
    return out0, out1, okx and oky and okz


@njit(cache=True, nogil=True, error_model="numpy")
def _trilinear(hv, origin, spacing, p, h, v, inside):
    """:func:`_point` at every point of ``p``."""
    for i in range(p.shape[0]):
        h[i], v[i], inside[i] = _point(hv, origin, spacing, p[i, 0], p[i, 1], p[i, 2])


def ray_distances(model, pts: np.ndarray, cap: float, cap_v: float) -> np.ndarray:
    """Distance from each point to the first face along each of :data:`N_DIRECTIONS` directions (march at
    0.25 m, then bisect to 1 mm), capped at ``cap`` horizontally and ``cap_v`` vertically; 0 at a point outside.

    Parameters
    ----------
    model : ArmModel
    pts : ndarray (N, 3)
    cap, cap_v : float
        m.

    Returns
    -------
    ndarray (N, 10)
    """
    def outside(p):
        return past_a_face_at(model, p[..., 0], p[..., 1], p[..., 2])

    dist = np.empty((pts.shape[0], N_DIRECTIONS))
    inside0 = ~outside(pts)
    for j, d in enumerate(_DIRS):
        c = cap if j < 8 else cap_v
        steps = np.arange(0.0, c + 0.25, 0.25)
        out = outside(pts[:, None, :] + steps[None, :, None] * d)             # (N, S)
        hit = out.any(axis=1)
        first = np.where(hit, out.argmax(axis=1), steps.size - 1)
        a = steps[np.maximum(first - 1, 0)]
        b = steps[first]
        for _ in range(8):                                                   # 0.25 m / 2^8 = 1 mm
            mid = 0.5 * (a + b)
            o = outside(pts + mid[:, None] * d)
            b = np.where(hit & o, mid, b)
            a = np.where(hit & ~o, mid, a)
        dist[:, j] = np.where(hit, np.minimum(b, c), c)
        dist[~inside0, j] = 0.0
    return dist


def floor_table(model, lo, hi, *, spacing: float = 0.2) -> FloorTable:
    """Tabulate the ray distances to the faces over a box (march at 0.25 m, then bisect to 1 mm).

    Parameters
    ----------
    model : ArmModel
    lo, hi : array_like (3,)
        Corners of the box, installation frame, m.
    spacing : float
        Grid spacing, m.

    Returns
    -------
    FloorTable
    """
    seq, dd = model.sequence, model.design_drift
    lead = esd_lead(seq) + max(seq.pre_alarm_lead, 0.0) + seq.margin
    cap = float(breakout_distance(lead, dd.speed, dd.acceleration)) + 0.5
    cap_v = dd.vertical_speed * lead + 0.5
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    n = np.maximum(np.ceil((hi - lo) / spacing).astype(int) + 1, 2)
    axes = [lo[i] + spacing * np.arange(n[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)

    dist = ray_distances(model, grid, cap, cap_v)
    return FloorTable(lo, spacing, dist.reshape(*n, N_DIRECTIONS), cap, cap_v)


_lead_values = njit(cache=True, nogil=True, inline="always")(lead_values)
_stage_of = njit(cache=True, nogil=True, inline="always")(stage_of)


@njit(cache=True, nogil=True)
def _scan(level, ttl, dt, ers_valve_time, erc_release_time, margin, lead_esd1, valve_worst, close_at_release):
    """The alarm sequence over one record: returns (stage reached, i_esd1, i_release, min time-to-limit). The
    valves are commanded at ESD-1 (``close_at_release``: at the release request, ``ers_valves_close_at =
    "ers2"``) and confirm ``ers_valve_time`` later (intact valves); until then the leads count ``valve_worst``
    (:func:`loadarm.arm.sequence.valve_worst_time`) from the command, as the controller does; the leads and the stage
    are :func:`loadarm.arm.sequence.lead_values` and :func:`loadarm.arm.sequence.stage_of`, compiled."""
    n = level.shape[0]
    raised = 0
    i_esd = -1
    i_cmd = -1
    i_rel = -1
    ttl_min = np.inf
    for i in range(n):
        t = i * dt
        if ttl[i] < ttl_min:
            ttl_min = ttl[i]
        lv = level[i]
        # the leads of the stages, shrinking once the valves are closing (loadarm.arm.sequence, compiled)
        confirmed = i_cmd >= 0 and t >= i_cmd * dt + ers_valve_time - 1e-9
        if i_cmd >= 0:
            valves_left = 0.0 if confirmed else max(i_cmd * dt + valve_worst - t, 0.0)
        else:
            valves_left = valve_worst
        rel_lead, sec_lead, esd_lead_now, pre = _lead_values(valves_left, erc_release_time, margin, lead_esd1, 0.0)
        # no measured route here (the design drift's table): the pre-alarm, which warns of a drift the monitor
        # measures, is the live monitor's alone
        lv = max(lv, _stage_of(ttl[i], np.inf, rel_lead, sec_lead, esd_lead_now, pre))
        if lv > raised:
            raised = lv
        if raised >= 2 and i_esd < 0:
            i_esd = i
        if i_cmd < 0 and ((raised >= 2 and not close_at_release) or raised >= 4):
            i_cmd = i
        if raised >= 4 and i_rel < 0 and i_cmd >= 0 and t >= i_cmd * dt + ers_valve_time - 1e-9:
            i_rel = i
    return raised, i_esd, i_rel, ttl_min


@dataclass(frozen=True)
class RecordMonitor:
    """What the connected-mode monitoring of one record found.

    Attributes
    ----------
    stage : int
        Most severe alarm stage (:class:`loadarm.vocab.Severity`).
    esd1_s, release_s : float
        When ESD-1 and the release fired (NaN: never).
    max_beta_deg, max_slew_deg : float
        Largest elbow angle and absolute slew.
    z_range_m : float
        Vertical excursion of the flange (max - min).
    min_time_to_limit_s : float
        Least design-drift time to a face (inf: none within the longest lead).
    outside : bool
        The flange left the envelope (the arm would be overstretched).
    esd1_face : str
        The face ESD-1 guarded (:data:`loadarm.vocab.FACES`; ``""``: no ESD-1): the position alarm's, or the
        design drift's first face from the flange at ESD-1 (the live monitor's forecast with no history).
    """

    stage: int
    esd1_s: float
    release_s: float
    max_beta_deg: float
    max_slew_deg: float
    z_range_m: float
    min_time_to_limit_s: float
    outside: bool
    esd1_face: str = ""


# the rules of the vectorised modules, compiled for the per-sample pass (a test holds each to its original)
_zone = njit(cache=True, nogil=True)(zone_level)
_past = njit(cache=True, nogil=True)(past_a_face)


@njit(cache=True, nogil=True, error_model="numpy")
def _samples(phi, alpha, beta, x, y, z, beta_thr, slew_thr, phi_rng, alpha_rng, beta_rng, hv, origin, spacing,
             drift, level, ttl, inside):
    """Per sample of the record, in one pass: the position alarm level (beta and slew; unreachable: release),
    whether a face is passed, the design-drift time to a face from the table (:func:`_point`,
    :func:`_time_to_limit`) and whether the sample is on the table. Returns the largest beta and absolute slew
    (NaN if none reachable), whether any sample was past a face, and the least and largest ``z``."""
    bmax = -np.inf
    smax = -np.inf
    zmin = np.inf
    zmax = -np.inf
    outside = False
    for i in range(beta.shape[0]):
        b, s = beta[i], abs(phi[i])
        lb = _zone(b, beta_thr[0], beta_thr[1], beta_thr[2], BETA_TOL_RAD)
        ls = _zone(s, slew_thr[0], slew_thr[1], slew_thr[2], 0.0)
        level[i] = LEVEL_RELEASE if lb == UNREACHABLE else max(lb, ls)
        if _past(phi[i], alpha[i], b, phi_rng, alpha_rng, beta_rng):
            outside = True
        if b > bmax:
            bmax = b
        if s > smax:
            smax = s
        h, v, inside[i] = _point(hv, origin, spacing, x[i], y[i], z[i])
        ttl[i] = _time_to_limit(h, v, drift)
        zmin = min(zmin, z[i])
        zmax = max(zmax, z[i])
    if bmax == -np.inf:
        bmax = np.nan
    return bmax, smax, outside, zmin, zmax


@njit(cache=True, nogil=True, error_model="numpy")
def _times_to_limit(h, v, drift, ttl):
    """:func:`_time_to_limit` at every sample (for the samples beyond the table, their rays cast)."""
    for i in range(h.shape[0]):
        ttl[i] = _time_to_limit(h[i], v[i], drift)


@njit(cache=True, nogil=True)
def relative_record(flange, reference, offset, out):
    """The flange record moved to the installation (``out[k, i] = offset[k] + (flange[i, k] - reference[k])``,
    ``out`` (3, n): one contiguous row per axis, for the vectorised inverse kinematics) and the standard
    deviation of each axis of ``flange`` (two passes, as ``numpy.std``), in one compiled routine (found: the
    vectorised offset, copy and three standard deviations were a twentieth of an hourly state).

    Parameters
    ----------
    flange : ndarray (n, 3)
    reference, offset : ndarray (3,)
    out : ndarray (3, n)
        Written.

    Returns
    -------
    ndarray (3,)
        Standard deviations, m.
    """
    n = flange.shape[0]
    mean = np.zeros(3)
    for i in range(n):
        for k in range(3):
            f = flange[i, k]
            out[k, i] = offset[k] + (f - reference[k])
            mean[k] += f
    mean /= n
    var = np.zeros(3)
    for i in range(n):
        for k in range(3):
            e = flange[i, k] - mean[k]
            var[k] += e * e
    return np.sqrt(var / n)


# the inverse kinematics' arithmetic, compiled from the functions the vectorised route calls (one formula)
_ik_cosine = njit(cache=True, nogil=True, error_model="numpy")(ik_cosine)
_ik_elbow = njit(cache=True, nogil=True, error_model="numpy")(ik_elbow)


@njit(cache=True, nogil=True, error_model="numpy")
def _ik_arguments(x, y, z, a, b, c, sb, cb, sa, ca):
    """The arguments of the elbow's two arctangents in :func:`loadarm.arm.slew.inverse3d` (elbow up) at every
    sample, in one compiled routine: :func:`loadarm.arm.kinematics.ik_cosine` and
    :func:`~loadarm.arm.kinematics.ik_elbow` compiled, bit for bit (``sb``, ``cb``, ``sa``, ``ca`` written; NaN
    where a point is out of reach, as there). The planar radius first (libm's ``hypot``, as NumPy's, kept in
    ``sb``), then the rest in a loop."""
    for i in range(x.shape[0]):
        sb[i] = math.hypot(x[i], y[i])
    for i in range(x.shape[0]):
        rho = sb[i]
        dy, r, cbi = _ik_cosine(a, b, c, rho, z[i])
        sb[i], sa[i], ca[i] = _ik_elbow(b, c, 1.0, rho, dy, r, cbi)
        cb[i] = cbi


def record_ik(arm, x: np.ndarray, y: np.ndarray, z: np.ndarray):
    """:func:`loadarm.arm.slew.inverse3d` (elbow up, unchecked: NaN out of reach) of a record, bit for bit, faster:
    its arithmetic in one compiled routine (:func:`_ik_arguments`), its three arctangents NumPy's SIMD ones (a
    compiled scalar ``atan2`` was four times slower). Found: the vectorised expression's twenty-odd passes over
    the record and its ``hypot`` were two thirds of the inverse kinematics' cost.

    Parameters
    ----------
    arm : Arm
    x, y, z : ndarray (n,)
        Contiguous float64, m.

    Returns
    -------
    JointAngles3D
    """

    n = x.shape[0]
    sb, cb, sa, ca = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    _ik_arguments(x, y, z, float(arm.a), float(arm.b), float(arm.c), sb, cb, sa, ca)
    return JointAngles3D(np.arctan2(y, x), np.arctan2(sa, ca, out=sa), np.arctan2(sb, cb, out=sb))


def monitor_record(model, table: FloorTable, p: np.ndarray, dt: float) -> RecordMonitor:
    """Run the connected-mode monitoring over one flange record.

    Parameters
    ----------
    model : ArmModel
    table : FloorTable
        Covering the positions of ``p`` (those beyond it are cast directly).
    p : ndarray (n, 3)
        Flange positions, installation frame, m, ``dt`` apart.
    dt : float
        s.

    Returns
    -------
    RecordMonitor

    Notes
    -----
    The inverse kinematics vectorised (NumPy's SIMD transcendentals: a compiled scalar loop was four times
    slower), then one compiled pass for the alarm levels, the faces and the design-drift time to a face from
    the table (:func:`_samples`); positions beyond the table get their ray distances cast directly (slower,
    exact); then the alarm sequence (:func:`_scan`). ``p`` in any layout; the transposed rows of
    :func:`relative_record` are read without a copy.
    """
    p = np.asarray(p, dtype=float)
    n = p.shape[0]
    x, y, z = (np.ascontiguousarray(p[:, k]) for k in range(3))   # no copy from relative_record's rows
    al, sl, lim, dd = model.alarms, model.slew, model.joint_limits, model.design_drift
    q = record_ik(model.arm, x, y, z)                                 # inverse3d's, bit for bit
    level = np.empty(n, dtype=np.int64)
    ttl = np.empty(n)
    ins = np.empty(n, dtype=np.bool_)
    drift = (float(table.cap), float(table.cap_v), float(dd.speed), float(dd.acceleration), float(dd.vertical_speed))
    bmax, smax, outside, zmin, zmax = _samples(
        np.asarray(q.phi, dtype=float), np.asarray(q.alpha, dtype=float), np.asarray(q.beta, dtype=float), x, y, z,
        (al.first, al.second, al.release), (sl.first, sl.second, sl.release), tuple(map(float, lim.phi)),
        tuple(map(float, lim.alpha)), tuple(map(float, lim.beta)), table._hv, table.origin, float(table.spacing),
        drift, level, ttl, ins)
    away = ~ins
    if away.any():                                # beyond the table (a rare, violent state): cast the rays there
        d = ray_distances(model, p[away], table.cap, table.cap_v)
        t_away = np.empty(d.shape[0])
        _times_to_limit(d[:, :8].min(axis=1), d[:, 8:].min(axis=1), drift, t_away)
        ttl[away] = t_away
    seq = model.sequence
    stage, i1, ir, tmin = _scan(level, ttl, dt, seq.ers_valve_time, seq.erc_release_time, seq.margin,
                                esd_lead(seq), valve_worst_time(seq), seq.ers_valves_close_at == "ers2")
    face = "" if i1 < 0 else _esd1_face(model, p[i1], q, i1, int(level[i1]))
    return RecordMonitor(int(stage), i1 * dt if i1 >= 0 else math.nan, ir * dt if ir >= 0 else math.nan,
                         float(np.degrees(bmax)), float(np.degrees(smax)), float(zmax - zmin), float(tmin),
                         bool(outside), face)


def _esd1_face(model, p, q, i: int, level: int) -> str:
    """The face ESD-1 guarded at sample ``i``, as the controller names it: the position alarm's when the position
    raised it, else the design drift's first face (one forecast, uncompiled: once per record)."""
    if level >= Severity.ESD1:
        thr = AlarmThresholds.from_model(model)
        return thr.face(float(np.asarray(q.beta)[i]), float(np.asarray(q.phi)[i]), Severity(min(level, 4)))
    monitor = EnvelopeMonitor(model, window=60.0)
    return monitor.time_to_limit(p, max(stage_leads(model.sequence).values())).face
