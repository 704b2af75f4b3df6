"""Moorings and fenders: the quasi-static restoring force, equilibrium and stiffness, against MoorPy and against
an independent NumPy route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.errors import ConfigError
from loadarm.params.berth import load_berth
from loadarm.ship.mooring import (
    MooringEquilibriumError,
    compile_moorings,
    equilibrium,
    line_tensions,
    restoring_force,
    stiffness,
)

from .hypo import examples

BERTH = "examples/berths/lng150k.toml"


@pytest.fixture(scope="module")
def mo():
    return compile_moorings(load_berth(BERTH))


def _numpy_route(mo, eta, alive):
    """The same physics written again with NumPy arrays and rotation matrices (no shared code)."""
    psi = mo.psi0 + eta[2]
    rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
    centre = mo.origin + eta[:2]
    r = mo.fairlead @ rot.T
    delta = centre + r - mo.bollard
    length = np.sqrt(np.sum(delta ** 2, axis=1) + mo.height ** 2)
    t = np.where(alive & (length > mo.l0), mo.ea * (length - mo.l0) / mo.l0, 0.0)
    f = -(t / length)[:, None] * delta
    force = np.array([f[:, 0].sum(), f[:, 1].sum(), np.sum(r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0])])
    # fenders: the side line u -> centre + rot (u, side), abreast of each fender
    for j, yf in enumerate(mo.fender_y):
        q0 = centre + rot @ np.array([0.0, mo.side])
        u = (yf - q0[1]) / rot[1, 0]
        q = q0 + u * rot[:, 0]
        d = -q[0]
        n = mo.fender_npts[j]
        if d > 0:
            xs, ys = mo.fender_defl[j, :n], mo.fender_load[j, :n]
            load = np.interp(d, xs, ys) if d <= xs[-1] else ys[-1] + (ys[-1] - ys[-2]) / (xs[-1] - xs[-2]) * (d - xs[-1])
            force += [load, 0.0, -(q[1] - centre[1]) * load]
    return force, t


@settings(max_examples=examples(200), deadline=None)
@given(x=st.floats(-0.5, 2.0), y=st.floats(-2.0, 2.0), psi=st.floats(-0.01, 0.01),
       parted=st.lists(st.integers(0, 15), max_size=16))
def test_the_kernel_matches_an_independent_numpy_route(mo, x, y, psi, parted):
    alive = mo.alive
    alive[parted] = False
    eta = np.array([x, y, psi])
    f, t = restoring_force(mo, eta, alive)
    f2, t2 = _numpy_route(mo, eta, alive)
    assert np.allclose(t, t2, rtol=1e-9, atol=1e-6)
    assert np.allclose(f, f2, rtol=1e-9, atol=1e-3)


def test_lines_only_pull_and_fenders_only_push(mo):
    # pushed hard onto the fenders: the lines go slack, the fenders push out (+x)
    f, t = restoring_force(mo, [-1.0, 0.0, 0.0])
    assert f[0] > 0 and np.all(t >= 0)
    breast = [i for i, n in enumerate(mo.names) if "breast" in n]
    assert np.all(t[breast] == 0.0), "breast lines slacken when the ship is pushed onto the fenders"
    # far off the fenders: only lines, pulling back (-x)
    f, t = restoring_force(mo, [1.0, 0.0, 0.0])
    assert f[0] < 0 and np.all(t[breast] > mo.pretension[breast])


def test_pretension_at_the_reference_pose(mo):
    assert np.allclose(line_tensions(mo, [0.0, 0.0, 0.0]), mo.pretension, rtol=1e-12)


def test_calm_equilibrium_and_stiffness(mo):
    eq = equilibrium(mo, np.zeros(3))
    f, _ = restoring_force(mo, eq)
    assert np.all(np.abs(f[:2]) < 1.0) and abs(f[2]) < 100.0
    assert eq[0] < 0, "the pretensioned lines pull the ship onto the fenders"
    k = stiffness(mo, eq)
    assert np.all(np.linalg.eigvalsh(0.5 * (k + k.T)) > 0)
    assert np.allclose(k, k.T, rtol=0.02, atol=1e-3 * np.max(np.abs(k)))


@pytest.mark.parametrize("load", [(2e5, 0.0, 0.0), (0.0, 2e5, 0.0), (0.0, 0.0, 2e7), (1e5, -1e5, 5e6)])
def test_static_offset_under_a_small_steady_load_follows_the_stiffness(mo, load):
    """Verification (issue 12, item 7): a load small enough to stay in one contact state moves the ship by
    K^-1 F (the tangent stiffness at the calm equilibrium), within 3 % (the lines' geometric stiffening) and
    10 micrometres (the second-order coupling of yaw into x)."""
    eq0 = equilibrium(mo, np.zeros(3))
    k = stiffness(mo, eq0)
    eq = equilibrium(mo, np.array(load), eta0=eq0)
    assert np.allclose(eq - eq0, np.linalg.solve(k, load), rtol=0.03, atol=1e-5)


def _python_stiffness(mo, eta, alive):
    """Central differences of the public restoring_force, as stiffness was written in Python before it was
    compiled (the route it is held to)."""
    from loadarm.ship.mooring import STEP

    k = np.empty((3, 3))
    for j in range(3):
        d = np.zeros(3)
        d[j] = STEP[j]
        k[:, j] = -(restoring_force(mo, eta + d, alive)[0] - restoring_force(mo, eta - d, alive)[0]) / (2 * STEP[j])
    return k


@settings(max_examples=examples(150), deadline=None)
@given(eta=st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-0.05, 0.05)), parted=st.integers(0, 6))
def test_the_compiled_stiffness_is_the_python_central_differences_bit_for_bit(mo, eta, parted):
    """stiffness (compiled, shared with the equilibrium's Newton) against the central differences of
    restoring_force written in Python, at poses with lines slack and taut, fenders touched or not."""
    alive = mo.alive.copy()
    alive[:parted] = False
    eta = np.array(eta)
    assert np.array_equal(stiffness(mo, eta, alive), _python_stiffness(mo, eta, alive))


def _python_newton(mo, load, alive, eta0, tol=1.0, max_iter=100, max_offset=50.0):
    """The damped Newton as it was written in Python before it was compiled (the route it is held to): the
    residual and the stiffness from the public restoring_force. The step by SciPy's LAPACK
    ``dgesv``, the routine numba's ``np.linalg.solve`` calls (NumPy's ``solve`` may be another LAPACK build:
    they agreed here, but a test across machines should not depend on two builds agreeing to the last bit)."""
    from scipy.linalg.lapack import dgesv

    scale = np.array([1.0, 1.0, 0.01])
    eta = np.array(eta0, dtype=float)

    def resid(e):
        return (restoring_force(mo, e, alive)[0] + load) * scale

    r = resid(eta)
    for _ in range(max_iter):
        if np.max(np.abs(r)) < tol:
            return eta
        k = _python_stiffness(mo, eta, alive) * scale[:, None]
        _, _, step, info = dgesv(k + 1e-6 * np.max(np.abs(k)) * np.eye(3), r)
        if info != 0:                                        # singular
            break
        a = 1.0
        while a > 1e-4:
            trial = eta + a * step
            rt = resid(trial)
            if np.max(np.abs(rt)) < np.max(np.abs(r)):
                break
            a *= 0.5
        eta, r = trial, rt
        if np.hypot(eta[0], eta[1]) > max_offset:
            break
    return None


@settings(max_examples=examples(150), deadline=None)
@given(load=st.tuples(st.floats(-3e7, 3e7), st.floats(-3e7, 3e7), st.floats(-3e9, 3e9)),
       parted=st.integers(0, 6), start=st.booleans())
def test_the_compiled_equilibrium_is_the_python_newton_bit_for_bit(mo, load, parted, start):
    """equilibrium's compiled Newton (found: its Python loop was a twentieth of an operability state) against
    the same iteration in Python over steady loads from nothing to far past what the lines hold, lines parted:
    the same pose bit for bit, or both give up."""
    alive = mo.alive.copy()
    alive[:parted] = False
    load = np.array(load)
    eta0 = equilibrium(mo, np.zeros(3)) if start else np.zeros(3)
    want = _python_newton(mo, load, alive, eta0)
    try:
        got = equilibrium(mo, load, alive, eta0=eta0)
    except MooringEquilibriumError:
        got = None
    assert (want is None and got is None) or np.array_equal(want, got), (want, got)


def test_breakout_has_no_equilibrium(mo):
    with pytest.raises(MooringEquilibriumError, match="cannot hold"):
        equilibrium(mo, [1e6, 0.0, 0.0], alive=~mo.alive)


def test_unknown_line_is_named(mo):
    with pytest.raises(ConfigError, match="'bow 9' is not in the berth file"):
        mo.parted(["bow 9"])


def test_agrees_with_moorpy(mo):
    """MoorPy (NREL's quasi-static mooring code) on the lines alone (the ship 0.3 m off the fenders, where
    MoorPy can express everything: it has no fenders): taut lines of negligible weight, EA as ours. Forces
    within 0.1 %, stiffness (MoorPy's analytic one) within 1 % (MoorPy's slack lines keep a catenary's small
    tension and stiffness, ours none)."""
    mp = pytest.importorskip("moorpy")
    eta = np.array([0.3, 0.2, 0.002])
    ms = mp.System(depth=200)
    ms.setLineType(name="taut", lineType={"m": 0.01, "d_vol": 0.001, "w": 1e-4, "EA": float(mo.ea[0])})
    zb = 50.0
    body = ms.addBody(-1, [mo.origin[0] + eta[0], mo.origin[1] + eta[1], zb, 0, 0, mo.psi0 + eta[2]])
    assert np.all(mo.ea == mo.ea[0])
    for i in range(len(mo.names)):
        ms.addPoint(1, [0.0, 0.0, 0.0])
        body.attachPoint(len(ms.pointList), [mo.fairlead[i, 0], mo.fairlead[i, 1], 0.0])
        ms.addPoint(1, [mo.bollard[i, 0], mo.bollard[i, 1], zb - mo.height[i]])
        ms.addLine(float(mo.l0[i]), "taut", nSegs=1, pointA=len(ms.pointList) - 1, pointB=len(ms.pointList))
    ms.initialize()
    ms.solveEquilibrium()
    f_mp = body.getForces(lines_only=True)[[0, 1, 5]]
    f, _ = restoring_force(mo, eta)
    assert np.allclose(f, f_mp, rtol=1e-3)
    k_mp = ms.getCoupledStiffnessA(lines_only=True)[np.ix_([0, 1, 5], [0, 1, 5])]
    k = stiffness(mo, eta)
    assert np.allclose(k, k_mp, rtol=0.01, atol=0.01 * np.abs(k_mp).max() * 1e-3)
