"""Passing-ship loads (issue 28, item 3): Wang's (1975) slender-body formulas with the bottom's images, checked by
an independent route (the integrals before integration by parts, by scipy's adaptive quadrature), their limits
(deep water; Tuck's shallow-water flow), their symmetries, the square of the speed and the decay with separation,
a worked example of the formula, the range of validity refused in one line, nothing changed without a passing
ship, and the example berth's passing scenario (docs/ship-motion.md) in the motion and the operability."""

from __future__ import annotations

import copy
import itertools
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import settings as hsettings
from hypothesis import strategies as st
from scipy.integrate import dblquad

from loadarm.errors import ConfigError
from loadarm.params.berth import RHO_SEA, parse_berth
from loadarm.params.sections import Operability
from loadarm.ship import motion as motion_mod
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import LF_CUTOFF, moored_state, simulate
from loadarm.ship.passing import (
    MOORED_MIDSHIP_COEFFICIENT,
    PassingShipRangeError,
    check_range,
    kernel_sum,
    passing_load,
    wang_loads,
)
from loadarm.studies.operability import state_ship

from .conftest import ROOT
from .hypo import examples
from .test_doc_numbers import cited

EXAMPLE = ROOT / "examples" / "berths" / "lng150k.toml"
DATA = tomllib.loads(EXAMPLE.read_text())
KN = 6.0 * 1852.0 / 3600.0                      # 6 kn, m/s
LNG = (278.0, MOORED_MIDSHIP_COEFFICIENT * 43.4 * 11.5)
BOX = (300.0, 0.97 * 48.0 * 12.0)               # the default passing ship: a 300 m container ship


def _with_passing(**kw):
    d = copy.deepcopy(DATA)
    d["passing_ship"] = dict(kw)
    return d


def _direct(xi, eta, u, moored, passing, rho=RHO_SEA):
    """Deep water, by scipy's adaptive quadrature of the forms before integration by parts: the surge force
    the pressure on the sections, the sway force and the yaw moment the cross flow's acceleration on twice the
    sections' area (displaced plus added mass), ``3 (x1 - x2 - xi) / R^5``."""
    (l1, a1), (l2, a2) = moored, passing

    def s1(x):
        return a1 * (1 - (2 * x / l1) ** 2)

    def ds1(x):
        return -8 * a1 * x / l1 ** 2

    def ds2(x):
        return -8 * a2 * x / l2 ** 2

    def r2(x1, x2):
        return (x1 - x2 - xi) ** 2 + eta ** 2

    opts = {"epsabs": 1e-9, "epsrel": 1e-8}
    k = rho * u * u / math.pi
    fx = dblquad(lambda x2, x1: ds1(x1) * ds2(x2) * (x1 - x2 - xi) / r2(x1, x2) ** 1.5,
                 -l1 / 2, l1 / 2, -l2 / 2, l2 / 2, **opts)[0]
    fy = dblquad(lambda x2, x1: s1(x1) * ds2(x2) * 3 * (x1 - x2 - xi) / r2(x1, x2) ** 2.5,
                 -l1 / 2, l1 / 2, -l2 / 2, l2 / 2, **opts)[0]
    mz = dblquad(lambda x2, x1: x1 * s1(x1) * ds2(x2) * 3 * (x1 - x2 - xi) / r2(x1, x2) ** 2.5,
                 -l1 / 2, l1 / 2, -l2 / 2, l2 / 2, **opts)[0]
    return np.array([-0.5 * k * fx, k * eta * fy, k * eta * mz])


@pytest.mark.parametrize("xi", [0.0, -150.0, 260.0])
def test_the_quadrature_matches_the_integrals_before_integration_by_parts(xi):
    got = wang_loads(xi, 150.0, KN, LNG, BOX)
    want = _direct(xi, 150.0, KN, LNG, BOX)
    scale = np.array([np.max(np.abs(wang_loads(np.linspace(-600, 600, 121), 150.0, KN, LNG, BOX)[:, k]))
                      for k in range(3)])
    assert np.all(np.abs(got - want) <= 1e-6 * scale), (got, want)


def test_the_image_sum_converges_and_has_its_two_limits():
    a = np.geomspace(0.1, 1e5, 70)
    h = 20.0
    q = kernel_sum(a * a, h)
    assert np.allclose(q, kernel_sum(a * a, h, n_images=2000), rtol=1e-7, atol=0)
    assert np.allclose(q[a < 0.05 * h], a[a < 0.05 * h] ** -3.0, rtol=1e-4)      # deep: the source alone
    far = a > 50 * h
    assert np.allclose(q[far] * h * a[far] ** 2, 1.0, rtol=1e-3)                 # Tuck's: spread over the depth
    assert np.allclose(kernel_sum(a * a, math.inf), a ** -3.0, rtol=1e-14, atol=0)
    assert np.sum(a < 0.05 * h) >= 5 and np.sum(far) >= 5


def test_the_worked_example_of_wang_finite_depth_formula():
    """N. Barczak's MathCAD sheet of Wang's formula (2016; "Calculation of forces and moments from Wang", its
    inputs and result quoted in the test suite of github.com/vamseeachanta/digitalmodel): a 950 ft ship of
    3192 ft^2 midship area passed abreast by a 475 ft ship of 6413 ft^2 at 11.2 ft/s, 190 ft apart in 95 ft of
    water, sea water 1.9905 slug/ft^3: sway force 7.644e4 lbf, surge force and yaw moment zero. Tolerance 0.1 %:
    the sheet's four digits (0.007 %) and our quadrature's 1e-6 leave room only for a different formula (the
    deep-water value is half of it, a different image spacing moves it by percents)."""
    ft, lbf = 0.3048, 4.4482216152605
    f = wang_loads(0.0, 190 * ft, 11.2 * ft, (950 * ft, 3192 * ft ** 2), (475 * ft, 6413 * ft ** 2), 95 * ft,
                   rho=1.9905 * 515.378818)
    assert f[1] / lbf == pytest.approx(7.644e4, rel=1e-3)
    assert abs(f[0]) < 1e-9 * f[1] and abs(f[2]) < 1e-9 * f[1] * 950 * ft


@hsettings(max_examples=examples(40))
@given(sep=st.floats(0.2, 3.0), frac=st.floats(0.05, 2.0), l2=st.floats(0.3, 1.5), depth=st.sampled_from(
    [math.inf, 20.0, 40.0]), side=st.sampled_from([1.0, -1.0]))
@pytest.mark.slow  # 2-3 s a case (make test's two minutes; CI runs it)
def test_sway_is_even_surge_and_yaw_odd_in_the_stagger_and_all_go_with_the_speed_squared(sep, frac, l2, depth,
                                                                                           side):
    moored, passing = LNG, (l2 * 278.0, 500.0)
    eta = side * sep * 278.0
    xi = np.array([frac * 278.0, -frac * 278.0])
    f = wang_loads(xi, eta, 3.0, moored, passing, depth)
    scale = np.abs(wang_loads(np.linspace(-3 * 278, 3 * 278, 61), eta, 3.0, moored, passing, depth)).max(axis=0)
    assert abs(f[0, 1] - f[1, 1]) <= 1e-9 * scale[1]
    assert abs(f[0, 0] + f[1, 0]) <= 1e-9 * scale[0]
    assert abs(f[0, 2] + f[1, 2]) <= 1e-9 * scale[2]
    g = wang_loads(xi, eta, -6.0, moored, passing, depth)       # twice as fast, the other way
    assert np.allclose(g, 4.0 * f, rtol=1e-12, atol=1e-9 * scale.max())
    # the sway force at closest approach pulls the moored ship towards the passing ship
    assert wang_loads(0.0, eta, 3.0, moored, passing, depth)[1] * eta > 0


@pytest.mark.slow
def test_the_loads_decay_with_separation_as_a_dipole_pair():
    """Far off, each hull is a dipole of its volume: the peak forces fall as ``eta^-4`` in deep water and as
    ``eta^-3`` many depths off (the flow spread over the depth), the yaw moment (a fore-and-aft symmetric hull
    turns in the dipole's gradient) one power faster; nearer, the loads fall all the way."""
    def peak(eta, depth):
        xi = np.linspace(-2 * eta, 2 * eta, 801)
        return np.abs(wang_loads(xi, eta, 3.0, LNG, BOX, depth)).max(axis=0)

    deep = peak(10 * 278.0, math.inf) / peak(20 * 278.0, math.inf)
    assert np.allclose(deep, [16.0, 16.0, 32.0], rtol=0.02), deep
    shallow = peak(10 * 278.0, 20.0) / peak(20 * 278.0, 20.0)
    assert np.allclose(shallow, [8.0, 8.0, 16.0], rtol=0.02), shallow
    near = [peak(e, 20.0)[1] for e in (100.0, 150.0, 300.0, 600.0)]
    assert all(a > b for a, b in itertools.pairwise(near))


@pytest.mark.parametrize("kw,expect", [
    ({"separation": 60.0}, "passing_ship.separation = 60 m is outside the passing-ship model's range [91.4, 1390] m"),
    ({"separation": 1500.0}, "passing_ship.separation = 1500 m is outside"),
    ({"draft": 14.0}, "passing_ship.draft = 14 m is outside the passing-ship model's range [0, 13.33] m"),
    ({"speed": 8.0}, "passing_ship.speed = 8 m/s is outside the passing-ship model's range (0, 7.004] m/s"),
])
def test_the_berth_refuses_a_passing_ship_outside_the_model_in_one_line(kw, expect):
    with pytest.raises(ConfigError) as exc:
        parse_berth(_with_passing(**kw), source="b.toml")
    msg = str(exc.value)
    assert msg.startswith("b.toml: ") and "\n" not in msg and expect in msg, msg


@pytest.mark.parametrize("kw,expect", [
    ({"speed": 12.0}, "passing_ship.speed = 12"),
    ({"heading": "sideways"}, "passing_ship.heading = 'sideways'"),
    ({"lenght": 300.0}, "did you mean 'length'"),
])
def test_the_berth_refuses_a_bad_passing_ship_key_in_one_line(kw, expect):
    with pytest.raises(ConfigError) as exc:
        parse_berth(_with_passing(**kw), source="b.toml")
    msg = str(exc.value)
    assert msg.startswith("b.toml: ") and "\n" not in msg and expect in msg, msg


def test_the_docs_commented_example_is_a_valid_passing_ship_with_the_defaults():
    text = (ROOT / "docs" / "ship-motion.md").read_text(encoding="utf-8")
    block = text.split("```toml\n[passing_ship]")[1].split("```")[0]
    table = tomllib.loads("[passing_ship]" + block)["passing_ship"]
    b = parse_berth(_with_passing(**table))
    assert b.passing_ship == parse_berth(_with_passing()).passing_ship
    assert parse_berth(DATA).passing_ship is None


def test_the_model_refuses_shallow_water_for_the_moored_ship():
    with pytest.raises(PassingShipRangeError, match=r"^berth.water_depth = 15 m is outside .* \[17.25, inf\]"):
        check_range((278.0, 43.4, 11.5), (300.0, 48.0, 9.0), 3.0, 150.0, 15.0)


@pytest.mark.parametrize("side", ["port", "starboard"])
@pytest.mark.parametrize("heading", ["same", "opposite"])
@pytest.mark.slow  # 2-3 s a case (make test's two minutes; CI runs it)
def test_the_load_is_in_the_ship_frame_and_pulls_towards_the_sea_side(side, heading):
    """The ship frame at the reference heading (port side to: bow along berth +y, psi0 = +90 deg; starboard:
    -90 deg), as ``_lf_load``'s, which the integration turns into the berth frame: abreast, the passing ship
    on the sea side (berth +x) pulls the moored ship off the berth; before it comes abreast, the passing ship
    then off the other end, the surge force and the yaw moment reverse with the heading, the sway force not."""
    from types import SimpleNamespace

    psi0 = math.pi / 2 if side == "port" else -math.pi / 2
    ship = SimpleNamespace(length=278.0, beam=43.4, draft=11.5, water_depth=20.0, psi0=psi0)
    p = parse_berth(_with_passing(heading=heading)).passing_ship
    t = p.closest_approach_time + np.array([0.0, -40.0])
    f = passing_load(t, ship, p)
    c, s = math.cos(psi0), math.sin(psi0)
    off = c * f[:, 0] - s * f[:, 1]                        # berth x
    assert off[0] > 2e5 and abs(f[0, 0]) < 1e-6 * off[0]
    other = passing_load(t, ship, parse_berth(_with_passing(heading="opposite" if heading == "same" else
                                                            "same")).passing_ship)
    assert f[1, 0] == pytest.approx(-other[1, 0], rel=1e-9) and f[1, 0] != 0
    assert f[1, 1] == pytest.approx(other[1, 1], rel=1e-9)
    assert f[1, 2] == pytest.approx(-other[1, 2], rel=1e-9) and f[1, 2] != 0


@pytest.fixture(scope="module")
def ships():
    ship = compile_ship(parse_berth(_with_passing()))
    return replace(ship, passing=None), ship


def _calm(ship):
    return ship.environment.model_copy(update={"wind_speed": 0.0, "current_speed": 0.0, "hs": 0.0})


def test_without_a_passing_ship_nothing_changes_bit_for_bit(ships, monkeypatch):
    plain, _ = ships
    env = plain.environment
    a = simulate(plain, env, 300.0, seed=3)
    fa, _, la = moored_state(plain, env, 300.0, seed=3)
    monkeypatch.setattr(motion_mod, "add_passing_load", lambda f, *args: f)       # the motion before the line
    b = simulate(plain, env, 300.0, seed=3)
    fb, _, lb = moored_state(plain, env, 300.0, seed=3)
    for key in ("pose", "pose_velocity", "tension", "flange", "flange_velocity"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    assert np.array_equal(fa, fb) and np.array_equal(la.tension_max, lb.tension_max)


def _scenario(ships):
    plain, ship = ships
    p = ship.passing
    run = simulate(ship, _calm(ship), 1200.0, seed=0)
    calm = simulate(plain, _calm(plain), 1200.0, seed=0)
    t = np.arange(0.0, 1200.0, 0.5)
    f = passing_load(t, ship, p)
    return p, run, calm, t, f


@pytest.mark.slow  # 1.5-2.5 s (make test's two-minute budget, 2026-12-06; CI runs it)
def test_the_example_passing_scenario_moves_the_ship_and_loads_the_lines(ships):
    _p, run, calm, t, f = _scenario(ships)
    rel = run.pose - run.mean_pose
    assert np.all(np.isfinite(run.pose)) and np.all(np.isfinite(run.tension))
    assert not run.parted
    # the load is slow: its content above the low-frequency cut-off is negligible (no low-pass needed)
    spec = np.abs(np.fft.rfft(f, axis=0)) ** 2
    w = 2 * math.pi * np.fft.rfftfreq(t.size, 0.5)
    assert np.sum(spec[w > LF_CUTOFF]) < 1e-6 * np.sum(spec)
    # and it is all but gone at the record's ends (the spline's reach)
    assert np.abs(f[0]).max() < 0.02 * np.abs(f).max(axis=0).max()
    # the lines feel it: calm water and no passing ship hold the pretension
    assert np.max(run.tension / run.mbl) > np.max(calm.tension / calm.mbl) + 0.01
    assert np.ptp(rel[:, 1]) > 0.05                         # surge (berth y) of centimetres
    assert np.ptp(calm.pose[:, 1]) < 1e-6


@pytest.mark.slow
def test_ship_motion_page_passing_ship_numbers(ships):
    p, run, calm, _t, f = _scenario(ships)
    rel = run.pose - run.mean_pose
    page = "docs/ship-motion.md"
    cited(page, f"peak surge force {np.abs(f[:, 0]).max() / 1e3:.0f} kN")
    cited(page, f"sway force {-f[:, 1].min() / 1e3:.0f} kN towards the passing ship")
    cited(page, f"{f[:, 1].max() / 1e3:.0f} kN away from it")
    cited(page, f"yaw moment {np.abs(f[:, 2]).max() / 1e6:.1f} MN m")
    cited(page, f"surges {np.ptp(rel[:, 1]) * 100:.0f} cm peak to peak")
    cited(page, f"moves {rel[:, 0].max() * 100:.1f} cm off the berth")
    i = int(np.argmax(np.max(run.tension / run.mbl, axis=0)))
    cited(page, f"largest line tension {np.max(run.tension / run.mbl) * 100:.1f} % of its MBL ({run.names[i]}")
    cited(page, f"{np.max(calm.tension / calm.mbl) * 100:.1f} % without the passing ship")
    moored = (278.0, MOORED_MIDSHIP_COEFFICIENT * 43.4 * 11.5)
    hull = (p.length, p.midship_coefficient * p.beam * p.draft)
    xi = np.linspace(-1500.0, 1500.0, 1201)
    sway = {e: np.abs(wang_loads(xi, e, p.speed, moored, hull, 20.0)[:, 1]).max() for e in (100.0, 150.0, 300.0)}
    cited(page, f"the peak sway force {sway[100.0] / 1e3:.0f} kN at 100 m, {sway[300.0] / 1e3:.0f} kN at 300 m")
    fast = (10 * 1852 / 3600 / p.speed) ** 2 * sway[100.0] / sway[150.0]
    cited(page, f"pulls about {fast:.0f} times harder")


def test_the_operability_option_applies_the_berths_passing_ship(ships):
    plain, ship = ships
    assert state_ship(ship, Operability(passing_ship=True)) is ship
    assert state_ship(ship, Operability()).passing is None
    with pytest.raises(ConfigError, match="operability.passing_ship = true needs a \\[passing_ship\\] table"):
        state_ship(plain, Operability(passing_ship=True))
    env = _calm(ship)
    _, _, on = moored_state(ship, env, 1200.0, seed=0)
    _, _, off = moored_state(state_ship(ship, Operability()), env, 1200.0, seed=0)
    assert on.surge_pp > off.surge_pp + 0.05 and np.max(on.tension_max) > np.max(off.tension_max)
