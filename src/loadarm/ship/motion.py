"""The moored ship's motion in time and the six-degree-of-freedom motion of its manifold flange (issue 12,
item 5).

Two parts, added (the usual separation of a moored ship's response):

* **Low frequency** (surge, sway, yaw; periods of tens of seconds to minutes): time-domain integration (RK4,
  compiled with numba) of ``M x'' + B x' + F_moor(x) = F_wind(t) + F_current(x') + F_drift(t)`` in the berth
  frame at midships, with the lines and fenders non-linear (:mod:`loadarm.ship.mooring`), the wind with its NPD
  gusts, the current on the relative velocity (its quadratic drag damps the motion), the Newman slow-drift
  force, and lines that part at a given time (the break-out case).
* **Wave frequency** (all six DOFs): the RAOs (:class:`loadarm.ship.model.ShipModel`) applied to a JONSWAP
  sea with cos-2s spreading, synthesised by FFT on the output grid.

The flange (``[ship] manifold``) follows the ship's pose: berth-frame position and velocity, and the
orientation of its face (roll, pitch and yaw of the ship). A record shorter than :data:`MIN_RECORD` is
synthesised on a record that long (for a fine frequency grid) and cut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft

from loadarm._numba import njit
from loadarm.params.berth import Environment
from loadarm.results import Metric, Result
from loadarm.ship.hydro import MEAN_DRIFT_DIRECTION, MEAN_DRIFT_OMEGA, interp_heading
from loadarm.ship.loads import (
    E_C,
    current_force,
    jonswap,
    npd_spectrum,
    sample_directions,
    spreading,
    uniform_draws,
    wind_force,
)
from loadarm.ship.longwave import setdown_load
from loadarm.ship.model import ShipModel, _rot3
from loadarm.ship.mooring import (
    equilibrium,
    fender_contact,
    fender_deflections,
    fender_loads,
    line_elongation,
    line_tension,
    line_tensions,
    restoring_kernel,
)
from loadarm.ship.passing import add_passing_load

__all__ = ["ShipMotion", "simulate", "flange_positions", "mean_load", "MIN_RECORD", "DT", "wave_components",
           "fft_length", "rise_of", "line_stretch_coefficients", "moored_state", "StateLoads", "ship_angles"]

#: Shortest record synthesised, s (frequency step 2 pi / 1800 s: 0.0035 rad/s).
MIN_RECORD = 1800.0
#: Output step, s (10 Hz).
DT = 0.1
#: Loads on the low-frequency motion are low-passed at this frequency, rad/s (a 10 s period: twice the highest
#: moored natural frequency of a large ship, and well above slow drift's difference frequencies).
LF_CUTOFF = 0.6


@dataclass(frozen=True)
class WaveComponents:
    """The realised sea on the FFT grid: frequency, amplitude, direction (berth frame, towards), phase of the
    components ``k = 1 .. K`` (the grid's first ``K``: those up to ``omega_max``)."""

    omega: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    phase: np.ndarray
    n: int


def wave_components(env: Environment, n: int, dt: float, rng: np.random.Generator, gamma: float = 3.3,
                    omega_max: float = math.inf) -> WaveComponents:
    """Draw the sea's components on the FFT grid of ``n`` samples ``dt`` apart.

    Parameters
    ----------
    env : Environment
    n : int
    dt : float
    rng : numpy.random.Generator
    gamma : float
    omega_max : float
        Keep the components up to this frequency, rad/s (the random draws are those of the whole grid, so a
        seed realises the same sea whatever the band kept; a ship answers nothing above its RAO grid).

    Returns
    -------
    WaveComponents
    """
    dw = 2 * math.pi / (n * dt)
    w = dw * np.arange(1, n // 2)
    keep = int(np.searchsorted(w, omega_max, side="right"))
    a = np.sqrt(2.0 * jonswap(w[:keep], env.hs, env.tp, gamma) * dw)
    direction = sample_directions(rng, w.size, math.radians(env.wave_direction_deg), env.spreading, keep=keep)
    phase = 2 * math.pi * uniform_draws(rng, w.size, keep)    # as rng.uniform(0, 2 pi, w.size)[:keep]
    return WaveComponents(w[:keep], a, direction, phase, n)


def fft_length(target: int) -> int:
    """The smallest even length at least ``target`` whose FFT is fast (found: rounding a fast length up to
    even, 36015 -> 36016 = 16 x 2251, made every hour-long synthesis 18 times slower).

    Parameters
    ----------
    target : int

    Returns
    -------
    int
    """
    n = next_fast_len(int(target), real=True)
    while n % 2:
        n = next_fast_len(n + 1, real=True)
    return n


def _synth(coef: np.ndarray, n: int) -> np.ndarray:
    """``Re sum_k coef_k exp(-i w_k t)`` on the grid (coef for k = 1 .. n//2 - 1, last axis time).

    The inverse FFT unscaled (``norm="forward"``) of the halved coefficients (exact: a power of two), so that no
    pass over the whole record scales it (found: the two passes of ``* n / 2`` were a third of the flange's
    synthesis)."""
    c = np.zeros(coef.shape[:-1] + (n // 2 + 1,), dtype=complex)
    np.multiply(np.conj(coef), 0.5, out=c[..., 1:coef.shape[-1] + 1])
    return irfft(c, n, axis=-1, norm="forward")


@njit(cache=True, nogil=True, error_model="numpy")
def _phasors(amplitude, phase, out):
    """``out = amplitude * exp(-i phase)``, one compiled pass (the compiler takes each component's cosine and
    sine in one ``sincos`` call: bit for bit NumPy's ``amplitude * (cos - i sin)``; found, NumPy's ``cos`` and
    ``sin`` apart took 1.6 times as long, its complex ``exp`` twice)."""
    for i in range(phase.shape[0]):
        p = phase[i]
        out[i] = complex(amplitude[i] * math.cos(p), -(amplitude[i] * math.sin(p)))


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _lf_rhs(x0, x1, x2, v0, v1, v2, f0, f1, f2, minv, damp, lines, table, alive, fy, fdefl, fload, fn, fprop, hull,
            psi0, origin, current, out_f, ten, per_line):
    """Acceleration (3 floats) of the low-frequency pose: scalars in and out, no allocation (the integration
    calls it four times a step). ``current`` is ``(vx, vy, kx, ky, el)``: the current's velocity and the ship's
    current-load factors. Inlined into the integrator (no reference counting of its arrays per call: found,
    about 0.5 us a call; fewer than 30 arguments, or Python passes them as ``*args``, which numba cannot
    inline). ``lines`` is :attr:`loadarm.ship.mooring.Moorings.lines` (the integration's copy, rendered lengths
    in it), ``table`` the lines' tension tables, ``per_line`` a (4, n) scratch; ``fprop`` the fenders'
    friction and hysteresis (:func:`loadarm.ship.mooring.fender_contact`)."""
    cur_vx, cur_vy, kx, ky, el = current
    psi = psi0 + x2
    c, s = math.cos(psi), math.sin(psi)
    restoring_kernel(x0, x1, c, s, lines, table, alive, fy, fdefl, fload, fn, hull, origin, out_f, ten, per_line)
    hx, hy, hz = fender_contact(x0, x1, c, s, v0, v1, v2, fy, fdefl, fload, fn, fprop, hull, origin)
    # external ship-frame load rotated to the berth frame
    fx = out_f[0] + hx + c * f0 - s * f1
    fyy = out_f[1] + hy + s * f0 + c * f1
    mz = out_f[2] + hz + f2
    # current on the relative velocity (ship frame)
    rx, ry = cur_vx - v0, cur_vy - v1
    u, w = c * rx + s * ry, -s * rx + c * ry
    sp2 = u * u + w * w
    if sp2 > 0:
        sp = math.sqrt(sp2)
        cu, sw = u / sp, w / sp
        gx, gy = kx * sp2 * cu, ky * sp2 * sw
        fx += c * gx - s * gy
        fyy += s * gx + c * gy
        mz += gy * el * cu
    fx -= damp[0, 0] * v0 + damp[0, 1] * v1 + damp[0, 2] * v2
    fyy -= damp[1, 0] * v0 + damp[1, 1] * v1 + damp[1, 2] * v2
    mz -= damp[2, 0] * v0 + damp[2, 1] * v1 + damp[2, 2] * v2
    return (minv[0, 0] * fx + minv[0, 1] * fyy + minv[0, 2] * mz,
            minv[1, 0] * fx + minv[1, 1] * fyy + minv[1, 2] * mz,
            minv[2, 0] * fx + minv[2, 1] * fyy + minv[2, 2] * mz)


@njit(cache=True, nogil=True, error_model="numpy")
def _line_events(k_prev, k, e_start, e_end, stretch, work, table, e_brake, e_break, brake, alive, part_at, paid,
                 tens, tmax):
    """The lines over the step from output sample ``k_prev`` to ``k`` (``k_prev`` -1: the first sample alone):
    each sample's elongation (linear between the step's ends, ``e_start`` and ``e_end``, plus the first-order
    ``stretch``, (lines, samples), when it has columns), the tension record ``tens`` (when it has rows; at
    most the brake's holding load), and the events at the step's end: a line whose elongation reached its breaking one parts (unless its
    brake renders first), a line past its brake's holding load renders (its unstretched length in ``work`` row
    5 grows by the excess, summed in ``paid``); ``tmax`` keeps each line's largest tension (from its largest
    elongation: the curve rises, so no sample's tension need be read for it). Returns True when a line parted or
    rendered."""
    nl = work.shape[1]
    has_stretch = stretch.shape[1] > 0
    rec = tens.shape[0] > 0
    lo = k_prev + 1 if k_prev >= 0 else k
    changed = False
    for j in range(nl):
        if not alive[j]:
            if rec:
                for q in range(lo, k + 1):
                    tens[q, j] = 0.0
            continue
        peak = -1e300
        broke = -1
        for q in range(lo, k + 1):
            u = (q - k_prev) / (k - k_prev) if k_prev >= 0 else 1.0
            e = (1.0 - u) * e_start[j] + u * e_end[j]
            if has_stretch:
                e += stretch[j, q]
            if broke < 0:                         # the largest elongation up to the parting, if any
                if e > peak:
                    peak = e
                if e >= e_break[j] and e_brake[j] >= e_break[j]:
                    broke = q
            if rec:
                t = 0.0 if broke >= 0 and q > broke else line_tension(e, work[6, j], table[j])
                tens[q, j] = t if t < brake[j] else brake[j]
        top = line_tension(peak, work[6, j], table[j])
        top = top if top < brake[j] else brake[j]
        if top > tmax[j]:
            tmax[j] = top
        if broke >= 0:
            alive[j] = False
            part_at[j] = broke
            changed = True
        elif peak > e_brake[j]:
            work[5, j] += peak - e_brake[j]
            paid[j] += peak - e_brake[j]
            changed = True
    return changed


@njit(cache=True, nogil=True, error_model="numpy")
def _elongations(x, y, psi, lines, origin, out):
    """Each line's elongation (stretched length less unstretched) at the pose ``(x, y, psi)`` (``psi`` the
    heading), into ``out``: the kernel's geometry alone (:func:`loadarm.ship.mooring.restoring_kernel`)."""
    c, s = math.cos(psi), math.sin(psi)
    cx, cy = origin[0] + x, origin[1] + y
    for i in range(lines.shape[1]):
        ax, ay, h = lines[0, i], lines[1, i], lines[4, i]
        rx = c * ax - s * ay                      # as the kernel writes it: the same elongation, bit for bit
        ry = s * ax + c * ay
        dx, dy = cx + rx - lines[2, i], cy + ry - lines[3, i]
        out[i] = math.sqrt(dx * dx + dy * dy + h * h) - lines[5, i]


@njit(cache=True, nogil=True)
def _part_named(k, alive, alive1, part_at, tens):
    """The named lines part at output sample ``k``: those alive and not in ``alive1`` (their tension record is
    0 from ``k``). Returns True when one did."""
    changed = False
    for j in range(alive.shape[0]):
        if alive[j] and not alive1[j]:
            alive[j] = False
            part_at[j] = k
            changed = True
            if tens.shape[0] > 0:
                tens[k, j] = 0.0
    return changed


@njit(cache=True, nogil=True, error_model="numpy")
def _lf_integrate(x0, v0, f_ship, every, dt, stride, minv, damp, lines, table, e_brake, e_break, brake, stretch,
                  alive0, alive1, i_part, fy, fdefl, fload, fn, fprop, hull, psi0, origin, cur_vx, cur_vy, kx, ky, el,
                  xs, vs, tens, part_at, paid, tmax):
    """RK4 of the low-frequency pose, ``stride`` output samples per step (the load taken at its samples at the
    step's start, middle and end: it is low-passed first, :data:`LF_CUTOFF`); the samples between from the cubic
    Hermite of the step's ends (error of order ``(w h)^4 / 384``: below 1e-4 of the motion for the 19 s and longer
    periods of a moored ship at :data:`LF_STEP`). A step ends exactly where the named lines part (``i_part``:
    from there ``alive1`` too) and at the last sample. At each step's end the lines' events
    (:func:`_line_events`: brakes rendering, lines parting at their breaking load, on the low-frequency
    elongation plus the first-order ``stretch``); after an event the step's end is evaluated again with the new
    lines, so the cascade follows from step to step. Empty ``vs`` and ``tens`` (no rows): the pose alone.
    ``f_ship`` holds the load at every ``every``-th output sample (:func:`_load_every`: only the samples the
    stages read). ``lines`` is :attr:`loadarm.ship.mooring.Moorings.lines` (copied: rendering lengthens the
    copy). ``part_at`` gets each line's sample of parting (-1: intact), ``paid`` the length its brake paid
    out, m, ``tmax`` its largest tension, N (whether ``tens`` records them or not)."""
    n = xs.shape[0]
    rates = vs.shape[0] > 0
    current = (cur_vx, cur_vy, kx, ky, el)
    nl = lines.shape[1]
    work = lines.copy()
    alive = alive0.copy()
    for j in range(nl):
        part_at[j] = -1
        paid[j] = 0.0
        tmax[j] = 0.0
        if not alive[j]:
            part_at[j] = 0
    out_f = np.zeros(3)
    ten = np.zeros(nl)
    e0 = np.zeros(nl)
    e_now = np.zeros(nl)
    per_line = np.empty((4, nl))
    a0, a1, a2 = x0[0], x0[1], x0[2]
    b0, b1, b2 = v0[0], v0[1], v0[2]
    k = 0
    k_prev = -1
    while True:
        xs[k, 0], xs[k, 1], xs[k, 2] = a0, a1, a2
        if rates:
            vs[k, 0], vs[k, 1], vs[k, 2] = b0, b1, b2
        p0, p1, p2 = f_ship[k // every, 0], f_ship[k // every, 1], f_ship[k // every, 2]
        # the lines' events first (their elongations alone: found, a second inlined evaluation of the whole
        # right-hand side after an event doubled the integrator's compile time), then the step's first stage
        _elongations(a0, a1, psi0 + a2, work, origin, e_now)
        changed = _line_events(k_prev, k, e0, e_now, stretch, work, table, e_brake, e_break, brake, alive,
                               part_at, paid, tens, tmax)
        if k >= i_part and _part_named(k, alive, alive1, part_at, tens):
            changed = True
        if changed:
            _elongations(a0, a1, psi0 + a2, work, origin, e_now)
        k1 = _lf_rhs(a0, a1, a2, b0, b1, b2, p0, p1, p2, minv, damp, work, table, alive, fy, fdefl,
                     fload, fn, fprop, hull, psi0, origin, current, out_f, ten, per_line)
        for j in range(nl):
            e0[j] = e_now[j]
        if k == n - 1:
            break
        k2 = min(k + stride, n - 1)
        if k < i_part < k2:
            k2 = i_part
        m = k2 - k
        big = m * dt
        q0, q1, q2 = f_ship[k2 // every, 0], f_ship[k2 // every, 1], f_ship[k2 // every, 2]
        if m % 2 == 0:
            km = (k + m // 2) // every
            m0, m1, m2 = f_ship[km, 0], f_ship[km, 1], f_ship[km, 2]
        else:                                    # (every is 1 then)
            kl = k + m // 2
            m0 = 0.5 * (f_ship[kl, 0] + f_ship[kl + 1, 0])
            m1 = 0.5 * (f_ship[kl, 1] + f_ship[kl + 1, 1])
            m2 = 0.5 * (f_ship[kl, 2] + f_ship[kl + 1, 2])
        h = 0.5 * big
        x20, x21, x22 = a0 + h * b0, a1 + h * b1, a2 + h * b2
        v20, v21, v22 = b0 + h * k1[0], b1 + h * k1[1], b2 + h * k1[2]
        k2s = _lf_rhs(x20, x21, x22, v20, v21, v22, m0, m1, m2, minv, damp, work, table, alive, fy,
                      fdefl, fload, fn, fprop, hull, psi0, origin, current, out_f, ten, per_line)
        x30, x31, x32 = a0 + h * v20, a1 + h * v21, a2 + h * v22
        v30, v31, v32 = b0 + h * k2s[0], b1 + h * k2s[1], b2 + h * k2s[2]
        k3 = _lf_rhs(x30, x31, x32, v30, v31, v32, m0, m1, m2, minv, damp, work, table, alive, fy,
                     fdefl, fload, fn, fprop, hull, psi0, origin, current, out_f, ten, per_line)
        x40, x41, x42 = a0 + big * v30, a1 + big * v31, a2 + big * v32
        v40, v41, v42 = b0 + big * k3[0], b1 + big * k3[1], b2 + big * k3[2]
        k4 = _lf_rhs(x40, x41, x42, v40, v41, v42, q0, q1, q2, minv, damp, work, table, alive, fy,
                     fdefl, fload, fn, fprop, hull, psi0, origin, current, out_f, ten, per_line)
        c0 = a0 + big / 6 * (b0 + 2 * v20 + 2 * v30 + v40)
        c1 = a1 + big / 6 * (b1 + 2 * v21 + 2 * v31 + v41)
        c2 = a2 + big / 6 * (b2 + 2 * v22 + 2 * v32 + v42)
        d0 = b0 + big / 6 * (k1[0] + 2 * k2s[0] + 2 * k3[0] + k4[0])
        d1 = b1 + big / 6 * (k1[1] + 2 * k2s[1] + 2 * k3[1] + k4[1])
        d2 = b2 + big / 6 * (k1[2] + 2 * k2s[2] + 2 * k3[2] + k4[2])
        if m > 1:
            for i in range(1, m):
                u = i / m
                hh00 = 2 * u ** 3 - 3 * u ** 2 + 1
                hh10 = u ** 3 - 2 * u ** 2 + u
                hh01 = -2 * u ** 3 + 3 * u ** 2
                hh11 = u ** 3 - u ** 2
                g00 = (6 * u ** 2 - 6 * u) / big
                g10 = 3 * u ** 2 - 4 * u + 1
                g01 = (-6 * u ** 2 + 6 * u) / big
                g11 = 3 * u ** 2 - 2 * u
                xs[k + i, 0] = hh00 * a0 + hh10 * big * b0 + hh01 * c0 + hh11 * big * d0
                xs[k + i, 1] = hh00 * a1 + hh10 * big * b1 + hh01 * c1 + hh11 * big * d1
                xs[k + i, 2] = hh00 * a2 + hh10 * big * b2 + hh01 * c2 + hh11 * big * d2
                if not rates:
                    continue
                vs[k + i, 0] = g00 * a0 + g10 * b0 + g01 * c0 + g11 * d0
                vs[k + i, 1] = g00 * a1 + g10 * b1 + g01 * c1 + g11 * d1
                vs[k + i, 2] = g00 * a2 + g10 * b2 + g01 * c2 + g11 * d2
        a0, a1, a2, b0, b1, b2 = c0, c1, c2, d0, d1, d2
        k_prev = k
        k = k2


@dataclass(frozen=True)
class ShipMotion(Result):
    """A moored ship's motion on a 10 Hz grid and its manifold flange.

    Attributes
    ----------
    t : ndarray (n,)
        s.
    pose, pose_velocity : ndarray (n, 3)
        Low-frequency pose (x, y m; psi rad) of midships, berth frame, and its rate.
    wave, wave_velocity : ndarray (n, 6)
        First-order motion of the centre of gravity (ship frame: m and rad) and its rate.
    flange, flange_velocity : ndarray (n, 3)
        Berth frame (z above still water), m and m/s.
    flange_angles : ndarray (n, 3)
        Roll, pitch, yaw of the flange face relative to the reference heading, rad.
    tension : ndarray (n, lines)
        N: the low-frequency tension plus the first-order motion's (``dL`` of
        :func:`line_stretch_coefficients` on the line's curve), at most the brake's holding load.
    names : tuple of str
        Line names.
    mbl : ndarray (lines,)
    parted : tuple of str
        The lines parted in the run, named (``part_time``) or overloaded, in the order they parted.
    part_time : float or None
        When the named lines were cut, s.
    mean_pose : ndarray (3,)
        Static equilibrium under the mean loads (intact).
    part_times : ndarray (lines,)
        When each line parted, s (NaN: it held).
    paid_out : ndarray (lines,)
        Length each winch brake paid out while rendering, m.
    brake, breaking_load : ndarray (lines,)
        N (brake ``inf``: on bitts).
    """

    t: np.ndarray
    pose: np.ndarray
    pose_velocity: np.ndarray
    wave: np.ndarray
    wave_velocity: np.ndarray
    flange: np.ndarray
    flange_velocity: np.ndarray
    flange_angles: np.ndarray
    tension: np.ndarray
    names: tuple[str, ...]
    mbl: np.ndarray
    parted: tuple[str, ...]
    part_time: float | None
    mean_pose: np.ndarray
    flange_reference: np.ndarray
    part_times: np.ndarray
    paid_out: np.ndarray
    brake: np.ndarray
    breaking_load: np.ndarray

    METRICS = (
        Metric("duration_s", "duration", "s", ".0f"),
        Metric("parted", "lines parted"),
        Metric("offset_x_mean_m", "mean offset off the berth", "m", "+.3f"),
        Metric("offset_x_max_m", "largest offset off the berth", "m", "+.3f"),
        Metric("offset_y_std_m", "offset along the berth, std", "m", ".3f"),
        Metric("yaw_max_deg", "largest yaw", "deg", ".2f"),
        Metric("flange_std_x_m", "flange std x (off)", "m", ".3f"),
        Metric("flange_std_y_m", "flange std y (along)", "m", ".3f"),
        Metric("flange_std_z_m", "flange std z (up)", "m", ".3f"),
        Metric("flange_speed_max_ms", "flange speed, max", "m/s", ".3f"),
        Metric("roll_max_deg", "largest roll", "deg", ".2f"),
        Metric("tension_max_kn", "largest line tension", "kN", ".0f"),
        Metric("tension_max_line", "in line"),
        Metric("tension_max_fraction_mbl", "largest tension / MBL", "", ".2f"),
        Metric("lines_rendered", "lines whose brake rendered"),
        Metric("paid_out_max_m", "largest brake pay-out", "m", ".2f"),
    )

    def _values(self) -> dict:
        rel = self.flange - self.flange_reference
        ratio = self.tension / self.mbl
        i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        sp = np.linalg.norm(self.flange_velocity, axis=1)
        return {"duration_s": float(self.t[-1] - self.t[0]),
                "parted": ", ".join(self.parted) if self.parted else "none", "part_time_s": self.part_time,
                "offset_x_mean_m": float(np.mean(self.pose[:, 0])), "offset_x_min_m": float(np.min(self.pose[:, 0])),
                "offset_x_max_m": float(np.max(self.pose[:, 0])),
                "offset_y_mean_m": float(np.mean(self.pose[:, 1])), "offset_y_std_m": float(np.std(self.pose[:, 1])),
                "yaw_max_deg": float(np.degrees(np.max(np.abs(self.pose[:, 2])))),
                "flange_std_x_m": float(np.std(rel[:, 0])), "flange_std_y_m": float(np.std(rel[:, 1])),
                "flange_std_z_m": float(np.std(rel[:, 2])),
                "flange_excursion_max_m": float(np.max(np.linalg.norm(rel, axis=1))),
                "flange_speed_max_ms": float(np.max(sp)),
                "roll_max_deg": float(np.degrees(np.max(np.abs(self.flange_angles[:, 0])))),
                "pitch_max_deg": float(np.degrees(np.max(np.abs(self.flange_angles[:, 1])))),
                "tension_max_kn": float(self.tension[i, j]) / 1e3, "tension_max_line": self.names[j],
                "tension_max_fraction_mbl": float(ratio[i, j]),
                "lines_rendered": ", ".join(n for n, p in zip(self.names, self.paid_out) if p > 0) or "none",
                "paid_out_max_m": float(np.max(self.paid_out)),
                "part_times_s": {n: float(t) for n, t in zip(self.names, self.part_times) if t == t}}

    def _figure(self):
        from matplotlib.figure import Figure

        fig = Figure(figsize=(8, 5), layout="constrained")
        ax = fig.subplots(2, 1, sharex=True)
        rel = self.flange - self.flange_reference
        for k, lab in enumerate(("x (off the berth)", "y (along)", "z (up)")):
            ax[0].plot(self.t, rel[:, k], lw=0.8, label=lab)
        ax[0].set_ylabel("flange offset [m]")
        ax[0].legend(loc="upper left", fontsize=8)
        j = int(np.argmax(np.max(self.tension / self.mbl, axis=0)))
        ax[1].plot(self.t, self.tension[:, j] / 1e3, lw=0.8, color="0.3", label=self.names[j])
        ax[1].axhline(self.mbl[j] / 1e3, color="0.5", ls="--", lw=0.8, label="MBL")
        ax[1].set_ylabel("tension [kN]")
        ax[1].set_xlabel("time [s]")
        ax[1].legend(loc="upper left", fontsize=8)
        return fig


def _at_flange(ship: ShipModel, six, axis: int = -1):
    """The first-order motion of the flange (``x + rot x r``, ship frame) from the centre of gravity's six
    (surge, sway, heave, roll, pitch, yaw along ``axis``): time samples or complex amplitudes alike."""
    six = np.moveaxis(six, axis, -1)
    out = six[..., :3] + np.cross(six[..., 3:], ship.manifold - ship.cog)
    return np.moveaxis(out, -1, axis)


@njit(cache=True, nogil=True)
def _flange_xyz(pose, d, psi0, origin, manifold, z0, out):
    """Berth-frame flange positions ``out[(n, 3)]`` from the low-frequency pose and the first-order flange
    displacement ``d`` (ship frame): one compiled pass (found: the vectorised expression's cosines, sines and
    seven temporaries were a twelfth of an hourly state's cost)."""
    for i in range(pose.shape[0]):
        psi = psi0 + pose[i, 2]
        c, s = math.cos(psi), math.sin(psi)
        lx = manifold[0] + d[i, 0]
        ly = manifold[1] + d[i, 1]
        out[i, 0] = origin[0] + pose[i, 0] + c * lx - s * ly
        out[i, 1] = origin[1] + pose[i, 1] + s * lx + c * ly
        out[i, 2] = z0 + d[i, 2]


def _flange_position(ship: ShipModel, pose, d) -> np.ndarray:
    """Berth-frame flange position (n, 3) from the low-frequency pose and the first-order flange displacement
    ``d`` (ship frame)."""
    mo = ship.moorings
    out = np.empty((pose.shape[0], 3))
    _flange_xyz(pose, d, mo.psi0, mo.origin, ship.manifold, ship.manifold[2] - ship.draft, out)
    return out


def flange_kinematics(ship: ShipModel, pose, pose_v, wave, wave_v):
    """Berth-frame flange position, velocity and face angles from the two motions."""
    d, dv = _at_flange(ship, wave), _at_flange(ship, wave_v)  # first-order flange motion, ship frame
    p = _flange_position(ship, pose, d)
    psi = ship.moorings.psi0 + pose[:, 2]
    c, s = np.cos(psi), np.sin(psi)
    lx, ly = ship.manifold[0] + d[:, 0], ship.manifold[1] + d[:, 1]
    r_dot = pose_v[:, 2]
    vx = pose_v[:, 0] - r_dot * (s * lx + c * ly) + c * dv[:, 0] - s * dv[:, 1]
    vy = pose_v[:, 1] + r_dot * (c * lx - s * ly) + s * dv[:, 0] + c * dv[:, 1]
    return p, np.stack([vx, vy, dv[:, 2]], axis=1), ship_angles(pose, wave)


def ship_angles(pose, wave) -> np.ndarray:
    """The ship's roll, pitch and yaw at the manifold (yaw from the mean heading), rad, shape (n, 3): the
    first-order roll and pitch, the low-frequency yaw plus the first-order yaw.

    Parameters
    ----------
    pose : ndarray (n, 3)
        The low-frequency pose (x, y, yaw).
    wave : ndarray (n, 6)
        The first-order motion of the centre of gravity.

    Returns
    -------
    ndarray (n, 3)
    """
    return np.stack([wave[:, 3], wave[:, 4], pose[:, 2] + wave[:, 5]], axis=1)


def mean_load(ship: ShipModel, env: Environment) -> np.ndarray:
    """Steady load (berth frame, about midships) of the mean wind, the current and the mean wave drift, at the
    reference heading.

    Parameters
    ----------
    ship : ShipModel
    env : Environment

    Returns
    -------
    ndarray (3,)
    """
    psi = ship.psi0
    th_w = math.radians(env.wind_direction_deg) - psi
    f = wind_force(ship.kind, env.wind_speed, th_w, ship.frontal_area, ship.lateral_area, ship.centroid_x,
                   ship.length)
    f = f + current_force(ship.current_kx, ship.current_ky, ship.length, env.current_speed,
                          math.radians(env.current_direction_deg) - psi)
    if env.hs > 0:

        w, th = MEAN_DRIFT_OMEGA, MEAN_DRIFT_DIRECTION
        # the density is separable, S(w) D(theta): the double trapezoid as two weighted contractions
        sw = jonswap(w, env.hs, env.tp) * _MEAN_DRIFT_WEIGHTS[0]
        dth = spreading(th, math.radians(env.wave_direction_deg), env.spreading) * _MEAN_DRIFT_WEIGHTS[1]
        grid = ship.mean_drift_grid                                  # (frequency, direction, 3)
        f = f + 2 * (dth @ (sw @ grid.reshape(sw.size, -1)).reshape(dth.size, 3))   # two matrix-vector products
    c, s = math.cos(psi), math.sin(psi)
    return np.array([c * f[0] - s * f[1], s * f[0] + c * f[1], f[2]])


def _trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Weights ``q`` with ``sum(q * f) = trapezoid(f, x)``."""
    dx = np.diff(x)
    q = np.zeros_like(x)
    q[:-1] += dx / 2
    q[1:] += dx / 2
    return q


_MEAN_DRIFT_WEIGHTS = (_trapezoid_weights(MEAN_DRIFT_OMEGA), _trapezoid_weights(MEAN_DRIFT_DIRECTION))


def _lengths(duration: float, dt: float) -> tuple[int, int]:
    """Output samples and FFT length of a record (at least :data:`MIN_RECORD` long)."""
    if not (duration > 0 and math.isfinite(duration)):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    n_out = int(round(duration / dt)) + 1
    return n_out, fft_length(max(n_out, int(math.ceil(MIN_RECORD / dt))))


def _sea(ship: ShipModel, env: Environment, n: int, dt: float, rng: np.random.Generator):
    """The realised sea up to the RAO grid's top frequency (above it the ship answers nothing), the components'
    headings relative to the ship and their complex amplitudes (``e^{-i w t}``)."""
    comp = wave_components(env, n, dt, rng, omega_max=float(ship.hydro.omega[-1]))
    return comp, comp.direction - ship.moorings.psi0, comp.amplitude * np.exp(-1j * comp.phase)


def _wave_coefficients(ship: ShipModel, comp: WaveComponents, beta, z) -> np.ndarray:
    """Complex amplitudes of the first-order motion of the centre of gravity, (6, components), ship frame."""
    h = ship.hydro
    return (interp_heading(ship.rao, h.heading, h.omega, comp.omega, beta) * z[:, None]).T


def _load_every(n: int, n_out: int, stride: int, i_part: int) -> int:
    """Every how many output samples the integration reads the low-frequency load: half a step when every
    step is whole (the record a whole number of steps, the lines parting, if at all, at a step's end) and the
    FFT length a multiple of it, else 1 (found: the load's inverse FFT on all n samples, nine in ten of them
    never read, was a twentieth of an hourly state)."""
    h = stride // 2
    whole = stride % 2 == 0 and (n_out - 1) % stride == 0 and (i_part >= n_out or i_part % stride == 0)
    return h if whole and h > 1 and n % h == 0 else 1


def _lf_load(ship: ShipModel, env: Environment, comp: WaveComponents, beta, n: int, n_out: int, dt: float,
             rng: np.random.Generator, every: int = 1) -> np.ndarray:
    """The low-frequency load (ship frame, (n_out - 1) // every + 1 samples by 3, every ``every``-th output
    sample): Newman slow drift, the set-down's (:mod:`loadarm.ship.longwave`) and the wind with its gusts, over the whole (periodic) FFT record, then
    low-passed (the sum-frequency part of Newman's square is not slow drift, and a moored ship does not answer
    faster loads); the current acts in the integration. The low-passed load is a trigonometric sum of the
    first ``k_cut`` bins: on ``n / every`` samples of the same period (``every`` divides ``n``, and
    ``k_cut`` is below that grid's Nyquist bin) its inverse FFT gives the same sum at every ``every``-th
    sample."""
    h = ship.hydro
    k_cut = int(np.searchsorted(2 * math.pi * np.fft.rfftfreq(n, dt), LF_CUTOFF, side="right"))
    band = np.zeros((3, k_cut), dtype=complex)                 # the low-passed load's FFT bins, as on n samples
    if env.hs > 0:
        tt = interp_heading(ship.drift, h.heading, h.omega, comp.omega, beta)                  # (nc, 3)
        mean_j = np.sum(comp.amplitude[:, None] ** 2 * tt, axis=0)
        coef = (comp.amplitude[:, None] * np.sqrt(np.abs(tt))).T * np.exp(-1j * comp.phase)
        # Newman's square has nothing above twice the highest component (bin 2K): on m >= 2K + k_cut samples of
        # the same period no alias falls into the low-passed band, which is then exact (found: the square on all
        # n samples was a fifth of an hourly state's cost, for bins that are dropped)
        m = fft_length(2 * coef.shape[1] + k_cut + 2)
        sq = _synth(coef, m)
        sq *= sq
        band += (2.0 * np.sign(mean_j))[:, None] * rfft(sq, axis=-1)[:, :k_cut] * (n / m)
        if ship.long_waves:                                    # the set-down, which Newman's leaves out
            rot = _rot3(ship.psi0)
            band += setdown_load(rot.T @ ship.mass_lf @ rot, comp.omega, comp.amplitude, comp.phase, beta,
                                 ship.water_depth, (ship.length, ship.beam), n, k_cut)
    if env.wind_speed > 0:
        df = 1.0 / (n * dt)
        f = df * np.arange(1, n // 2)
        amp = np.sqrt(2.0 * npd_spectrum(f, env.wind_speed) * df)
        coef = np.empty(f.size, dtype=complex)
        _phasors(amp, rng.uniform(0, 2 * math.pi, f.size), coef)
        gust = _synth(coef, n)
        speed = np.maximum(env.wind_speed + gust, 0.0)
        # the wind load is the square of the speed times a constant vector (the direction is the mean wind's):
        # one transform of the square instead of three of the loads
        per_v2 = wind_force(ship.kind, 1.0, math.radians(env.wind_direction_deg) - ship.moorings.psi0,
                            ship.frontal_area, ship.lateral_area, ship.centroid_x, ship.length)
        band += per_v2[:, None] * rfft(speed * speed)[None, :k_cut]
    nc = n // every
    if not (n % every == 0 and k_cut <= nc // 2):
        raise ValueError(f"every={every} does not divide the FFT length {n} or leaves the load's band out")
    spec = np.zeros((3, nc // 2 + 1), dtype=complex)
    spec[:, :k_cut] = band
    return np.ascontiguousarray(irfft(spec, nc, axis=-1)[:, :(n_out - 1) // every + 1].T / every)


def _lf_stride(ship: ShipModel, dt: float) -> int:
    """Output samples per low-frequency integration step."""
    return max(1, int(round(ship.lf_step / dt)))


def _lf_motion(ship: ShipModel, env: Environment, f_ship: np.ndarray, every: int, n_out: int, eq: np.ndarray,
               dt: float, alive0, alive1, i_part: int, *, rates: bool = True, stretch=None):
    """Integrate the low-frequency pose over ``n_out`` samples under ``f_ship`` (every ``every``-th sample's);
    with ``rates`` False only the pose (its rate and the line tensions come back empty). ``stretch``: the lines'
    first-order elongation per output sample (lines, n_out), contiguous, or None. Returns the pose, its rate, the tensions,
    each line's sample of parting (-1 intact), the length its brake paid out and its largest tension."""
    mo = ship.moorings
    nl = len(mo.names)
    pose = np.empty((n_out, 3))
    pose_v = np.empty((n_out if rates else 0, 3))
    tension = np.empty((n_out if rates else 0, nl))
    part_at = np.empty(nl, dtype=np.int64)
    paid = np.empty(nl)
    tmax = np.empty(nl)
    cur = math.radians(env.current_direction_deg)
    _lf_integrate(eq.copy(), np.zeros(3), f_ship, every, dt, _lf_stride(ship, dt),
                  np.linalg.inv(ship.mass_lf), ship.damping_lf, mo.lines_at(rise_of(env)), mo.table, mo.e_brake,
                  mo.e_break, mo.brake, np.zeros((nl, 0)) if stretch is None else stretch,
                  alive0, alive1, i_part, mo.fender_y, mo.fender_defl, mo.fender_load, mo.fender_npts,
                  mo.fender_prop, mo.hull,
                  mo.psi0, mo.origin, env.current_speed * math.cos(cur), env.current_speed * math.sin(cur),
                  ship.current_kx, ship.current_ky, E_C * ship.length, pose, pose_v, tension, part_at, paid, tmax)
    return pose, pose_v, tension, part_at, paid, tmax


def rise_of(env: Environment) -> float:
    """How far the fairleads stand above where they were when the lines were tended: the tide less the draft
    change, m.

    Parameters
    ----------
    env : Environment

    Returns
    -------
    float
    """
    return float(env.tide - env.draft_change)


def _stretch(ship: ShipModel, wave: np.ndarray, eq, rise: float) -> np.ndarray:
    """The lines' first-order elongation, (lines, samples) and contiguous, as the integration reads it (``wave``
    is the synthesis's transposed view: ``C^T wave^T`` needs no copy)."""
    return np.ascontiguousarray(line_stretch_coefficients(ship, eq, rise).T @ wave.T)


def line_stretch_coefficients(ship: ShipModel, eq, rise: float = 0.0) -> np.ndarray:
    """How each line's length follows the first-order motion: ``dL = wave @ C`` with ``wave`` the centre of
    gravity's six (ship frame, m and rad) and ``C`` (6, lines), from the line's direction at the pose ``eq``
    (small motions: ``dL = u . (xi + theta x r)``, ``u`` the unit vector from bollard to fairlead, ``r`` the
    fairlead from the centre of gravity).

    Parameters
    ----------
    ship : ShipModel
    eq : array_like (3,)
        Low-frequency pose.
    rise : float
        m.

    Returns
    -------
    ndarray (6, lines)
    """
    mo = ship.moorings
    psi = mo.psi0 + float(eq[2])
    c, s = math.cos(psi), math.sin(psi)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    fair = mo.fairlead
    pos = np.empty_like(fair)
    pos[:, :2] = mo.origin + np.asarray(eq[:2]) + fair[:, :2] @ rot[:2, :2].T
    pos[:, 2] = fair[:, 2] - ship.draft + rise
    u = pos - mo.bollard
    u /= np.linalg.norm(u, axis=1)[:, None]
    w = u @ rot                                   # in the ship frame
    r = fair - ship.cog
    return np.vstack([w.T, np.cross(r, w).T])


def simulate(ship: ShipModel, env: Environment, duration: float, *, seed: int = 0, parted: tuple[str, ...] = (),
             part_time: float | None = None, dt: float = DT, waves: bool = True, slow: bool = True) -> ShipMotion:
    """The moored ship's motion over ``duration`` seconds.

    Parameters
    ----------
    ship : ShipModel
    env : Environment
    duration : float
        s.
    seed : int
    parted : tuple of str
        Lines that part at ``part_time``.
    part_time : float, optional
        s from the start.
    dt : float
        Output and integration step, s.
    waves : bool
        Include the first-order wave motion.
    slow : bool
        Include the low-frequency motion (else the ship stays at its mean pose).

    Returns
    -------
    ShipMotion

    Raises
    ------
    ConfigError
        A parted line that is not in the berth, or no mean equilibrium (the moorings cannot hold the ship).
    """

    n_out, n = _lengths(duration, dt)
    mo = ship.moorings
    alive0 = mo.alive
    alive1 = mo.parted(parted) if parted else alive0
    rise = rise_of(env)
    rng = np.random.default_rng(seed)
    comp, beta, z = _sea(ship, env, n, dt, rng)
    if waves and env.hs > 0:
        coef = _wave_coefficients(ship, comp, beta, z)
        wave = _synth(coef, n)[:, :n_out].T
        wave_v = _synth(-1j * comp.omega * coef, n)[:, :n_out].T
    else:
        wave = np.zeros((n_out, 6))
        wave_v = np.zeros((n_out, 6))
    eq = equilibrium(mo, mean_load(ship, env), eta0=ship.eq0, rise=rise)
    t = np.arange(n_out) * dt
    stretch = _stretch(ship, wave, eq, rise) if waves and env.hs > 0 else None
    if slow:
        i_part = n_out + 1 if part_time is None or not parted else int(math.ceil(part_time / dt - 1e-9))
        every = _load_every(n, n_out, _lf_stride(ship, dt), i_part)
        f_ship = _lf_load(ship, env, comp, beta, n, n_out, dt, rng, every)
        f_ship = add_passing_load(f_ship, ship, every, dt)      # deterministic and slow: no low-pass
        pose, pose_v, tension, part_at, paid, _ = _lf_motion(ship, env, f_ship, every, n_out, eq, dt, alive0,
                                                             alive1, i_part, stretch=stretch)
    else:
        pose = np.tile(eq, (n_out, 1))
        pose_v = np.zeros((n_out, 3))
        t_eq = line_tensions(mo, eq, rise=rise)
        tension = np.tile(t_eq, (n_out, 1))
        if stretch is not None:
            e_eq = np.array([float(line_elongation(t_eq[i], mo.segments[i])) for i in range(len(mo.names))])
            tension = np.minimum(np.column_stack([mo.tension_of(i, e_eq[i] + stretch[i])
                                                  for i in range(len(mo.names))]), mo.brake)
        part_at, paid = np.full(len(mo.names), -1), np.zeros(len(mo.names))
    flange, flange_v, angles = flange_kinematics(ship, pose, pose_v, wave, wave_v)
    ref, _, _ = flange_kinematics(ship, eq[None, :], np.zeros((1, 3)), np.zeros((1, 6)), np.zeros((1, 6)))
    part_times = np.where(part_at >= 0, part_at * dt, np.nan)
    order = np.argsort(np.where(part_at >= 0, part_at, np.iinfo(np.int64).max), kind="stable")
    return ShipMotion(t=t, pose=pose, pose_velocity=pose_v, wave=wave, wave_velocity=wave_v, flange=flange,
                      flange_velocity=flange_v, flange_angles=angles, tension=tension, names=mo.names, mbl=mo.mbl,
                      parted=tuple(mo.names[i] for i in order if part_at[i] >= 0),
                      part_time=part_time if parted else None, mean_pose=eq, flange_reference=ref[0],
                      part_times=part_times, paid_out=paid, brake=mo.brake, breaking_load=mo.breaking_load)


def flange_positions(ship: ShipModel, env: Environment, duration: float, *, seed: int = 0, dt: float = DT) \
        -> tuple[np.ndarray, np.ndarray]:
    """The flange's berth-frame position alone, intact moorings: what :func:`simulate` with the same seed gives
    as ``flange`` and ``flange_reference`` (the same sea, loads, line events and low-frequency motion), for the
    operability kernel. Cheaper: the six first-order motions without their rates (six FFTs instead of twelve),
    and no rates or tensions are kept.

    Parameters
    ----------
    ship : ShipModel
    env : Environment
    duration : float
        s.
    seed : int
    dt : float
        s.

    Returns
    -------
    flange : ndarray (n, 3)
        Berth frame, m.
    reference : ndarray (3,)
        The flange at the mean equilibrium, calm water.
    """
    flange, reference, _ = _state(ship, env, duration, seed, dt, loads=False)
    return flange, reference


@dataclass(frozen=True)
class StateLoads:
    """What a terminal judges a moored state by (:func:`moored_state`): the lines, the fenders, the ship's
    motions (PIANC's measures).

    Attributes
    ----------
    tension_max : ndarray (lines,)
        Each line's largest tension, first-order motion included, N.
    fender_max : ndarray (fenders,)
        Each fender's largest reaction on its loading curve (on the low-frequency pose, 1 s samples), N.
    fender_deflection_max : ndarray (fenders,)
        Each fender's largest deflection (the same samples), m.
    surge_pp, heave_pp : float
        Peak-to-peak surge and heave of the centre of gravity, m.
    sway_off : float
        Largest move of the centre of gravity off the berth from the calm equilibrium (PIANC's zero-to-peak
        sway), m.
    roll_pp, pitch_pp, yaw_pp : float
        Peak-to-peak, rad.
    parted : int
        Lines parted in the state.
    paid_out : float
        Largest brake pay-out, m.
    """

    tension_max: np.ndarray
    fender_max: np.ndarray
    fender_deflection_max: np.ndarray
    surge_pp: float
    sway_off: float
    heave_pp: float
    roll_pp: float
    pitch_pp: float
    yaw_pp: float
    parted: int
    paid_out: float


def moored_state(ship: ShipModel, env: Environment, duration: float, *, seed: int = 0, dt: float = DT,
                 angles: bool = False):
    """:func:`flange_positions` and the state's loads and motions (:class:`StateLoads`), for the operability
    judged by the terminal's criteria; with ``angles``, the ship's roll, pitch and yaw at the manifold too (what
    :func:`simulate` gives as ``flange_angles``: a bank's flanges turn with them).

    Parameters
    ----------
    ship : ShipModel
    env : Environment
    duration : float
        s.
    seed : int
    dt : float
        s.
    angles : bool
        Return the angles too.

    Returns
    -------
    flange : ndarray (n, 3)
    reference : ndarray (3,)
    loads : StateLoads
    angles : ndarray (n, 3)
        Only with ``angles``: rad.
    """
    return _state(ship, env, duration, seed, dt, loads=True, angles=angles)


def _ranges(ship: ShipModel, pose: np.ndarray, wave: np.ndarray) -> tuple[float, ...]:
    """Surge and heave peak to peak, the move off the berth, roll, pitch and yaw peak to peak, of the centre of
    gravity (the low-frequency pose turned into the ship frame plus the first-order motion)."""
    mo = ship.moorings
    c, s = math.cos(mo.psi0), math.sin(mo.psi0)
    dx, dy = pose[:, 0] - ship.eq0[0], pose[:, 1] - ship.eq0[1]
    surge = c * dx + s * dy + wave[:, 0]
    sway = -s * dx + c * dy + wave[:, 1]
    off = c * surge - s * sway                                 # the move's berth x: off the berth
    yaw = pose[:, 2] + wave[:, 5]

    def pp(v):
        return float(np.max(v) - np.min(v)) if v.size else 0.0

    return (pp(surge), max(float(np.max(off)), 0.0), pp(wave[:, 2]), pp(wave[:, 3]), pp(wave[:, 4]), pp(yaw))


def _state(ship: ShipModel, env: Environment, duration: float, seed: int, dt: float, *, loads: bool,
           angles: bool = False):
    """The flange and, with ``loads``, the state's :class:`StateLoads` (one sea, one integration); with
    ``angles``, the ship's angles (:func:`ship_angles`) last."""
    n_out, n = _lengths(duration, dt)
    mo = ship.moorings
    rng = np.random.default_rng(seed)
    comp, beta, z = _sea(ship, env, n, dt, rng)
    rise = rise_of(env)
    eq = equilibrium(mo, mean_load(ship, env), eta0=ship.eq0, rise=rise)
    if env.hs > 0:
        coef = _wave_coefficients(ship, comp, beta, z)
        wave = _synth(coef, n)[:, :n_out].T
        d = _at_flange(ship, wave)
        stretch = _stretch(ship, wave, eq, rise)
    else:
        wave = np.zeros((n_out, 6))
        d = np.zeros((n_out, 3))
        stretch = None
    every = _load_every(n, n_out, _lf_stride(ship, dt), n_out + 1)
    f_ship = _lf_load(ship, env, comp, beta, n, n_out, dt, rng, every)
    f_ship = add_passing_load(f_ship, ship, every, dt)          # deterministic and slow: no low-pass
    pose, _, _, part_at, paid, tmax = _lf_motion(ship, env, f_ship, every, n_out, eq, dt, mo.alive, mo.alive,
                                                 n_out + 1, rates=False, stretch=stretch)
    flange = _flange_position(ship, pose, d)
    reference = _flange_position(ship, eq[None, :], np.zeros((1, 3)))[0]
    if not loads:
        return flange, reference, None
    step = max(1, int(round(1.0 / dt)))
    fenders = fender_loads(mo, pose[::step])
    deflections = fender_deflections(mo, pose[::step])
    surge, off, heave, roll, pitch, yaw = _ranges(ship, pose, wave)
    state = StateLoads(tmax, np.max(fenders, axis=0), np.max(deflections, axis=0), surge, off, heave, roll, pitch,
                       yaw, int(np.sum(part_at >= 0)), float(np.max(paid)))
    return (flange, reference, state, ship_angles(pose, wave)) if angles else (flange, reference, state)
