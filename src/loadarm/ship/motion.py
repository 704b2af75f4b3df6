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
from numba import njit
from scipy.fft import irfft, next_fast_len, rfft

from ..berth import Environment
from ..results import Metric, Result
from .loads import E_C, current_force, jonswap, npd_spectrum, sample_directions, wind_force
from .model import ShipModel
from .mooring import _restoring

__all__ = ["ShipMotion", "simulate", "MIN_RECORD", "DT", "wave_components", "fft_length"]

#: Shortest record synthesised, s (frequency step 2 pi / 1800 s: 0.0035 rad/s).
MIN_RECORD = 1800.0
#: Output step, s (10 Hz).
DT = 0.1
#: Loads on the low-frequency motion are low-passed at this frequency, rad/s (a 10 s period: twice the highest
#: moored natural frequency of a large ship, and well above slow drift's difference frequencies).
LF_CUTOFF = 0.6


def _interp_heading(table: np.ndarray, heading: np.ndarray, omega_grid: np.ndarray, w: np.ndarray,
                    beta: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of ``table[(nw, nb, ...)]`` at (w, beta); zero above the grid's top frequency,
    the lowest frequency's value below it; headings periodic."""
    nb = heading.size
    bb = np.mod(beta, 2 * math.pi)
    hp = np.concatenate([heading, [2 * math.pi]])
    j = np.clip(np.searchsorted(hp, bb, side="right") - 1, 0, nb - 1)
    fb = (bb - hp[j]) / (hp[j + 1] - hp[j])
    j1 = (j + 1) % nb
    wi = np.clip(w, omega_grid[0], omega_grid[-1])
    i = np.clip(np.searchsorted(omega_grid, wi, side="right") - 1, 0, omega_grid.size - 2)
    fw = (wi - omega_grid[i]) / (omega_grid[i + 1] - omega_grid[i])
    extra = (slice(None),) + (None,) * (table.ndim - 2)
    fw, fb = fw[extra], fb[extra]
    out = ((1 - fw) * ((1 - fb) * table[i, j] + fb * table[i, j1])
           + fw * ((1 - fb) * table[i + 1, j] + fb * table[i + 1, j1]))
    out[w > omega_grid[-1]] = 0
    return out


@dataclass(frozen=True)
class WaveComponents:
    """The realised sea on the FFT grid: frequency, amplitude, direction (berth frame, towards), phase."""

    omega: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    phase: np.ndarray
    n: int


def wave_components(env: Environment, n: int, dt: float, rng: np.random.Generator, gamma: float = 3.3) \
        -> WaveComponents:
    """Draw the sea's components on the FFT grid of ``n`` samples ``dt`` apart.

    Parameters
    ----------
    env : Environment
    n : int
    dt : float
    rng : numpy.random.Generator
    gamma : float

    Returns
    -------
    WaveComponents
    """
    dw = 2 * math.pi / (n * dt)
    w = dw * np.arange(1, n // 2)
    a = np.sqrt(2.0 * jonswap(w, env.hs, env.tp, gamma) * dw)
    direction = sample_directions(rng, w.size, math.radians(env.wave_direction_deg), env.spreading)
    phase = rng.uniform(0.0, 2 * math.pi, w.size)
    return WaveComponents(w, a, direction, phase, n)


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
    """``Re sum_k coef_k exp(-i w_k t)`` on the grid (coef for k = 1 .. n//2 - 1, last axis time)."""
    c = np.zeros(coef.shape[:-1] + (n // 2 + 1,), dtype=complex)
    c[..., 1:coef.shape[-1] + 1] = np.conj(coef)
    return irfft(c, n, axis=-1) * n / 2


@njit(cache=True, nogil=True)
def _lf_rhs(x0, x1, x2, v0, v1, v2, f0, f1, f2, minv, damp, fair, height, boll, ea, l0, alive, fy, fdefl, fload,
            fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xbuf, out_f, ten):
    """Acceleration (3 floats) of the low-frequency pose: scalars in and out, no allocation (the 10 Hz
    integration calls it four times a step)."""
    xbuf[0], xbuf[1], xbuf[2] = x0, x1, x2
    _restoring(xbuf, fair, height, boll, ea, l0, alive, fy, fdefl, fload, fn, side, psi0, origin, out_f, ten)
    psi = psi0 + x2
    c, s = math.cos(psi), math.sin(psi)
    # external ship-frame load rotated to the berth frame
    fx = out_f[0] + c * f0 - s * f1
    fyy = out_f[1] + s * f0 + c * f1
    mz = out_f[2] + f2
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


@njit(cache=True, nogil=True)
def _lf_integrate(x0, v0, f_ship, dt, stride, minv, damp, fair, height, boll, ea, l0, alive0, alive1, i_part, fy,
                  fdefl, fload, fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xs, vs, tens):
    """RK4 of the low-frequency pose, ``stride`` output samples per step (the load taken at its samples at the
    step's start, middle and end: it is low-passed first, :data:`LF_CUTOFF`); the samples between from the cubic
    Hermite of the step's ends (error of order ``(w h)^4 / 384``: below 1e-4 of the motion for the 19 s and longer
    periods of a moored ship at :data:`LF_STEP`), their tensions interpolated linearly. A step ends exactly where
    the lines part (``i_part``: from there ``alive1``) and at the last sample. The tensions between two steps are
    filled once the next step's first stage has the end's."""
    n = f_ship.shape[0]
    nl = fair.shape[0]
    out_f = np.zeros(3)
    ten = np.zeros(nl)
    ten0 = np.zeros(nl)
    xbuf = np.zeros(3)
    a0, a1, a2 = x0[0], x0[1], x0[2]
    b0, b1, b2 = v0[0], v0[1], v0[2]
    k = 0
    k_prev = -1
    while True:
        alive = alive1 if k >= i_part else alive0
        xs[k, 0], xs[k, 1], xs[k, 2] = a0, a1, a2
        vs[k, 0], vs[k, 1], vs[k, 2] = b0, b1, b2
        p0, p1, p2 = f_ship[k, 0], f_ship[k, 1], f_ship[k, 2]
        k1 = _lf_rhs(a0, a1, a2, b0, b1, b2, p0, p1, p2, minv, damp, fair, height, boll, ea, l0, alive, fy, fdefl,
                     fload, fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xbuf, out_f, ten)
        for j in range(nl):                      # the first stage is at the step's own pose: its tensions
            tens[k, j] = ten[j]
        if k_prev >= 0:                          # the previous step's samples between: tensions interpolated
            m_prev = k - k_prev
            for i in range(1, m_prev):
                u = i / m_prev
                for j in range(nl):
                    tens[k_prev + i, j] = (1 - u) * ten0[j] + u * ten[j]
        for j in range(nl):
            ten0[j] = ten[j]
        if k == n - 1:
            break
        k2 = min(k + stride, n - 1)
        if k < i_part < k2:
            k2 = i_part
        m = k2 - k
        big = m * dt
        q0, q1, q2 = f_ship[k2, 0], f_ship[k2, 1], f_ship[k2, 2]
        if m % 2 == 0:
            km = k + m // 2
            m0, m1, m2 = f_ship[km, 0], f_ship[km, 1], f_ship[km, 2]
        else:
            kl = k + m // 2
            m0 = 0.5 * (f_ship[kl, 0] + f_ship[kl + 1, 0])
            m1 = 0.5 * (f_ship[kl, 1] + f_ship[kl + 1, 1])
            m2 = 0.5 * (f_ship[kl, 2] + f_ship[kl + 1, 2])
        h = 0.5 * big
        x20, x21, x22 = a0 + h * b0, a1 + h * b1, a2 + h * b2
        v20, v21, v22 = b0 + h * k1[0], b1 + h * k1[1], b2 + h * k1[2]
        k2s = _lf_rhs(x20, x21, x22, v20, v21, v22, m0, m1, m2, minv, damp, fair, height, boll, ea, l0, alive, fy,
                      fdefl, fload, fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xbuf, out_f, ten)
        x30, x31, x32 = a0 + h * v20, a1 + h * v21, a2 + h * v22
        v30, v31, v32 = b0 + h * k2s[0], b1 + h * k2s[1], b2 + h * k2s[2]
        k3 = _lf_rhs(x30, x31, x32, v30, v31, v32, m0, m1, m2, minv, damp, fair, height, boll, ea, l0, alive, fy,
                     fdefl, fload, fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xbuf, out_f, ten)
        x40, x41, x42 = a0 + big * v30, a1 + big * v31, a2 + big * v32
        v40, v41, v42 = b0 + big * k3[0], b1 + big * k3[1], b2 + big * k3[2]
        k4 = _lf_rhs(x40, x41, x42, v40, v41, v42, q0, q1, q2, minv, damp, fair, height, boll, ea, l0, alive, fy,
                     fdefl, fload, fn, side, psi0, origin, cur_vx, cur_vy, kx, ky, el, xbuf, out_f, ten)
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
        N.
    names : tuple of str
        Line names.
    mbl : ndarray (lines,)
    parted : tuple of str
    part_time : float or None
    mean_pose : ndarray (3,)
        Static equilibrium under the mean loads (intact).
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
                "tension_max_fraction_mbl": float(ratio[i, j])}

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


def _flange(ship: ShipModel, pose, pose_v, wave, wave_v):
    """Berth-frame flange position, velocity and face angles from the two motions."""
    mo = ship.moorings
    r = ship.manifold - ship.cog                              # CoG to flange, ship frame
    rot = wave[:, 3:]
    d = wave[:, :3] + np.cross(rot, r)                        # first-order flange displacement, ship frame
    dv = wave_v[:, :3] + np.cross(wave_v[:, 3:], r)
    psi = mo.psi0 + pose[:, 2]
    c, s = np.cos(psi), np.sin(psi)
    lx = ship.manifold[0] + d[:, 0]
    ly = ship.manifold[1] + d[:, 1]
    px = mo.origin[0] + pose[:, 0] + c * lx - s * ly
    py = mo.origin[1] + pose[:, 1] + s * lx + c * ly
    pz = ship.manifold[2] - ship.draft + d[:, 2]
    r_dot = pose_v[:, 2]
    vx = pose_v[:, 0] - r_dot * (s * lx + c * ly) + c * dv[:, 0] - s * dv[:, 1]
    vy = pose_v[:, 1] + r_dot * (c * lx - s * ly) + s * dv[:, 0] + c * dv[:, 1]
    angles = np.stack([wave[:, 3], wave[:, 4], pose[:, 2] + wave[:, 5]], axis=1)
    return np.stack([px, py, pz], axis=1), np.stack([vx, vy, dv[:, 2]], axis=1), angles


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
        w = np.linspace(0.05, 2.5, 246)                     # 0.01 rad/s; the spectra are smooth on it
        th = np.linspace(-math.pi, math.pi, 73)             # 5 deg
        from .loads import spreading

        dens = jonswap(w, env.hs, env.tp)[:, None] * spreading(th, math.radians(env.wave_direction_deg),
                                                               env.spreading)[None, :]
        beta = (th[None, :] - psi) * np.ones_like(w)[:, None]
        tt = _interp_heading(ship.drift, ship.hydro.heading, ship.hydro.omega, np.repeat(w, th.size),
                             beta.ravel()).reshape(w.size, th.size, 3)
        f = f + 2 * np.trapezoid(np.trapezoid(dens[..., None] * tt, th, axis=1), w, axis=0)
    c, s = math.cos(psi), math.sin(psi)
    return np.array([c * f[0] - s * f[1], s * f[0] + c * f[1], f[2]])


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
    from .mooring import equilibrium

    if not (duration > 0 and math.isfinite(duration)):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    mo = ship.moorings
    alive0 = mo.alive
    alive1 = mo.parted(parted) if parted else alive0
    n_out = int(round(duration / dt)) + 1
    n = fft_length(max(n_out, int(math.ceil(MIN_RECORD / dt))))
    rng = np.random.default_rng(seed)
    comp = wave_components(env, n, dt, rng)
    # wave-frequency motion of the CoG (ship frame) from the RAOs, at the ship's reference heading
    beta = comp.direction - mo.psi0
    z = comp.amplitude * np.exp(-1j * comp.phase)                         # complex amplitude (e^{-i w t})
    h = ship.hydro
    # the RAOs and drift coefficients are zero above the grid's top frequency: interpolated only below it
    band = comp.omega <= h.omega[-1]
    if waves and env.hs > 0:
        r = np.zeros((comp.omega.size, 6), dtype=complex)
        r[band] = _interp_heading(ship.rao, h.heading, h.omega, comp.omega[band], beta[band])     # (nc, 6)
        coef = (r * z[:, None]).T                                               # (6, nc)
        wave = _synth(coef, n)[:, :n_out].T
        wave_v = _synth(-1j * comp.omega * coef, n)[:, :n_out].T
    else:
        wave = np.zeros((n_out, 6))
        wave_v = np.zeros((n_out, 6))
    mean = mean_load(ship, env)
    eq = equilibrium(mo, mean, eta0=ship.eq0)
    t = np.arange(n_out) * dt
    if slow:
        # Newman slow drift (ship frame), wind with gusts (ship frame), over the whole (periodic) FFT record, then
        # low-passed (the sum-frequency part of Newman's square is not slow drift, and a moored ship does not
        # answer faster loads); the current acts in the integration
        f_full = np.zeros((n, 3))
        if env.hs > 0:
            tt = np.zeros((comp.omega.size, 3))
            tt[band] = _interp_heading(ship.drift, h.heading, h.omega, comp.omega[band], beta[band])   # (nc, 3)
            mean_j = np.sum(comp.amplitude[:, None] ** 2 * tt, axis=0)
            sq = _synth((comp.amplitude[:, None] * np.sqrt(np.abs(tt))).T * np.exp(-1j * comp.phase), n)
            f_full += (np.sign(mean_j)[:, None] * 2.0 * sq ** 2).T
        if env.wind_speed > 0:
            df = 1.0 / (n * dt)
            f = df * np.arange(1, n // 2)
            amp = np.sqrt(2.0 * npd_spectrum(f, env.wind_speed) * df)
            gust = _synth(amp * np.exp(-1j * rng.uniform(0, 2 * math.pi, f.size)), n)
            speed = np.maximum(env.wind_speed + gust, 0.0)
            f_full += wind_force(ship.kind, speed, math.radians(env.wind_direction_deg) - mo.psi0, ship.frontal_area,
                                 ship.lateral_area, ship.centroid_x, ship.length)
        spec = rfft(f_full, axis=0)
        spec[2 * math.pi * np.fft.rfftfreq(n, dt) > LF_CUTOFF] = 0.0
        f_ship = np.ascontiguousarray(irfft(spec, n, axis=0)[:n_out])
        cur = math.radians(env.current_direction_deg)
        pose = np.empty((n_out, 3))
        pose_v = np.empty((n_out, 3))
        tension = np.empty((n_out, len(mo.names)))
        i_part = n_out + 1 if part_time is None or not parted else int(math.ceil(part_time / dt - 1e-9))
        _lf_integrate(eq.copy(), np.zeros(3), f_ship, dt, max(1, int(round(ship.lf_step / dt))), np.linalg.inv(ship.mass_lf),
                      ship.damping_lf, mo.fairlead,
                      mo.height, mo.bollard, mo.ea, mo.l0, alive0, alive1, i_part, mo.fender_y, mo.fender_defl,
                      mo.fender_load, mo.fender_npts, mo.side, mo.psi0, mo.origin,
                      env.current_speed * math.cos(cur), env.current_speed * math.sin(cur), ship.current_kx,
                      ship.current_ky, E_C * ship.length, pose, pose_v, tension)
    else:
        pose = np.tile(eq, (n_out, 1))
        pose_v = np.zeros((n_out, 3))
        from .mooring import line_tensions

        tension = np.tile(line_tensions(mo, eq), (n_out, 1))
    flange, flange_v, angles = _flange(ship, pose, pose_v, wave, wave_v)
    ref, _, _ = _flange(ship, eq[None, :], np.zeros((1, 3)), np.zeros((1, 6)), np.zeros((1, 6)))
    return ShipMotion(t=t, pose=pose, pose_velocity=pose_v, wave=wave, wave_velocity=wave_v, flange=flange,
                      flange_velocity=flange_v, flange_angles=angles, tension=tension, names=mo.names, mbl=mo.mbl,
                      parted=tuple(parted), part_time=part_time if parted else None, mean_pose=eq,
                      flange_reference=ref[0])
