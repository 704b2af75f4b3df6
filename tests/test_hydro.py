"""Hydrodynamics of the design ship (capytaine): the shipped coefficients, their cache, the known limits.

Tolerances: the shipped solve has 1280 panels (64 along the length); panel methods converge at second order in
the panel size, so the hydrostatics agree with the hull's own integrals to under 1 %; the long-wave and
short-wave limits are approached, not reached, on the frequency grid (stated per test).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from loadarm.errors import ConfigError
from loadarm.params.berth import RHO_SEA, load_berth
from loadarm.ship import hydro
from loadarm.ship.hull import hull_mesh
from loadarm.ship.model import compile_ship

BERTH = "examples/berths/lng150k.toml"


@pytest.fixture(scope="module")
def berth():
    return load_berth(BERTH)


@pytest.fixture(scope="module")
def h(berth):
    return hydro.load_hydro(hydro.hydro_spec(berth.ship, berth.berth.water_depth))


@pytest.fixture(scope="module")
def ship(berth):
    return compile_ship(berth)


def test_the_example_coefficients_ship_with_the_package(berth):
    key = hydro.hydro_spec(berth.ship, berth.berth.water_depth).key()
    assert hydro._shipped(key) is not None, "re-solve: python -c 'from loadarm.ship import hydro; ...' (docs)"


def test_the_key_changes_with_every_input(berth):
    base = hydro.hydro_spec(berth.ship, berth.berth.water_depth)
    keys = {base.key()}
    for change in ({"draft": 11.0}, {"water_depth": 25.0}, {"nx": 32}, {"omega": (0.5, 1.0)}, {"mass": 1e8},
                   {"cog": (0.0, 0.0, 1.0)}):
        keys.add(hydro.HydroSpec(**(base.__dict__ | change)).key())
    assert len(keys) == 7


def test_hydrostatics_agree_with_the_hull_integrals(berth, h):
    """Second route: heave stiffness rho g A_wp and the displaced volume from the hull's own integrals."""
    s = berth.ship
    cb = s.displacement / (RHO_SEA * s.length_pp * s.beam * s.draft)
    hull = hull_mesh(s.length_pp, s.beam, s.draft, s.depth, cb, nx=200, nz=40)
    awp = hull.waterplane_area(s.draft)
    assert h.stiffness[2, 2] == pytest.approx(RHO_SEA * hydro.G * awp, rel=0.01)
    assert h.stiffness[3, 3] > 0, "the loading condition must be stable (GM > 0)"


def test_added_mass_and_damping_are_symmetric_and_damping_dissipates(h):
    """Reciprocity: A_ij = A_ji in theory; a constant-panel method meets it to its discretisation error. Checked
    on the couplings the motions depend on (heave-pitch, sway-roll, sway-yaw, roll-yaw) to 10 % of
    sqrt(A_ii A_jj) (measured: up to 6 %). The surge-pitch coupling is not: the thin hull's surge coefficients
    are small and its reciprocity error reaches a factor 3 at the short end (noted in docs/ship-motion.md)."""
    pairs = ((2, 4), (1, 3), (1, 5), (3, 5))
    for a, b in zip(h.added_mass, h.damping):
        for m in (a, b):
            for i, j in pairs:
                scale = math.sqrt(abs(a[i, i] * a[j, j]))
                assert abs(m[i, j] - m[j, i]) <= 0.1 * scale, (i, j)
        assert np.all(np.diag(b) > -1e-6 * np.max(np.abs(b))), "radiation damping >= 0"


def test_no_irregular_frequency_spike(h):
    """Found: a lid at 1 % of the draft with hull-sized panels gave negative heave damping and added mass at
    1.25 rad/s. With the fine lid the heave coefficients are smooth: positive, no jump over 30 %."""
    a33, b33 = h.added_mass[:, 2, 2], h.damping[:, 2, 2]
    assert np.all(a33 > 0)
    assert np.all(b33 > -1e-6 * np.max(b33))
    jumps = np.abs(np.diff(a33)) / a33[:-1]
    assert np.max(jumps) < 0.3


def test_port_and_starboard_mirror(h):
    """Headings beta and 2 pi - beta: surge, heave, pitch equal; sway, roll, yaw opposite (the hull is
    symmetric; the mirrored half is built, not solved, so this checks the solver's own symmetry at pi/2 too)."""
    k90 = int(np.argmin(np.abs(h.heading - math.pi / 2)))
    k270 = int(np.argmin(np.abs(h.heading - 3 * math.pi / 2)))
    assert np.allclose(h.excitation[:, k270], h.excitation[:, k90] * hydro.MIRROR)
    k180 = int(np.argmin(np.abs(h.heading - math.pi)))
    head = np.abs(h.excitation[:, k180])
    # to round-off of the mirrored half: 1e-4 of the heave force (moments: times the length)
    assert np.all(head[:, 1] <= 1e-4 * np.max(head[:, 2])), "head seas excite no sway"
    assert np.all(head[:, [3, 5]] <= 1e-4 * 278.0 * np.max(head[:, 2])), "nor roll, nor yaw"


def test_heave_rao_tends_to_one_in_long_waves(ship):
    """In beam seas the ship is narrow against the longest wave on the grid (42 s: about 590 m long in 20 m of
    water): it follows the surface, within 5 %. In head seas that wave is only twice the ship long (the heave
    averages the elevation along it, as kL/2 = 1.5 makes sin(x)/x = 0.67): the RAO grows towards 1 as the
    waves lengthen, without reaching it on the grid."""
    h = ship.hydro
    k = int(np.argmin(np.abs(np.degrees(h.heading) - 90)))
    assert abs(ship.rao[0, k, 2]) == pytest.approx(1.0, abs=0.05)
    k = int(np.argmin(np.abs(np.degrees(h.heading) - 180)))
    head = np.abs(ship.rao[:6, k, 2])
    assert np.all(np.diff(head) < 0) and 0.67 < head[0] < 1.0


def test_beam_sea_drift_tends_to_the_wall_limit(ship):
    """Short waves are fully reflected by the weather side: 0.5 rho g L a^2 for a wall of length L. The hull
    is wall-sided over its parallel midbody only, so the shortest waves give 0.9-1.05 of it."""
    h = ship.hydro
    k = int(np.argmin(np.abs(h.heading - math.pi / 2)))
    limit = 0.5 * RHO_SEA * hydro.G * 278.0
    assert 0.9 < ship.drift[-1, k, 1] / limit < 1.05
    # free floating, long waves pass the ship and radiate nothing back: no drift (moored, the sway resonance near
    # 25 s radiates and drifts: the moored coefficients peak there)
    d6 = np.zeros((6, 6))
    d6[3, 3] = hydro.roll_damping(h, 0.05)
    free = hydro.mean_drift(h, hydro.rao(h, damping=d6))
    assert abs(free[0, k, 1]) / limit < 0.01
    assert 0.9 < free[-1, k, 1] / limit < 1.05


def test_natural_periods_from_hydrostatics(ship):
    """Heave, roll and pitch periods against 2 pi sqrt((M + A) / C) with A at the period itself (fixed point)."""
    p = ship.natural_periods()
    h = ship.hydro
    for j, name in ((2, "heave_s"), (3, "roll_s"), (4, "pitch_s")):
        t = 10.0
        for _ in range(50):
            a = np.interp(2 * math.pi / t, h.omega, h.added_mass[:, j, j])
            t = 2 * math.pi * math.sqrt((h.inertia[j, j] + a) / h.stiffness[j, j])
        assert p[name] == pytest.approx(t, rel=0.05)      # the grid's 0.05 rad/s step
    assert 8 < p["heave_s"] < 14 and 15 < p["roll_s"] < 30 and 8 < p["pitch_s"] < 13


@pytest.mark.slow
def test_the_mean_drift_is_cached_by_what_it_depends_on(tmp_path, monkeypatch, ship):
    """The cached far-field drift is capytaine's, bit for bit; other RAOs get another file; a damaged file is
    computed again and replaced; a cache that cannot be written still gives the drift."""
    monkeypatch.setenv("LOADARM_CACHE", str(tmp_path / "c"))
    h, rao = ship.hydro, ship.rao
    direct = hydro.mean_drift(h, rao)
    assert np.array_equal(hydro.cached_mean_drift(h, rao), direct)
    [f] = list((tmp_path / "c").glob("drift-*.npy"))
    assert np.array_equal(hydro.cached_mean_drift(h, rao), direct)            # from the file
    hydro.cached_mean_drift(h, rao * 1.01)
    assert len(list((tmp_path / "c").glob("drift-*.npy"))) == 2
    f.write_bytes(b"not an array")
    assert np.array_equal(hydro.cached_mean_drift(h, rao), direct)
    assert np.array_equal(np.load(f), direct)
    monkeypatch.setenv("LOADARM_CACHE", str(tmp_path / "file"))
    (tmp_path / "file").write_text("a file where the cache folder would be")
    assert np.array_equal(hydro.cached_mean_drift(h, rao), direct)


def test_the_stored_coefficients_are_joined_as_capytaine_joins_them(berth):
    """hydro._open joins the stored real and imaginary parts without importing capytaine: the same dataset as
    capytaine's merge_complex_values, every variable and coordinate."""
    import xarray as xr
    from capytaine.io.xarray import merge_complex_values

    path = hydro._shipped(hydro.hydro_spec(berth.ship, berth.berth.water_depth).key())
    with xr.open_dataset(path) as ds:
        want = merge_complex_values(ds.load())
    assert hydro._open(path).identical(want)


def test_the_key_reads_capytaine_s_major_version_from_its_metadata():
    import capytaine

    assert hydro._capytaine_major() == capytaine.__version__.split(".")[0]


def test_nothing_stored_is_refused_with_the_command_to_run(tmp_path, monkeypatch, berth):
    monkeypatch.setenv("LOADARM_CACHE", str(tmp_path))
    spec = hydro.hydro_spec(berth.ship, 33.0)
    with pytest.raises(ConfigError, match="loadarm hydro --berth"):
        hydro.load_hydro(spec)


def test_capytaine_on_a_coarse_mesh_meets_the_known_limits_and_is_cached(tmp_path, monkeypatch, berth):
    """The real solver, coarse (192 panels, three frequencies): long-wave heave RAO -> 1, heave period from the
    hydrostatics, no sway in head seas; the result is written to the cache once and read back."""
    pytest.importorskip("capytaine")
    monkeypatch.setenv("LOADARM_CACHE", str(tmp_path))
    spec = hydro.hydro_spec(berth.ship, berth.berth.water_depth, nx=24, nz=4, omega=(0.15, 0.6, 1.0),
                            headings_deg=(0.0, 90.0, 180.0))
    calls = []
    h = hydro.load_hydro(spec, solve=True, on_solve=calls.append)
    assert calls == [spec]
    files = list(tmp_path.glob("*.nc"))
    assert [f.name for f in files] == [f"{spec.key()}.nc"]
    assert files[0].stat().st_mode & 0o044, "a cache file is readable like any output"
    r = hydro.rao(h)
    k90 = int(np.argmin(np.abs(h.heading - math.pi / 2)))
    assert abs(r[0, k90, 2]) == pytest.approx(1.0, abs=0.06)
    k180 = int(np.argmin(np.abs(h.heading - math.pi)))
    assert np.all(np.abs(h.excitation[:, k180, 1]) < 1e-4 * np.abs(h.excitation[:, k180, 2]).max())
    assert h.stiffness[2, 2] == pytest.approx(RHO_SEA * hydro.G * 9034.0, rel=0.05)
    again = hydro.load_hydro(spec, solve=True, on_solve=calls.append)
    assert len(calls) == 1, "the second load reads the cache"
    assert np.array_equal(again.added_mass, h.added_mass)
