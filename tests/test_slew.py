"""3D kinematics: the slew joint plus the planar closed form."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from loadarm.arm.geometry import Arm
from loadarm.arm.kinematics import forward, inverse
from loadarm.arm.slew import forward3d, inverse3d, reach_mask3d
from loadarm.errors import UnreachableError


@given(st.floats(1, 30), st.floats(1, 30), st.floats(1, 30), st.floats(-math.pi + 1e-3, math.pi - 1e-3),
       st.floats(-1.0, 2.5), st.floats(0.05, 3.0))
def test_inverse3d_of_forward3d_round_trip(a, b, c, phi, alpha, beta):
    arm = Arm(a, b, c)
    x, y, z = forward3d(arm, phi, alpha, beta)
    if math.hypot(float(x), float(y)) < 1e-3:
        return                                     # on the riser axis the slew is undefined
    q = inverse3d(arm, x, y, z)
    x2, y2, z2 = forward3d(arm, q.phi, q.alpha, q.beta)
    assert math.dist((float(x), float(y), float(z)), (float(x2), float(y2), float(z2))) < 1e-9


def _rot_z(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@given(st.floats(-0.69, 0.69), st.floats(4.0, 19.0), st.floats(-4.0, 12.0))
def test_slewed_target_is_the_planar_problem_rotated(phi, x, z):
    """Independent route: rotate a planar target by an explicit rotation matrix; the 3D inverse must recover
    the slew and the planar angles, and the 3D forward must equal the rotated planar forward. (Found weak: the
    old test compared y = 0 targets, where inverse3d calls inverse on the same numbers, equal by construction.)

    Tolerances: 1e-12 rad / 1e-11 m are a few ulps of a rotation and a hypot on lengths up to 30 m.
    """
    arm = Arm(7.0, 12.0, 8.2)
    if not reach_mask3d(arm, x, 0.0, z):
        return
    p = _rot_z(phi) @ np.array([x, 0.0, z])
    q3 = inverse3d(arm, p[0], p[1], p[2])
    q2 = inverse(arm, x, z)
    assert float(q3.phi) == pytest.approx(phi, abs=1e-12)
    assert float(q3.alpha) == pytest.approx(float(q2.alpha), abs=1e-12)
    assert float(q3.beta) == pytest.approx(float(q2.beta), abs=1e-12)
    xp, zp = forward(arm, q2.alpha, q2.beta)
    expected = _rot_z(phi) @ np.array([float(xp), 0.0, float(zp)])
    got = np.array([float(v) for v in forward3d(arm, phi, q2.alpha, q2.beta)])
    assert np.max(np.abs(got - expected)) < 1e-11


def test_slew_angle_and_refusal(arm):
    q = inverse3d(arm, 10.0, 10.0, 2.0)
    assert float(q.phi) == pytest.approx(math.pi / 4)
    with pytest.raises(UnreachableError, match=r"\(30.0000, 10.0000, 0.0000\) m is out of reach"):
        inverse3d(arm, [10.0, 30.0], [0.0, 10.0], [2.0, 0.0])
    assert np.isnan(inverse3d(arm, 40.0, 0.0, 0.0, check=False).beta)
