"""The moored ship compiled once (like the arm's :class:`loadarm.arm.model.ArmModel`): hydrodynamics, moorings,
RAOs and drift coefficients at the calm equilibrium, the low-frequency mass and damping, the load factors.

:func:`compile_ship` reads nothing from disk but the cached coefficients (:func:`loadarm.ship.hydro.load_hydro`);
the motion (:mod:`loadarm.ship.motion`) and the alarm design take the :class:`ShipModel`.

Low-frequency pose and frames: see :mod:`loadarm.ship.mooring` (midships, berth frame). The hydrodynamic
coefficients and RAOs are about the centre of gravity in the ship frame; :func:`midships_transform` moves the
surge-sway-yaw ones to midships.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from loadarm.errors import ConfigError
from loadarm.params.berth import RHO_SEA, Berth, load_berth
from loadarm.ship import hydro as _hydro
from loadarm.ship.hydro import MEAN_DRIFT_DIRECTION, MEAN_DRIFT_OMEGA, interp_heading
from loadarm.ship.loads import current_coefficients
from loadarm.ship.mooring import Moorings, compile_moorings, equilibrium, stiffness

if TYPE_CHECKING:
    from loadarm.params.scenario import Scenario

__all__ = ["ShipModel", "compile_ship", "moored_ship", "LF_DOFS", "midships_transform", "lf_step", "LF_STEP", "LF_MAX_STEP"]

#: The ship-frame DOFs of the low-frequency motion, indices into the six of :data:`loadarm.ship.hydro.DOFS`.
LF_DOFS = (0, 1, 5)


def midships_transform(lcg: float) -> np.ndarray:
    """``S`` with ``(u, v, psi)_midships = S (u, v, psi)_cog`` (small yaw), for surge, sway, yaw.

    Parameters
    ----------
    lcg : float
        Centre of gravity forward of midships, m.

    Returns
    -------
    ndarray (3, 3)
    """
    return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, -lcg], [0.0, 0.0, 1.0]])


def _rot3(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class ShipModel:
    """A berth's design ship, compiled (immutable).

    Attributes
    ----------
    moorings : Moorings
    hydro : Hydro
    rao : ndarray (nw, nb, 6), complex
        About the centre of gravity, free-floating in surge, sway and yaw (the moorings, 40-120 s, answer
        nothing at wave periods: their motion is the low-frequency one, solved apart), with the viscous roll
        damping.
    drift : ndarray (nw, nb, 3)
        Mean drift coefficients (surge, sway N/m^2, yaw N m/m^2), ship frame, about midships.
    mass_lf : ndarray (3, 3)
        Low-frequency inertia (mass plus zero-frequency-end added mass), berth frame, at midships.
    damping_lf : ndarray (3, 3)
        Linear low-frequency damping, berth frame.
    eq0 : ndarray (3,)
        Calm equilibrium pose (lines against fenders).
    k0 : ndarray (3, 3)
        Mooring stiffness there, berth frame (lines and the fenders the ship lies against).
    k_lines : ndarray (3, 3)
        The lines' stiffness alone there (the ship moving off its fenders): the moored natural periods and the
        modes of the low-frequency damping.
    manifold, cog : ndarray (3,)
        Ship frame (z above the keel).
    environment : Environment
        The berth file's design environment (scenarios override keys of it).
    lf_step : float
        Low-frequency integration step, s (:func:`lf_step`).
    long_waves : bool
        The set-down loads the low-frequency motion (``[berth] bound_long_waves``, :mod:`loadarm.ship.longwave`).
    passing : PassingShip or None
        The berth's ``[passing_ship]`` (:mod:`loadarm.ship.passing`): its load joins the low-frequency one in
        every run; None: no passing ship.
    """

    moorings: Moorings
    hydro: _hydro.Hydro
    rao: np.ndarray
    drift: np.ndarray
    mass_lf: np.ndarray
    damping_lf: np.ndarray
    eq0: np.ndarray
    k0: np.ndarray
    k_lines: np.ndarray
    manifold: np.ndarray
    cog: np.ndarray
    length: float
    beam: float
    draft: float
    kind: str
    frontal_area: float
    lateral_area: float
    centroid_x: float
    current_kx: float
    current_ky: float
    current_cyc: float
    water_depth: float
    lf_damping_ratio: float
    manifold_tolerance: float = 0.0
    names: tuple[str, ...] = field(default=())
    environment: object = None
    lf_step: float = 0.1
    long_waves: bool = True
    passing: object = None

    @property
    def psi0(self) -> float:
        """Reference heading, rad."""
        return self.moorings.psi0

    @cached_property
    def mean_drift_grid(self) -> np.ndarray:
        """The drift coefficients on :func:`loadarm.ship.motion.mean_load`'s grid, (246, 73, 3), read-only,
        interpolated once per ship (the coefficients and the grid never change; every sea state of a study
        reuses them)."""

        w, th = MEAN_DRIFT_OMEGA, MEAN_DRIFT_DIRECTION
        beta = (th[None, :] - self.psi0) * np.ones_like(w)[:, None]
        grid = interp_heading(self.drift, self.hydro.heading, self.hydro.omega, np.repeat(w, th.size),
                              beta.ravel()).reshape(w.size, th.size, 3)
        grid.setflags(write=False)
        return grid

    def natural_periods(self) -> dict[str, float]:
        """Natural periods, s: surge, sway and yaw of the moored ship (eigenvalues of the low-frequency
        system on its lines at the calm equilibrium: the ship moving off its fenders) and heave, roll and pitch
        (hydrostatics with the added mass at the resonance).

        Returns
        -------
        dict
        """
        ev = np.linalg.eigvals(np.linalg.solve(self.mass_lf, self.k_lines))
        periods = sorted(2 * math.pi / math.sqrt(max(e.real, 1e-12)) for e in ev)[::-1]
        out = {f"lf_mode_{i + 1}_s": p for i, p in enumerate(periods)}
        h = self.hydro
        for j, name in ((2, "heave_s"), (3, "roll_s"), (4, "pitch_s")):
            w = np.sqrt(np.maximum(h.stiffness[j, j], 0.0) / (h.inertia[j, j] + h.added_mass[:, j, j]))
            i = int(np.argmin(np.abs(w - h.omega)))
            out[name] = 2 * math.pi / w[i] if w[i] > 0 else math.inf
        return out


#: The finest low-frequency integration step, s (the 10 Hz output step).
LF_STEP = 0.1
#: The coarsest, s (:func:`loadarm.ship.motion._lf_integrate` integrates on the low-passed load).
LF_MAX_STEP = 1.0
#: Largest ``omega * step`` at the finest step: RK4 is stable on an undamped oscillator up to 2.83; with room.
LF_STABILITY = 2.0
#: ``omega * step`` chosen for accuracy (RK4's error per period about ``(omega h)^4 / 120``: 5e-4 at 0.5).
LF_ACCURACY = 0.5


def _stiffest(mo: Moorings, h) -> tuple[float, float, list]:
    m_min = min(h.inertia[0, 0] + h.added_mass[0, 0, 0], h.inertia[1, 1] + h.added_mass[0, 1, 1])
    k_lines = float(np.sum(mo.line_stiffness_max))
    slopes = [float(np.max(np.diff(mo.fender_load[j, :n]) / np.diff(mo.fender_defl[j, :n])))
              for j, n in enumerate(mo.fender_npts)]
    return m_min, k_lines, slopes


def lf_step(mo: Moorings, h) -> float:
    """The low-frequency integration step for these moorings: the coarsest multiple of :data:`LF_STEP` up to
    :data:`LF_MAX_STEP` with ``omega_max h <= LF_ACCURACY`` (``omega_max`` from every line and fender at once
    on the lightest of surge and sway).

    Parameters
    ----------
    mo : Moorings
    h : Hydro

    Returns
    -------
    float
        s.
    """
    m_min, k_lines, slopes = _stiffest(mo, h)
    w = math.sqrt((k_lines + sum(slopes)) / m_min)
    k = int(min(LF_MAX_STEP / LF_STEP, max(1.0, math.floor(LF_ACCURACY / (w * LF_STEP) + 1e-9))))
    return k * LF_STEP


def _check_step(berth: Berth, mo: Moorings, h, source: str) -> None:
    """Refuse lines or fenders so stiff that the ship's fastest low-frequency motion cannot be integrated at
    :data:`LF_STEP` (found by reasoning about hostile input: a fender curve rising 100 MN in a millimetre would
    make the integration blow up into NaN instead of a message)."""
    m_min, k_lines, slopes = _stiffest(mo, h)
    k_max = k_lines + sum(slopes)
    limit = m_min * (LF_STABILITY / LF_STEP) ** 2
    if k_max > limit:
        j = int(np.argmax(slopes))
        raise ConfigError(
            f"{source}: the lines and fenders are too stiff for the motion's {LF_STEP:g} s step: together {k_max:.3g} N/m "
            f"(lines {k_lines:.3g}, stiffest fender {mo.fender_names[j]!r} {slopes[j]:.3g} N/m) against at most "
            f"{limit:.3g} N/m for this ship (natural period above {2 * math.pi * LF_STEP / LF_STABILITY:.2f} s); "
            "check the fender curves' units (N and m) and the lines' materials and lengths")


def compile_ship(berth: Berth, *, solve: bool = False, progress: bool = False, source: str = "<berth>") -> ShipModel:
    """Compile a berth's design ship.

    Parameters
    ----------
    berth : Berth
    solve : bool
        Run capytaine when no coefficients are stored (:func:`loadarm.ship.hydro.load_hydro`).
    progress : bool
    source : str
        The berth file, for messages.

    Returns
    -------
    ShipModel

    Raises
    ------
    ConfigError
        No stored coefficients and ``solve`` false; or no calm equilibrium.
    """
    s = berth.ship
    h = _hydro.load_hydro(_hydro.hydro_spec(s, berth.berth.water_depth), solve=solve, progress=progress)
    mo = compile_moorings(berth, source=source)
    _check_step(berth, mo, h, source)
    try:
        eq0 = equilibrium(mo, np.zeros(3))
    except ConfigError as exc:
        raise type(exc)(f"{source}: in calm weather: {exc}") from None
    k0 = stiffness(mo, eq0)
    k_lines = stiffness(mo, eq0, fenders=False)
    # berth-frame (x, y, psi) = T (u, v, psi) ship frame; midships = S cog
    t = _rot3(mo.psi0)
    sm = midships_transform(s.lcg)
    sinv = np.linalg.inv(sm)
    idx = np.ix_(LF_DOFS, LF_DOFS)
    m_cog = h.inertia[idx] + h.added_mass[0][idx]
    m_mid_ship = sinv.T @ m_cog @ sinv
    mass_lf = t @ m_mid_ship @ t.T
    # first order: free-floating in surge, sway and yaw (no mooring stiffness: docs/ship-motion.md)
    d6 = np.zeros((6, 6))
    d6[3, 3] = _hydro.roll_damping(h, s.roll_damping_ratio)
    motion = _hydro.rao(h, damping=d6)
    drift_cog = _hydro.cached_mean_drift(h, motion)
    # yaw moment about midships: N_mid = N_cog + lcg Y
    drift = drift_cog.copy()
    drift[..., 2] += s.lcg * drift_cog[..., 1]
    # linear low-frequency damping: a fraction of critical on each mode of the ship on its lines (M, K_lines)
    ev, vec = np.linalg.eig(np.linalg.solve(mass_lf, k_lines))
    ev, vec = ev.real, vec.real
    mm = vec.T @ mass_lf @ vec
    kk = vec.T @ k_lines @ vec
    crit = np.diag(2.0 * s.lf_damping_ratio * np.sqrt(np.maximum(np.diag(kk), 0.0) * np.diag(mm)))
    vinv = np.linalg.inv(vec)
    damping_lf = vinv.T @ crit @ vinv
    volume = s.displacement / RHO_SEA
    kx, ky, cyc = current_coefficients(s.length_pp, s.beam, s.draft, volume, berth.berth.water_depth,
                                       0.98 * s.beam * s.draft, s.propeller_area,
                                       max(berth.environment.current_speed, 0.1), RHO_SEA)
    return ShipModel(moorings=mo, hydro=h, rao=motion, drift=drift, mass_lf=mass_lf, damping_lf=damping_lf,
                     eq0=eq0, k0=k0, k_lines=k_lines, manifold=np.array(s.manifold, dtype=float),
                     cog=np.array([s.lcg, 0.0, s.kg]), length=s.length_pp, beam=s.beam, draft=s.draft, kind=s.kind,
                     frontal_area=s.frontal_windage, lateral_area=s.lateral_windage,
                     centroid_x=s.windage_centroid_x, current_kx=kx, current_ky=ky, current_cyc=cyc,
                     water_depth=berth.berth.water_depth, lf_damping_ratio=s.lf_damping_ratio,
                     manifold_tolerance=berth.berth.manifold_tolerance, names=mo.names,
                     environment=berth.environment, lf_step=lf_step(mo, h),
                     long_waves=berth.berth.bound_long_waves, passing=berth.passing_ship)


def moored_ship(sc: "Scenario") -> "ShipModel | None":
    """Read a moored scenario's berth file and compile its ship (the edge of a moored run; a campaign compiles
    once per batch and passes it on).

    Parameters
    ----------
    sc : Scenario
        With ``[ship] model = "moored"`` and its berth path made absolute
        (:func:`loadarm.params.scenario.resolve_berth`).

    Returns
    -------
    ShipModel or None
        None for ``model = "simple"``.
    """
    if sc.ship.model != "moored":
        return None
    return compile_ship(load_berth(sc.ship.berth), source=sc.ship.berth)
