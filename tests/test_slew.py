"""3D kinematics: the slew joint plus the planar closed form."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from loadarm.errors import UnreachableError
from loadarm.geometry import Arm
from loadarm.kinematics import forward, inverse
from loadarm.slew import forward3d, inverse3d, reach_mask3d


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


def test_planar_case_is_exactly_the_2d_model(arm):
    xs = np.linspace(4, 19, 40)
    zs = np.linspace(-4, 12, 40)
    ok = reach_mask3d(arm, xs, 0 * xs, zs)
    q3 = inverse3d(arm, xs[ok], 0.0, zs[ok])
    q2 = inverse(arm, xs[ok], zs[ok])
    assert np.all(q3.phi == 0.0)
    assert np.array_equal(q3.alpha, q2.alpha) and np.array_equal(q3.beta, q2.beta)
    x, y, z = forward3d(arm, 0.0, q2.alpha, q2.beta)
    x2, z2 = forward(arm, q2.alpha, q2.beta)
    assert np.array_equal(x, x2) and np.array_equal(z, z2) and np.all(y == 0)


def test_slew_angle_and_refusal(arm):
    q = inverse3d(arm, 10.0, 10.0, 2.0)
    assert float(q.phi) == pytest.approx(math.pi / 4)
    with pytest.raises(UnreachableError, match=r"\(30.0000, 10.0000, 0.0000\) m is out of reach"):
        inverse3d(arm, [10.0, 30.0], [0.0, 10.0], [2.0, 0.0])
    assert np.isnan(inverse3d(arm, 40.0, 0.0, 0.0, check=False).beta)
