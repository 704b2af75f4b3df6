"""MuJoCo verification of the kinematics (issue: below 0.01 deg and 0.1 mm on several geometries)."""

import numpy as np
import pytest

from loadarm.arm.dynamics import mass_model
from loadarm.design.multibody import build_mjcf, load_model, verify_kinematics
from loadarm.design.trajectory import plan_approach
from loadarm.params.compiler import compile_model
from loadarm.params.config import parse_config

ANGLE_TOL_DEG = 0.01
LENGTH_TOL_MM = 0.1


def _variant(inst, arm=None, mount=None, stored=None, flange=None, masses=None, cylinders=None):
    d = inst.model_dump()
    if arm:
        d["arm"].update(dict(zip(("riser", "inboard", "outboard"), arm)))
    if mount:
        d["actuators"].update(dict(zip(("a1", "b1", "b2", "c2"), mount)))
    if stored:
        d["approach"]["stored"] = stored
    if flange:
        d["approach"]["flange"] = flange
    if masses:
        d["masses"].update(masses)
    if cylinders:
        d["cylinders"].update(cylinders)
    return compile_model(parse_config(d))


CASES = {
    "paper": {},
    "short arm": dict(arm=(5.0, 9.0, 6.5), mount=(0.8, 1.2, 1.0, 0.6), stored=(3.0, 8.0), flange=(10.0, -1.0)),
    # its own cylinder 2 stroke: with the default one the release angle would lie past the stroke end (refused)
    "long arm": dict(arm=(9.0, 16.0, 12.0), mount=(1.5, 1.5, 2.0, 0.8), stored=(4.5, 13.0), flange=(20.0, 0.0),
                     cylinders={"length_range_2": (1.3, 2.8)}),
    "above riser top": dict(stored=(3.82, 10.4), flange=(16.0, 12.0)),
    "no pantograph": dict(masses={"counterweight_outboard_kg": 0.0}),
}


@pytest.mark.parametrize("name", list(CASES))
def test_mujoco_agrees_with_closed_form(inst, name):
    case = _variant(inst, **CASES[name])
    plan = plan_approach(case, timing="smooth", samples=61)
    res = verify_kinematics(case, plan)
    s = res.summary()
    assert s["max_angle_diff_deg"] < ANGLE_TOL_DEG
    assert s["max_length_diff_mm"] < LENGTH_TOL_MM
    # in fact they agree to round-off of the settled constraint
    assert s["max_angle_diff_deg"] < 1e-6 and s["max_length_diff_mm"] < 1e-5


def test_mjcf_is_self_consistent(model):
    xml = build_mjcf(model.arm, model.mount, mass_model(model))
    m = load_model(xml)
    assert m.njnt == 3 and m.ntendon == 2
    # MuJoCo's total mass equals the mass model's (+ the 1e-6 kg coupler-tip marker)
    assert float(m.body_mass.sum()) == pytest.approx(mass_model(model).total_mass + 1e-6, rel=1e-12)
    kin = load_model(build_mjcf(model.arm, model.mount, mass_model(model),
                                kinematic=True))
    assert kin.neq == 2 and kin.nmocap == 1 and np.allclose(kin.opt.gravity, 0)
