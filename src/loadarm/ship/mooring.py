"""Moorings and fenders: quasi-static restoring force, equilibrium and stiffness in the horizontal plane
(issue 12, item 3).

The ship's low-frequency pose is ``eta = (x, y, psi)``: the displacement of midships in the berth frame of
:mod:`loadarm.params.berth` from its reference position (the side against the fender faces, midships at
``[berth] ship_y``) and the change of heading, rad, counter-clockwise seen from above. At the reference the bow
points along berth +y (port side to) or -y (starboard side to).

* A **line** runs straight from its fairlead (ship frame, carried by the pose; its height is taken at the mean
  draft) to its bollard (berth frame). It pulls only: ``T = EA max(L - L0, 0) / L0``, with the unstretched
  length ``L0`` set so that the line holds its pretension at the reference pose. Lines may be marked parted.
* A **fender** on the fender line (berth x = 0) pushes only, along berth +x, with its load-deflection curve
  (piecewise linear; beyond the last point the last slope is kept) at the point of the ship's side abreast of it.

The force and yaw moment (about midships) are a numba kernel (:func:`restoring_force`) that the time-domain
motion calls every step; :func:`equilibrium` (Newton on the kernel) and :func:`stiffness` (central differences
of the kernel, a 3 x 3 matrix ``K = -dF/d eta``) serve the static analysis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from loadarm._numba import njit
from loadarm.errors import ConfigError
from loadarm.params.berth import Berth

__all__ = ["Moorings", "compile_moorings", "restoring_force", "equilibrium", "stiffness", "line_tensions",
           "MooringEquilibriumError"]


class MooringEquilibriumError(ConfigError):
    """The moorings cannot hold the ship against a load (no equilibrium within the search)."""


@dataclass(frozen=True)
class Moorings:
    """The berth's lines and fenders, compiled to arrays (immutable; parted lines are a mask passed in).

    Attributes
    ----------
    names : tuple of str
    fairlead : ndarray (n, 2)
        Ship frame x, y, m.
    height : ndarray (n,)
        Fairlead height minus bollard height, m (at the mean draft).
    bollard : ndarray (n, 2)
        Berth frame x, y, m.
    ea, l0, mbl, pretension : ndarray (n,)
    fender_names : tuple of str
    fender_y : ndarray (m,)
    fender_defl, fender_load : ndarray (m, k)
        Curves padded to a common length by repeating the last segment's slope.
    fender_npts : ndarray (m,) int
    side : float
        Ship-frame y of the side against the fenders (+B/2 port side to, -B/2 starboard).
    psi0 : float
        Heading at the reference pose, rad.
    origin : ndarray (2,)
        Berth x, y of midships at the reference pose.
    """

    names: tuple[str, ...]
    fairlead: np.ndarray
    height: np.ndarray
    bollard: np.ndarray
    ea: np.ndarray
    l0: np.ndarray
    mbl: np.ndarray
    pretension: np.ndarray
    fender_names: tuple[str, ...]
    fender_y: np.ndarray
    fender_defl: np.ndarray
    fender_load: np.ndarray
    fender_npts: np.ndarray
    side: float
    psi0: float
    origin: np.ndarray

    @cached_property
    def lines(self) -> np.ndarray:
        """The lines' constants as rows, one column per line, for the compiled kernel: fairlead x, y, bollard x,
        y, height, EA, L0 (ndarray (7, n), contiguous: the kernel's loop over the lines then runs on SIMD
        lanes)."""
        return np.ascontiguousarray(np.vstack([self.fairlead.T, self.bollard.T, self.height, self.ea, self.l0]))

    @property
    def alive(self) -> np.ndarray:
        """All lines intact: a fresh mask, ndarray (n,) bool."""
        return np.ones(len(self.names), dtype=np.bool_)

    def parted(self, names) -> np.ndarray:
        """The mask with the named lines parted.

        Parameters
        ----------
        names : iterable of str

        Returns
        -------
        ndarray (n,) bool

        Raises
        ------
        ConfigError
            A name that is not a line of the berth.
        """
        alive = self.alive
        for n in names:
            if n not in self.names:
                raise ConfigError(f"mooring line {n!r} is not in the berth file (lines: {', '.join(self.names)})")
            alive[self.names.index(n)] = False
        return alive


def compile_moorings(berth: Berth) -> Moorings:
    """Compile a berth's lines and fenders.

    Parameters
    ----------
    berth : Berth

    Returns
    -------
    Moorings
    """
    s = berth.ship
    port = berth.berth.side == "port"
    psi0 = math.pi / 2 if port else -math.pi / 2
    side = s.beam / 2 if port else -s.beam / 2
    origin = np.array([s.beam / 2, berth.berth.ship_y])
    fair = np.array([m.fairlead[:2] for m in berth.moorings], dtype=float)
    boll = np.array([m.bollard[:2] for m in berth.moorings], dtype=float)
    height = np.array([(m.fairlead[2] - s.draft) - m.bollard[2] for m in berth.moorings], dtype=float)
    ea = np.array([m.axial_stiffness for m in berth.moorings], dtype=float)
    t0 = np.array([m.pretension for m in berth.moorings], dtype=float)
    c, sn = math.cos(psi0), math.sin(psi0)
    p = origin + fair @ np.array([[c, sn], [-sn, c]])
    length = np.sqrt(np.sum((p - boll) ** 2, axis=1) + height ** 2)
    l0 = length / (1.0 + t0 / ea)
    k = max(len(f.deflection) for f in berth.fenders)
    defl = np.zeros((len(berth.fenders), k))
    load = np.zeros((len(berth.fenders), k))
    for i, f in enumerate(berth.fenders):
        n = len(f.deflection)
        defl[i, :n], load[i, :n] = f.deflection, f.load
        defl[i, n:], load[i, n:] = f.deflection[-1], f.load[-1]
    return Moorings(names=tuple(m.name for m in berth.moorings), fairlead=fair, height=height, bollard=boll,
                    ea=ea, l0=l0, mbl=np.array([m.mbl for m in berth.moorings], dtype=float), pretension=t0,
                    fender_names=tuple(f.name for f in berth.fenders),
                    fender_y=np.array([f.y for f in berth.fenders], dtype=float), fender_defl=defl,
                    fender_load=load, fender_npts=np.array([len(f.deflection) for f in berth.fenders]),
                    side=side, psi0=psi0, origin=origin)


@njit(cache=True, nogil=True, inline="always")
def _fender_load(d, defl, load, n):
    if d <= 0.0:
        return 0.0
    for j in range(1, n):
        if d <= defl[j] or j == n - 1:
            slope = (load[j] - load[j - 1]) / (defl[j] - defl[j - 1])
            return load[j - 1] + slope * (d - defl[j - 1])
    return 0.0


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def restoring_kernel(x, y, c, s, lines, alive, fy, fdefl, fload, fn, side, origin, out, tension, per_line):
    """The restoring force (``out``: x, y, yaw moment) and the line tensions (``tension``) at the pose ``(x, y,
    psi)``, given as ``x, y`` and the heading's cosine and sine ``c, s`` (the caller has them: one pair a
    stage); ``lines`` is :attr:`Moorings.lines`, ``per_line`` a (3, n) scratch. Each line's force is computed apart
    (a loop without a running sum, which the compiler runs on SIMD lanes; numpy's error model: no
    division-by-zero branch, the lengths are positive) and then summed in line order (the same sum, bit for
    bit, as one loop: found, 2.4 times faster for sixteen lines)."""
    cx, cy = origin[0] + x, origin[1] + y
    gxs, gys, mzs = per_line[0], per_line[1], per_line[2]
    for i in range(lines.shape[1]):
        ax, ay, h, ea, l0 = lines[0, i], lines[1, i], lines[4, i], lines[5, i], lines[6, i]
        rx = c * ax - s * ay
        ry = s * ax + c * ay
        dx, dy = cx + rx - lines[2, i], cy + ry - lines[3, i]
        length = math.sqrt(dx * dx + dy * dy + h * h)
        t = ea * (length - l0) / l0 if alive[i] and length > l0 else 0.0
        tension[i] = t
        gx, gy = -t * dx / length, -t * dy / length
        gxs[i] = gx
        gys[i] = gy
        mzs[i] = rx * gy - ry * gx
    fx = fyy = mz = 0.0
    for i in range(gxs.shape[0]):       # (found: ranging over lines.shape[1] here kept the loop above scalar)
        fx += gxs[i]
        fyy += gys[i]
        mz += mzs[i]
    # the side against the fenders: points (cx, cy) + R (u, side); abreast of a fender where berth y = fy
    qx0, qy0 = cx - s * side, cy + c * side
    for j in range(fy.shape[0]):
        u = (fy[j] - qy0) / s
        qx = qx0 + u * c
        f = _fender_load(-qx, fdefl[j], fload[j], fn[j])
        rx, ry = qx - cx, fy[j] - cy
        fx += f
        mz += -ry * f
    out[0], out[1], out[2] = fx, fyy, mz


def restoring_force(mo: Moorings, eta, alive=None) -> tuple[np.ndarray, np.ndarray]:
    """Force of the lines and fenders on the ship at a pose.

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
        Pose: x, y (m, berth frame), psi (rad).
    alive : ndarray (n,) bool, optional
        Intact lines (default all).

    Returns
    -------
    force : ndarray (3,)
        Berth-frame x, y force (N) and yaw moment about midships (N m).
    tension : ndarray (n,)
        Line tensions, N.
    """
    out = np.zeros(3)
    ten = np.zeros(len(mo.names))
    x, y, psi = (float(v) for v in np.asarray(eta, dtype=float))
    restoring_kernel(x, y, math.cos(mo.psi0 + psi), math.sin(mo.psi0 + psi), mo.lines,
               mo.alive if alive is None else alive, mo.fender_y, mo.fender_defl, mo.fender_load, mo.fender_npts,
               mo.side, mo.origin, out, ten, np.empty((3, len(mo.names))))
    return out, ten


def line_tensions(mo: Moorings, eta, alive=None) -> np.ndarray:
    """Line tensions at a pose, N.

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
    alive : ndarray (n,) bool, optional

    Returns
    -------
    ndarray (n,)
    """
    return restoring_force(mo, eta, alive)[1]


#: Central-difference steps for the stiffness: 1 mm and 1e-5 rad (a 140 m lever: 1.4 mm).
STEP = np.array([1e-3, 1e-3, 1e-5])


@njit(cache=True, nogil=True, error_model="numpy")
def _stiffness(eta, psi0, lines, alive, fy, fdefl, fload, fn, side, origin, step_d, k):
    """``k = -dF/d eta`` at the pose ``eta`` by central differences of the restoring force (steps ``step_d``),
    written into ``k`` (3, 3): :func:`stiffness`, and each iteration of :func:`_newton`."""
    nl = lines.shape[1]
    ten, per_line = np.zeros(nl), np.empty((3, nl))
    fp, fm, e = np.empty(3), np.empty(3), np.empty(3)
    for j in range(3):
        e[:] = eta
        e[j] = eta[j] + step_d[j]
        psi = psi0 + e[2]
        restoring_kernel(e[0], e[1], math.cos(psi), math.sin(psi), lines, alive, fy, fdefl, fload, fn, side, origin, fp,
                   ten, per_line)
        e[j] = eta[j] - step_d[j]
        psi = psi0 + e[2]
        restoring_kernel(e[0], e[1], math.cos(psi), math.sin(psi), lines, alive, fy, fdefl, fload, fn, side, origin, fm,
                   ten, per_line)
        for q in range(3):
            k[q, j] = -(fp[q] - fm[q]) / (2 * step_d[j])


def stiffness(mo: Moorings, eta, alive=None) -> np.ndarray:
    """Tangent stiffness ``K = -dF/d eta`` at a pose (central differences of :func:`restoring_force`, compiled:
    :func:`_stiffness`, which the equilibrium's Newton takes too).

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
    alive : ndarray (n,) bool, optional

    Returns
    -------
    ndarray (3, 3)
        Units N/m, N/rad, N m/m, N m/rad.
    """
    k = np.empty((3, 3))
    _stiffness(np.array(eta, dtype=float), float(mo.psi0), mo.lines,
               mo.alive if alive is None else np.asarray(alive, dtype=bool), mo.fender_y, mo.fender_defl,
               mo.fender_load, mo.fender_npts, mo.side, mo.origin, STEP, k)
    return k


@njit(cache=True, nogil=True, error_model="numpy")
def _force_scaled(e0, e1, e2, load, scale, psi0, lines, alive, fy, fdefl, fload, fn, side, origin, out, ten,
                  per_line, r):
    """``r = (restoring force at the pose (e0, e1, e2) + load) * scale``: :func:`equilibrium`'s residual."""
    psi = psi0 + e2
    restoring_kernel(e0, e1, math.cos(psi), math.sin(psi), lines, alive, fy, fdefl, fload, fn, side, origin, out, ten,
               per_line)
    for q in range(3):
        r[q] = (out[q] + load[q]) * scale[q]


@njit(cache=True, nogil=True, error_model="numpy")
def _newton(eta, load, tol, max_iter, max_offset, psi0, lines, alive, fy, fdefl, fload, fn, side, origin, step_d):
    """:func:`equilibrium`'s damped Newton, compiled: the tangent stiffness (:func:`_stiffness`, rows scaled as
    the residual), the step by LAPACK's solve, halved until the residual
    falls. ``eta`` is updated in place. Returns the outcome (0 converged, 1 gave up: beyond ``max_offset`` or
    out of iterations, 2 singular stiffness) and the last (scaled) residual."""
    nl = lines.shape[1]
    out, ten, per_line = np.zeros(3), np.zeros(nl), np.empty((3, nl))
    scale = np.array([1.0, 1.0, 0.01])
    r, rt = np.empty(3), np.empty(3)
    k, e = np.empty((3, 3)), np.empty(3)
    _force_scaled(eta[0], eta[1], eta[2], load, scale, psi0, lines, alive, fy, fdefl, fload, fn, side, origin,
                  out, ten, per_line, r)
    for _ in range(max_iter):
        r_norm = np.max(np.abs(r))
        if r_norm < tol:
            return 0, r
        _stiffness(eta, psi0, lines, alive, fy, fdefl, fload, fn, side, origin, step_d, k)
        for q in range(3):                        # rows scaled as the residual
            for j in range(3):
                k[q, j] *= scale[q]
        a_mat = k.copy()
        reg = 1e-6 * np.max(np.abs(k))
        for q in range(3):
            a_mat[q, q] = k[q, q] + reg
        try:
            step = np.linalg.solve(a_mat, r)
        except Exception:
            return 2, r
        a = 1.0
        while a > 1e-4:
            for q in range(3):
                e[q] = eta[q] + a * step[q]
            _force_scaled(e[0], e[1], e[2], load, scale, psi0, lines, alive, fy, fdefl, fload, fn, side, origin,
                          out, ten, per_line, rt)
            if np.max(np.abs(rt)) < r_norm:
                break
            a *= 0.5
        eta[:] = e
        r[:] = rt
        if math.hypot(eta[0], eta[1]) > max_offset:
            return 1, r
    return 1, r


def equilibrium(mo: Moorings, load, alive=None, *, eta0=None, tol: float = 1.0, max_iter: int = 100,
                max_offset: float = 50.0) -> np.ndarray:
    """The pose where lines and fenders balance a steady load (damped Newton, compiled: :func:`_newton`; found,
    its Python loop called the compiled force about sixteen times a solve at some 8 us a call: a twentieth of an
    operability state).

    Parameters
    ----------
    mo : Moorings
    load : array_like (3,)
        Steady external force (N, berth frame) and yaw moment about midships (N m).
    alive : ndarray (n,) bool, optional
    eta0 : array_like (3,), optional
        Start (default the reference pose).
    tol : float
        Residual force, N (moments are divided by 100 m).
    max_iter : int
    max_offset : float
        Give up beyond this offset, m: the ship has broken out.

    Returns
    -------
    ndarray (3,)

    Raises
    ------
    MooringEquilibriumError
        No equilibrium (the ship breaks out, or the search fails).
    """
    load = np.array(load, dtype=float)
    eta = np.zeros(3) if eta0 is None else np.array(eta0, dtype=float)
    status, r = _newton(eta, load, float(tol), int(max_iter), float(max_offset), float(mo.psi0), mo.lines,
                        mo.alive if alive is None else np.asarray(alive, dtype=bool), mo.fender_y, mo.fender_defl,
                        mo.fender_load, mo.fender_npts, mo.side, mo.origin, STEP)
    if status == 0:
        return eta
    raise MooringEquilibriumError(f"no mooring equilibrium for the load {load.tolist()} (N, N, N m): the lines "
                                  f"cannot hold the ship (residual {np.max(np.abs(r)):.3g} N at pose "
                                  f"{np.round(eta, 3).tolist()})")
