"""Moorings and fenders: the quasi-static restoring force, equilibrium and stiffness, against MoorPy and against
an independent NumPy route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from loadarm.errors import ConfigError
from loadarm.params.berth import load_berth
from loadarm.ship.mooring import (
    MooringEquilibriumError,
    compile_moorings,
    equilibrium,
    line_elongation,
    line_tensions,
    restoring_force,
    stiffness,
)

from .hypo import examples

BERTH = "examples/berths/lng150k.toml"


@pytest.fixture(scope="module")
def mo():
    return compile_moorings(load_berth(BERTH))


def _exact_tension(mo, i, e):
    """A line's tension at elongation e from its segments' material curves directly (the series equation
    sum L_s eps_s(T) = e solved by Brent's method): no table."""
    if e <= 0:
        return 0.0
    def f(t):
        return sum(ln * eb * (t / mb) ** p for ln, mb, eb, p in mo.segments[i]) - e
    hi = mo.breaking_load[i]
    while f(hi) < 0:
        hi *= 2
    return brentq(f, 0.0, hi, xtol=1e-6)


def _numpy_route(mo, eta, alive, rise=0.0):
    """The same physics written again with NumPy arrays and rotation matrices and the material curves solved
    directly (no shared code)."""
    psi = mo.psi0 + eta[2]
    rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
    centre = mo.origin + eta[:2]
    r = mo.fairlead[:, :2] @ rot.T
    delta = centre + r - mo.bollard[:, :2]
    length = np.sqrt(np.sum(delta ** 2, axis=1) + (mo.height + rise) ** 2)
    t = np.array([_exact_tension(mo, i, length[i] - mo.unstretched[i]) if alive[i] else 0.0
                  for i in range(len(mo.names))])
    f = -(t / length)[:, None] * delta
    force = np.array([f[:, 0].sum(), f[:, 1].sum(), np.sum(r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0])])
    # fenders: the side line u -> centre + rot (u, side), abreast of each fender
    for j, yf in enumerate(mo.fender_y):
        q0 = centre + rot @ np.array([0.0, mo.side])
        u = (yf - q0[1]) / rot[1, 0]
        q = q0 + u * rot[:, 0]
        d = -q[0]
        n = mo.fender_npts[j]
        if d > 0 and abs(u) <= mo.half_length:
            xs, ys = mo.fender_defl[j, :n], mo.fender_load[j, :n]
            load = np.interp(d, xs, ys) if d <= xs[-1] else ys[-1] + (ys[-1] - ys[-2]) / (xs[-1] - xs[-2]) * (d - xs[-1])
            force += [load, 0.0, -(q[1] - centre[1]) * load]
    return force, t


#: The tables' interpolation error, at most 0.04 % of a line's breaking load on the shipped lines (measured over
#: 3000 elongations per line against the curves solved directly): held to 0.1 %.
TABLE_TOL = 1e-3


@settings(max_examples=examples(200), deadline=None)
@given(x=st.floats(-0.5, 2.0), y=st.floats(-2.0, 2.0), psi=st.floats(-0.01, 0.01),
       parted=st.lists(st.integers(0, 15), max_size=16), rise=st.floats(-2.0, 2.0))
@example(x=2.0, y=0.0, psi=0.0, parted=[], rise=2.0)     # found (thorough profile): breast lines past breaking
def test_the_kernel_matches_an_independent_numpy_route(mo, x, y, psi, parted, rise):
    """Tensions within the table's tolerance of the material curves solved directly, up to the breaking load
    (past it the table keeps its last slope and the line parts: there both are past it); forces within the sum
    of those over the lines (and 1e-9 of the force), at poses where no line is past breaking."""
    alive = mo.alive
    alive[parted] = False
    eta = np.array([x, y, psi])
    f, t = restoring_force(mo, eta, alive, rise=rise)
    f2, t2 = _numpy_route(mo, eta, alive, rise)
    tol = TABLE_TOL * mo.breaking_load
    held = t2 <= mo.breaking_load
    assert np.all(np.abs(t - t2)[held] <= tol[held] + 1e-9 * np.abs(t2[held]))
    assert np.all(t[~held] >= mo.breaking_load[~held] - tol[~held])
    if not np.all(held):
        return
    assert np.allclose(f[:2], f2[:2], rtol=1e-9, atol=tol.sum())
    assert abs(f[2] - f2[2]) <= 1e-9 * abs(f2[2]) + tol.sum() * 150.0


def test_the_tables_follow_the_material_curves(mo):
    """Every line's table against the series equation solved directly, over 400 elongations from slack to
    breaking (past it the line parts): within TABLE_TOL of the breaking load; the table ends at the breaking
    load, and rises beyond it (the kernel keeps the last slope)."""
    for i in range(len(mo.names)):
        assert mo.tension_of(i, 1.1 * mo.e_break[i]) > mo.breaking_load[i]
        es = np.linspace(-0.1, mo.e_break[i], 400)
        exact = np.array([_exact_tension(mo, i, e) for e in es])
        assert np.max(np.abs(mo.tension_of(i, es) - exact)) <= TABLE_TOL * mo.breaking_load[i], mo.names[i]
        assert mo.table[i, -1] == mo.breaking_load[i]


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
    """The unstretched lengths are set from the curves solved directly: the table gives the pretension back
    within its tolerance, the curves exactly."""
    assert np.all(np.abs(line_tensions(mo, [0.0, 0.0, 0.0]) - mo.pretension) <= TABLE_TOL * mo.breaking_load)
    _, exact = _numpy_route(mo, np.zeros(3), mo.alive)
    assert np.allclose(exact, mo.pretension, rtol=1e-6)


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
    K^-1 F (the tangent stiffness at the calm equilibrium), within 3 % (the lines' geometric and material
    stiffening) and 0.3 mm (the second-order coupling into x: a 0.12 m move along the berth lengthens a 42 m
    breast line by 0.12^2 / (2 x 42) = 0.17 mm, which the fenders take)."""
    eq0 = equilibrium(mo, np.zeros(3))
    k = stiffness(mo, eq0)
    eq = equilibrium(mo, np.array(load), eta0=eq0)
    assert np.allclose(eq - eq0, np.linalg.solve(k, load), rtol=0.03, atol=3e-4)


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


def _moorpy_system(mo, eta, rise=0.0):
    """The berth's lines in MoorPy (NREL's quasi-static mooring code), written from the berth's own records:
    each line a main line and a tail (two MoorPy lines joined at a free point), each segment MoorPy's
    nonlinear straight element with its material's tension-strain table (300 points up to its MBL), negligible
    weight; the ship a body placed at the pose. MoorPy has no fenders: the lines alone. A line shorter between
    its ends than unstretched is slack and left out."""
    mp = pytest.importorskip("moorpy")
    from loadarm.params.berth import load_berth

    berth = load_berth(BERTH)
    ms = mp.System(depth=200)
    zb = 50.0
    body = ms.addBody(-1, [mo.origin[0] + eta[0], mo.origin[1] + eta[1], zb, 0, 0, mo.psi0 + eta[2]])
    for i, line in enumerate(berth.moorings):
        segs = [(line.material, mo.segments[i][0][0], line.mbl)]
        if line.tail_length > 0:
            segs.append((line.tail_material, line.tail_length, line.tail_mbl))
        names = []
        for k, (mat, length, mbl) in enumerate(segs):
            m = berth.material(mat)
            frac = np.linspace(0.0, 1.0, 300)
            name = f"{i}-{k}"
            ms.lineTypes[name] = {"name": name, "m": 0.01, "w": 1e-4, "d_vol": 0.001, "MBL": mbl,
                                  "Str": m.strain_at_break * frac ** m.exponent, "Ten": mbl * frac,
                                  "material": mat, "cost": 0.0, "EAd": 0.0, "EAd_Lm": 0.0, "Cd": 0.0, "Ca": 0.0,
                                  "CdAx": 0.0, "CaAx": 0.0, "input_d": 0.0, "input_type": {}}
            names.append((name, length))
        boll = np.array([mo.bollard[i, 0], mo.bollard[i, 1], zb - mo.height[i] - rise])
        psi = mo.psi0 + eta[2]
        c, s_ = math.cos(psi), math.sin(psi)
        fair = np.array([mo.origin[0] + eta[0] + c * mo.fairlead[i, 0] - s_ * mo.fairlead[i, 1],
                         mo.origin[1] + eta[1] + s_ * mo.fairlead[i, 0] + c * mo.fairlead[i, 1], zb])
        if np.linalg.norm(fair - boll) <= sum(length for _, length in names):
            continue        # slack (geometry alone): MoorPy's straight elements cannot hold a slack joint
        ms.addPoint(1, [0.0, 0.0, 0.0])
        body.attachPoint(len(ms.pointList), [mo.fairlead[i, 0], mo.fairlead[i, 1], 0.0])
        a = len(ms.pointList)
        if len(names) == 2:
            joint = boll + (fair - boll) * names[1][1] / np.linalg.norm(fair - boll)
            ms.addPoint(0, joint)        # the joint: free (started a tail's length from the bollard)
            j = len(ms.pointList)
            ms.addPoint(1, boll)
            # each element from its lower end to its upper one (found: MoorPy's nonlinear element, given its
            # upper end first, turns its vertical force the wrong way and the joint sinks metres)
            ms.addLine(names[0][1], names[0][0], nSegs=1, pointA=j, pointB=a)
            ms.addLine(names[1][1], names[1][0], nSegs=1, pointA=len(ms.pointList), pointB=j)
        else:
            ms.addPoint(1, boll)
            ms.addLine(names[0][1], names[0][0], nSegs=1, pointA=len(ms.pointList), pointB=a)
    return ms, body


def _moorpy_force(mo, eta):
    """The lines' force on the ship at a pose, by MoorPy: its joints solved to 0.1 mm."""
    ms, body = _moorpy_system(mo, eta)
    ms.initialize()
    ms.solveEquilibrium(tol=1e-4, maxIter=2000)
    return body.getForces(lines_only=True)[[0, 1, 5]]


#: Poses for MoorPy: off the berth from the fenders to where the first line reaches its brake's holding load
#: (a fraction of it), along the berth (springs slack) and in yaw.
def _moorpy_poses(mo):
    brake_x = _offset_at_first_brake(mo)
    return [np.array(e) for e in ([0.3, 0.0, 0.0], [0.5 * brake_x, 0.4, 0.001], [0.95 * brake_x, -0.5, -0.001],
                                  [0.5, 1.5, 0.0])]


def test_agrees_with_moorpy(mo):
    """MoorPy on the same lines: the force within 2 % (the issue's bar) at poses off the berth from the
    fenders to where the first line reaches its brake's holding load, along the berth and in yaw (found
    within 0.01 %)."""
    pytest.importorskip("moorpy")
    scale = np.array([1.0, 1.0, 1.0 / 100.0])       # moments as forces at 100 m
    for eta in _moorpy_poses(mo):
        f_mp = _moorpy_force(mo, eta)
        f, _ = restoring_force(mo, eta, fenders=False)
        assert np.max(np.abs(f - f_mp) * scale) <= 0.02 * np.max(np.abs(f_mp) * scale), (eta, f, f_mp)


@pytest.mark.slow
def test_the_stiffness_agrees_with_moorpy(mo):
    """The stiffness against central differences of MoorPy's force, its joints solved again at each pose
    (MoorPy's own coupled stiffness keeps the joints where they were, which drops the tails: found 3 times
    ours), within 2 % on the diagonal at the same poses."""
    pytest.importorskip("moorpy")
    step = np.array([0.01, 0.01, 1e-4])
    for eta in _moorpy_poses(mo):
        k = stiffness(mo, eta, fenders=False)
        for d in range(3):
            de = np.zeros(3)
            de[d] = step[d]
            k_mp = -(_moorpy_force(mo, eta + de)[d] - _moorpy_force(mo, eta - de)[d]) / (2 * step[d])
            assert abs(k[d, d] - k_mp) <= 0.02 * abs(k_mp), (eta, d, k[d, d], k_mp)


def _offset_at_first_brake(mo):
    """The offset off the berth at which the first line's tension reaches its brake's holding load."""
    x = 0.0
    while np.all(line_tensions(mo, [x, 0.0, 0.0]) < mo.brake):
        x += 0.02
    return x


def test_a_tide_changes_a_breast_line_as_a_hand_calculation_says(mo):
    """A 1.5 m tide lifts the fairleads 1.5 m: a forward breast line (fairlead to bollard 41.75 m across, 6.5 m
    up) gets longer by sqrt(41.75^2 + 8^2) - sqrt(41.75^2 + 6.5^2) = 0.26 m (the issue's figure), and its
    tension, with the ship held at the reference pose, is what its HMPE main line and nylon tail give at the
    pretension's elongation plus 0.26 m (the series equation solved by hand: brentq); a 1.5 m fall slackens it
    to what 0.26 m less gives."""
    i = mo.names.index("fwd breast 1")
    # port side to, bow along berth +y: the ship-frame fairlead (x, y) lies at berth origin + (-y, x)
    across = math.hypot(mo.origin[0] - mo.fairlead[i, 1] - mo.bollard[i, 0],
                        mo.origin[1] + mo.fairlead[i, 0] - mo.bollard[i, 1])
    h = mo.height[i]
    assert abs(h - 6.5) < 1e-9 and abs(across - 41.75) < 0.01
    e0 = float(line_elongation(mo.pretension[i], mo.segments[i]))
    for rise in (1.5, -1.5):
        d_len = math.hypot(across, h + rise) - math.hypot(across, h)
        hand = _exact_tension(mo, i, e0 + d_len)
        got = line_tensions(mo, np.zeros(3), rise=rise)[i]
        assert abs(got - hand) <= TABLE_TOL * mo.breaking_load[i], (rise, got, hand)
    assert 0.25 < math.hypot(across, h + 1.5) - math.hypot(across, h) < 0.27
    up = line_tensions(mo, np.zeros(3), rise=1.5)[i]
    down = line_tensions(mo, np.zeros(3), rise=-1.5)[i]
    assert 150e3 < up < 175e3 and 40e3 < down < 60e3       # about +-60 kN on these lines (370 kN on the old)


def test_the_mooring_page_cites_the_lines(mo):
    """docs/ship-motion.md section 4: the example breast line's lengths, stiffness and the tide's effect, and
    section 3 the moored periods, recomputed."""
    from loadarm.ship.model import compile_ship

    from .test_doc_numbers import cited

    i = mo.names.index("fwd breast 1")
    main, tail = mo.segments[i][0][0], mo.segments[i][1][0]
    cited("docs/ship-motion.md", f"{mo.unstretched[i]:.1f} m unstretched ({main:.1f} m HMPE, {tail:g} m nylon)")
    e0 = float(line_elongation(mo.pretension[i], mo.segments[i]))
    k = (mo.tension_of(i, e0 + 1e-3) - mo.tension_of(i, e0 - 1e-3)) / 2e-3
    cited("docs/ship-motion.md", f"{k / 1e6:.2f} MN/m at its pretension")
    up = line_tensions(mo, np.zeros(3), rise=1.5)[i] - mo.pretension[i]
    down = line_tensions(mo, np.zeros(3), rise=-1.5)[i] - mo.pretension[i]
    cited("docs/ship-motion.md", f"+{up / 1e3:.0f} kN, and a 1.5 m fall {down / 1e3:.0f} kN")
    p = compile_ship(load_berth(BERTH)).natural_periods()
    lf = sorted(p[f"lf_mode_{j}_s"] for j in (1, 2, 3))
    cited("docs/ship-motion.md", f"three moored modes of {lf[0]:.0f}-{lf[-1]:.0f} s")


def test_the_ship_page_justifies_the_free_floating_raos():
    """docs/ship-motion.md section 3: the lines' stiffness against the inertia at wave periods, recomputed
    (the reason the first-order response is free-floating)."""
    from loadarm.ship.model import compile_ship

    from .test_doc_numbers import cited

    ship = compile_ship(load_berth(BERTH))
    h = ship.hydro
    ratios = []
    for period in (10.0, 16.0):
        w = 2 * math.pi / period
        i = int(np.argmin(np.abs(h.omega - w)))
        ratios += [ship.k_lines[0, 0] / (w * w * (h.inertia[1, 1] + h.added_mass[i, 1, 1])),
                   ship.k_lines[1, 1] / (w * w * (h.inertia[0, 0] + h.added_mass[i, 0, 0]))]
    a, b, c, d = (100 * r for r in ratios)
    cited("docs/ship-motion.md", f"sway {a:.1f} % and surge {b:.1f} % at 10 s, {c:.1f} % and {d:.0f} % at a 16 s")


@pytest.mark.slow
def test_a_line_follows_moordyn_in_a_slow_motion(mo, tmp_path, monkeypatch):
    """The dynamic check (issue 28, item 2): the forward breast line in MoorDyn (NREL's lumped-mass mooring
    dynamics: the nylon tail from the bollard and the HMPE main line to the fairlead, 4 and 8 segments, joined
    at a 10 kg free point; each material's curve as a 30-point tension-strain table, MoorDyn's limit; light lines
    well below the surface, where MoorDyn puts them) with its fairlead driven off the berth +-1 m at a 60 s
    period, a moored ship's slow sway, from the pretension's geometry, over two periods: its dynamic tension at
    the fairlead against ours, quasi-static on the same stretched length, within 1 % of the breaking load over
    the second period (measured 0.22 %: at mooring periods the line's own inertia and damping hardly matter,
    which is why the motion takes the lines quasi-statically). MoorDyn's slack line keeps its weight's few
    hundred newtons, ours none."""
    moordyn = pytest.importorskip("moordyn")
    monkeypatch.chdir(tmp_path)
    i = mo.names.index("fwd breast 1")
    (main_len, mbl, eb, p), (tail_len, tmbl, teb, tp) = mo.segments[i]
    for name, m_bl, e_b, ex in (("main.dat", mbl, eb, p), ("tail.dat", tmbl, teb, tp)):
        fr = np.linspace(0.0, 1.0, 30) ** 1.5                 # denser where the curve bends most
        rows = "\n".join(f"{a:.9g} {b:.9g}" for a, b in zip(e_b * fr ** ex, m_bl * fr))
        (tmp_path / name).write_text("strain tension\n(-) (N)\n---\n" + rows)     # MoorDyn skips 3 lines
    across = math.hypot(mo.origin[0] - mo.fairlead[i, 1] - mo.bollard[i, 0],
                        mo.origin[1] + mo.fairlead[i, 0] - mo.bollard[i, 1])
    h = mo.height[i]
    boll = np.array([0.0, 0.0, -60.0])
    fair = boll + np.array([across, 0.0, h])
    stretched_tail = tail_len * (1 + teb * (mo.pretension[i] / tmbl) ** tp)
    joint = boll + (fair - boll) * stretched_tail / np.linalg.norm(fair - boll)

    def pt(v):
        return " ".join(f"{c:.5f}" for c in v)

    (tmp_path / "lines.txt").write_text(f"""--------------------- MoorDyn Input File ------------------------------------
loadarm: the forward breast line, driven slowly
----------------------- LINE TYPES ------------------------------------------
TypeName   Diam    Mass/m     EA     BA/-zeta    EI    Cd     Ca     CdAx    CaAx
(name)     (m)     (kg/m)     (N)    (N-s/-)    (N-m^2) (-)   (-)    (-)     (-)
main       0.044   1.25       main.dat  -0.8     0     1.2    1.0    0.0     0.0
tail       0.088   5.0        tail.dat  -0.8     0     1.2    1.0    0.0     0.0
---------------------- POINTS --------------------------------
ID   Attachment  X       Y     Z      Mass   Volume  CdA    Ca
(#)   (-)        (m)     (m)   (m)    (kg)   (m^3)   (m^2)  (-)
1     Fixed      {pt(boll)} 0 0 0 0
2     Free       {pt(joint)} 10 0 0 0
3     Coupled    {pt(fair)} 0 0 0 0
---------------------- LINES --------------------------------------
ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  LineOutputs
(#)   (name)     (#)      (#)       (m)       (-)     (-)
1     tail       1        2        {tail_len:.6f}   4       -
2     main       2        3        {main_len:.6f}   8       -
---------------------- OPTIONS -----------------------------------------
0.0002   dtM       - time step to use in mooring integration (s)
3.0e6    kb        - bottom stiffness (Pa/m)
3.0e5    cb        - bottom damping (Pa-s/m)
200      WtrDpth   - water depth (m)
5.0      ICDfac
0.001    ICthresh
60       TmaxIC
------------------------- need this line --------------------------------------
""")
    system = moordyn.Create(str(tmp_path / "lines.txt"))
    try:
        moordyn.Init(system, list(fair), [0.0, 0.0, 0.0])
        period, amp, dt = 60.0, 1.0, 0.05
        w = 2 * math.pi / period
        worst, t = 0.0, 0.0
        for _ in range(int(2 * period / dt)):
            x = fair + np.array([amp * math.sin(w * (t + dt)), 0.0, 0.0])
            v = [amp * w * math.cos(w * (t + dt)), 0.0, 0.0]
            f = moordyn.Step(system, list(x), v, t, dt)
            t += dt
            if t > period:
                ours = _exact_tension(mo, i, float(np.linalg.norm(x - boll)) - mo.unstretched[i])
                worst = max(worst, abs(float(np.linalg.norm(f)) - ours))
    finally:
        moordyn.Close(system)
    assert worst <= 0.01 * mo.breaking_load[i], worst
