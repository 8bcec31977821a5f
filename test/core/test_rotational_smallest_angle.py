"""The rotational FIC resolves the axis r/theta only above its smallest angle, 1e-12 rad: a rotation error of
exactly that angle is the rest state (no moment, theta read as 0, in D), as a zero one is
(test_rotational_zero_angle.py), and the next float above it is resolved, with the linear region's moment
M = FIC(theta) r/theta = K0 r (paper Eq. 1 and 2 on the angle). Each axis of the base frame, so that theta is the
component itself, to the bit."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.attractor import Phase
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor

PROFILE = ForceProfile(20.0, 0.5, 0.5, 5.0)
SMALLEST_ANGLE = 1e-12   # [rad], rotational_attractor's


@pytest.mark.parametrize("axis", range(3))
def test_exactly_the_smallest_angle_is_rest_and_the_next_float_is_resolved(axis: int) -> None:
    above = float(np.nextafter(SMALLEST_ANGLE, 1.0))
    for angle, resolved in ((SMALLEST_ANGLE, False), (above, True)):
        rotation = np.zeros(3)
        rotation[axis] = angle
        assert math.sqrt(float(rotation @ rotation)) == angle
        attractor = RotationalAttractor(PROFILE, rate_deadband=0.001)
        moment = attractor.moment(rotation, np.zeros(3))
        snapshot = attractor.snapshot()
        assert snapshot.phase.tolist() == [Phase.DIVERGENCE] * 3
        if resolved:
            np.testing.assert_allclose(moment, PROFILE.stiffness * rotation, rtol=1e-15, atol=0.0)
            assert moment[axis] > 0.0
            assert snapshot.scalar.errors == (angle,)
        else:
            np.testing.assert_array_equal(moment, np.zeros(3))
            assert snapshot.scalar.errors == (0.0,) and snapshot.scalar.forces == (0.0,)
