"""The loop-gain bound G = k_F s_M K_H <= 1 at its edge (docs/CONTROL_LAWS.md, "Master"): inclusive, with a
relative slack of 1e-12 for the rounding of the product, so 1 + 1e-12 and the float below it are taken and the float
above it is refused in one line."""
from __future__ import annotations

import math

import pytest

from fic_core.errors import FicInputError
from fic_core.master import checked_loop_gain

EDGE = 1.0 + 1e-12


@pytest.mark.parametrize("gain", [1.0, math.nextafter(EDGE, 0.0), EDGE])
def test_a_gain_up_to_the_slack_is_taken(gain: float) -> None:
    assert checked_loop_gain(gain, 1.0, 1.0) == gain
    assert checked_loop_gain(1.0, 1.0, gain) == gain


def test_the_next_float_above_the_slack_is_refused_in_one_line() -> None:
    with pytest.raises(FicInputError, match="above the loop-gain bound") as refused:
        checked_loop_gain(1.0, math.nextafter(EDGE, 2.0), 1.0)
    assert "\n" not in str(refused.value)


def test_scales_whose_product_is_one_are_taken() -> None:
    for force_scale, workspace_scale, haptic_gain in [(4.0, 0.25, 1.0), (10.0, 0.1, 1.0), (3.0, 1.0 / 3.0, 1.0),
                                                      (1.0 / 0.7, 0.7, 1.0)]:
        assert checked_loop_gain(force_scale, workspace_scale, haptic_gain) == pytest.approx(1.0, rel=1e-15)
