"""The profile's storage (docs/CONTROL_LAWS.md, the integral of Eq. 1) is built on log(cosh(u)), written so that it
does not overflow for large |u|: both forms (array and scalar) against the textbook formula where cosh is finite,
and against |u| - log 2 where it is not; and the storage at the end of the linear region is K0 a^2/2 exactly (both
sides of the switch meet there, and the linear side is the one computed)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.profile import ForceProfile, _log_cosh, _scalar_log_cosh

ARGUMENTS = [0.0, 1e-8, 0.3, 1.0, math.pi, 5.0, 18.0, 40.0, 300.0, 700.0]


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("u", ARGUMENTS)
def test_log_cosh_matches_the_textbook_formula(u: float, sign: float) -> None:
    expected = math.log(math.cosh(sign * u))
    assert _scalar_log_cosh(sign * u) == pytest.approx(expected, rel=1e-14, abs=4e-16)
    assert float(_log_cosh(np.array(sign * u))) == pytest.approx(expected, rel=1e-14, abs=4e-16)


@pytest.mark.parametrize("u", [800.0, 1e4, 1e300])
def test_log_cosh_of_a_large_argument_is_finite_and_its_asymptote(u: float) -> None:
    """cosh overflows past ~710; log cosh(u) = |u| - log 2 + log(1 + e^(-2|u|)), the last term below 1e-600."""
    for value in (_scalar_log_cosh(u), _scalar_log_cosh(-u), float(_log_cosh(np.array(u))),
                  float(_log_cosh(np.array(-u)))):
        assert math.isfinite(value)
        assert value == pytest.approx(u - math.log(2.0), rel=1e-15)


def test_log_cosh_array_form_is_the_scalar_form_item_by_item() -> None:
    grid = np.linspace(-50.0, 50.0, 2001)
    np.testing.assert_allclose(_log_cosh(grid), [_scalar_log_cosh(float(u)) for u in grid], rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize("profile", [ForceProfile(200.0, 0.05, 0.5, 10.0), ForceProfile(20.0, 0.5, 0.5, 5.0),
                                     ForceProfile(1000.0, 0.05, 0.3, 60.0), ForceProfile(50.0, 0.1, 0.9, 6.0)])
def test_the_storage_at_the_end_of_the_linear_region_is_k0_a_squared_over_two(profile: ForceProfile) -> None:
    """The linear region is closed, as the force's is: at a = xi x_b the storage is the linear one, to the last
    bit (the saturated formula there differs by a rounding on some profiles)."""
    end = profile.linear_limit
    assert float(profile.energy(end)) == float(profile.energy(-end)) == 0.5 * profile.stiffness * end ** 2
    assert profile.scalar_energy(end) == profile.scalar_energy(-end) == 0.5 * profile.stiffness * end * end
