"""Moorings and fenders: quasi-static restoring force, equilibrium and stiffness in the horizontal plane
(issue 12, item 3; real lines: issue 28).

The ship's low-frequency pose is ``eta = (x, y, psi)``: the displacement of midships in the berth frame of
:mod:`loadarm.params.berth` from its reference position (the side against the fender faces, midships at
``[berth] ship_y``) and the change of heading, rad, counter-clockwise seen from above. At the reference the bow
points along berth +y (port side to) or -y (starboard side to).

* A **line** runs straight from its fairlead (ship frame, carried by the pose; its height follows the water
  level and the draft: ``rise``) to its bollard (berth frame). It is a main line and a tail in series, each with
  its material's load-extension curve (:data:`loadarm.params.berth.ROPE_MATERIALS`): compiled once into the
  line's tension as a function of its elongation ``e = L - Lu`` (``Lu`` its unstretched length), a table on a
  uniform grid of ``e`` (:data:`TABLE_POINTS` points up to the breaking load, linear between; the series sum
  of the segments' strains inverted on a fine grid of tension). It pulls only; ``Lu`` is set so that the line
  holds its pretension at the reference pose, and grows when the winch brake renders
  (:func:`loadarm.ship.motion.simulate` carries it as state). Lines may be marked parted.
* A **fender** on the fender line (berth x = 0) pushes only, along berth +x, with its load-deflection curve
  (piecewise linear; beyond the last point the last slope is kept) at the point of the ship's side abreast of it.

The force and yaw moment (about midships) are a numba kernel (:func:`restoring_kernel`) that the time-domain
motion calls every step; :func:`equilibrium` (Newton on the kernel) and :func:`stiffness` (central differences
of the kernel, a 3 x 3 matrix ``K = -dF/d eta``) serve the static analysis. MoorPy, on the same lines (main
line and tail joined at a free point, the same material curves), is the independent route
(``tests/test_mooring.py``).
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
           "fender_loads", "fender_deflections", "fender_contact", "MooringEquilibriumError", "segment_strain", "TABLE_POINTS", "line_elongation"]

#: Points of each line's tension-elongation table (linear between: at 64 points the largest error of a
#: polynomial curve of power up to 1 / 0.6 is below 0.1 % of the breaking load; tests/test_mooring.py).
TABLE_POINTS = 64
#: Fine tension grid on which the series strains are summed and inverted (points from 0 to the breaking load).
_FINE = 4001


class MooringEquilibriumError(ConfigError):
    """The moorings cannot hold the ship against a load (no equilibrium within the search)."""


def segment_strain(tension, mbl: float, strain_at_break: float, exponent: float):
    """A rope segment's strain at a tension: ``strain_at_break (T / MBL) ** exponent`` (0 at or below 0).

    Parameters
    ----------
    tension : float or ndarray
        N.
    mbl, strain_at_break, exponent : float

    Returns
    -------
    float or ndarray
    """
    t = np.maximum(np.asarray(tension, dtype=float), 0.0) / mbl
    return strain_at_break * t ** exponent


def line_elongation(tension, segments) -> np.ndarray:
    """A line's elongation at a tension: its segments' strains times their unstretched lengths, summed (series).

    Parameters
    ----------
    tension : float or ndarray
        N.
    segments : sequence of (length, mbl, strain_at_break, exponent)

    Returns
    -------
    ndarray
        m.
    """
    return sum(length * segment_strain(tension, mbl, eb, p) for length, mbl, eb, p in segments)


@dataclass(frozen=True)
class Moorings:
    """The berth's lines and fenders, compiled to arrays (immutable; parted lines are a mask passed in).

    Attributes
    ----------
    names : tuple of str
    fairlead : ndarray (n, 3)
        Ship frame x, y (m) and height above the keel.
    height : ndarray (n,)
        Fairlead height minus bollard height, m, at the reference water level and draft.
    bollard : ndarray (n, 3)
        Berth frame x, y, z (m).
    unstretched : ndarray (n,)
        Unstretched length ``Lu`` (main line and tail), m.
    tail_length : ndarray (n,)
        m (0: no tail).
    segments : tuple of tuples
        Per line, its segments ``(length, mbl, strain_at_break, exponent)``, main line first.
    e_step : ndarray (n,)
        Elongation step of the line's table, m.
    table : ndarray (n, TABLE_POINTS)
        Tension at elongation ``k e_step``, N.
    mbl : ndarray (n,)
        Main line's MBL, N.
    breaking_load : ndarray (n,)
        The weaker segment's MBL: the line parts there, N.
    brake : ndarray (n,)
        Winch brake holding load, N (``inf``: on bitts).
    e_brake, e_break : ndarray (n,)
        Elongations at the brake's holding load and at the breaking load, m.
    pretension : ndarray (n,)
    fender_names : tuple of str
    fender_y : ndarray (m,)
    fender_defl, fender_load : ndarray (m, k)
        Curves padded to a common length by repeating the last segment's slope.
    fender_npts : ndarray (m,) int
    fender_prop : ndarray (3, m)
        Rows: friction coefficient, unload ratio (hysteresis), rated deflection (m); for the low-frequency
        motion's :func:`fender_contact`.
    fender_rated : ndarray (m,)
        Reaction at the rated deflection, N.
    side : float
        Ship-frame y of the side against the fenders (+B/2 port side to, -B/2 starboard).
    half_length : float
        Half the ship's length: the side touches a fender only abreast of the hull, m.
    psi0 : float
        Heading at the reference pose, rad.
    origin : ndarray (2,)
        Berth x, y of midships at the reference pose.
    """

    names: tuple[str, ...]
    fairlead: np.ndarray
    height: np.ndarray
    bollard: np.ndarray
    unstretched: np.ndarray
    tail_length: np.ndarray
    segments: tuple
    e_step: np.ndarray
    table: np.ndarray
    mbl: np.ndarray
    breaking_load: np.ndarray
    brake: np.ndarray
    e_brake: np.ndarray
    e_break: np.ndarray
    pretension: np.ndarray
    fender_names: tuple[str, ...]
    fender_y: np.ndarray
    fender_defl: np.ndarray
    fender_load: np.ndarray
    fender_npts: np.ndarray
    fender_prop: np.ndarray
    fender_rated: np.ndarray
    side: float
    half_length: float
    psi0: float
    origin: np.ndarray

    @cached_property
    def hull(self) -> np.ndarray:
        """The side against the fenders and the half length, for the kernel (ndarray (2,))."""
        return np.array([self.side, self.half_length])

    @cached_property
    def lines(self) -> np.ndarray:
        """The lines' constants as rows, one column per line, for the compiled kernel: fairlead x, y, bollard x,
        y, height, unstretched length, table step (ndarray (7, n), contiguous: the kernel's loop over the lines
        then runs on SIMD lanes). A copy with another row 5 carries rendered lines; :meth:`lines_at` another
        row 4, another water level."""
        return self.lines_at(0.0)

    def lines_at(self, rise: float) -> np.ndarray:
        """:attr:`lines` with the fairleads ``rise`` metres higher (tide up, or the ship lighter, since the lines
        were tended): a fresh array.

        Parameters
        ----------
        rise : float
            m.

        Returns
        -------
        ndarray (7, n)
        """
        return np.ascontiguousarray(np.vstack([self.fairlead[:, :2].T, self.bollard[:, :2].T, self.height + rise,
                                               self.unstretched, self.e_step]))

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

    def tension_of(self, i: int, elongation):
        """Line ``i``'s tension at an elongation, from its table (what the kernel computes), N.

        Parameters
        ----------
        i : int
        elongation : float or ndarray
            m.

        Returns
        -------
        ndarray
        """
        e = np.asarray(elongation, dtype=float)
        grid = self.e_step[i] * np.arange(TABLE_POINTS)
        tab = self.table[i]
        slope = (tab[-1] - tab[-2]) / self.e_step[i]
        return np.where(e <= 0, 0.0, np.where(e <= grid[-1], np.interp(e, grid, tab), tab[-1] + slope * (e - grid[-1])))

    @cached_property
    def line_stiffness_max(self) -> np.ndarray:
        """Each line's largest tangent stiffness up to its breaking load, N/m (the table's steepest step over
        the unstretched length's share: ``dT/de``)."""
        return np.max(np.diff(self.table, axis=1), axis=1) / self.e_step


def _line_table(segments, breaking: float) -> tuple[float, np.ndarray]:
    """A line's uniform elongation grid step and the tensions on it, up to its breaking load."""
    t_fine = np.linspace(0.0, breaking, _FINE)
    e_fine = line_elongation(t_fine, segments)
    step = float(e_fine[-1]) / (TABLE_POINTS - 1)
    grid = step * np.arange(TABLE_POINTS)
    table = np.interp(grid, e_fine, t_fine)
    table[-1] = breaking
    return step, table


def compile_moorings(berth: Berth, *, source: str = "<berth>") -> Moorings:
    """Compile a berth's lines and fenders.

    Parameters
    ----------
    berth : Berth
    source : str
        The berth file, for messages.

    Returns
    -------
    Moorings

    Raises
    ------
    ConfigError
        A tail as long as its line (nothing left of the main line between fairlead and bollard).
    """
    s = berth.ship
    port = berth.berth.side == "port"
    psi0 = math.pi / 2 if port else -math.pi / 2
    side = s.beam / 2 if port else -s.beam / 2
    origin = np.array([s.beam / 2, berth.berth.ship_y])
    fair = np.array([m.fairlead for m in berth.moorings], dtype=float)
    boll = np.array([m.bollard for m in berth.moorings], dtype=float)
    height = np.array([(m.fairlead[2] - s.draft) - m.bollard[2] for m in berth.moorings], dtype=float)
    t0 = np.array([m.pretension for m in berth.moorings], dtype=float)
    c, sn = math.cos(psi0), math.sin(psi0)
    p = origin + fair[:, :2] @ np.array([[c, sn], [-sn, c]])
    length = np.sqrt(np.sum((p - boll[:, :2]) ** 2, axis=1) + height ** 2)
    n = len(berth.moorings)
    segs, lu, steps, tables = [], np.empty(n), np.empty(n), np.empty((n, TABLE_POINTS))
    breaking, brake, e_brake, e_break = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i, m in enumerate(berth.moorings):
        main, tail = berth.material(m.material), berth.material(m.tail_material)
        tail_seg = [(m.tail_length, m.tail_mbl, tail.strain_at_break, tail.exponent)] if m.tail_length > 0 else []
        # the main line's unstretched length: what is left of the stretched length at the pretension
        stretched_tail = sum(ln * (1 + segment_strain(t0[i], mb, eb, ex)) for ln, mb, eb, ex in tail_seg)
        main_len = (length[i] - stretched_tail) / (1 + segment_strain(t0[i], m.mbl, main.strain_at_break,
                                                                      main.exponent))
        if main_len < 1.0:
            raise ConfigError(f"{source}: moorings line {m.name!r}: tail_length = {m.tail_length:g} m leaves "
                              f"{main_len:.3g} m of main line between fairlead and bollard ({length[i]:.3g} m "
                              f"apart); the tail must be shorter than the line by at least 1 m")
        seg = tuple([(float(main_len), m.mbl, main.strain_at_break, main.exponent)] + tail_seg)
        segs.append(seg)
        lu[i] = sum(x[0] for x in seg)
        breaking[i] = m.breaking_load
        steps[i], tables[i] = _line_table(seg, breaking[i])
        brake[i] = m.brake * m.mbl if m.brake > 0 else math.inf
        e_break[i] = float(line_elongation(breaking[i], seg))
        e_brake[i] = float(line_elongation(brake[i], seg)) if math.isfinite(brake[i]) else math.inf
    k = max(len(f.deflection) for f in berth.fenders)
    defl = np.zeros((len(berth.fenders), k))
    load = np.zeros((len(berth.fenders), k))
    for i, f in enumerate(berth.fenders):
        nf = len(f.deflection)
        defl[i, :nf], load[i, :nf] = f.deflection, f.load
        defl[i, nf:], load[i, nf:] = f.deflection[-1], f.load[-1]
    return Moorings(names=tuple(m.name for m in berth.moorings), fairlead=fair, height=height, bollard=boll,
                    unstretched=lu, tail_length=np.array([m.tail_length for m in berth.moorings], dtype=float),
                    segments=tuple(segs), e_step=steps, table=np.ascontiguousarray(tables),
                    mbl=np.array([m.mbl for m in berth.moorings], dtype=float), breaking_load=breaking,
                    brake=brake, e_brake=e_brake, e_break=e_break, pretension=t0,
                    fender_names=tuple(f.name for f in berth.fenders),
                    fender_y=np.array([f.y for f in berth.fenders], dtype=float), fender_defl=defl,
                    fender_load=load, fender_npts=np.array([len(f.deflection) for f in berth.fenders]),
                    fender_prop=np.ascontiguousarray(np.array([[f.friction, f.unload_ratio, f.rated_deflection]
                                                               for f in berth.fenders], dtype=float).T),
                    fender_rated=np.array([f.rated_load for f in berth.fenders], dtype=float),
                    side=side, half_length=s.length_pp / 2, psi0=psi0, origin=origin)


@njit(cache=True, nogil=True, inline="always")
def line_tension(e, step, row):
    """A line's tension at elongation ``e`` from its table ``row`` (uniform step ``step``; linear between,
    the last slope beyond, 0 when slack)."""
    if e <= 0.0:
        return 0.0
    u = e / step
    k = int(u)
    last = row.shape[0] - 1
    if k >= last:
        k = last - 1
    return row[k] + (u - k) * (row[k + 1] - row[k])


@njit(cache=True, nogil=True, inline="always")
def _fender_load(d, defl, load, n):
    if d <= 0.0:
        return 0.0
    for j in range(1, n):
        if d <= defl[j] or j == n - 1:
            slope = (load[j] - load[j - 1]) / (defl[j] - defl[j - 1])
            return load[j - 1] + slope * (d - defl[j - 1])
    return 0.0


#: Sliding speed of a fender's contact over which its friction builds to ``mu R``, m/s (a regularised Coulomb
#: law, ``tanh(v / V_SLIP)``: a moored ship's low-frequency speeds are 0.05-0.5 m/s, so friction is fully
#: developed in motion and smooth through a reversal, which the integration's 0.1 s step needs).
V_SLIP = 0.01
#: Speed of the hull off a fender over which its reaction falls to the unloading curve, m/s (the same reason).
V_UNLOAD = 0.01


@njit(cache=True, nogil=True, inline="always")
def _abreast(fy_j, qx0, qy0, c, s, half):
    """Berth x of the point of the hull's side abreast of a fender at berth y ``fy_j`` (the side's points are
    ``(qx0, qy0) + u (c, s)``), or NaN when none is: the hull along the fender line, or the fender beyond its
    ends (``|u|`` over ``half`` the length). The restoring force and the fenders' contact share it."""
    if abs(s) < 1e-9:
        return math.nan
    u = (fy_j - qy0) / s
    if abs(u) > half:
        return math.nan
    return qx0 + u * c


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def fender_contact(x, y, c, s, vx, vy, r, fy, fdefl, fload, fn, fprop, hull, origin):
    """What the fenders add, in motion, to :func:`restoring_kernel`'s loading-curve reaction: the hysteresis
    (a fender the hull moves off gives back ``unload_ratio`` of its loading reaction, blended in over
    :data:`V_UNLOAD`) and the friction along the fender's face (``-mu R tanh(v / V_SLIP)`` against the
    contact's sliding along the berth, at the contact point: a yaw moment too).

    Parameters
    ----------
    x, y : float
        The pose's offset, m, as :func:`restoring_kernel` takes it.
    c, s : float
        Cosine and sine of the heading.
    vx, vy : float
        The pose's velocity, berth frame, m/s.
    r : float
        Yaw rate, rad/s.
    fy, fdefl, fload, fn : ndarray
        :attr:`Moorings.fender_y`, ``fender_defl``, ``fender_load``, ``fender_npts``.
    fprop : ndarray
        :attr:`Moorings.fender_prop` (friction, unload ratio, rated deflection; 3 by fenders).
    hull, origin : ndarray
        :attr:`Moorings.hull` and ``origin``.

    Returns
    -------
    tuple of float
        The berth-frame x and y force, N, and the yaw moment about midships, N m.
    """
    cx, cy = origin[0] + x, origin[1] + y
    side, half = hull[0], hull[1]
    qx0, qy0 = cx - s * side, cy + c * side
    fx = fyy = mz = 0.0
    for j in range(fy.shape[0]):
        qx = _abreast(fy[j], qx0, qy0, c, s, half)
        if qx != qx:
            continue
        f = _fender_load(-qx, fdefl[j], fload[j], fn[j])
        if f <= 0.0:
            continue
        rx, ry = qx - cx, fy[j] - cy
        wx = vx - r * ry                      # the hull's velocity at the contact
        wy = vy + r * rx
        w = wx / V_UNLOAD                     # moving off the fender: unloading
        w = 0.0 if w < 0.0 else (1.0 if w > 1.0 else w)
        dn = -(1.0 - fprop[1, j]) * w * f     # the reaction's drop to the unloading curve
        ft = -fprop[0, j] * (f + dn) * math.tanh(wy / V_SLIP)
        fx += dn
        fyy += ft
        mz += rx * ft - ry * dn
    return fx, fyy, mz


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def restoring_kernel(x, y, c, s, lines, table, alive, fy, fdefl, fload, fn, hull, origin, out, tension, per_line):
    """The restoring force (``out``: x, y, yaw moment) and the line tensions (``tension``) at the pose ``(x, y,
    psi)``, given as ``x, y`` and the heading's cosine and sine ``c, s`` (the caller has them: one pair a
    stage); ``lines`` is :attr:`Moorings.lines` (or a copy with rendered lengths or another water level),
    ``table`` :attr:`Moorings.table`, ``hull`` :attr:`Moorings.hull`, ``per_line`` a (4, n) scratch whose last
    row gets the elongations. Each
    line's force is computed apart (a loop without a running sum, which the compiler runs on SIMD lanes; numpy's
    error model: no division-by-zero branch, the lengths are positive) and then summed in line order (the same
    sum, bit for bit, as one loop: found, 2.4 times faster for sixteen lines)."""
    cx, cy = origin[0] + x, origin[1] + y
    gxs, gys, mzs, es = per_line[0], per_line[1], per_line[2], per_line[3]
    for i in range(lines.shape[1]):
        ax, ay, h, lu = lines[0, i], lines[1, i], lines[4, i], lines[5, i]
        rx = c * ax - s * ay
        ry = s * ax + c * ay
        dx, dy = cx + rx - lines[2, i], cy + ry - lines[3, i]
        length = math.sqrt(dx * dx + dy * dy + h * h)
        e = length - lu
        es[i] = e
        t = line_tension(e, lines[6, i], table[i]) if alive[i] else 0.0
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
    # the side against the fenders: points (cx, cy) + R (u, side); abreast of a fender where berth y = fy, if
    # that point lies on the hull (|u| up to half its length: found, a ship broken out and turned across the
    # berth met fenders "abreast" of it hundreds of metres off its ends, and the motion blew up)
    side, half = hull[0], hull[1]
    qx0, qy0 = cx - s * side, cy + c * side
    for j in range(fy.shape[0]):
        qx = _abreast(fy[j], qx0, qy0, c, s, half)
        if qx != qx:
            continue
        f = _fender_load(-qx, fdefl[j], fload[j], fn[j])
        rx, ry = qx - cx, fy[j] - cy
        fx += f
        mz += -ry * f
    out[0], out[1], out[2] = fx, fyy, mz


def _fenders(mo: Moorings, fenders: bool):
    """The fender arrays for the kernel; none (empty arrays) for the lines alone."""
    if fenders:
        return mo.fender_y, mo.fender_defl, mo.fender_load, mo.fender_npts
    return mo.fender_y[:0], mo.fender_defl[:0], mo.fender_load[:0], mo.fender_npts[:0]


def restoring_force(mo: Moorings, eta, alive=None, *, rise: float = 0.0, fenders: bool = True) \
        -> tuple[np.ndarray, np.ndarray]:
    """Force of the lines and fenders on the ship at a pose.

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
        Pose: x, y (m, berth frame), psi (rad).
    alive : ndarray (n,) bool, optional
        Intact lines (default all).
    rise : float
        Fairleads above their reference height (tide up, draft less), m.
    fenders : bool
        False: the lines alone.

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
    restoring_kernel(x, y, math.cos(mo.psi0 + psi), math.sin(mo.psi0 + psi), mo.lines_at(float(rise)), mo.table,
                     mo.alive if alive is None else np.asarray(alive, dtype=bool), *_fenders(mo, fenders), mo.hull,
                     mo.origin, out, ten, np.empty((4, len(mo.names))))
    return out, ten


def fender_deflections(mo: Moorings, poses) -> np.ndarray:
    """Each fender's deflection at each of many poses (NumPy over the poses; the kernel's fender rule: the point
    of the ship's side abreast of the fender, on the hull, pressed behind the fender line; 0 out of contact), m.

    Parameters
    ----------
    mo : Moorings
    poses : ndarray (k, 3)

    Returns
    -------
    ndarray (k, fenders)
    """
    poses = np.asarray(poses, dtype=float)
    psi = mo.psi0 + poses[:, 2]
    c, s = np.cos(psi), np.sin(psi)
    cx, cy = mo.origin[0] + poses[:, 0], mo.origin[1] + poses[:, 1]
    qx0, qy0 = cx - s * mo.side, cy + c * mo.side
    out = np.zeros((poses.shape[0], mo.fender_y.size))
    safe = np.where(np.abs(s) < 1e-9, np.nan, s)
    for j, fy in enumerate(mo.fender_y):
        u = (fy - qy0) / safe
        d = -(qx0 + u * c)
        ok = np.isfinite(u) & (np.abs(u) <= mo.half_length) & (d > 0)
        out[:, j] = np.where(ok, d, 0.0)
    return out


def fender_loads(mo: Moorings, poses) -> np.ndarray:
    """Each fender's reaction at each of many poses, on its loading curve (:func:`fender_deflections`), N.

    Parameters
    ----------
    mo : Moorings
    poses : ndarray (k, 3)

    Returns
    -------
    ndarray (k, fenders)
    """
    d = fender_deflections(mo, poses)
    out = np.zeros_like(d)
    for j in range(d.shape[1]):
        n = int(mo.fender_npts[j])
        xs, ys = mo.fender_defl[j, :n], mo.fender_load[j, :n]
        slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        load = np.where(d[:, j] <= xs[-1], np.interp(d[:, j], xs, ys), ys[-1] + slope * (d[:, j] - xs[-1]))
        out[:, j] = np.where(d[:, j] > 0, load, 0.0)
    return out


def line_tensions(mo: Moorings, eta, alive=None, *, rise: float = 0.0) -> np.ndarray:
    """Line tensions at a pose, N.

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
    alive : ndarray (n,) bool, optional
    rise : float
        m (:func:`restoring_force`).

    Returns
    -------
    ndarray (n,)
    """
    return restoring_force(mo, eta, alive, rise=rise)[1]


#: Central-difference steps for the stiffness: 1 mm and 1e-5 rad (a 140 m lever: 1.4 mm).
STEP = np.array([1e-3, 1e-3, 1e-5])


@njit(cache=True, nogil=True, error_model="numpy")
def _stiffness(eta, psi0, lines, table, alive, fy, fdefl, fload, fn, hull, origin, step_d, k):
    """``k = -dF/d eta`` at the pose ``eta`` by central differences of the restoring force (steps ``step_d``),
    written into ``k`` (3, 3): :func:`stiffness`, and each iteration of :func:`_newton`."""
    nl = lines.shape[1]
    ten, per_line = np.zeros(nl), np.empty((4, nl))
    fp, fm, e = np.empty(3), np.empty(3), np.empty(3)
    for j in range(3):
        e[:] = eta
        e[j] = eta[j] + step_d[j]
        psi = psi0 + e[2]
        restoring_kernel(e[0], e[1], math.cos(psi), math.sin(psi), lines, table, alive, fy, fdefl, fload, fn, hull,
                         origin, fp, ten, per_line)
        e[j] = eta[j] - step_d[j]
        psi = psi0 + e[2]
        restoring_kernel(e[0], e[1], math.cos(psi), math.sin(psi), lines, table, alive, fy, fdefl, fload, fn, hull,
                         origin, fm, ten, per_line)
        for q in range(3):
            k[q, j] = -(fp[q] - fm[q]) / (2 * step_d[j])


def stiffness(mo: Moorings, eta, alive=None, *, rise: float = 0.0, fenders: bool = True) -> np.ndarray:
    """Tangent stiffness ``K = -dF/d eta`` at a pose (central differences of :func:`restoring_force`, compiled:
    :func:`_stiffness`, which the equilibrium's Newton takes too).

    Parameters
    ----------
    mo : Moorings
    eta : array_like (3,)
    alive : ndarray (n,) bool, optional
    rise : float
        m (:func:`restoring_force`).
    fenders : bool
        False: the lines alone (the moored natural periods: the ship moving off its fenders).

    Returns
    -------
    ndarray (3, 3)
        Units N/m, N/rad, N m/m, N m/rad.
    """
    k = np.empty((3, 3))
    _stiffness(np.array(eta, dtype=float), float(mo.psi0), mo.lines_at(float(rise)), mo.table,
               mo.alive if alive is None else np.asarray(alive, dtype=bool), *_fenders(mo, fenders), mo.hull,
               mo.origin, STEP, k)
    return k


@njit(cache=True, nogil=True, error_model="numpy")
def _force_scaled(e0, e1, e2, load, scale, psi0, lines, table, alive, fy, fdefl, fload, fn, hull, origin, out, ten,
                  per_line, r):
    """``r = (restoring force at the pose (e0, e1, e2) + load) * scale``: :func:`equilibrium`'s residual."""
    psi = psi0 + e2
    restoring_kernel(e0, e1, math.cos(psi), math.sin(psi), lines, table, alive, fy, fdefl, fload, fn, hull, origin,
                     out, ten, per_line)
    for q in range(3):
        r[q] = (out[q] + load[q]) * scale[q]


@njit(cache=True, nogil=True, error_model="numpy")
def _newton(eta, load, tol, max_iter, max_offset, psi0, lines, table, alive, fy, fdefl, fload, fn, hull, origin,
            step_d):
    """:func:`equilibrium`'s damped Newton, compiled: the tangent stiffness (:func:`_stiffness`, rows scaled as
    the residual), the step by LAPACK's solve, halved until the residual
    falls. ``eta`` is updated in place. Returns the outcome (0 converged, 1 gave up: beyond ``max_offset`` or
    out of iterations, 2 singular stiffness) and the last (scaled) residual."""
    nl = lines.shape[1]
    out, ten, per_line = np.zeros(3), np.zeros(nl), np.empty((4, nl))
    scale = np.array([1.0, 1.0, 0.01])
    r, rt = np.empty(3), np.empty(3)
    k, e = np.empty((3, 3)), np.empty(3)
    _force_scaled(eta[0], eta[1], eta[2], load, scale, psi0, lines, table, alive, fy, fdefl, fload, fn, hull,
                  origin, out, ten, per_line, r)
    for _ in range(max_iter):
        r_norm = np.max(np.abs(r))
        if r_norm < tol:
            return 0, r
        _stiffness(eta, psi0, lines, table, alive, fy, fdefl, fload, fn, hull, origin, step_d, k)
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
            _force_scaled(e[0], e[1], e[2], load, scale, psi0, lines, table, alive, fy, fdefl, fload, fn, hull,
                          origin, out, ten, per_line, rt)
            if np.max(np.abs(rt)) < r_norm:
                break
            a *= 0.5
        eta[:] = e
        r[:] = rt
        if math.hypot(eta[0], eta[1]) > max_offset:
            return 1, r
    return 1, r


def equilibrium(mo: Moorings, load, alive=None, *, eta0=None, tol: float = 1.0, max_iter: int = 100,
                max_offset: float = 50.0, rise: float = 0.0, lines=None) -> np.ndarray:
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
    rise : float
        Fairleads above their reference height, m (:func:`restoring_force`).
    lines : ndarray (7, n), optional
        The lines' rows as the kernel takes them (rendered lengths; default :meth:`Moorings.lines_at` ``rise``).

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
    rows = mo.lines_at(float(rise)) if lines is None else lines
    status, r = _newton(eta, load, float(tol), int(max_iter), float(max_offset), float(mo.psi0), rows, mo.table,
                        mo.alive if alive is None else np.asarray(alive, dtype=bool), mo.fender_y, mo.fender_defl,
                        mo.fender_load, mo.fender_npts, mo.hull, mo.origin, STEP)
    if status == 0:
        return eta
    raise MooringEquilibriumError(f"no mooring equilibrium for the load {load.tolist()} (N, N, N m): the lines "
                                  f"cannot hold the ship (residual {np.max(np.abs(r)):.3g} N at pose "
                                  f"{np.round(eta, 3).tolist()})")
