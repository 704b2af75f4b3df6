"""The bank's loads on the ship's manifold (issue 31, item 4): the connected, free-wheeling arm's wrench at the flange
held to MuJoCo and to the arm's potential energy, its properties, the check against the allowable and the record."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.arm.dynamics import G, Lump, MassModel, mass_model
from loadarm.arm.envelope import berth_box
from loadarm.arm.manifold import (
    LOAD_NAMES,
    chain_jacobian,
    flange_wrench,
    friction_signs,
)
from loadarm.arm.slew import forward3d, inverse3d
from loadarm.arm.swivel import coupler_rotation, swivel_angles
from loadarm.design.manifold import (
    MANIFOLD_LOAD_EVENT,
    arm_masses,
    check_manifold_loads,
    mujoco_flange_wrench,
    record_manifold_loads,
    wind_coefficient,
)
from loadarm.errors import ConfigError
from loadarm.files import read_toml
from loadarm.params.bank import load_bank, parse_bank
from loadarm.vocab import EVENTS

from .hypo import examples

EXAMPLE = Path(__file__).resolve().parents[1] / "src" / "loadarm" / "examples" / "banks" / "lng150k_bank.toml"
ZERO = np.zeros(3)


@pytest.fixture(scope="module")
def bank():
    return load_bank(EXAMPLE)


def _random_states(bank, n, seed):
    rng = np.random.default_rng(seed)
    q = bank.connected[0] + rng.uniform(-0.3, 0.3, (n, 3))
    s = rng.uniform(-0.6, 0.6, (n, 3))
    return q, s, rng.normal(0.0, 0.3, (n, 3)), rng.normal(0.0, 0.5, (n, 3)), rng.normal(0.0, 1.0e3, (n, 6))


def test_the_flange_wrench_agrees_with_mujoco(bank):
    """Independent route: the same chain of six hinges in MuJoCo (mj_inverse, mj_applyFT for the wind at the pipes'
    midpoints, mj_jacSite at the flange's face, the coupler body's axes). Over 60 random states (poses around the
    connection, swivels up to 34 deg, rates, accelerations, friction, wind across every pipe, a 1 m coupler) the
    forces agree to 1e-6 N and the moments to 1e-6 N m (measured: about 1e-7 on loads up to 1.3e5)."""
    q, s, qd, qdd, fr = _random_states(bank, 60, 7)
    masses = arm_masses(bank, 0)
    kw = {"wind": np.array([12.0, -9.0, 2.0]), "wind_k": wind_coefficient(bank), "friction": fr, "coupler_length": 1.0}
    ours = flange_wrench(masses, q, qd, qdd, s, **kw)
    theirs = mujoco_flange_wrench(masses, q, qd, qdd, s, **kw)
    assert np.abs(ours.loads).max() > 1e4
    np.testing.assert_allclose(ours.force, theirs.force, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours.moment, theirs.moment, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours.loads, theirs.loads, rtol=0, atol=1e-6)


def _potential(masses: MassModel, p) -> float:
    """The arm's potential energy with its tip at ``p``, from each lump's height (not the Lagrangian's constants)."""
    _, a, b = (float(v) for v in inverse3d(masses.arm, *p))
    angle = {"inboard": a, "outboard": a - b + math.pi, "lever": a - b}
    z = 0.0
    for lump in masses.lumps:
        base = masses.arm.a + (masses.arm.b * math.cos(a) if lump.link == "outboard" else 0.0)
        z += lump.mass * (base + lump.offset * math.cos(angle[lump.link]))
    return G * z


@settings(max_examples=examples(40), deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(-2.0, 2.0), st.floats(0.0, 1.0))
def test_the_static_load_is_the_potential_s_gradient(u, v, y, fill):
    """Second route, static: with no wind, motion or friction the flange carries the arm's unbalance, the force on
    the ship ``-dV/dp`` (``V`` the lumps' potential energy through the inverse kinematics, central differences of
    1e-5 m), anywhere on the flange box and for any fill; agreement 1e-6 relative plus 1e-3 N."""
    b = load_bank(EXAMPLE)
    model = b.models[0]
    bx = berth_box(model.datasheet)
    p = np.array([bx.x_near + u * (bx.x_far - bx.x_near), y, bx.y_low + v * (bx.y_high - bx.y_low)])
    masses = mass_model(model, fill=fill)
    q = np.array([float(w) for w in inverse3d(model.arm, *p)])
    s = np.array(list(swivel_angles(*q)), dtype=float)
    w = flange_wrench(masses, q, ZERO, ZERO, s)
    h = 1e-5
    grad = np.array([(_potential(masses, p + h * e) - _potential(masses, p - h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(w.force, -grad, rtol=1e-6, atol=1e-3)
    assert np.all(w.moment == 0.0) and w.loads[3] == 0.0 and w.loads[4] == 0.0


def test_the_chain_s_jacobian_is_its_forward_kinematics_differentiated(bank):
    """The linear rows are the tip's position (forward3d) and the angular rows the coupler's orientation
    (coupler_rotation, ``dR R^T``) differentiated by central differences: 1e-8."""
    q, s, *_ = _random_states(bank, 5, 3)
    h = 1e-6
    for qi, si in zip(q, s, strict=True):
        x = np.concatenate([qi, si])
        j = chain_jacobian(bank.models[0].arm, qi, si)
        for k in range(6):
            e = np.zeros(6)
            e[k] = h
            lin = (np.array(forward3d(bank.models[0].arm, *(x + e)[:3])) -
                   np.array(forward3d(bank.models[0].arm, *(x - e)[:3]))) / (2 * h)
            r = coupler_rotation(*x)
            dr = (coupler_rotation(*(x + e)) - coupler_rotation(*(x - e))) / (2 * h)
            w = dr @ r.T
            np.testing.assert_allclose(j[:3, k], lin, atol=1e-8)
            np.testing.assert_allclose(j[3:, k], [w[2, 1], w[0, 2], w[1, 0]], atol=1e-8)


def _balanced(masses: MassModel) -> MassModel:
    """The same arm with its counterweights set to balance it exactly about both joints (``g_a = g_ab = 0``)."""
    d_in = sum(l.mass * l.offset for l in masses.lumps if l.link == "inboard" and l.name != "counterweight_inboard")
    m_out = sum(l.mass for l in masses.lumps if l.link == "outboard")
    d_out = sum(l.mass * l.offset for l in masses.lumps if l.link == "outboard")
    cw_in = masses.by_name("counterweight_inboard")
    cw_out = masses.by_name("counterweight_outboard")
    return masses.with_counterweights((d_in + m_out * masses.arm.b) / -cw_in.offset, d_out / cw_out.offset)


@settings(max_examples=examples(40), deadline=None)
@given(st.floats(-0.4, 0.4), st.floats(0.9, 1.8), st.floats(1.2, 2.4), st.floats(0.0, 1.0),
       st.tuples(*[st.floats(-0.5, 0.5)] * 3))
def test_a_balanced_arm_at_rest_loads_the_flange_with_nothing(phi, alpha, beta, fill, s):
    """Counterweights that balance the arm about both joints: with no wind, motion or friction the flange carries
    nothing, anywhere (1e-6 N against the arm's 1e5 N weight)."""
    masses = _balanced(mass_model(load_bank(EXAMPLE).models[0], fill=fill))
    w = flange_wrench(masses, (phi, alpha, beta), ZERO, ZERO, s, coupler_length=1.0)
    assert np.abs(w.force).max() < 1e-6 and np.abs(w.moment).max() < 1e-6


@settings(max_examples=examples(40), deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.0, 1500.0))
def test_the_load_is_affine_in_the_product_s_density(fill, density):
    """The product adds its weight linearly: ``L(rho)`` is affine (``L(2 rho) - L(rho) = L(rho) - L(0)``), and an
    empty arm's load does not depend on the density; 1e-6 N."""
    b = load_bank(EXAMPLE)
    model = b.models[0]
    q = b.connected[0]
    s = np.array(list(swivel_angles(*q)), dtype=float)

    def load(rho, f):
        ms = dataclasses.replace(model.masses, product_density=rho)
        return flange_wrench(mass_model(dataclasses.replace(model, masses=ms), fill=f), q, ZERO, ZERO,
                             s).force

    np.testing.assert_allclose(load(2 * density, fill) - load(density, fill), load(density, fill) - load(0.0, fill),
                               atol=1e-6)
    np.testing.assert_allclose(load(density, 0.0), load(0.0, 0.0), atol=1e-6)


def test_the_torsion_is_the_third_swivel_s_friction_and_friction_is_linear(bank):
    """Swivel 3 turns about the flange's normal, so the torsion on the flange is its friction torque exactly; the
    loads are linear in the six frictions (the check's 64 extremes bound every friction at rest)."""
    q, s, qd, qdd, fr = _random_states(bank, 20, 11)
    masses = arm_masses(bank, 1)
    with_f = flange_wrench(masses, q, qd, qdd, s, friction=fr, coupler_length=0.7)
    without = flange_wrench(masses, q, qd, qdd, s, coupler_length=0.7)
    np.testing.assert_allclose(with_f.loads[:, 4], fr[:, 5], atol=1e-9)
    np.testing.assert_allclose(without.loads[:, 4], 0.0, atol=1e-9)
    f2 = flange_wrench(masses, q, qd, qdd, s, friction=2 * fr, coupler_length=0.7)
    np.testing.assert_allclose(f2.force - with_f.force, with_f.force - without.force, atol=1e-6)
    assert friction_signs().shape == (64, 6) and len({tuple(r) for r in friction_signs()}) == 64


def test_the_example_bank_is_within_oc_imf_placeholders_and_an_overload_alarms(bank):
    """The example bank's worst loads over the design case, the flange box's corners, the wind from 12 directions
    and calm, and the friction's extremes, against the bank file's allowables: within them; with allowables a
    tenth as large, each exceedance names the alarm's event code, the arm and the load."""
    r = check_manifold_loads(bank)
    assert r.ok and r.exceeded == [] and 0.0 < r.utilisation.max() < 1.0
    assert r.static.shape == (4, 5) and np.all(r.worst >= np.abs(r.static) - 1e-9)
    assert r.static[2, 2] > 0 > r.static[0, 2]      # the empty vapour arm lifts its flange, a full liquid arm presses
    d = r.to_dict()
    assert d["within_allowable"] is True and set(d["arms"]) == set(bank.names)
    small = bank.file.manifold_loads.model_copy(update={k: getattr(bank.file.manifold_loads, k) / 10 for k in LOAD_NAMES})
    weak = dataclasses.replace(bank, file=bank.file.model_copy(update={"manifold_loads": small}))
    r2 = check_manifold_loads(weak)
    assert not r2.ok and r2.exceeded
    assert {e["code"] for e in r2.exceeded} == {MANIFOLD_LOAD_EVENT} and MANIFOLD_LOAD_EVENT in EVENTS
    assert all(e["value"] > e["allowable"] for e in r2.exceeded)


def test_a_still_record_gives_the_design_case_and_a_moving_one_its_worst_and_when(bank):
    """A record of a ship at rest: every sample is the design case's static load (no rate, so no friction). A ship
    heaving 0.3 m over 8 s and rolling 1 deg: the worst load is above the static one, at a sample of the record,
    and the inertia is in it (the same record at 1/10 the frequency loads less)."""
    t = np.arange(0.0, 60.0, 0.1)
    still = record_manifold_loads(bank, t, np.zeros((t.size, 3)), np.zeros((t.size, 3)))
    static = check_manifold_loads(bank).static
    np.testing.assert_allclose(still.loads, np.broadcast_to(static[:, None, :], still.loads.shape), atol=1e-6)

    def moving(period):
        d = np.column_stack([0 * t, 0 * t, 0.3 * np.sin(2 * np.pi * t / period)])
        a = np.column_stack([np.radians(1.0) * np.sin(2 * np.pi * t / period), 0 * t, 0 * t])
        return record_manifold_loads(bank, t, d, a)

    fast, slow = moving(8.0), moving(80.0)
    assert np.all(fast.worst[:, 2] > np.abs(static[:, 2]))
    assert np.all(np.isin(fast.worst_time, t))
    assert fast.worst[:, 2].max() > slow.worst[:, 2].max()
    assert fast.summary()["within_allowable"] is True


def test_bad_input_is_refused_in_one_line(bank):
    """A non-finite state, an uneven record and a negative wind speed in the bank file: each refused in one line."""
    with pytest.raises(ValueError) as e:
        flange_wrench(arm_masses(bank, 0), (0.0, np.nan, 1.0), ZERO, ZERO, ZERO)
    assert "\n" not in str(e.value) and "finite" in str(e.value)
    t = np.array([0.0, 0.1, 0.3, 0.4])
    with pytest.raises(ValueError) as e:
        record_manifold_loads(bank, t, np.zeros((4, 3)), np.zeros((4, 3)))
    assert "\n" not in str(e.value) and "evenly" in str(e.value)
    data = read_toml(EXAMPLE, "bank")
    data["manifold_loads"]["wind_speed"] = -1.0
    with pytest.raises(ConfigError) as e:
        parse_bank(data, source="b.toml")
    assert "\n" not in str(e.value) and "manifold_loads.wind_speed" in str(e.value)


def test_lumps_and_model_are_unchanged_by_the_check(bank):
    """The connected arm's product: liquid arms full, the vapour return empty (its installation's density)."""
    full, empty = arm_masses(bank, 0), arm_masses(bank, 2)
    assert full.total_mass > empty.total_mass
    per_m = bank.models[0].masses.product_density * math.pi * bank.models[0].masses.pipe_inner_diameter ** 2 / 4
    assert math.isclose(full.total_mass - empty.total_mass, per_m * (bank.models[0].arm.b + bank.models[0].arm.c),
                        rel_tol=1e-12)
    assert isinstance(full.lumps[0], Lump)


def _run(capsys, *args):
    from loadarm.cli import main

    code = main(list(args))
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.mark.slow  # make test's 2-minute budget (2-4 s here); CI runs it
def test_check_bank_gives_each_arm_s_flange_load_and_refuses_an_overloaded_manifold_in_one_line(capsys):
    """``loadarm check --bank``: the example's verdict per arm (its largest load over its allowable) in the table
    and the JSON; a manifold a quarter as strong refused (exit 2) in one line naming the alarm's label, the arm,
    the load and the key."""
    import json

    code, out, err = _run(capsys, "check", "--bank", str(EXAMPLE))
    assert code == 0, err
    line = next(x for x in out.splitlines() if x.startswith("within the allowable loads"))
    assert "flange load / allowable, largest" in out and line.split()[-1] == "True"
    code, out, err = _run(capsys, "check", "--bank", str(EXAMPLE), "--json")
    d = json.loads(out)["manifold_loads"]
    assert d["within_allowable"] is True and set(d["arms"]) == {"L1", "L2", "V1", "L3"}
    code, _, err = _run(capsys, "check", "--bank", str(EXAMPLE.parent / "overloaded_manifold.toml"))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "MANIFOLD LOAD: arm 'V1'" in err and "manifold_loads.bending_moment = 5 kN m" in err


@pytest.mark.slow                 # 6 s: make test keeps to its 2-minute budget; CI runs it
def test_a_report_naming_a_bank_has_its_section(tmp_path):
    """An installation naming a ``[report] bank`` (no berth: no ship's record): the report's section 8d with each
    arm's row (its flange, its nearest arm, its governing load and its share of the allowable, its release),
    the bank's three figures, and summary.json's ``bank`` with the manifold loads' verdict."""
    import json
    import re
    import shutil

    from loadarm.params.config import load_config
    from loadarm.present.report import build_report

    root = Path(__file__).resolve().parents[1] / "src" / "loadarm" / "examples"
    (tmp_path / "banks").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "banks" / EXAMPLE.name)
    shutil.copy(root / "full.toml", tmp_path / "full.toml")
    text = re.sub(r"\[report\].*", '[report]\nbank = "banks/lng150k_bank.toml"\n', (root / "paper.toml").read_text(),
                  flags=re.S)
    (tmp_path / "mine.toml").write_text(text)
    files = build_report(load_config(tmp_path / "mine.toml"), tmp_path / "out", source=tmp_path / "mine.toml")
    html = files.html.read_text()
    summary = json.loads(files.summary.read_text())
    assert "8d. The bank of arms: clearance, loads on the manifold, emergency release" in html
    assert "F3 (vapour)" in html and "MANIFOLD LOAD" in html
    assert {"bank_clearance.png", "bank_manifold_loads.png", "bank_release.png"} <= {p.name for p in files.figures.values()}
    assert "bank_manifold_record.png" not in {p.name for p in files.figures.values()}
    b = summary["bank"]
    assert b["manifold_loads"]["within_allowable"] is True and b["manifold_record"] is None
    assert b["release"]["verdict"] == "pass" and b["file"] == "lng150k_bank.toml"
    # the approaches as check --bank orders them (found: the report checked them all at once), and the swivels
    assert b["approach_order"]["waves"] == [["L1", "L2"], ["V1", "L3"]] and b["clearance"]["clear"] is True
    assert b["swivel_margin_deg"] == pytest.approx({"L1": 30.0, "L2": 30.0, "V1": 30.0, "L3": 30.0}, abs=0.05)
    assert "L1 + L2, then V1 + L3;" in html and "swivel margin, design case [deg]" in html and "approach wave" in html
    assert b["flanging_area_corners"]["least_clearance_m"] == pytest.approx(1.688, abs=5e-4)
    assert b["swivel_envelope"]["least_deg"] == pytest.approx(27.32, abs=0.005) and "motions [deg]" in html
    # the example's allowables are OCIMF's as quoted: the report says they are unconfirmed, and which
    assert b["allowables_confirmed_by"] == "" and len(b["allowables_unconfirmed"]) == 5
    assert "<strong>unconfirmed</strong>: axial force, lateral force, vertical force, bending moment, torsion moment" \
        in html


@pytest.mark.slow                 # 8 s: make test keeps to its 2-minute budget; CI runs it
def test_a_report_on_a_bank_the_check_refuses_says_so_and_shows_what_it_can(tmp_path, capsys):
    """Found: the report stopped on a bank whose pumps cannot drive its approaches (no order), and never said that
    a bank check --bank refuses was refused. The undersized power unit with pumps of 0.1 L/min: the report's bank
    section opens with every refusal, in the check's order (the approaches, the release), draws the clearance of
    every arm approaching at once, and summary.json says ``ok`` false with the same lines; check --bank refuses
    it in one line, the first of them (the one place of the rules: ``studies.bank_check``)."""
    import json
    import re
    import shutil

    from loadarm.params.config import load_config
    from loadarm.present.report import build_report

    root = Path(__file__).resolve().parents[1] / "src" / "loadarm" / "examples"
    (tmp_path / "banks").mkdir()
    shutil.copy(root / "full.toml", tmp_path / "full.toml")
    weak = (EXAMPLE.parent / "undersized_hpu.toml").read_text().replace("pump_flow = 6.67e-4", "pump_flow = 1.67e-6")
    assert "pump_flow = 1.67e-6" in weak
    (tmp_path / "banks" / "weak.toml").write_text(weak)
    text = re.sub(r"\[report\].*", '[report]\nbank = "banks/weak.toml"\n', (root / "paper.toml").read_text(), flags=re.S)
    (tmp_path / "mine.toml").write_text(text)
    files = build_report(load_config(tmp_path / "mine.toml"), tmp_path / "out", source=tmp_path / "mine.toml")
    html = files.html.read_text()
    b = json.loads(files.summary.read_text())["bank"]
    assert b["ok"] is False and len(b["refusals"]) == 2 and b["approach_order"] is None
    assert "power_unit: the duty pumps deliver 0.1 L/min" in b["refusals"][0]
    assert "power_unit: the accumulators deliver" in b["refusals"][1]
    i = html.index("<strong>Refused.</strong>")
    assert html.index("the duty pumps deliver", i) < html.index("the accumulators deliver", i)
    assert "no order could be made" in html and b["clearance"] is not None and b["clearance_all_at_once"] is True
    assert "bank_clearance.png" in {p.name for p in files.figures.values()}
    code, _, err = _run(capsys, "check", "--bank", str(tmp_path / "banks" / "weak.toml"))
    assert code == 2 and err.strip().endswith(b["refusals"][0])
    assert len(err.strip().splitlines()) == 1


def test_a_record_past_the_allowable_gives_each_exceedance_its_code_and_first_time(bank):
    """A manifold a tenth as strong through a heaving ship: each exceedance carries the alarm's event code and the
    first sample past the allowable, where the load is past it and no earlier sample is."""
    small = bank.file.manifold_loads.model_copy(update={k: getattr(bank.file.manifold_loads, k) / 10
                                                         for k in LOAD_NAMES})
    weak = dataclasses.replace(bank, file=bank.file.model_copy(update={"manifold_loads": small}))
    t = np.arange(0.0, 30.0, 0.1)
    d = np.column_stack([0 * t, 0 * t, 0.3 * np.sin(2 * np.pi * t / 8.0)])
    r = record_manifold_loads(weak, t, d, np.zeros((t.size, 3)), wind=(10.0, 0.0, 0.0))
    assert r.exceeded and not r.summary()["within_allowable"]
    for e in r.exceeded:
        i, j = weak.names.index(e["arm"]), LOAD_NAMES.index(e["load"])
        k = int(np.searchsorted(t, e["first_time_s"]))
        series = np.abs(r.loads[i, :, j])
        assert e["code"] == MANIFOLD_LOAD_EVENT and series[k] > e["allowable"] and np.all(series[:k] <= e["allowable"])


def test_the_worst_load_over_a_metocean_record_per_state_and_when(bank):
    """Over the shipped record's first 4 hours (each a sea state of 120 s at the example berth, as the operability
    study takes them): one row per state; each state's worst is the record of that state's ship motion in its wind
    and tide recomputed (the same seed); the summary names the worst, its hour and second; a manifold a tenth as
    strong is over in every hour, each exceedance with the alarm's code."""
    from loadarm.design.manifold import berth_wind, motion_manifold_loads
    from loadarm.params.berth import load_berth
    from loadarm.ship.model import compile_ship
    from loadarm.ship.motion import simulate
    from loadarm.studies.manifold import manifold_states
    from loadarm.studies.operability import record_rows, state_environment

    ex = EXAMPLE.parents[1]
    bf = load_berth(ex / "berths" / "lng150k.toml")
    ship = compile_ship(bf)
    rows, _ = record_rows(ex / "metocean" / "sample.csv", 4)
    r = manifold_states(bank, ship, bf.environment, rows, x_bearing_deg=bf.berth.x_bearing_deg, duration=120.0)
    assert r.worst.shape == (4, 4, 5) and len(r.times) == 4
    env = state_environment(bf.environment, rows[2], bf.berth.x_bearing_deg)
    again = motion_manifold_loads(bank, simulate(ship, env, 120.0, seed=int(rows[2]["index"])), wind=berth_wind(env),
                                  lift=(0.0, 0.0, rows[2]["tide_m"]))
    np.testing.assert_allclose(r.worst[2], again.worst, rtol=1e-12)
    np.testing.assert_allclose(r.when[2], again.worst_time, rtol=0)
    s = r.summary()
    assert s["states"] == 4 and s["within_allowable"] is True and s["hours_over"] == 0 and s["at"].startswith("20")
    small = bank.file.manifold_loads.model_copy(update={k: getattr(bank.file.manifold_loads, k) / 10
                                                         for k in LOAD_NAMES})
    weak = dataclasses.replace(bank, file=bank.file.model_copy(update={"manifold_loads": small}))
    w = manifold_states(weak, ship, bf.environment, rows, x_bearing_deg=bf.berth.x_bearing_deg, duration=120.0)
    assert w.summary()["hours_over"] == 4 and {e["code"] for e in w.exceeded} == {MANIFOLD_LOAD_EVENT}
    flood = [rows[0], {**rows[1], "tide_m": 40.0}]            # a 40 m tide lifts the flanges out of every arm's reach
    f = manifold_states(bank, ship, bf.environment, flood, x_bearing_deg=bf.berth.x_bearing_deg, duration=60.0)
    assert list(f.out_of_reach) == [False, True] and f.summary()["out_of_reach"] == 1
    assert f.summary()["within_allowable"] is True and np.isfinite(f.summary()["max_utilisation"])
