"""Hydrodynamic coefficients of the design ship from capytaine, cached as NetCDF (issue 12, item 2).

capytaine (the open-source linear potential-flow BEM solver) is run once per hull, loading condition and water
depth on the parametric hull of :mod:`loadarm.ship.hull` (port half, mirrored by capytaine's
``ReflectionSymmetricMesh``; a lid on the waterplane removes the irregular frequencies). ``fill_dataset``
gives, over wave frequency ``omega`` and heading ``wave_direction`` (the direction the waves travel towards,
from the ship's bow towards port: 0 = following seas, pi/2 = waves from starboard towards port):

* added mass ``A(omega)`` and radiation damping ``B(omega)``, 6 x 6, about the centre of gravity;
* wave excitation ``X(omega, beta)`` (Froude-Krylov + diffraction), 6 complex, per metre of wave amplitude;
* hydrostatic stiffness ``C`` and the inertia matrix ``M`` of the loading condition;
* Kochin functions of the radiated and diffracted waves, from which the far-field (Maruo) mean drift force
  follows for any motion.

What is stored is the solver's output, keyed by a hash of every input (hull dimensions, loading condition,
water depth, mesh resolution, the frequency and heading grids, capytaine's major version). The motion RAOs
and the mean drift coefficients are derived at load time (:func:`rao`, :func:`mean_drift`) because they
also depend on the roll damping that potential flow lacks (a fraction of critical, declared in the berth
file) and the moorings, which are cheap to change; the mean drift (3 s) is cached in its turn under a hash of
the RAOs (:func:`cached_mean_drift`).

Headings are solved over [0, pi]; the hull is symmetric port-starboard, so (pi, 2 pi) follows by mirroring
(sway, roll and yaw change sign). Frequencies above the grid's top give zero response (short waves do not move
a ship hundreds of metres long); below its bottom the lowest value is held (the RAO's long-wave limit is
checked by a test).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Callable

import numpy as np

from loadarm._numba import njit
from loadarm.errors import ConfigError
from loadarm.files import atomic_open, atomic_path
from loadarm.params.berth import RHO_SEA, ShipSection
from loadarm.ship.hull import hull_mesh

__all__ = ["HydroSpec", "Hydro", "hydro_spec", "solve_hydro", "load_hydro", "cache_dir", "G", "DOFS",
           "OMEGA", "HEADINGS_DEG", "SHIPPED", "HYDRO_FORMAT", "save_hydro", "cached_mean_drift",
           "DRIFT_FORMAT"]

G = 9.80665
DOFS = ("Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw")
#: Frequency grid, rad/s: 0.15-1.45 (periods 4.3-42 s): a 150 000 m^3 carrier's response to waves shorter than
#: 4 s is nil, and the long end reaches its heave/pitch resonance and the long-wave limit.
OMEGA = tuple(round(0.15 + 0.05 * i, 2) for i in range(27))
#: Headings solved, deg (0 = following seas); (180, 360) by port-starboard symmetry.
HEADINGS_DEG = tuple(range(0, 181, 15))
#: Kochin-function angles (rad): the full circle and one step either side, as capytaine's far-field drift needs.
N_THETA = 73
#: Depth of the lid below the waterline, fraction of the draft.
LID_DEPTH = 0.04
#: Bump when what is stored or how it is made changes (the key changes with it).
HYDRO_FORMAT = 1
#: Package folder of the coefficients shipped for the example berths.
SHIPPED = "loadarm.ship.data"


@dataclass(frozen=True)
class HydroSpec:
    """Everything a hydrodynamic solve depends on (its hash is the cache key)."""

    length: float
    beam: float
    draft: float
    depth: float
    block_coefficient: float
    cog: tuple[float, float, float]        # capytaine frame: x forward of midships, y to port, z up from the waterline
    mass: float
    radii: tuple[float, float, float]
    water_depth: float
    nx: int
    nz: int
    omega: tuple[float, ...]
    headings_deg: tuple[float, ...]
    rho: float = RHO_SEA

    def key(self) -> str:
        """Hash of the inputs, 16 hex digits.

        Returns
        -------
        str
        """
        d = dict(self.__dict__, format=HYDRO_FORMAT, capytaine=_capytaine_major())
        blob = json.dumps(d, sort_keys=True, default=list).encode()
        return hashlib.sha256(blob).hexdigest()[:16]


def _capytaine_major() -> str:
    """capytaine's major version, from its installed metadata (found: importing capytaine for it took 1.5 s of
    every ship's compilation)."""
    from importlib.metadata import version

    return version("capytaine").split(".")[0]


def hydro_spec(ship: ShipSection, water_depth: float, *, nx: int = 64, nz: int = 10,
               omega: tuple[float, ...] = OMEGA, headings_deg: tuple[float, ...] = HEADINGS_DEG) -> HydroSpec:
    """The solve that describes a berth's design ship.

    Parameters
    ----------
    ship : ShipSection
    water_depth : float
        m.
    nx, nz : int
        Hull panels along the length and per side keel to draft (:func:`loadarm.ship.hull.hull_mesh`); the
        default gives panels under 6 m, a sixth of the shortest wavelength on the grid at 20 m depth.
    omega : tuple of float
        rad/s.
    headings_deg : tuple of float
        Within [0, 180].

    Returns
    -------
    HydroSpec
    """
    cb = ship.displacement / (RHO_SEA * ship.length_pp * ship.beam * ship.draft)
    return HydroSpec(length=ship.length_pp, beam=ship.beam, draft=ship.draft, depth=ship.depth,
                     block_coefficient=round(cb, 6), cog=(ship.lcg, 0.0, ship.kg - ship.draft),
                     mass=ship.displacement, radii=(ship.r_xx, ship.r_yy, ship.r_zz), water_depth=water_depth,
                     nx=nx, nz=nz, omega=tuple(omega), headings_deg=tuple(headings_deg))


def _body(spec: HydroSpec):
    import capytaine as cpt

    h = hull_mesh(spec.length, spec.beam, spec.draft, spec.depth, spec.block_coefficient, nx=spec.nx, nz=spec.nz)
    port = h.faces[0:2 * ((len(h.faces) - spec.nx) // 2):2]         # the port side's faces (they alternate)
    half = cpt.Mesh(h.vertices - [0.0, 0.0, spec.draft], port).immersed_part()
    mesh = cpt.ReflectionSymmetricMesh(half=half, plane="xOz")
    # a lid a little below the waterline, panels finer than the hull's: found, a lid at -1 % of the draft with the
    # default (hull-sized) panels left a spike of negative heave damping at 1.25 rad/s; at -4 % with half-size
    # panels the coefficients are smooth through the first irregular frequency (tests/test_hydro.py)
    lid = mesh.generate_lid(z=-LID_DEPTH * spec.draft, faces_max_radius=0.5 * spec.length / spec.nx)
    m, (rx, ry, rz) = spec.mass, spec.radii
    inertia = np.diag([m, m, m, m * rx * rx, m * ry * ry, m * rz * rz])
    body = cpt.FloatingBody(mesh=mesh, lid_mesh=lid, dofs=cpt.rigid_body_dofs(rotation_center=spec.cog),
                            center_of_mass=spec.cog, mass=m, name="hull")
    return body, inertia


def solve_hydro(spec: HydroSpec, *, progress: bool = False):
    """Run capytaine for a spec (about a minute on two cores for the default mesh; seconds for a coarse one).

    Parameters
    ----------
    spec : HydroSpec
    progress : bool
        Show capytaine's progress bar.

    Returns
    -------
    xarray.Dataset
        Real-valued (complex variables split into ``_re``/``_im``), with the spec's key and inputs as attributes,
        ready for NetCDF.
    """
    import capytaine as cpt
    import xarray as xr
    from capytaine.io.xarray import separate_complex_values

    body, inertia = _body(spec)
    theta = np.linspace(-2 * math.pi / (N_THETA - 1), 2 * math.pi + 2 * math.pi / (N_THETA - 1), N_THETA + 2)
    coords = {"omega": np.asarray(spec.omega), "wave_direction": np.radians(spec.headings_deg),
              "radiating_dof": list(body.dofs), "water_depth": [spec.water_depth], "rho": [spec.rho],
              "theta": theta}
    ds = cpt.BEMSolver().fill_dataset(xr.Dataset(coords=coords), body, hydrostatics=True, progress_bar=progress)
    ds = ds.squeeze([d for d in ("water_depth", "rho") if d in ds.dims])
    keep = ["added_mass", "radiation_damping", "Froude_Krylov_force", "diffraction_force", "hydrostatic_stiffness",
            "kochin_radiation", "kochin_diffraction", "wavenumber", "wavelength"]
    out = xr.Dataset({k: ds[k] for k in keep if k in ds})
    out["inertia_matrix"] = xr.DataArray(inertia, dims=("influenced_dof", "radiating_dof"),
                                         coords={"influenced_dof": list(DOFS), "radiating_dof": list(DOFS)})
    out.attrs.update({"key": spec.key(), "spec": json.dumps(spec.__dict__, default=list),
                      "generator": "loadarm.ship.hydro", "capytaine": cpt.__version__,
                      "panels": int(body.mesh.nb_faces), "g": G})
    return separate_complex_values(out)


def cache_dir() -> Path:
    """Where solved coefficients are kept: ``$LOADARM_CACHE`` or ``~/.cache/loadarm/hydro``.

    Returns
    -------
    Path
    """
    base = os.environ.get("LOADARM_CACHE")
    return Path(base) if base else Path.home() / ".cache" / "loadarm" / "hydro"


def _shipped(key: str) -> Path | None:
    try:
        p = resources.files(SHIPPED) / f"{key}.nc"
    except ModuleNotFoundError:
        return None
    return Path(str(p)) if p.is_file() else None


def _open(path: Path):
    """The stored dataset, complex variables joined again (their real and imaginary parts are stored along a
    ``complex`` dimension, as capytaine's ``separate_complex_values`` wrote them; joined here without
    importing capytaine, which took 1.5 s of every ship's compilation)."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        ds = ds.load()
    if "complex" not in ds.coords:
        return ds
    for name in list(ds.data_vars):
        da = ds[name]
        if "complex" in da.dims:
            ds[name] = xr.DataArray(da.sel(complex="re").data + 1j * da.sel(complex="im").data,
                                    dims=[d for d in da.dims if d != "complex"])
    return ds.drop_vars("complex")


@dataclass(frozen=True)
class Hydro:
    """Solved coefficients on their grids, as plain arrays (the maths takes these, not the dataset).

    Attributes
    ----------
    omega : ndarray (nw,)
    heading : ndarray (nb,)
        rad, over [0, 2 pi) after mirroring.
    added_mass, damping : ndarray (nw, 6, 6)
    excitation : ndarray (nw, nb, 6), complex
        Per metre of wave amplitude, phase relative to the wave crest at the origin (midships).
    stiffness, inertia : ndarray (6, 6)
    kochin_rad : ndarray (nw, nt, 6), complex
    kochin_dif : ndarray (nw, nb, nt), complex
    theta : ndarray (nt,)
    wavenumber : ndarray (nw,)
    water_depth, rho : float
    key : str
    panels : int
    """

    omega: np.ndarray
    heading: np.ndarray
    added_mass: np.ndarray
    damping: np.ndarray
    excitation: np.ndarray
    stiffness: np.ndarray
    inertia: np.ndarray
    kochin_rad: np.ndarray
    kochin_dif: np.ndarray
    theta: np.ndarray
    wavenumber: np.ndarray
    water_depth: float
    rho: float
    key: str
    panels: int


#: Sign of each DOF under the port-starboard mirror (y -> -y).
MIRROR = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])


def _from_dataset(ds) -> Hydro:
    dofs = list(DOFS)
    a = ds["added_mass"].sel(influenced_dof=dofs, radiating_dof=dofs).transpose("omega", ...).values
    b = ds["radiation_damping"].sel(influenced_dof=dofs, radiating_dof=dofs).transpose("omega", ...).values
    x = (ds["Froude_Krylov_force"] + ds["diffraction_force"]).sel(influenced_dof=dofs)
    x = x.transpose("omega", "wave_direction", "influenced_dof").values
    beta = ds["wave_direction"].values
    kr = ds["kochin_radiation"].sel(radiating_dof=dofs).transpose("omega", "theta", "radiating_dof").values
    kd = ds["kochin_diffraction"].transpose("omega", "wave_direction", "theta").values
    # mirror the headings (pi, 2 pi): beta -> 2 pi - beta
    inner = (beta > 1e-9) & (beta < math.pi - 1e-9)
    heading = np.concatenate([beta, 2 * math.pi - beta[inner][::-1]])
    x = np.concatenate([x, x[:, inner][:, ::-1] * MIRROR], axis=1)
    c = ds["hydrostatic_stiffness"].sel(influenced_dof=dofs, radiating_dof=dofs).values
    m = ds["inertia_matrix"].sel(influenced_dof=dofs, radiating_dof=dofs).values
    return Hydro(omega=ds["omega"].values, heading=heading, added_mass=a, damping=b, excitation=x, stiffness=c,
                 inertia=m, kochin_rad=kr, kochin_dif=kd, theta=ds["theta"].values,
                 wavenumber=ds["wavenumber"].values, water_depth=float(ds["water_depth"]), rho=float(ds["rho"]),
                 key=str(ds.attrs["key"]), panels=int(ds.attrs["panels"]))


def load_hydro(spec: HydroSpec, *, solve: bool = False, progress: bool = False,
               on_solve: Callable[[HydroSpec], None] | None = None) -> Hydro:
    """The coefficients for a spec: shipped with the package, else from the cache, else solved (if allowed)
    and cached.

    Parameters
    ----------
    spec : HydroSpec
    solve : bool
        Run capytaine when nothing is stored (minutes); otherwise refuse.
    progress : bool
        Show the solver's progress bar.
    on_solve : callable, optional
        Called before a solve starts (for a message).

    Returns
    -------
    Hydro

    Raises
    ------
    ConfigError
        Nothing stored for this ship and ``solve`` is false.
    """
    key = spec.key()
    path = _shipped(key) or (cache_dir() / f"{key}.nc")
    if not path.is_file():
        if not solve:
            raise ConfigError(f"no hydrodynamic coefficients for this ship, loading condition and water depth "
                              f"(key {key}); run `loadarm hydro --berth FILE` once to compute them with capytaine "
                              f"(about a minute on two cores for the default mesh); they are then cached in "
                              f"{cache_dir()}")
        if on_solve is not None:
            on_solve(spec)
        save_hydro(solve_hydro(spec, progress=progress), path)
    return _from_dataset(_open(path))


def save_hydro(ds, path: str | Path) -> Path:
    """Write a solved dataset as NetCDF, atomically (a temporary file beside it, renamed).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`solve_hydro`.
    path : str or Path

    Returns
    -------
    Path
    """

    p = Path(path)
    with atomic_path(p) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")
    return p


def roll_damping(h: Hydro, ratio: float) -> float:
    """Viscous roll damping coefficient for a fraction of critical at the roll natural frequency, N m s/rad.

    Parameters
    ----------
    h : Hydro
    ratio : float
        Fraction of critical damping.

    Returns
    -------
    float
    """
    c44 = h.stiffness[3, 3]
    if c44 <= 0:
        return 0.0
    a44 = np.interp(math.sqrt(c44 / (h.inertia[3, 3] + h.added_mass[-1, 3, 3])), h.omega, h.added_mass[:, 3, 3])
    return 2.0 * ratio * math.sqrt(c44 * (h.inertia[3, 3] + a44))


def rao(h: Hydro, *, damping: np.ndarray | None = None, stiffness: np.ndarray | None = None) -> np.ndarray:
    """Motion RAOs about the centre of gravity, per metre of wave amplitude.

    ``xi = X / (-omega^2 (M + A) - i omega (B + B_extra) + C + C_extra)`` (capytaine's convention: motion
    ``Re(xi exp(-i omega t))``).

    Parameters
    ----------
    h : Hydro
    damping : ndarray (6, 6), optional
        Extra (viscous) damping.
    stiffness : ndarray (6, 6), optional
        Extra stiffness (the moorings, linearised).

    Returns
    -------
    ndarray (nw, nb, 6), complex
        m/m for translations, rad/m for rotations.
    """
    w = h.omega[:, None, None]
    bx = np.zeros((6, 6)) if damping is None else damping
    cx = np.zeros((6, 6)) if stiffness is None else stiffness
    z = -w ** 2 * (h.inertia + h.added_mass) - 1j * w * (h.damping + bx) + h.stiffness + cx   # (nw, 6, 6)
    return np.linalg.solve(z[:, None], h.excitation[..., None])[..., 0]


#: Bump when :func:`mean_drift` changes what it computes (its cached results are keyed with it).
DRIFT_FORMAT = 1


def cached_mean_drift(h: Hydro, motion: np.ndarray) -> np.ndarray:
    """:func:`mean_drift`, kept in :func:`cache_dir` under a hash of everything it depends on (the coefficients'
    key, the RAOs' bytes, :data:`DRIFT_FORMAT`, capytaine's major version): found, capytaine's far-field drift
    was 3 s of the 5 s every compilation of a ship took, the same each time. A cached file that cannot be read
    or does not fit is computed again and replaced; a cache that cannot be written is left as it is.

    Parameters
    ----------
    h : Hydro
    motion : ndarray (nw, nb, 6), complex

    Returns
    -------
    ndarray (nw, nb, 3)
    """

    motion = np.ascontiguousarray(motion, dtype=complex)
    digest = hashlib.sha256(f"{h.key}|{DRIFT_FORMAT}|{_capytaine_major()}|{motion.shape}".encode())
    digest.update(motion.tobytes())
    path = cache_dir() / f"drift-{digest.hexdigest()[:16]}.npy"
    shape = (h.omega.size, h.heading.size, 3)
    try:
        out = np.load(path, allow_pickle=False)
        if out.shape == shape and out.dtype == np.float64 and np.all(np.isfinite(out)):
            return out
    except (OSError, ValueError, EOFError):
        pass
    out = mean_drift(h, motion)
    try:
        with atomic_open(path, "wb") as fh:
            np.save(fh, out, allow_pickle=False)
    except OSError:
        pass
    return out


def mean_drift(h: Hydro, motion: np.ndarray) -> np.ndarray:
    """Far-field (Maruo) mean drift force per square metre of wave amplitude, from capytaine's
    ``far_field_mean_drift_force`` on the stored Kochin functions, one heading at a time (only the diagonal is
    needed; the mirrored headings by symmetry).

    Parameters
    ----------
    h : Hydro
    motion : ndarray (nw, nb, 6), complex
        RAOs (:func:`rao`).

    Returns
    -------
    ndarray (nw, nb, 3)
        Surge, sway force (N/m^2) and yaw moment (N m/m^2), ship frame.
    """
    import xarray as xr
    from capytaine.post_pro.mean_drift_force import far_field_mean_drift_force

    n_solved = h.kochin_dif.shape[1]
    out = np.zeros((h.omega.size, h.heading.size, 3))
    for k in range(n_solved):
        beta = h.heading[k:k + 1]
        ds = xr.Dataset(
            {"kochin_diffraction": (("omega", "wave_direction", "theta"), h.kochin_dif[:, k:k + 1]),
             "kochin_radiation": (("omega", "theta", "radiating_dof"), h.kochin_rad),
             "wavenumber": ("omega", h.wavenumber)},
            coords={"omega": h.omega, "wave_direction": beta, "theta": h.theta, "radiating_dof": list(DOFS),
                    "water_depth": h.water_depth, "rho": h.rho, "g": G})
        x = xr.DataArray(motion[:, k:k + 1], dims=("omega", "wave_direction", "radiating_dof"),
                         coords={"omega": h.omega, "wave_direction": beta, "radiating_dof": list(DOFS)})
        f = far_field_mean_drift_force(x, ds)
        for j, name in enumerate(("drift_force_surge", "drift_force_sway", "drift_force_yaw")):
            out[:, k, j] = np.real(f[name].values[:, 0, 0])
    inner = (h.heading[:n_solved] > 1e-9) & (h.heading[:n_solved] < math.pi - 1e-9)
    out[:, n_solved:] = out[:, :n_solved][:, inner][:, ::-1] * np.array([1.0, -1.0, -1.0])
    return out


def interp_heading(table: np.ndarray, heading: np.ndarray, omega_grid: np.ndarray, w: np.ndarray,
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
    flat = table.reshape(table.shape[0], table.shape[1], -1)
    out = np.empty((w.size, flat.shape[2]), dtype=table.dtype)
    _bilinear(flat, i, j, j1, fw, fb, w > omega_grid[-1], out)
    return out.reshape((w.size,) + table.shape[2:])


@njit(cache=True, nogil=True)
def _bilinear(table, i, j, j1, fw, fb, above, out):
    """The weighted sum of :func:`interp_heading` (``table[(nw, nb, m)]`` at cells ``i, j`` with weights ``fw,
    fb``; zero where ``above``), in the vectorised expression's order (bit for bit), one compiled pass: found,
    its four gathers and their temporaries were most of the sea's coefficients' cost."""
    for k in range(out.shape[0]):
        if above[k]:
            for m in range(out.shape[1]):
                out[k, m] = 0
            continue
        a, b, c, u, v = i[k], j[k], j1[k], fw[k], fb[k]
        for m in range(out.shape[1]):
            out[k, m] = ((1 - u) * ((1 - v) * table[a, b, m] + v * table[a, c, m])
                         + u * ((1 - v) * table[a + 1, b, m] + v * table[a + 1, c, m]))


#: The grid :func:`mean_load` integrates the mean drift over: frequency (0.01 rad/s; the spectra are smooth on
#: it), rad/s, and the direction the waves travel, berth frame (5 deg), rad.
MEAN_DRIFT_OMEGA = np.linspace(0.05, 2.5, 246)


MEAN_DRIFT_DIRECTION = np.linspace(-math.pi, math.pi, 73)
