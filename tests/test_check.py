"""The design check (`loadarm check`): faces, distances, absorbed drift, the ERS accumulator, refusals."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.arm.faces import FACES, breakout_distance, face_margins, first_face
from loadarm.cli import main
from loadarm.design.check import accumulator_usable_volume, design_check, esd_lead, release_lead

from .conftest import PAPER_TOML
from .hypo import examples


def _with(model, section, **kw):
    return dataclasses.replace(model, **{section: dataclasses.replace(getattr(model, section), **kw)})


def test_paper_case_passes_with_the_worked_example_numbers(model):
    c = design_check(model)
    assert c.ok and not c.problems
    assert c.esd_lead == 35.0 and c.release_lead == 20.0      # 10 s valves + 5 s timeout + 3 s PERC + 2 s
    off = c.rows[0]
    assert off.direction.startswith("off the berth") and off.face == "beta_max"
    assert off.needed == pytest.approx(0.15 * 35 - 0.15 ** 2 / (2 * 0.01))
    assert off.alarm_at == pytest.approx(off.available - off.needed)
    assert off.max_speed == pytest.approx(off.needed / 20.0)
    # the customer's 123 deg fires 2.81 m out, past the 1.03 m where the design drift needs ESD-1: not "pass"
    assert off.angle_late and c.summary()["verdict"] == "holds by the floor alone"


def test_available_distance_agrees_with_an_independent_walk(model):
    """Independent route: step 1 mm along each ray with the scalar inverse kinematics and the joint limits."""
    from loadarm.arm.slew import inverse3d

    lim = model.joint_limits
    c = design_check(model)
    p0 = np.array(c.flange)
    for row, vec in zip(c.rows, ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))):
        d = np.array(vec, dtype=float)
        s = max(row.available - 0.01, 0.0)
        while s < row.available + 0.01:
            p = p0 + s * d
            q = inverse3d(model.arm, *p, check=False)
            vals = (float(q.phi), float(q.alpha), float(q.beta))
            if any(math.isnan(v) for v in vals) or not lim.contains(vals):
                break
            s += 0.001
        assert s == pytest.approx(row.available, abs=0.0011), row.direction


@settings(max_examples=examples(100), deadline=None)
@given(st.floats(1e-3, 1.0), st.floats(1e5, 100e5), st.floats(1.05, 3.0), st.floats(1.05, 3.0), st.floats(1.0, 1.67))
def test_accumulator_volume_against_the_gas_law(volume, precharge, k_min, k_max, n):
    """Independent route: the gas volume at each pressure from p V^n = const by bisection."""
    p_min = precharge * k_min
    p_max = p_min * k_max
    v1 = volume * precharge / p_max                        # charged isothermally

    def gas_volume(p):                                     # then p v^n = p_max v1^n, solved numerically
        lo, hi = v1, 1e3 * volume
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if p_max * v1 ** n / mid ** n > p else (lo, mid)
        return 0.5 * (lo + hi)

    assert accumulator_usable_volume(volume, precharge, p_max, p_min, n) == pytest.approx(
        gas_volume(p_min) - v1, rel=1e-9)


@settings(max_examples=examples(100), deadline=None)
@given(st.floats(0.0, 200.0), st.floats(0.01, 1.0), st.floats(1e-3, 1.0))
def test_breakout_distance_is_the_integral_of_the_speed(t, v, a):
    # the speed is piecewise linear: with its kink on the grid the trapezoid rule is exact (up to round-off)
    tt = np.unique(np.concatenate([np.linspace(0.0, t, 101), [min(v / a, t)]]))
    speed = np.minimum(a * tt, v)
    assert float(breakout_distance(t, v, a)) == pytest.approx(float(np.trapezoid(speed, tt)), rel=1e-9, abs=1e-12)


def test_refuses_a_design_drift_the_alarms_cannot_absorb(model):
    fast = _with(model, "design_drift", speed=0.5, acceleration=0.1)
    c = design_check(fast)
    assert not c.ok and any("already in alarm" in p for p in c.problems)
    slow_breakout = _with(model, "design_drift", acceleration=0.001)   # the floor fires too late for 0.15 m/s
    c = design_check(slow_breakout)
    assert not c.ok and any("absorb" in p and "below the design drift" in p for p in c.problems)


def test_refuses_an_accumulator_too_small_for_the_ers(model):
    c = design_check(_with(model, "accumulator", volume=5e-3))
    assert not c.ok and "ERS accumulator delivers" in c.problems[0]


def test_cli_check_exit_codes_and_json(capsys, tmp_path):
    assert main(["check", "--config", str(PAPER_TOML), "--json"]) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    assert data["verdict"] == "holds by the floor alone" and len(data["directions"]) == 6
    bad = tmp_path / "fast.toml"
    bad.write_text(PAPER_TOML.read_text() + "\n[design_drift]\nspeed = 0.5\nacceleration = 0.1\n")
    assert main(["check", "--config", str(bad), "--png", str(tmp_path / "c.png")]) == 2
    err = capsys.readouterr().err
    assert "refused" in err and "already in alarm" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "c.png").stat().st_size > 10_000           # the figure shows why


def test_faces_cover_reach_and_every_joint_limit(model):
    lim = model.joint_limits
    far = face_margins(model, 40.0, 0.0, 7.0)
    assert first_face(far)[0] and FACES[int(first_face(far)[1])] == "beta_max" and far[0] == -np.inf
    near = face_margins(model, 0.5, 0.0, 7.0)                       # inside the folded arm's reach
    assert first_face(near)[0] and FACES[int(first_face(near)[1])] == "beta_min"
    ok = face_margins(model, 13.0, 0.0, 1.0)
    assert not first_face(ok)[0] and np.all(ok > 0)
    side = face_margins(model, 10.0, 10.0 * math.tan(lim.phi[1] + 0.01), 1.0)
    assert FACES[int(first_face(side)[1])] == "slew_pos" and first_face(side)[0]
    assert esd_lead(model.sequence) == 35.0 and release_lead(model.sequence) == 20.0


@pytest.mark.parametrize("angles,refused,want", [
    ([None, 0.5, 1.0], False, "pass"),                      # each angle at or before the bar
    ([None, 0.5, 1.0 + 1e-9], False, "holds by the floor alone"),
    ([3.0, None, None], False, "holds by the floor alone"),
    ([3.0, None, None], True, "refused"),
    ([None, None, None], False, "pass"),
])
def test_a_marker_past_the_bar_is_never_shown_with_a_pass(angles, refused, want):
    """Found: the section-8 figure drew the customer's 123 deg marker (2.8 m off the berth) past the "fires at the
    latest" bar (1.03 m) under the verdict "pass". check_verdict, which the figure's title and the report read,
    never says pass while any angle fires past its bar; the figure draws such a marker red."""
    from loadarm.design.check import DirectionCheck, check_verdict

    rows = [DirectionCheck(f"d{i}", "beta_max", 5.0, a, 4.0, 1.0, 0.2, math.inf, 0.15) for i, a in enumerate(angles)]
    assert check_verdict(rows, refused) == want
    late = any(r.angle_alarm is not None and r.angle_alarm > r.alarm_at for r in rows)
    assert not (late and check_verdict(rows, refused) == "pass")
