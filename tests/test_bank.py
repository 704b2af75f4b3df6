"""A bank of arms on one jetty (issue 31, items 1-3): the bank file, the triple swivel's angles held to MuJoCo and
to their own forward kinematics, the arm-to-arm clearance held to two independent routes."""

import math
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from loadarm.arm.clearance import PARTS, ArmShape, capsules, pair_clearance, path_clearance, segment_distance
from loadarm.arm.envelope import berth_box
from loadarm.arm.geometry import Arm
from loadarm.arm.slew import forward3d, inverse3d
from loadarm.arm.swivel import (
    coupler_rotation,
    rot_x,
    rot_y,
    rot_z,
    ship_rotation,
    swivel_angles,
    swivel_margins,
)
from loadarm.errors import ConfigError
from loadarm.params.bank import load_bank
from loadarm.params.kinds import identify
from loadarm.vocab import BANK_FACE_TABLE, SWIVEL_FACE_TABLE

from .hypo import examples

BANKS = Path(__file__).resolve().parents[1] / "src" / "loadarm" / "examples" / "banks"
EXAMPLE = BANKS / "lng150k_bank.toml"

# ---------------------------------------------------------------------------------------------------- bank file


@pytest.fixture(scope="module")
def bank():
    return load_bank(EXAMPLE)


def test_the_example_bank_reads_four_arms_each_on_its_flange(bank):
    """Three liquid arms and a vapour return, each on one flange; the installations resolved against the bank
    file; each arm reaches its flange (forward kinematics of its connected pose lands on it) and the arms keep
    the bank's clearance connected and stowed."""
    assert bank.names == ("L1", "L2", "V1", "L3")
    assert [f.product for f in bank.flanges] == ["liquid", "liquid", "vapour", "liquid"]
    assert all(p == (BANKS.parent / "full.toml").resolve() for p in bank.paths)
    for i, m in enumerate(bank.models):
        x, y, z = forward3d(m.arm, *bank.connected[i])
        assert np.allclose([x, y, z], bank.flange_position(i), atol=1e-9)
    need = bank.file.clearance.min_clearance
    for q in (bank.connected, bank.stowed):
        r = path_clearance(bank.shapes, [qi[None, :] for qi in q], required=need)
        assert r.clear and r.min_clearance > need and r.to_dict()["face"] is None
    assert identify(EXAMPLE)[0].name == "bank"


def test_a_bank_with_arms_too_close_is_refused_in_one_line():
    with pytest.raises(ConfigError) as err:
        load_bank(BANKS / "too_close.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(BANKS / "too_close.toml"))
    assert "'L1'" in msg and "'L2'" in msg and "overlap by" in msg
    assert "clearance.min_clearance = 0.5 m: valid range [0.5, inf) m" in msg


def test_the_undersized_power_unit_reads_as_a_bank(bank):
    """Its refusal is the release simulation's (issue 31, item 5); the file itself is valid."""
    small = load_bank(BANKS / "undersized_hpu.toml")
    pu = small.file.power_unit
    assert pu.accumulators * pu.accumulator_volume < bank.file.power_unit.accumulators * \
        bank.file.power_unit.accumulator_volume / 100


def _write(tmp_path, text: str, name: str = "bank.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize(("old", "new", "expect"), [
    ("pipe_radius = 0.3 ", "pipe_radius = -0.3 ", "clearance.pipe_radius = -0.3: Input should be greater than 0; "
                                                   "valid range (0, 3] m"),
    ("min_pressure = 1.0e7", "min_pressure = 2.5e7", "power_unit pressures must satisfy precharge_pressure"),
    ('arm = "V1"', 'arm = "V2"', "manifold.flanges 'F3': arm = 'V2' is not an arm of the bank"),
    ("pumps = 2", "pumps = 2.5", "power_unit.pumps = 2.5"),
    ("swivel3_deg = [-30.0, 30.0]", "swivel3_deg = [10.0, 30.0]", "swivels.swivel3_deg = [10, 30] deg"),
    ("heading_deg = 90.0", "heading = 90.0", "unknown key 'manifold.heading' (did you mean 'heading_deg'?)"),
    ('installation = "../full.toml"\ny = -5.25', 'installation = "nowhere.toml"\ny = -5.25',
     "arms.0.installation = 'nowhere.toml' (L1)"),
    ("position = [14.0, 0.0, 1.0]", "position = [30.0, 0.0, 1.0]", "arms 'L1' cannot reach its flange 'F1'"),
])
def test_a_wrong_value_is_refused_in_one_line_naming_file_and_key(tmp_path, old, new, expect):
    text = EXAMPLE.read_text().replace("../full.toml", str(BANKS.parent / "full.toml"))
    old = old.replace("../full.toml", str(BANKS.parent / "full.toml"))
    assert old in text
    p = _write(tmp_path, text.replace(old, new, 1).replace("nowhere.toml", str(tmp_path / "nowhere.toml")))
    with pytest.raises(ConfigError) as err:
        load_bank(p)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(p)), msg
    assert expect.replace("nowhere.toml", str(tmp_path / "nowhere.toml")) in msg, msg


def test_arms_of_different_sizes_and_relative_installations(tmp_path):
    """An arm's installation is found relative to the bank file, and arms may differ: a shorter vapour arm."""
    full = (BANKS.parent / "full.toml").read_text()
    (tmp_path / "arms").mkdir()
    _write(tmp_path / "arms", full, "liquid.toml")
    _write(tmp_path / "arms", full.replace("outboard = 8.2", "outboard = 7.6"), "vapour.toml")
    text = EXAMPLE.read_text().replace('installation = "../full.toml"\ny = 1.75', 'installation = '
                                       '"arms/vapour.toml"\ny = 1.75').replace("../full.toml", "arms/liquid.toml")
    b = load_bank(_write(tmp_path, text))
    assert [m.arm.c for m in b.models] == [8.2, 8.2, 7.6, 8.2]

# ----------------------------------------------------------------------------------------- segment distances


_coord = st.floats(-5.0, 5.0, allow_nan=False)
_point = st.tuples(_coord, _coord, _coord)


@settings(max_examples=examples(100), deadline=None)
@given(_point, _point, _point, _point)
def test_segment_distance_is_dense_sampling_s_minimum(p0, p1, q0, q1):
    """Against dense sampling: with n points on each segment, the true closest points lie within half a step of
    sampled ones, so the sampled minimum is at most the true one plus half of each step, and never below it."""
    p0, p1, q0, q1 = map(np.asarray, (p0, p1, q0, q1))
    d, s, t = segment_distance(p0, p1, q0, q1)
    n = 401
    u = np.linspace(0.0, 1.0, n)
    ps = p0 + u[:, None] * (p1 - p0)
    qs = q0 + u[:, None] * (q1 - q0)
    sampled = np.min(np.linalg.norm(ps[:, None, :] - qs[None, :, :], axis=-1))
    half_steps = (np.linalg.norm(p1 - p0) + np.linalg.norm(q1 - q0)) / (2 * (n - 1))
    assert d <= sampled + 1e-12
    assert sampled <= d + half_steps + 1e-12
    # and s, t are where it is
    assert np.isclose(np.linalg.norm(p0 + s * (p1 - p0) - q0 - t * (q1 - q0)), d, atol=1e-12)


def test_segment_distance_is_scipy_s_constrained_minimum_and_handles_degenerate_segments():
    """Against scipy's bounded minimisation of the squared distance over (s, t) in [0, 1]^2 (a convex problem:
    its minimum is the distance), on random segments, parallel ones, crossing ones and points: 1e-6 m (the
    optimiser's tolerance, far below any capsule's radius)."""
    rng = np.random.default_rng(31)
    cases = [rng.normal(size=(4, 3)) * 3 for _ in range(40)]
    a = np.array([0.0, 0.0, 0.0])
    cases += [np.array([a, [1, 0, 0], [0.5, 1, 0], [2.5, 1, 0]]),                       # parallel, overlapping
              np.array([a, [1, 0, 0], [3, 1, 0], [4, 1, 0]]),                           # parallel, apart
              np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0.2], [0, 1, 0.2]]),             # crossing above
              np.array([a, a, [0, 1, 0], [0, 1, 3]]),                                   # a point and a segment
              np.array([[0, 2, 0], [4, 2, 0], [1, 0, 0], [1, 0, 0]]),                   # a segment and a point
              np.array([a, a, [1, 1, 1], [1, 1, 1]])]                                   # two points
    for p0, p1, q0, q1 in cases:
        def f(v, p0=p0, p1=p1, q0=q0, q1=q1):
            g = p0 + v[0] * (p1 - p0) - q0 - v[1] * (q1 - q0)
            return g @ g, np.array([2 * g @ (p1 - p0), -2 * g @ (q1 - q0)])

        best = min((minimize(f, x0, jac=True, bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                             options={"ftol": 1e-15, "gtol": 1e-12})
                    for x0 in ([0.5, 0.5], [0, 1])), key=lambda r: r.fun)
        d, _, _ = segment_distance(p0, p1, q0, q1)
        assert abs(d - math.sqrt(max(best.fun, 0.0))) < 1e-6, (p0, p1, q0, q1)
    # vectorised: the batch is the loop
    batch = np.array(cases)
    d_all, _, _ = segment_distance(batch[:, 0], batch[:, 1], batch[:, 2], batch[:, 3])
    assert np.array_equal(d_all, [segment_distance(*c)[0] for c in cases])


# ---------------------------------------------------------------------------------------------------- clearance


def test_the_capsules_follow_the_arm_s_kinematics(bank):
    """The outboard pipe ends at the coupler of forward3d; the inboard counterweight lies on the inboard arm's
    line behind the hinge; the riser stands at the arm's base."""
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(-0.6, 0.6, 50), rng.uniform(0.3, 2.0, 50), rng.uniform(0.4, 2.8, 50)])
    shape = bank.shapes[1]
    c = capsules(shape, *q.T)
    x, y, z = forward3d(shape.arm, *q.T)
    assert np.allclose(c[:, 2, 1], np.column_stack([x, y, z]) + shape.base, atol=1e-12)
    inboard = c[:, 1, 1] - c[:, 1, 0]
    cw = c[:, 4, 1] - c[:, 4, 0]
    assert np.allclose(np.cross(inboard, cw), 0.0, atol=1e-9) and np.all(np.einsum("ij,ij->i", inboard, cw) < 0)
    assert np.allclose(np.linalg.norm(cw, axis=1), shape.counterweight_distances[0])
    assert np.allclose(c[:, 0, 0], shape.base)


def test_path_clearance_is_every_pair_at_every_step_and_finds_the_clash(bank):
    """Two arms swung towards each other along a path: the vectorised check is the loop of per-pose checks, its
    smallest clearance is where the loop's is, and it reports the clash once the arms overlap. Timed: four arms,
    2000 poses."""
    n = 2000
    k = np.linspace(0.0, 1.0, n)
    qs = []
    for i, q0 in enumerate(bank.connected):
        q = np.repeat(q0[None, :], n, axis=0)
        if i == 1:
            q[:, 0] = q0[0] + 0.9 * k                      # L2 slews towards V1 (+y)
        qs.append(q)
    t0 = time.perf_counter()
    r = path_clearance(bank.shapes, qs, k * 60.0, required=bank.file.clearance.min_clearance)
    elapsed = time.perf_counter() - t0
    loop = np.array([[min(float(pair_clearance(bank.shapes[i], bank.shapes[j], qs[i][m], qs[j][m])[0])
                          for i, j in r.pairs) for m in range(0, n, 97)]])
    assert np.allclose(r.minimum[::97], loop[0], atol=1e-12)
    # L2's coupler swings past V1's: the deepest overlap is the two triple swivels' where the couplers pass nearest
    tips = [np.column_stack(forward3d(bank.shapes[i].arm, *qs[i].T)) + bank.shapes[i].base for i in (1, 2)]
    nearest = int(np.argmin(np.linalg.norm(tips[0] - tips[1], axis=1)))
    assert r.pair == (1, 2) and not r.clear and abs(r.index - nearest) <= 1
    assert r.parts == ("triple swivel", "triple swivel")
    assert r.minimum[0] > r.required > r.min_clearance
    assert set(r.parts) <= set(PARTS) and "L2" in r.where() and "V1" in r.where()
    assert set(r.to_dict()) == {m.key for m in r.METRICS} and r.to_dict()["face"] == "clash"
    assert elapsed < 2.0, elapsed                          # about 0.22 s measured: 6 pairs x 36 capsule pairs x 2000


def test_two_arms_far_apart_have_the_riser_gap_less_the_radii():
    """A check with a known answer: two vertical, unslewed arms side by side, stowed the same way: the closest
    parts are the widest at the same height, and the clearance is the spacing less twice the widest radius."""
    arm = Arm(7.0, 12.0, 8.2)
    radii = (0.4, 0.3, 0.3, 0.6, 0.7, 0.7)
    a = ArmShape("A", arm, (0.0, 0.0, 0.0), (3.0, 2.5), radii)
    b = ArmShape("B", arm, (0.0, 5.0, 0.0), (3.0, 2.5), radii)
    q = inverse3d(arm, 3.82, 0.0, 10.4)
    gap, _ = pair_clearance(a, b, list(q), list(q))
    assert float(gap) == pytest.approx(5.0 - 2 * 0.7, abs=1e-12)


# ------------------------------------------------------------------------------------------------ triple swivel

_small = st.floats(-0.25, 0.25, allow_nan=False)


def _pose(fx, fy, fz, box, arm):
    """A reachable connected pose on the datasheet's flange box, along the berth within the slew."""
    p = (box.x_near + fx * (box.x_far - box.x_near), (2 * fy - 1) * 8.0, box.y_low + fz * (box.y_high - box.y_low))
    q = inverse3d(arm, *p, check=False)
    return np.array([float(v) for v in q])


@settings(max_examples=examples(300), deadline=None)
@given(st.floats(-0.7, 0.7), st.floats(0.2, 2.1), st.floats(0.3, 2.9), _small, _small, _small,
       st.sampled_from([math.pi / 2, -math.pi / 2, 0.3]))
def test_the_swivel_angles_lay_the_coupler_on_the_ship_s_flange(phi, alpha, beta, roll, pitch, yaw, heading):
    """Forward kinematics of the arm and the three swivels rebuilds the flange's orientation (the ship's
    rotation) from the swivel angles, to rounding (1e-12 on a rotation matrix's entries)."""
    s = swivel_angles(phi, alpha, beta, roll, pitch, yaw, heading=heading)
    r = coupler_rotation(phi, alpha, beta, *s)
    assert np.allclose(r, ship_rotation(roll, pitch, yaw, heading), atol=1e-12)


def test_the_swivels_at_rest_hang_the_coupler_plumb_and_take_roll_pitch_yaw_alone(bank):
    """Ship at rest, no slew: swivel 1 undoes the outboard arm's angle, the others stay at zero. With the bow along
    +y, the ship's roll turns swivel 1 alone, its yaw swivel 2 alone, its pitch swivel 3 alone (by minus it)."""
    q = bank.connected[0].copy()
    q[0] = 0.0
    s = swivel_angles(*q)
    assert np.allclose([s.s1, s.s2, s.s3], [-(q[1] - q[2]), 0.0, 0.0], atol=1e-15)
    for k, (rpy, expect) in enumerate((((0.05, 0, 0), (0.05, 0, 0)), ((0, 0.05, 0), (0, 0, -0.05)),
                                       ((0, 0, 0.05), (0, 0.05, 0)))):
        d = np.array(list(swivel_angles(*q, *rpy))) - np.array(list(s))
        if k != 1:
            assert np.allclose(d, expect, atol=1e-15), (rpy, d)
        else:   # pitch about the ship's transverse axis turns about the flange's normal only when the arm is plumb
            assert abs(d[2] + 0.05) < 2e-3 and np.all(np.abs(d[:2]) < 0.02), d


def test_the_swivel_angles_agree_with_mujoco(bank):
    """The independent route: MuJoCo's model of the arm with the three swivels as hinge joints solves the
    swivels (Gauss-Newton on its rotational Jacobian, from zero) for 300 random connected poses and ship
    attitudes; measured agreement about 1e-13 rad (tolerance 1e-9 rad: 10 nm at 10 m). Its forward kinematics
    at the closed form's angles is the ship's rotation to 1e-12."""
    from loadarm.design.swivels import mujoco_coupler_rotation, mujoco_swivel_angles

    model = bank.models[0]
    box = berth_box(bank.installations[0].datasheet)
    rng = np.random.default_rng(2031)
    n = 300
    q = np.array([_pose(*rng.uniform(0, 1, 3), box, model.arm) for _ in range(n)])
    q = q[np.isfinite(q).all(axis=1)]
    rpy = rng.uniform(-0.2, 0.2, (q.shape[0], 3))
    s = np.column_stack(list(swivel_angles(*q.T, *rpy.T)))
    target = ship_rotation(*rpy.T)
    t0 = time.perf_counter()
    sm = mujoco_swivel_angles(model.arm, q, target)
    elapsed = time.perf_counter() - t0
    assert np.isfinite(sm).all()
    assert np.max(np.abs(sm - s)) < 1e-9
    assert np.max(np.abs(mujoco_coupler_rotation(model.arm, q, s) - target)) < 1e-12
    assert elapsed < 1.0, elapsed                          # about 0.1 s measured


@settings(max_examples=examples(300), deadline=None)
@given(st.tuples(*[st.floats(0.0, 1.0)] * 3), st.tuples(*[st.floats(-0.1, 0.1)] * 3),
       st.sampled_from([math.pi / 2, -math.pi / 2]))
def test_each_swivel_face_s_words_say_which_ship_rotation_brings_it_nearer(bank, fractions, rpy, heading):
    """Turning the ship the way a swivel face's words say (heeled away from the jetty, yawed anticlockwise, its
    +y end up: the face's ``turning``, a rotation vector in the jetty frame) shrinks that face's margin, for an
    arm connected anywhere on the datasheet's flange box along the berth, the ship a few degrees off, either
    side alongside. By 1 mrad: small against the swivels' travel, large against rounding."""
    model = bank.models[0]
    q = _pose(*fractions, berth_box(bank.installations[0].datasheet), model.arm)
    assume(np.isfinite(q).all() and abs(q[0]) < model.slew.limit)
    limits = bank.file.swivels.limits()
    r0 = ship_rotation(*rpy, heading)
    m = np.swapaxes(rot_z(q[0]) @ rot_y(q[1] - q[2]), -1, -2)

    def margins(r):
        v = m @ r
        s = (np.arctan2(-v[2, 0], v[0, 0]), np.arctan2(v[1, 0], np.hypot(v[0, 0], v[2, 0])),
             np.arctan2(-v[1, 2], v[1, 1]))
        return swivel_margins(s, limits)

    base = margins(r0)
    assert np.allclose(base, swivel_margins(swivel_angles(*q, *rpy, heading=heading), limits), atol=1e-12)
    for i, face in enumerate(SWIVEL_FACE_TABLE):
        w = 1e-3 * np.asarray(face.turning)
        turn = rot_z(0.0)
        angle = np.linalg.norm(w)
        axis = w / angle
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        turn = turn + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k           # Rodrigues
        assert margins(turn @ r0)[i] < base[i], (face.name, face.words, q, rpy)


def test_the_swivel_faces_words_match_their_turning():
    """Words and declared rotation agree: heeling away from the jetty (at -x) is about +y, anticlockwise yaw
    about +z, the +y end up about +x; every face of the bank has words, a unit and a distinct code."""
    for f in SWIVEL_FACE_TABLE:
        w, (tx, ty, tz) = f.words, f.turning
        assert ("away from the jetty" in w) == (ty > 0) and ("towards the jetty" in w) == (ty < 0)
        assert ("anticlockwise" in w) == (tz > 0) and (" clockwise" in w) == (tz < 0)
        assert ("+y end up" in w) == (tx > 0) and ("-y end up" in w) == (tx < 0)
        assert (f.end == "max") == (sum(f.turning) > 0)
    assert len({f.name for f in BANK_FACE_TABLE}) == len(BANK_FACE_TABLE) == 7
    # the example's own connected poses are well inside the swivels' travel, ship at rest
    b = load_bank(EXAMPLE)
    s = swivel_angles(*b.connected.T)
    assert np.all(swivel_margins(s, b.file.swivels.limits()) > math.radians(20))


def test_rotations_are_right_handed():
    assert np.allclose(rot_z(math.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rot_x(math.pi / 2) @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(rot_y(math.pi / 2) @ [0, 0, 1], [1, 0, 0])


def test_the_bank_s_planned_approaches_are_checked_all_along(bank):
    """All at once or one after another, each arm ends on its flange and the check covers the whole run: one
    after another takes the sum of the plans' durations; the clearance at the end is the connected one."""
    from loadarm.design.bank import bank_approaches, check_bank_approaches

    t, qs = bank_approaches(bank)
    for i, q in enumerate(qs):
        assert np.allclose(q[-1], bank.connected[i], atol=1e-9) and np.allclose(q[0], bank.stowed[i], atol=1e-6)
    order = ("V1", "L2", "L3", "L1")
    t2, qs2 = bank_approaches(bank, order=order)
    assert t2[-1] > 3 * t[-1]
    first = bank.names.index("V1")
    assert np.allclose(qs2[bank.names.index("L1")][: len(t2) // 2], bank.stowed[bank.names.index("L1")], atol=1e-6)
    assert not np.allclose(qs2[first][len(t2) // 8], bank.stowed[first])
    r = check_bank_approaches(bank, order=order)
    connected = path_clearance(bank.shapes, [q[None, :] for q in bank.connected]).min_clearance
    assert r.clear and r.min_clearance == pytest.approx(connected, abs=1e-9)
    with pytest.raises(ValueError, match="must name every arm"):
        bank_approaches(bank, order=("L1", "L2"))


def test_the_bank_page_shows_the_bank_file_s_parameters():
    from loadarm.params.bank import bank_parameter_markdown

    doc = (Path(__file__).resolve().parents[1] / "docs" / "bank.md").read_text()
    assert bank_parameter_markdown() in doc, "regenerate with: python -m loadarm.present.docsgen --tables"


def test_a_single_pump_has_no_standby_and_a_vapour_flange_takes_no_density():
    """Found by review: `standby_pumps` defaulting to one refused a single-pump bank that had loaded before; now
    the default is one only with two pumps or more. A density on the vapour return (which runs empty) is refused
    in one line rather than ignored."""
    from loadarm.params.bank import PowerUnit, parse_bank

    assert PowerUnit(pumps=1).standby == 0 and PowerUnit(pumps=1).duty_flow == PowerUnit().pump_flow
    assert PowerUnit(pumps=3).standby == 1 and PowerUnit(pumps=3, standby_pumps=0).standby == 0
    with pytest.raises(ValueError, match="standby_pumps = 2 must be below pumps = 2"):
        PowerUnit(pumps=2, standby_pumps=2)
    import tomllib

    data = tomllib.loads(EXAMPLE.read_text())
    data["manifold"]["flanges"][2]["density"] = 2.0
    with pytest.raises(ConfigError) as exc:
        parse_bank(data, source="bank.toml")
    assert "\n" not in str(exc.value) and "F3: density = 2 kg/m^3 on a vapour flange" in str(exc.value)
