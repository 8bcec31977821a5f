"""The secant stiffness's two forms at the edge of its linearisation (profile.py, ``secant_stiffness``): at and
below ``1e-9 x_b`` (and past xi x_b), F_c(a)/a is taken from the tangent line at the start of the saturation,
F0 + F_c'(xi x_b+) (a - xi x_b), because the quotient of two tanh values has lost its digits there; above it, the
quotient itself. The edge belongs to the line, in the array form and in the float form (``scalar_secant_stiffness``,
"``secant_stiffness`` on one axis") alike: a magnitude of exactly 1e-9 x_b, where the quotient misses the line by
far more than rounding, is on the tangent line in both, on either side of zero."""
from __future__ import annotations

import math

import pytest

from fic_core.profile import ForceProfile


def _tangent_slope(stiffness: float, saturation_error: float, saturation_start: float, max_force: float) -> float:
    """Eq. 1's derivative just past xi x_b, dF / (1 - tanh(-pi)) x sech^2(-pi) / S, from the parameters."""
    start_force = saturation_start * stiffness * saturation_error
    width = (1.0 - saturation_start) * saturation_error / (2.0 * math.pi)
    return (max_force - start_force) / (1.0 - math.tanh(-math.pi)) * (1.0 - math.tanh(-math.pi) ** 2) / width


@pytest.mark.parametrize("saturation_error", [0.05, 0.5, 1e-3])
@pytest.mark.parametrize("stiffness, saturation_start, max_force", [(1e4, 1e-11, 30.0), (200.0, 1e-12, 30.0),
                                                                    (5e3, 0.0, 2.0), (200.0, 0.0, 30.0)])
def test_a_magnitude_of_exactly_the_edge_is_on_the_tangent_line_in_both_forms(
        stiffness: float, saturation_error: float, saturation_start: float, max_force: float) -> None:
    profile = ForceProfile(stiffness, saturation_error, saturation_start, max_force)
    start = saturation_start * saturation_error
    start_force = saturation_start * stiffness * saturation_error
    slope = _tangent_slope(stiffness, saturation_error, saturation_start, max_force)
    edge = 1e-9 * saturation_error
    assert start < edge
    on_the_line = (start_force + slope * (edge - start)) / edge
    quotient = abs(float(profile.force(edge))) / edge
    # The quotient has lost digits here: it misses the line by far more than the 1e-13 asked below.
    assert not math.isclose(quotient, on_the_line, rel_tol=1e-12)
    for value in (float(profile.secant_stiffness(edge)), profile.scalar_secant_stiffness(edge),
                  float(profile.secant_stiffness(-edge)), profile.scalar_secant_stiffness(-edge)):
        assert math.isclose(value, on_the_line, rel_tol=1e-13), (value, on_the_line, quotient)
