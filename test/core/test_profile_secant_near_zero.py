"""The secant stiffness F_c(a)/a of a profile with no linear region (xi = 0) at magnitudes far below its saturation
error: the quotient there loses its digits to tanh's cancellation, so the profile must still give the limit of the
secant as a -> 0+, which a float quotient at a ten-millionth of x_b gives to about a part in a million."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.profile import ForceProfile


@pytest.mark.parametrize("saturation_error", [1e2, 1e4])
@pytest.mark.parametrize("fraction", [1e-15, 1e-13, 1e-11])
def test_the_secant_far_below_the_saturation_error_is_its_limit_at_zero(saturation_error: float,
                                                                        fraction: float) -> None:
    profile = ForceProfile(stiffness=100.0, saturation_error=saturation_error, saturation_start=0.0, max_force=10.0)
    # A ten-millionth of x_b: the quotient still keeps about eight digits, and the secant has moved from its limit
    # by under a part in a million (it grows by about 6 a / x_b of itself).
    moderate = 1e-7 * saturation_error
    limit = float(profile.force(np.array([moderate]))[0]) / moderate
    secant = float(profile.secant_stiffness(np.array([fraction * saturation_error]))[0])
    assert secant == pytest.approx(limit, rel=1e-5)
