"""Issue 28, item 1: lines as terminals moor them, in the motion: winch brakes that render at their setting,
lines that part at their breaking load and the cascade that follows, and tensions that include the
first-order motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from loadarm.params.berth import Berth, load_berth
from loadarm.ship.model import compile_ship
from loadarm.ship.motion import line_stretch_coefficients, simulate

BERTH = "examples/berths/lng150k.toml"
BREAST = ("fwd breast 1", "fwd breast 2", "aft breast 1", "aft breast 2")


@pytest.fixture(scope="module")
def berth():
    return load_berth(BERTH)


@pytest.fixture(scope="module")
def ship(berth):
    return compile_ship(berth)


@pytest.fixture(scope="module")
def on_bitts(berth):
    """The example berth with every line on bitts (no brake: a line holds until it parts)."""
    data = berth.model_dump()
    data["moorings"] = tuple(dict(m, brake=0.0) for m in data["moorings"])
    return compile_ship(Berth.model_validate(data))


def _gale(berth, speed):
    return berth.environment.model_copy(update=dict(hs=0.0, current_speed=0.0, wind_speed=speed,
                                                    wind_direction_deg=0.0))


def test_brakes_render_at_their_setting_and_the_ship_walks_off(ship, berth):
    """The breast lines cut at 100 s in a 30 m/s wind off the berth: the head and stern lines take the load,
    reach their brakes' 600 kN and render. No tension ever passes a brake's holding load, each rendered line
    reached it, no line parts (the brakes protect them), the brakes pay out line and the ship walks off the
    berth by metres (each gust renders the brakes again: the pay-out is not hauled back)."""
    m = simulate(ship, _gale(berth, 30.0), 900.0, seed=1, parted=BREAST, part_time=100.0)
    assert np.all(m.tension <= ship.moorings.brake)
    assert set(m.parted) == set(BREAST)
    rendered = m.paid_out > 0
    assert rendered.sum() >= 4 and m.paid_out.max() > 1.0
    assert m.pose[-1, 0] - m.pose[900, 0] > 3.0
    assert np.all(np.max(m.tension[:, rendered], axis=0) == ship.moorings.brake[rendered])
    assert "fwd breast 1" in m.summary()["parted"] and m.to_dict()["paid_out_max_m"] > 1.0


def test_lines_on_bitts_part_at_their_breaking_load_and_the_cascade_follows(on_bitts, berth):
    """The same with every line on bitts in 33 m/s: the head, spring and stern lines are loaded past their
    breaking load one after the other (the issue: before, a stern line carried 76 % of its MBL and nothing
    followed). Each parts in the step where its tension reaches its breaking load (within one sample's
    growth), carries nothing after, and the ship breaks out."""
    mo = on_bitts.moorings
    m = simulate(on_bitts, _gale(berth, 33.0), 900.0, seed=1, parted=BREAST, part_time=100.0)
    assert len(m.parted) == len(mo.names), "every line parts: the cascade"
    times = [m.part_times[mo.names.index(n)] for n in m.parted]
    assert times == sorted(times)
    for j, t in enumerate(m.part_times):
        k = int(round(t / 0.1))
        if mo.names[j] in BREAST:
            assert t == 100.0 and np.all(m.tension[k:, j] == 0.0)
            continue
        assert np.all(m.tension[k + 1:, j] == 0.0)
        peak = m.tension[k, j]
        assert mo.breaking_load[j] <= peak <= 1.01 * mo.breaking_load[j], (mo.names[j], peak)
        assert np.all(m.tension[:k, j] < mo.breaking_load[j])
    assert m.pose[-1, 0] > 20.0


def _exact_tension(mo, i, e):
    if e <= 0:
        return 0.0
    return brentq(lambda t: sum(ln * eb * (t / mb) ** p for ln, mb, eb, p in mo.segments[i]) - e, 0.0,
                  4 * mo.breaking_load[i], xtol=1e-6)


def _fairleads_exact(ship, pose, six):
    """Berth-frame fairlead positions from the low-frequency pose and the first-order six of the centre of
    gravity, by a finite rotation (SciPy's, roll-pitch-yaw as a rotation vector's small-angle equivalent: the
    exact rigid-body map, no linearisation)."""
    mo = ship.moorings
    psi = mo.psi0 + pose[2]
    rot_lf = Rotation.from_euler("z", psi)
    r = mo.fairlead - ship.cog
    moved = ship.cog + six[:3] + Rotation.from_rotvec(six[3:]).apply(r)
    pos = rot_lf.apply(np.column_stack([moved[:, :2], np.zeros(len(r))]))
    pos[:, :2] += mo.origin + pose[:2]
    pos[:, 2] = moved[:, 2] - ship.draft
    return pos


def test_the_line_stretch_is_the_rigid_body_motion_to_second_order(ship):
    """line_stretch_coefficients (dL = u . (xi + theta x r)) against the lengths of the lines to fairleads
    moved by the exact rigid-body map: the error is second order (halving the motion quarters it) and within
    its bound, each fairlead's displacement squared over its line's length plus its lever times the angle
    squared (a 0.5 m, 0.3 deg motion: a few millimetres)."""
    mo = ship.moorings
    pose = np.array([0.3, -0.2, 0.002])
    c = line_stretch_coefficients(ship, pose)
    base = _fairleads_exact(ship, pose, np.zeros(6))
    length0 = np.linalg.norm(base - mo.bollard, axis=1)
    rng = np.random.default_rng(5)
    direction = rng.normal(size=6)
    direction[:3] *= 0.5 / np.linalg.norm(direction[:3])
    direction[3:] *= math.radians(0.3) / np.linalg.norm(direction[3:])
    errs = []
    for scale in (1.0, 0.5):
        six = scale * direction
        moved = _fairleads_exact(ship, pose, six)
        exact = np.linalg.norm(moved - mo.bollard, axis=1) - length0
        err = np.abs(six @ c - exact)
        d = np.linalg.norm(moved - base, axis=1)
        bound = d ** 2 / length0 + np.linalg.norm(mo.fairlead - ship.cog, axis=1) * np.sum(six[3:] ** 2)
        assert np.all(err <= bound), (err, bound)
        errs.append(np.max(err))
    assert errs[0] < 0.01
    assert 3.0 < errs[0] / errs[1] < 5.0


def test_tensions_include_the_first_order_motion(ship, berth):
    """Hs 2 m, Tp 9.3 s, beam seas (the issue's state): the recorded tension of each line at sampled times is
    the tension of the line to its fairlead moved by the low-frequency pose and the exact first-order rigid
    motion, read from the material curves solved directly (within 1 % of the breaking load: the table's
    0.1 %, the stretch's second order and the brake's cap aside); and the first-order motion adds to the
    tension the low-frequency motion alone gives (the issue: 577 kN from the low-frequency motion, 1282 kN
    with the first order, on the old lines)."""
    mo = ship.moorings
    env = berth.environment.model_copy(update=dict(hs=2.0, tp=9.3, wave_direction_deg=0.0))
    m = simulate(ship, env, 600.0, seed=2)
    lf = simulate(ship, env, 600.0, seed=2, waves=False)

    def fast(t):                                   # the tension less its 20 s running mean: the wave-frequency part
        kernel = np.ones(201) / 201
        return np.array([t[:, i] - np.convolve(t[:, i], kernel, mode="same") for i in range(t.shape[1])])[:, 300:-300]

    # the wave-frequency part of each line's tension: 2.5-4.4 times what the low-frequency motion alone gives it
    # (whose own fast part is the set-down's 10-30 s content; 3 times or more before the set-down)
    assert np.all(np.std(fast(m.tension), axis=1) > 2 * np.std(fast(lf.tension), axis=1))
    assert np.max(np.std(fast(m.tension), axis=1)) > 20e3
    rendered_from = np.where(m.paid_out > 0, 0, 10 ** 9)
    for k in range(50, 6000, 397):
        pos = _fairleads_exact(ship, m.pose[k], m.wave[k])
        length = np.linalg.norm(pos - mo.bollard, axis=1)
        for i in range(len(mo.names)):
            if k >= rendered_from[i]:
                continue                       # a rendered line's unstretched length is the run's state
            want = min(_exact_tension(mo, i, length[i] - mo.unstretched[i]), mo.brake[i])
            assert abs(m.tension[k, i] - want) <= 0.01 * mo.breaking_load[i], (k, mo.names[i], m.tension[k, i], want)


def test_the_events_read_the_kernel_s_elongations_bit_for_bit(ship):
    """The integrator judges the lines on _elongations (the kernel's geometry alone, so that the whole
    right-hand side is not evaluated twice a step): the same numbers as the kernel's, bit for bit, at poses
    off, along and turned."""
    from loadarm.ship.mooring import restoring_kernel
    from loadarm.ship.motion import _elongations

    mo = ship.moorings
    for x, y, psi in ((0.0, 0.0, 0.0), (0.7, -0.4, 0.003), (2.5, 1.2, -0.01)):
        per_line = np.empty((4, len(mo.names)))
        h = mo.psi0 + psi
        restoring_kernel(x, y, math.cos(h), math.sin(h), mo.lines, mo.table, mo.alive, mo.fender_y, mo.fender_defl,
                         mo.fender_load, mo.fender_npts, mo.hull, mo.origin, np.zeros(3), np.zeros(len(mo.names)),
                         per_line)
        out = np.empty(len(mo.names))
        _elongations(x, y, h, mo.lines, mo.origin, out)
        assert np.array_equal(out, per_line[3])
