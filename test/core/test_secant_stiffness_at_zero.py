"""``secant_stiffness`` gives F_c(e)/e with its limit at e = 0 "with no division by ~0" (its docstring): at e = 0
(and -0.0) it is K0 with a linear range and the profile's slope at the origin without one, and no floating-point
division by zero or invalid operation happens on the way, for a lone zero or zeros inside an array."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.profile import ForceProfile


@pytest.mark.parametrize("saturation_start", [0.5, 0.0])
def test_the_secant_at_zero_is_the_slope_at_the_origin_without_a_floating_point_error(
        saturation_start: float) -> None:
    profile = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=saturation_start,
                           max_force=40.0)
    step = 1e-10
    # The oracle: the forward difference quotient of F_c at the origin (F_c is C^1 there, its curvature bounded).
    slope = float(profile.force(np.array([step]))[0]) / step
    errors = np.array([0.0, -0.0, 0.01, -0.03, 0.0])
    with np.errstate(all="raise"):
        secant = profile.secant_stiffness(errors)
        lone = profile.secant_stiffness(0.0)
    assert math.isclose(float(lone), slope, rel_tol=1e-5)
    assert secant[0] == secant[1] == secant[4] == float(lone)
    expected = [float(profile.force(np.array([value]))[0]) / value for value in (0.01, -0.03)]
    np.testing.assert_allclose(secant[2:4], expected, rtol=1e-12)
    if saturation_start > 0.0:
        assert float(lone) == profile.stiffness
